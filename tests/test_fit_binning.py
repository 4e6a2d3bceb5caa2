"""Binned readout seen through the camera's processing: JPEG, demosaicing, smoothing."""

import cv2
import numpy as np
import pytest

from decoder.binning import binned_groups
from rollsim.fit.binning import JPEG_BLOCK_ROWS, detect_binning, paired_steps, row_steps
from rollsim.render import render_frames
from rollsim.scene import load_scene


def _jpeg(frame: np.ndarray, quality: int) -> np.ndarray:
    ok, data = cv2.imencode(".jpg", np.clip(np.rint(frame), 0, 255).astype(np.uint8),
                            [cv2.IMWRITE_JPEG_QUALITY, quality])
    assert ok
    return cv2.imdecode(data, cv2.IMREAD_UNCHANGED).astype(np.float64)


def _striped_frames(rng, binning: int, offset: int = 0, n_frames: int = 4, shape=(240, 64)) -> list[np.ndarray]:
    """Noisy frames of moving stripes (a 17.3-row period), rows read in groups of ``binning`` from row ``offset``."""
    rows = np.arange(shape[0] + binning)
    out = []
    for f in range(n_frames):
        stripes = 100 + 60 * (np.mod(rows + 5.1 * f, 17.3) < 8.65)
        frame = stripes[:, None] + rng.normal(0, 4, (rows.size, shape[1]))
        if binning > 1:  # each group's mean written to all its rows
            groups = frame[: (rows.size // binning) * binning].reshape(-1, binning, shape[1]).mean(axis=1)
            frame = np.repeat(groups, binning, axis=0)
        out.append(frame[binning - offset if offset else 0:][: shape[0]])
    return out


def test_paired_steps_counts_the_pairs_by_exact_enumeration():
    # Steps alternating small (within) and large (across) from step 0.
    steps = np.tile([1.0, 3.0], 50)
    fraction, offset, pairs = paired_steps(steps)
    assert (fraction, offset) == (1.0, 0)
    # 99 steps give 49 pairs at offset 0; those holding step 7 mod 8 are left out.
    within = np.arange(0, 99, 2)
    within = within[within + 1 < 100]
    clear = (within % JPEG_BLOCK_ROWS != JPEG_BLOCK_ROWS - 1) & ((within + 1) % JPEG_BLOCK_ROWS != JPEG_BLOCK_ROWS - 1)
    assert pairs == int(clear.sum())
    # Ties are not decided: flat rows give no pairs and no binning.
    assert paired_steps(np.zeros(100)) == (0.5, 0, 0)
    assert detect_binning([np.full((100, 8), 255.0)] * 3) == (1, 0)


@pytest.mark.parametrize("quality", [60, 75, 90, 100])
@pytest.mark.parametrize("offset", [0, 1])
def test_jpeg_binned_rows_are_detected(quality, offset):
    rng = np.random.default_rng(quality + offset)
    frames = [_jpeg(f, quality) for f in _striped_frames(rng, 2, offset)]
    assert detect_binning(frames) == (2, offset)


@pytest.mark.parametrize("quality", [60, 75, 90, 100])
def test_jpeg_rows_without_binning_are_not_read_as_binned(quality):
    rng = np.random.default_rng(quality)
    frames = [_jpeg(f, quality) for f in _striped_frames(rng, 1)]
    assert detect_binning(frames) == (1, 0)
    fraction, _, pairs = paired_steps(row_steps(frames))
    assert pairs > 60 and fraction < 0.8


def test_the_order_of_steps_finds_what_identical_groups_miss():
    # JPEG's error makes the binned rows differ: the ratio of steps misses the
    # groups, their order does not.
    rng = np.random.default_rng(5)
    frames = [_jpeg(f, 70) for f in _striped_frames(rng, 2)]
    assert binned_groups(row_steps(frames)) == (1, 0)
    assert detect_binning(frames) == (2, 0)


def test_a_binned_colour_camera_through_jpeg_is_fitted_binned():
    # Bayer colour, demosaiced, JPEG 85, binned by 2: the fit reads the
    # binning on the luminance and renders it.
    from rollsim.fit import fit_camera

    overrides = ["link.pattern=square", "link.clock_hz=4000", "seed=5", "camera.width_px=480",
                 "camera.height_px=360", "camera.row_time_us=31.7", "camera.exposure_us=140", "camera.iso=4000",
                 "led.size_mm=2.4", "led.position_px=[250.3,170.6]", "led.luminous_intensity_cd=0.0012",
                 "camera.binning_rows=2", "camera.output=rgb8", "effects.bayer.pattern=RGGB",
                 "effects.tone_curve.curve=srgb", "effects.jpeg.quality=85"]
    hidden = load_scene("paper-geometric", overrides)
    images, _ = render_frames(hidden, 4)
    fit = fit_camera([np.asarray(im) for im in images], hidden.link.clock_hz, load_scene("paper-geometric", []))
    assert fit.estimates["binning_rows"].value == 2 and fit.scene.camera.binning_rows == 2
    assert fit.estimates["row_time_us"].value == pytest.approx(hidden.camera.row_time_s * 1e6, rel=0.005)


def test_jpeg_and_smoothing_without_binning_stay_unbinned_at_every_block_place():
    # Rendered frames without binning, through GRBG demosaicing, smoothing of
    # a row and JPEG 60: JPEG's error orders pairs of steps in most of the
    # pairs taken together (0.90 of them), but not at every place in its
    # blocks, as binning does.
    overrides = ["link.pattern=square", "link.clock_hz=4000", "seed=1", "camera.width_px=480", "camera.height_px=360",
                 "camera.row_time_us=31.7", "camera.exposure_us=140", "camera.iso=4000", "led.size_mm=2.4",
                 "led.position_px=[250.3,170.6]", "led.luminous_intensity_cd=0.0012", "camera.output=rgb8",
                 "effects.bayer.pattern=GRBG", "effects.tone_curve.curve=srgb", "effects.jpeg.quality=60",
                 "effects.isp_smoothing.sigma_rows_px=1.0"]
    images, _ = render_frames(load_scene("paper-geometric", overrides), 4)
    luminance = [np.asarray(im, dtype=np.float64) @ np.array([0.299, 0.587, 0.114]) for im in images]
    fraction, _, pairs = paired_steps(row_steps(luminance))
    assert pairs > 100 and fraction < 0.85
    assert detect_binning(luminance) == (1, 0)


def _model_profiles(binning: tuple[int, int], seed: int, smoothing_rows: float = 0.0) -> tuple[np.ndarray, list]:
    """Four frames' row profiles of the stripe model (period 17.5 rows, exposure 7.7 rows, levels 40 and 200),
    at four phases, with noise of 0.5 levels."""
    from rollsim.fit.stripes import stripe_profile

    rng = np.random.default_rng(seed)
    rows = np.arange(100, 400)
    profiles = [stripe_profile(rows, 17.5, 3.1 + 4.3 * f, 7.7, smoothing_rows, 1.0, 200 / 255, 40 / 255,
                               binning=binning) + rng.normal(0, 0.5, rows.size) for f in range(4)]
    return rows, profiles


@pytest.mark.parametrize("offset", [0, 1])
def test_stripes_edges_in_steps_of_two_rows_read_as_binned(offset):
    # The model's own binned profiles: the unbinned model leaves a residual
    # of the staircase, the binned one (at the right offset) only the noise.
    from rollsim.fit.binning import BINNED_RESIDUAL_RATIO, binned_if_nearer
    from rollsim.fit.stripes import fit_stripes

    rows, profiles = _model_profiles((2, offset), seed=offset)
    unbinned = fit_stripes(profiles, rows, 17.5)
    fit, binning, ratio = binned_if_nearer(unbinned, profiles, rows, 17.5)
    assert binning == (2, offset) and ratio == pytest.approx(fit.rms_residual / unbinned.rms_residual)
    assert fit.rms_residual <= BINNED_RESIDUAL_RATIO * unbinned.rms_residual
    assert fit.rms_residual == pytest.approx(0.5, rel=0.2)  # the noise
    assert fit.exposure_rows == pytest.approx(7.7, abs=0.1)


@pytest.mark.parametrize("smoothing_rows", [0.0, 1.5])
def test_stripes_of_an_unbinned_camera_stay_unbinned(smoothing_rows):
    from rollsim.fit.binning import BINNED_RESIDUAL_RATIO, binned_if_nearer
    from rollsim.fit.stripes import fit_stripes

    rows, profiles = _model_profiles((1, 0), seed=7, smoothing_rows=smoothing_rows)
    unbinned = fit_stripes(profiles, rows, 17.5)
    fit, binning, ratio = binned_if_nearer(unbinned, profiles, rows, 17.5)
    assert binning == (1, 0) and fit is unbinned and ratio > BINNED_RESIDUAL_RATIO


@pytest.mark.parametrize("offset", [0, 1])
def test_a_given_binning_finds_its_groups_first_row(offset):
    # Binning told (fit-camera --binning-rows 2), its groups' first row not:
    # started from groups at row 0, the stripes' fit at the right offset
    # leaves only the noise, the other the staircase's misfit. The exposure
    # is read up to the reflection E <-> P - E (the refinement's choice).
    from rollsim.fit.binning import nearest_offset
    from rollsim.fit.stripes import fit_stripes

    rows, profiles = _model_profiles((2, offset), seed=3 + offset, smoothing_rows=0.6)
    from_row_0 = fit_stripes(profiles, rows, 17.5, binning=(2, 0))
    fit, binning = nearest_offset(from_row_0, profiles, rows, 17.5, 2)
    assert binning == (2, offset)
    assert fit.rms_residual == pytest.approx(0.5, rel=0.2)  # the noise
    assert min(abs(fit.exposure_rows - 7.7), abs(fit.exposure_rows - (17.5 - 7.7))) < 0.15
    assert nearest_offset(from_row_0, profiles, rows, 17.5, 1) == (from_row_0, (1, 0))
    if offset == 0:
        assert fit is from_row_0  # kept as fitted, not fitted again
