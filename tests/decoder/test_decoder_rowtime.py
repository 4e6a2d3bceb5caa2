"""decoder.rowtime: row time from square-wave frames."""

import cv2
import numpy as np
import pytest
from synth import core_saturated, make_transmitter, profile_from_chips, synth_frame

from decoder import RowTimeError, estimate_row_time
from decoder.profile import RowProfile
from decoder.rowtime import FEW_EDGES, clips_long, led_region_rows, most_frames_agree, profile_period_rows, \
    runs_fit_a_square_wave, spectral_period_rows

# (clock Hz, row time s, exposure s): stripe periods of 2.5 to 25 rows,
# exposures from a quarter chip to 1.5 chips.
COMBOS = [
    (8000.0, 27.8e-6, 100e-6),
    (2000.0, 18.5e-6, 300e-6),
    (10000.0, 15.0e-6, 25e-6),
    (4000.0, 40.0e-6, 380e-6),
]


def square_frames(clock_hz, row_time_s, exposure_s, n=3, seed=0):
    """Noisy, unevenly lit, blooming square-wave frames."""
    rng = np.random.default_rng(seed)
    frames = []
    for _ in range(n):
        tx = make_transmitter(pattern="square", clock_hz=clock_hz, start_s=rng.uniform(0, 1e-3))
        rows = np.arange(1080)
        # Uneven band brightness: a slow random modulation of +-25 %.
        gain = 1.0 + 0.25 * np.sin(2 * np.pi * rows / rng.uniform(150, 400) + rng.uniform(0, 6))
        frame = synth_frame(
            tx, shape=(1080, 400), row_time_s=row_time_s, exposure_s=exposure_s, size=float(rng.uniform(600, 1000)),
            centre=(200 + rng.uniform(-50, 50), 540 + rng.uniform(-100, 100)), on_dn=300.0, off_dn=20.0,
            background_dn=50.0, noise_dn=20.0, poisson_scale=1.0, vignetting=0.3, gradient_dn=30.0,
            row_gain=gain, bloom_rows=1.0, rng=rng,
        )
        frames.append(frame.image)
    return frames


@pytest.mark.parametrize("clock_hz, row_time_s, exposure_s", COMBOS)
def test_row_time_within_half_a_percent(clock_hz, row_time_s, exposure_s):
    estimate, uncertainty = estimate_row_time(square_frames(clock_hz, row_time_s, exposure_s), clock_hz)
    assert estimate == pytest.approx(row_time_s, rel=0.005)
    assert 0 < uncertainty < 0.005 * row_time_s
    # The stated uncertainty is honest: the error is within a few sigma.
    assert abs(estimate - row_time_s) < 5 * uncertainty + 1e-4 * row_time_s


def test_single_frame_and_files(tmp_path):
    frames = square_frames(8000.0, 27.8e-6, 100e-6, n=1, seed=3)
    path = tmp_path / "square.png"
    cv2.imwrite(str(path), frames[0])
    from_file = estimate_row_time([path], 8000.0)
    from_array = estimate_row_time(frames, 8000.0)
    assert from_file == pytest.approx(from_array)
    assert from_array[0] == pytest.approx(27.8e-6, rel=0.005)


def test_frames_without_led_are_skipped():
    frames = square_frames(8000.0, 27.8e-6, 100e-6, n=1, seed=4)
    dark = [np.zeros((300, 300), np.uint8), np.full((300, 300), 255, np.uint8)]
    estimate, _ = estimate_row_time(dark + frames, 8000.0)
    assert estimate == pytest.approx(27.8e-6, rel=0.005)
    with pytest.raises(RowTimeError):
        estimate_row_time(dark, 8000.0)
    with pytest.raises(ValueError):
        estimate_row_time(frames, 0.0)


def test_spectral_period_of_a_sine():
    rows = np.arange(800)
    values = 100 + 50 * np.sin(2 * np.pi * rows / 9.37)
    assert spectral_period_rows(values) == pytest.approx(9.37, rel=0.01)
    assert spectral_period_rows(np.ones(8)) is None


# Rendered square-pattern frames of four cameras (rollsim's renderer, default
# effects: ambient light, shot and read noise), and a noisy, unevenly bright
# one: ISO 20000, a dim LED at the frame's top edge over a dim background
# (pixel noise about 16 DN against a stripe contrast of about 60 DN), under
# mains flicker (depth 0.5: slow bands) and cos^4 vignetting.
RENDERED = {
    "nexus5": [],
    "galaxy_s3": [],
    "iphone4s": [],
    "iphone3gs": [],
    "galaxy_s3_noisy_uneven": [
        "camera.preset=galaxy_s3", "camera.iso=20000", "led.luminous_intensity_cd=0.003",
        "environment.ambient_lux=30", "led.position_px=[1500, 300]", "effects.flicker.depth=0.5",
        "effects.vignetting=null", "effects.shot_noise.method=gaussian",
    ],
}


@pytest.mark.parametrize("camera", list(RENDERED))
def test_rendered_square_frames_of_four_cameras(camera):
    from rollsim.render import render_frames
    from rollsim.scene import load_scene

    overrides = RENDERED[camera] or [f"camera.preset={camera}"]
    scene = load_scene("paper-default", ["link.pattern=square", "link.distance_cm=8", *overrides])
    images, _ = render_frames(scene, 3)
    estimate, uncertainty = estimate_row_time(images, scene.link.clock_hz)
    assert estimate == pytest.approx(scene.camera.row_time_s, rel=0.005)
    assert abs(estimate - scene.camera.row_time_s) < 5 * uncertainty + 1e-4 * scene.camera.row_time_s


def pulse_length_frames(lengths, seed=0, rows_per_chip=4.5, n=3):
    """Frames of a pulse-length code: ON and OFF runs of random lengths (chips)."""
    rng = np.random.default_rng(seed)
    frames = []
    for _ in range(n):
        chips = []
        while len(chips) < 400:
            chips += [1] * int(rng.choice(lengths)) + [0] * int(rng.choice(lengths))
        values = profile_from_chips(chips[:400], rows_per_chip, exposure_rows=0.8, on=220, off=30, noise=3, rng=rng)[:1000]
        noisy = np.tile(values[:, None], (1, 300)) + rng.normal(0, 5, (values.size, 300))
        frames.append(np.clip(noisy, 0, 255).astype(np.uint8))
    return frames


@pytest.mark.parametrize("lengths", [(1, 3), (2, 6), (1, 2, 3)])
def test_a_pulse_length_code_gives_no_estimate(lengths):
    # 1- and 3-chip runs put every edge on a 2-chip grid, as a square wave's
    # (the regression fits); 2- and 6-chip runs on a 4-chip grid (it would
    # say half the row time). Their run lengths vary: not a square wave.
    with pytest.raises(RowTimeError, match="no frame shows a square-wave LED"):
        estimate_row_time(pulse_length_frames(lengths), 8000.0)


def test_run_lengths_of_a_square_wave_and_of_data():
    bounds = np.cumsum([0, 3, 4, 5, 4, 5, 4, 5, 4, 3])  # OFF 4, ON 5 (widened by the exposure): period 9
    values = np.array([0, 1, 0, 1, 0, 1, 0, 1, 0])
    assert runs_fit_a_square_wave(values, bounds, 9.0)
    assert not runs_fit_a_square_wave(values, bounds, 12.0)  # the runs do not add up to the period
    data = np.cumsum([0, 3, 2, 6, 6, 2, 2, 6, 2, 3])  # runs of 1 and 3 chips at 2 rows per chip
    assert not runs_fit_a_square_wave(values, data, 8.0)


def test_run_lengths_of_a_square_wave_saturated_in_its_core():
    # ON runs widen and OFF runs narrow together where the LED saturates
    # (4 + 4 rows in the halo, 6 + 2 in the core): each pair adds up to the period.
    bounds = np.cumsum([0, 3, 4, 4, 5, 3, 6, 2, 6, 2, 6, 2, 5, 3, 4, 4, 3])
    values = np.array([1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0])
    assert runs_fit_a_square_wave(values, bounds, 8.0)
    assert not runs_fit_a_square_wave(values, bounds, 10.0)
    # Whole runs of each level, none beside one of the other: no pair to add up.
    apart = np.array([1, 0, 1, -1, 0, 1, 0, -1, 1, 0, 1, -1, 0, 1, 0])
    assert not runs_fit_a_square_wave(apart, np.arange(apart.size + 1) * 4.0, 8.0)


@pytest.mark.parametrize("period_rows", [8.26, 10.37, 16.0])
def test_a_square_wave_saturated_in_its_core_gives_its_period(period_rows):
    rng = np.random.default_rng(int(period_rows * 100))
    level = core_saturated(profile_from_chips([1, 0] * int(1080 / period_rows), period_rows / 2, 0.4 * period_rows))
    values = 40.0 + 210.0 * level + rng.normal(0.0, 1.0, level.size)
    found = profile_period_rows(RowProfile(0, values, np.full(values.size, 1.0)))
    assert found is not None and found[0] == pytest.approx(period_rows, rel=0.002)


def test_a_long_clipped_period_is_read_from_its_fundamental_not_its_harmonic():
    # A saturated LED over a short region (rollsim bench fit-camera seed 5
    # camera 24): 4.2 full scales, 10.88 rows a chip, an exposure of 0.96
    # chips, 128 rows: clipped ON plateaus of ~16 rows between OFF dips of ~6.
    rows_per_chip = 10.88
    level = profile_from_chips([1, 0] * 8, rows_per_chip, 0.96 * rows_per_chip)[:128]
    rng = np.random.default_rng(24)
    values = np.clip(np.minimum(4.2 * level, 1.0) * 255.0 + rng.normal(0.0, 1.0, level.size), 0.0, 255.0)
    # The first guess's running mean (an eighth of the profile, 16 rows)
    # removes much of the 21.8-row period and little of its harmonic.
    assert spectral_period_rows(values) == pytest.approx(rows_per_chip, rel=0.05)
    assert spectral_period_rows(values, slow_fraction=1 / 4) == pytest.approx(2 * rows_per_chip, rel=0.05)
    profile = RowProfile(0, values, np.full(values.size, 1.0))
    found = profile_period_rows(profile, FEW_EDGES, full_scale_dn=255.0)
    assert found is not None and found[0] == pytest.approx(2 * rows_per_chip, rel=0.005)
    # The second guess only where the frame's full scale says the plateaus clip.
    assert profile_period_rows(profile, FEW_EDGES) is None


def test_the_second_guess_is_not_made_where_the_plateaus_do_not_clip():
    rng = np.random.default_rng(5)
    clipped = np.clip(np.tile([255.0] * 16 + [40.0] * 6, 6) + rng.normal(0, 1, 132), 0, 255)
    assert clips_long(clipped, 255.0)
    assert not clips_long(clipped, None)
    assert not clips_long(0.7 * clipped, 255.0)  # the same shape below the clip
    assert not clips_long(np.array([]), 255.0)


def test_the_cli_refuses_data_frames(tmp_path, capsys):
    from rollsim.cli import main

    out = tmp_path / "data"
    assert main(["render", "paper-default", "--frames", "2", "--out", str(out), "--quiet", "--workers", "1"]) == 0
    capsys.readouterr()
    assert main(["estimate-row-time", str(out / "frames"), "--clock-hz", "8000"]) == 2
    assert capsys.readouterr().err.strip() == "rollsim: error: no frame shows a square-wave LED to calibrate the row time from"


def _short_square_frames(n_frames: int, period_rows: float = 40.0, rows: int = 160, seed: int = 4) -> list:
    """Crops of an LED four stripe periods tall whose ends (12 rows each) are dark: six or seven edges a
    frame. The exposure is 0.4 periods (a box of 16 rows), whose ramps keep the spectrum's strongest line
    at the period in so short a profile."""
    from scipy.ndimage import uniform_filter1d

    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n_frames):
        phase = rng.uniform(0, period_rows)
        level = np.where(np.mod(np.arange(rows) + phase, period_rows) < period_rows / 2, 200.0, 30.0)
        level = uniform_filter1d(level, int(0.4 * period_rows))
        level[:12] = level[-12:] = 30.0
        out.append(np.clip(np.rint(level[:, None] + rng.normal(0, 3, (rows, 24))), 0, 255).astype(np.uint8))
    return out


def test_frames_of_six_or_seven_edges_give_the_row_time_when_most_agree():
    from decoder.rowtime import FEW_EDGES, MIN_EDGES

    frames = _short_square_frames(3, seed=49)  # a draw whose every frame reads six edges (checked below)
    edges = [profile_period_rows(RowProfile(0, f.mean(axis=1), np.full(f.shape[0], 3 / np.sqrt(24))), FEW_EDGES)
             for f in frames]
    assert all(e is not None and FEW_EDGES <= e[2] < MIN_EDGES for e in edges)  # no frame has eight
    clock_hz = 1000.0  # 40 rows a period: a row time of 50 us
    estimate, uncertainty = estimate_row_time(frames, clock_hz)
    assert estimate == pytest.approx(50e-6, rel=0.005)
    assert uncertainty > 0
    # One frame of the few edges among frames that show none is not enough.
    blank = np.full_like(frames[0], 30)
    with pytest.raises(RowTimeError):
        estimate_row_time([frames[0], blank, blank], clock_hz)


def _faint_stripes_on_a_disk(period_rows: float, rows: int = 190, rim_rows: int = 6, seed: int = 0) -> np.ndarray:
    """A row profile: a bright LED (about 108 of 255) carrying stripes of 10 levels
    (a long exposure), its disk's rim a step to a black background at both ends."""
    from scipy.ndimage import uniform_filter1d

    rng = np.random.default_rng(seed)
    phase = rng.uniform(0, period_rows)
    stripes = np.where(np.mod(np.arange(rows) + phase, period_rows) < period_rows / 2, 113.0, 103.0)
    level = uniform_filter1d(stripes, int(0.3 * period_rows))
    level[:rim_rows] = level[-rim_rows:] = 4.0
    level[rim_rows - 1] = level[-rim_rows] = 55.0  # the rim's blur
    return level + rng.normal(0.0, 0.5, rows)


@pytest.mark.parametrize("period_rows", [23.0, 29.0, 31.5])
def test_faint_stripes_between_a_disk_rim_give_their_period(period_rows):
    # The rim's step (100 levels) is ten times the stripes': within 1.5
    # periods of either end the binariser's envelope would be the rim's.
    from decoder.rowtime import led_rows

    values = _faint_stripes_on_a_disk(period_rows)
    noise = np.full(values.size, 0.5)
    rows = led_rows(values, noise)
    assert rows.start == 6 and rows.stop == values.size - 6
    found = profile_period_rows(RowProfile(0, values, noise))
    assert found is not None and found[0] == pytest.approx(period_rows, rel=0.005)


def test_a_profile_within_its_levels_keeps_every_row():
    # Dark OFF stripes on a dark background: the ends are the OFF level, not beyond it.
    from decoder.rowtime import led_rows

    values = np.where(np.mod(np.arange(200), 20) < 10, 200.0, 10.0)
    values[:7] = 10.0
    assert led_rows(values, np.full(200, 1.0)) == slice(0, 200)


def test_a_saturated_square_wave_reads_while_stripes_within_the_clip_do_not():
    """ON rows clipped at 255 and OFF rows well below read; the same stripes moved
    within CLIPPED_DN of full scale (the rows count clipped pixels, not light) do not."""
    from decoder.rowtime import CLIPPED_DN

    rng = np.random.default_rng(0)
    rows = np.arange(200)
    on = (rows % 20) < 12
    noise = np.full(rows.size, 0.3)
    clipped = RowProfile(0, np.where(on, 255.0, 140.0) + rng.normal(0, 0.3, rows.size), noise)
    found = profile_period_rows(clipped, full_scale_dn=255.0)
    assert found is not None and found[0] == pytest.approx(20.0, rel=0.005)
    near_clip = RowProfile(0, np.where(on, 255.0, 255.0 - 0.5 * CLIPPED_DN) + rng.normal(0, 0.3, rows.size), noise)
    assert profile_period_rows(near_clip) is not None  # the depth not known: read
    assert profile_period_rows(near_clip, full_scale_dn=255.0) is None


def _red_led_on_white(n_frames: int = 3, period_rows: float = 23.3, seed: int = 0) -> list:
    """A red LED's stripes (R 150–250, G and B 20: its face hides the wall) on a
    white wall (150 in every channel), the same phase in every frame (a frame
    period of whole waveform periods: nothing moves between frames)."""
    from scipy.ndimage import uniform_filter1d

    rng = np.random.default_rng(seed)
    rows, cols = 480, 640
    square = np.where(np.mod(np.arange(rows) + 7.0, period_rows) < period_rows / 2, 250.0, 150.0)
    red = uniform_filter1d(square, 5)
    image = np.full((rows, cols, 3), 150.0)
    image[40:440, 200:440, 0] = red[40:440, None]
    image[40:440, 200:440, 1:] = 20.0
    return [np.clip(np.rint(image + rng.normal(0.0, 2.0, image.shape)), 0, 255).astype(np.uint8)
            for _ in range(n_frames)]


def test_a_red_led_on_a_white_background_is_read_in_its_own_channel():
    # The mean of the channels is brighter on the wall (150) than on the LED
    # (about 80): the brightest region of that mean is the wall, of the red
    # channel the LED (200 on average).
    from decoder.region import block_means, choose_factor, detect_regions
    from decoder.rowtime import channel_blocks

    frames = _red_led_on_white()
    blocks = block_means(frames[0], choose_factor(frames[0].shape[:2]))
    brightest = detect_regions(blocks, close_rows=16.0, max_regions=1)[0]
    assert brightest.rows.start < 40 or brightest.rows.stop > 440  # the background's rows
    red = detect_regions(channel_blocks(blocks, 0), close_rows=16.0, max_regions=1)[0]
    assert red.rows.start >= 36 and red.rows.stop <= 444
    clock_hz = 2000.0  # a 1 ms period over 23.3 rows: 42.918 us a row
    estimate, _ = estimate_row_time(frames, clock_hz)
    assert estimate == pytest.approx(1e-3 / 23.3, rel=0.005)


def test_the_reading_kept_has_enough_edges_then_the_least_error():
    from decoder.rowtime import MIN_EDGES, best_reading

    few, noisy, sharp = (20.0, 0.001, MIN_EDGES - 1), (20.0, 0.5, MIN_EDGES), (20.1, 0.05, MIN_EDGES + 4)
    assert best_reading([few, noisy, sharp]) == sharp
    assert best_reading([few, noisy]) == noisy  # enough edges first
    assert best_reading([None, few]) == few
    assert best_reading([None, None]) is None


def _saturated_disk_profile(phase_chips: float, period_rows: float = 62.0, rows: int = 330) -> RowProfile:
    """A saturated LED's row profile over a few periods (ON clipped at 255, OFF at
    the black background's level), its disk's rim inside an ON run at each end."""
    level = profile_from_chips(np.tile([1.0, 0.0], 40), period_rows / 2, exposure_rows=0.3 * period_rows,
                               phase_chips=phase_chips)[:rows]
    values = np.minimum(8.0 + 600.0 * level, 255.0)
    on = np.flatnonzero(values > 250.0)
    top, bottom = on[on > 5][0] + 8, on[on < rows - 5][-1] - 8
    values[:top] = values[bottom:] = 8.0
    rng = np.random.default_rng(0)
    return RowProfile(0, values + rng.normal(0.0, 0.5, rows), np.full(rows, 0.5))


@pytest.mark.parametrize("phase_chips", [0.6, 0.8, 1.0, 1.2])
def test_a_disk_rim_inside_an_on_run_is_not_a_stripe_edge(phase_chips):
    # The rim's rise and fall lie 8 and more rows off the stripes' grid; read
    # as edges they moved the period by 1.8-4 % (rollsim bench fit-camera,
    # seed 6, camera 39: +3.45 %).
    from decoder.rowtime import FEW_EDGES

    found = profile_period_rows(_saturated_disk_profile(phase_chips), FEW_EDGES, full_scale_dn=255.0)
    assert found is not None and found[0] == pytest.approx(62.0, rel=0.001)


def _binned_profile(period_rows: float, phase_chips: float, rows: int = 70, k: int = 2, seed: int = 0) -> RowProfile:
    """A binned sensor's profile: each group of k rows exposed together, its value written to all k."""
    level = profile_from_chips(np.tile([1.0, 0.0], 200), period_rows / 2, exposure_rows=1.0,
                               phase_chips=phase_chips)[:rows]
    rng = np.random.default_rng(seed)
    groups = 10.0 + 100.0 * level[0::k] + rng.normal(0.0, 1.0, level[0::k].size)
    return RowProfile(0, np.repeat(groups, k)[:rows], np.full(rows, 1.0))


@pytest.mark.parametrize("period_rows", [5.3, 6.09])
def test_binned_rows_place_edges_between_groups(period_rows):
    # Read row by row, every edge sits on a group's edge: at 3 groups a
    # period the period moved by up to 0.8 %, at 2.65 it was not read at all.
    from decoder.rowtime import FEW_EDGES, binned_profile

    grouped, k = binned_profile(_binned_profile(period_rows, 0.0))
    assert k == 2 and grouped.values.size == 35
    for i, phase in enumerate(np.linspace(0.0, 2.0, 9)[:-1]):
        found = profile_period_rows(_binned_profile(period_rows, phase, seed=i), FEW_EDGES)
        assert found is not None and found[0] == pytest.approx(period_rows, rel=0.005)


def test_frames_combined_by_inverse_variance_where_they_agree_and_evenly_where_they_scatter():
    from decoder.rowtime import combined_period

    # Frames within their errors: the inverse-variance mean.
    periods, errors = np.array([10.0, 10.02, 9.99]), np.array([0.01, 0.02, 0.03])
    w = 1.0 / errors**2
    assert combined_period(periods, errors)[0] == pytest.approx(np.sum(w * periods) / np.sum(w))
    # Equal errors: the plain mean, whatever the scatter.
    assert combined_period(np.array([10.0, 10.5, 9.7]), np.full(3, 0.01))[0] == pytest.approx(np.mean([10.0, 10.5, 9.7]))
    # Frames scattering ten times beyond their errors: the one that happens to
    # fit best (error 0.001) no longer carries the mean.
    periods, errors = np.array([9.8, 10.0, 10.2, 10.1, 9.9, 10.3]), np.array([0.02, 0.02, 0.02, 0.02, 0.02, 0.001])
    period, sigma = combined_period(periods, errors)
    assert abs(period - periods.mean()) < 0.02 and sigma >= np.std(periods, ddof=1) / np.sqrt(periods.size)


def _lit_band(rows: int, height: int = 400, width: int = 60) -> np.ndarray:
    frame = np.full((height, width), 10, np.uint8)
    top = (height - rows) // 2
    frame[top:top + rows, 10:50] = 200
    return frame


def test_led_region_rows_measures_the_lit_rows():
    assert led_region_rows(np.zeros((300, 300), np.uint8)) == 0
    assert abs(led_region_rows(_lit_band(120)) - 120) <= 8  # a block and the profile's ends


def test_a_reading_in_one_frame_of_three_stands_only_where_the_others_show_a_short_led():
    # A period of 40 rows read in one frame: the others' LED spans 0.5 or 7.5 periods.
    found = [(40.0, 0.1, 8), None, None]
    short, tall = _lit_band(20), _lit_band(300)
    assert most_frames_agree([tall, short, short], found)  # too few periods to show the edges
    assert not most_frames_agree([tall, tall, tall], found)  # a square wave would show in them
    assert most_frames_agree([tall, tall, tall], [(40.0, 0.1, 8), (40.0, 0.1, 8), None])
