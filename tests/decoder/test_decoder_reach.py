"""Reading past a region's found rows as far as its stripes reach (decoder.reach)."""

import numpy as np
import pytest

from decoder import pipeline
from decoder.profile import RowProfile, profile_rows, row_profile, with_end_rows
from decoder import reach
from decoder.reach import noise_sum_threshold, striped_reach, striped_rows
from decoder.region import Region, block_means, extended, room_to_grow

PITCH = 4.5
WINDOW = 27  # (longest run 5 + 1) chips of 4.5 rows, as paper-default's
NOISE = 1.0


def chips_profile(n_bits: int, gap: float, seed: int = 0) -> np.ndarray:
    """Row means of Manchester chips of random bits (OFF 0, ON ``gap``) at ``PITCH`` rows per chip, unit noise."""
    rng = np.random.default_rng(seed)
    bits = rng.integers(0, 2, n_bits)
    chips = np.stack([bits, 1 - bits], axis=1).ravel()
    rows = np.arange(int(chips.size * PITCH))
    return gap * chips[(rows / PITCH).astype(int)] + rng.normal(0.0, NOISE, rows.size)


def profile(values: np.ndarray, first_row: int = 0) -> RowProfile:
    return RowProfile(first_row, values, np.full(values.size, NOISE), None)


def test_noise_alone_is_not_striped():
    values = np.random.default_rng(1).normal(50.0, NOISE, 5000)
    assert not striped_rows(profile(values), PITCH, WINDOW).any()


def test_stripes_six_sigmas_deep_are_striped_everywhere():
    # A gap of 6 sigmas of a row mean: a window of 6 chips holds 3 to 6 edges (5 sigmas leave a few windows short).
    assert striped_rows(profile(chips_profile(100, 6.0)), PITCH, WINDOW).all()


@pytest.mark.parametrize("lag, window", [(1, 9), (2, 27), (5, 60)])
def test_noise_exceeds_the_threshold_as_often_as_it_says(monkeypatch, lag, window):
    """The scaled chi-square of noise_sum_threshold, checked on 40 000 windows
    of white noise at a false-alarm probability of 1 %."""
    monkeypatch.setattr(reach, "STRIPE_FALSE_ALARM", 0.01)
    noise = np.random.default_rng(8).normal(0.0, 1.0, (40_000, window + lag))
    sums = (((noise[:, lag:] - noise[:, :-lag]) ** 2) / 2.0).sum(axis=1)
    rate = float(np.mean(sums > noise_sum_threshold(np.array([window]), lag)[0]))
    assert 0.0075 <= rate <= 0.0135


@pytest.mark.parametrize("background", [0.0, 1.5, 6.0])
def test_the_reach_stops_where_the_stripes_end(background):
    """Stripes over rows 0 to 450, background (at the OFF level, between the
    levels, at the ON level) below: found rows 0 to 360 reach 90 rows on,
    within a chip; none past the stripes, where a detector would read the
    noise as chips."""
    stripes = chips_profile(50, 6.0, seed=2)
    values = np.concatenate([stripes, background + np.random.default_rng(3).normal(0.0, NOISE, 200)])
    above, below = striped_reach(profile(values), slice(0, 360), PITCH, WINDOW)
    assert above == 0
    assert stripes.size - 360 - PITCH <= below <= stripes.size - 360 + PITCH


def test_stripes_running_to_the_end_are_reached_to_it():
    values = chips_profile(50, 6.0, seed=4)
    assert striped_reach(profile(values), slice(4, values.size - 3), PITCH, WINDOW) == (4, 3)


def test_nothing_past_stripes_that_end_inside_the_rows_found():
    values = np.concatenate([chips_profile(30, 6.0, seed=5), np.random.default_rng(6).normal(0.0, NOISE, 300)])
    assert striped_reach(profile(values, 100), slice(100, 100 + 270 + 150), PITCH, WINDOW) == (0, 0)


def region(rows: slice, cols: slice) -> Region:
    weights = np.ones((rows.stop - rows.start, cols.stop - cols.start), np.float32)
    return Region(rows, cols, weights, int(weights.size))


def test_regions_one_above_the_other_share_the_rows_between_them():
    upper, lower = region(slice(100, 200), slice(10, 30)), region(slice(240, 400), slice(20, 40))
    assert room_to_grow([upper, lower], 1080, 72) == [(72, 20), (20, 72)]


def test_regions_side_by_side_and_the_frame_edges_bound_nothing_but_the_frame():
    left, right = region(slice(30, 500), slice(0, 10)), region(slice(600, 1060), slice(20, 30))
    assert room_to_grow([left, right], 1080, 72) == [(30, 72), (72, 20)]


def test_rows_added_repeat_their_end_rows_columns():
    weights = np.zeros((3, 4), np.float32)
    weights[0, 1:3] = 1
    weights[1] = 1
    weights[2, 0] = 1
    grown = extended(Region(slice(10, 13), slice(0, 4), weights, 7), 2, 1)
    assert grown.rows == slice(8, 14)
    assert np.array_equal(grown.weights, np.stack([weights[0], weights[0], *weights, weights[2]]))


def test_the_rows_added_are_the_grown_regions_profile_there():
    rng = np.random.default_rng(7)
    frame = rng.integers(0, 255, (400, 160), dtype=np.uint8)
    blocks = block_means(frame, 4)
    found = region(slice(100, 300), slice(5, 30))
    found.weights[0, :10] = 0  # the end rows' own columns are kept
    found_profile = row_profile(blocks, found)
    looked_at = with_end_rows(blocks, found_profile, found, 40, 25)
    whole = row_profile(blocks, extended(found, 40, 25))
    assert looked_at.first_row == 60 and len(looked_at) == 265
    np.testing.assert_allclose(looked_at.values, whole.values)
    # The added rows carry the end rows' noise, measured on the region.
    assert looked_at.noise[0] == found_profile.noise[0] and looked_at.noise[-1] == found_profile.noise[-1]
    part = profile_rows(looked_at, slice(90, 310))
    assert part.first_row == 90 and np.array_equal(part.values, looked_at.values[30:250])


# ------------------------------------------------------------------ rendered frames

def rendered(scene_name: str, overrides: list[str], index: int):
    from rollsim.stages.decode import settings_from_scene
    from rollsim.render import RenderPipeline
    from rollsim.scene import load_scene

    scene = load_scene(scene_name, [*overrides, f"frames={index + 1}"])
    return RenderPipeline(scene).render(index), settings_from_scene(scene)


def decoded(frame, settings):
    return pipeline.decode_frame(frame.image, settings.phy, settings.clock_hz, settings.row_time_s,
                                 exposure_s=settings.exposure_s)


def test_a_phy_sdu_at_the_frames_top_edge_is_read_through_the_rows_reached(monkeypatch):
    """paper-default with CRC-8, frame 0: its first PHY-SDU starts on row 0, and
    the region found starts on row 4. Read on to the frame's edge, it is read;
    without the reach, it is not (its SYNC's first chip is in rows 0 to 4)."""
    frame, settings = rendered("paper-default", ["link.check=crc8"], 0)
    first = frame.truth["sdus"][0]
    assert first["first_row"] == 0

    def reads_it():
        return any(d.check_ok and d.first_row_f < first["last_row"] / 2 for d in decoded(frame, settings))

    assert reads_it()
    monkeypatch.setattr(pipeline, "REACH_CHIPS", 0.0)
    assert not reads_it()


def test_the_stripe_rows_measured_do_not_move_with_the_reach(monkeypatch):
    frame, settings = rendered("paper-default", ["link.check=crc8"], 0)

    def stripe_rows():
        views = pipeline.inspect_frame(frame.image, settings.phy, settings.clock_hz, settings.row_time_s,
                                       exposure_s=settings.exposure_s)
        return [view.stripe_rows for view in views], views[0].rows

    with_reach, read_rows = stripe_rows()
    monkeypatch.setattr(pipeline, "REACH_CHIPS", 0.0)
    without, found_rows = stripe_rows()
    assert read_rows.start < found_rows.start  # the reach was used
    assert with_reach == without


def test_background_above_a_small_led_is_not_read_as_chips():
    """A sweep cell at 20 cm on 480 columns: the LED's face (27 DN OFF) is
    darker than the lit wall above it (68 DN, between its OFF and ON levels).
    Reading 16 chips past the region whatever the rows held made the wall's
    noise a PHY-SDU's SYNC, and a parity-2 undetected error, in this frame;
    the reach stops at the LED's stripes."""
    frame, settings = rendered("paper-geometric", ["seed=5092125301580550816", "camera.width_px=480",
                                                   "link.distance_cm=20", "link.clock_hz=8000"], 15)
    led_first = frame.truth["led_rows"][0]
    pitch = 1.0 / (settings.clock_hz * settings.row_time_s)
    assert all(d.first_row_f >= led_first - pitch for d in decoded(frame, settings))


@pytest.mark.parametrize("above, below", [(0, 1), (1, 0), (2, 3), (13, 14), (40, 72)])
def test_the_reach_is_that_of_the_whole_profiles_flags(above, below):
    """striped_reach looks only at the rows near the ends: it gives what the
    flags of the whole profile give, down to a reach of one row."""
    values = np.concatenate([chips_profile(60, 6.0, seed=9), np.random.default_rng(10).normal(0.0, NOISE, 80)])
    whole = profile(values, 500)
    found = slice(500 + above, 500 + values.size - below)
    flags = striped_rows(whole, PITCH, WINDOW)
    expected = (reach._reach(flags[:above][::-1], WINDOW), reach._reach(flags[values.size - below:], WINDOW))
    assert striped_reach(whole, found, PITCH, WINDOW) == expected
