"""decoder.edges: the rows a whole PHY-SDU may lie in, and the level step that ends a final OFF run."""

import numpy as np
import pytest
from synth import profile_from_chips

from rollsim.protocol import PhyFormat

from decoder.edges import SPAN_TOLERANCE_ROWS, STEP_SIGMAS, last_face_row, led_edges
from decoder.pipeline import binarise_at_pitch, decode_profile
from decoder.profile import RowProfile

PHY = PhyFormat(5, 19, "crc8")
PITCH = 4.5
EXPOSURE_ROWS = 3.6  # paper-geometric: 100 µs at 27.8 µs a row
NOISE = 2.0
WALL_ROWS = 12


def chips_ending_off() -> np.ndarray:
    """Chips of four PHY-SDUs, sequences 0 to 3, the third ending in an OFF chip."""
    rng = np.random.default_rng(5)
    while True:
        payload = rng.integers(0, 2, (4, PHY.payload_bits), dtype=np.uint8)
        chips = PHY.encode(np.arange(4), payload)
        if chips[2, -1] == 0:
            return chips.reshape(-1)


def profile_over_wall(face_off: float, wall: float, on: float, wall_rows: int = WALL_ROWS, seed: int = 0) -> RowProfile:
    """An LED's rows whose last ends the third PHY-SDU, then rows of a flat wall, with noise.

    Exposure 3.6 rows, OFF level ``face_off``. Row ``y`` integrates the
    chips over rows ``[y, y + 3.6]``, so its middle (where the renderer's
    truth puts it) lies 1.8 rows on: the LED's rows end where that middle
    reaches the end of the third PHY-SDU, and its last rows see the fourth
    one's SYNC smeared in, as a rendered frame's do.
    """
    led = profile_from_chips(chips_ending_off(), PITCH, EXPOSURE_ROWS, on=on, off=face_off)
    led_rows = int(3 * PHY.sdu_chips * PITCH - 0.5 * EXPOSURE_ROWS)
    values = np.concatenate([led[:led_rows], np.full(wall_rows, wall)])
    values = values + np.random.default_rng(seed).normal(0.0, NOISE, values.size)
    return RowProfile(0, values, np.full(values.size, NOISE))


def last_sdu_read(profile: RowProfile) -> bool:
    found = decode_profile(profile, PHY, PITCH)
    return any(sdu.sequence == 2 and sdu.check_ok for sdu in found)


@pytest.mark.parametrize("face_off, wall, on", [(25.0, 60.0, 190.0), (100.0, 60.0, 250.0)])
def test_a_phy_sdu_ending_in_off_chips_on_the_leds_last_row_is_read_where_the_face_differs(face_off, wall, on):
    # paper-geometric's face is darker than its wall (25 against 60 DN);
    # a brighter face steps down instead.
    for seed in range(5):
        assert last_sdu_read(profile_over_wall(face_off, wall, on, seed=seed))


def test_a_face_matching_the_background_shows_no_end_and_its_last_phy_sdu_is_not_claimed():
    # Nothing in the profile shows where the OFF chips end.
    for seed in range(5):
        profile = profile_over_wall(25.0, 25.0, 190.0, seed=seed)
        assert not last_sdu_read(profile)
        truncated = decode_profile(profile, PHY, PITCH, include_truncated=True)
        assert any(sdu.sequence == 2 and sdu.status == "truncated" for sdu in truncated)


def with_stripes_before(run: np.ndarray, off: float = 25.0, on: float = 190.0):
    """Rows of chips (4.5 rows each, OFF level ``off``) then ``run``, and the run's first row."""
    stripes = np.where((np.arange(45) // PITCH) % 2 == 0, on, off)
    return np.concatenate([stripes, run]), stripes.size


def test_last_face_row_is_the_last_row_on_the_off_levels_side():
    values, start = with_stripes_before(np.concatenate([np.full(6, 25.0), [40.0, 57.0], np.full(10, 60.0)]))
    assert last_face_row(values, np.full(values.size, 1.0), start, PITCH) == start + 6
    # A brighter face (OFF at 100 DN) over a darker wall.
    values, start = with_stripes_before(np.concatenate([np.full(6, 100.0), [80.0, 63.0], np.full(10, 60.0)]),
                                        off=100.0, on=250.0)
    assert last_face_row(values, np.full(values.size, 1.0), start, PITCH) == start + 6


@pytest.mark.parametrize("run", [
    # The background within the band of the OFF level.
    np.concatenate([np.full(8, 25.0), np.full(10, 25.0 + 0.5 * STEP_SIGMAS)]),
    # Too few rows of background.
    np.concatenate([np.full(8, 25.0), np.full(4, 60.0)]),
    # Stripes after the OFF rows: no flat background.
    np.concatenate([np.full(8, 25.0), np.tile([60.0, 60.0, 90.0, 90.0], 4)]),
    # The face seen more than a chip before the background begins: the rows
    # between show neither.
    np.concatenate([np.full(8, 25.0), np.full(6, 100.0), np.full(10, 60.0)]),
])
def test_last_face_row_needs_the_face_then_a_chip_of_flat_background_off_the_off_level(run):
    values, start = with_stripes_before(run)
    assert last_face_row(values, np.full(values.size, 1.0), start, PITCH) is None


def test_last_face_row_needs_the_leds_off_level_before_the_run():
    values, start = with_stripes_before(np.concatenate([np.full(8, 25.0), np.full(10, 60.0)]))
    assert last_face_row(values, np.full(values.size, 1.0), 20, PITCH) is None
    assert last_face_row(values, np.full(values.size, 1.0), values.size, PITCH) is None


def test_last_face_row_rarely_claims_noise_as_the_face():
    # An OFF run that is all background (the LED ended on its ON run):
    # only noise beyond 4 sigma of the difference could claim a row, about
    # 1e-4 per profile.
    rng = np.random.default_rng(11)
    claims = 0
    for _ in range(2000):
        values, start = with_stripes_before(rng.normal(60.0, NOISE, 20))
        claims += last_face_row(values, np.full(values.size, NOISE), start, PITCH) is not None
    assert claims <= 2


@pytest.mark.parametrize("frame, width_px", [(83, 480), (287, 1920)])
def test_paper_geometric_reads_the_phy_sdu_ending_on_its_disks_last_rows(frame, width_px):
    # paper-geometric with CRC-8, 300 frames: 3 of 750 fully visible
    # PHY-SDUs end in an OFF chip on row 1070 of a disk ending on row 1072
    # (frames 83, 134 and 287); all were missed, now all are read.
    from rollsim.stages.decode import settings_from_scene
    from rollsim.render import RenderPipeline
    from rollsim.scene import load_scene

    from decoder import decode_frame

    scene = load_scene("paper-geometric", ["link.check=crc8", f"camera.width_px={width_px}"])
    settings = settings_from_scene(scene)
    image = RenderPipeline(scene).render(frame)
    last = image.truth["sdus"][-2]
    assert last["fully_visible"] and last["last_row"] == 1070 and image.truth["led_rows"][1] == 1072
    found = decode_frame(image.image, settings.phy, settings.clock_hz, settings.row_time_s, frame,
                         exposure_s=settings.exposure_s)
    assert any(sdu.check_ok and sdu.sequence == last["sequence"] and sdu.bits == last["bits"] for sdu in found)
    assert all(sdu.sequence != last["sequence"] or sdu.bits == last["bits"] for sdu in found if sdu.check_ok)


def test_the_level_step_widens_the_phy_sdus_rows_but_not_the_measured_stripe_rows():
    # The ROI ratio measures the stripe rows (the emitter was fitted to
    # them): a lone OFF chip at the LED's end is no stripe.
    profile = profile_over_wall(25.0, 60.0, 190.0)
    levels, runs = binarise_at_pitch(profile, PHY, PITCH)
    _, _, span, striped = led_edges(runs, levels, PITCH, profile.values, profile.noise)
    last_on = int(np.flatnonzero(runs.values == 1)[-1])
    assert striped[1] == pytest.approx(runs.bounds[last_on + 1] + SPAN_TOLERANCE_ROWS)
    assert span[0] == striped[0] and span[1] > striped[1] + 0.5 * PITCH
