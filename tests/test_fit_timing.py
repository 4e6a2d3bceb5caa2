"""The fit's check renders its frames at the frames' own stripe phases: one frame period and
one waveform start that put every rendered frame's stripes where the frames have them."""

import math

import numpy as np
import pytest

from rollsim.bench.fit_camera import HiddenCamera, hidden_scene
from rollsim.fit.check import MAX_TIMING_RESIDUAL_PERIODS, aligned_shift, matched_timing, wrapped
from rollsim.render import render_frames

# A 320x240 frame filled by the LED; stripes of 2 / (clock · row time) = 5.7 rows,
# short enough that a profile interpolated by half a row is visibly blurred.
CAMERA = HiddenCamera(index=0, width_px=320, height_px=240, row_time_us=35.0, exposure_chips=0.6, clock_hz=10000.0,
                      on_full_scales=0.6, led_diameter_px=360.0, led_x_px=160.0, led_y_px=120.0,
                      background_full_scales=0.0, binning_rows=1, jpeg_quality=None, colour=False, iso=400.0,
                      read_noise_e=2.0, srgb=False, smoothing_rows=0.0, seed=5)


def _shifts_rows(scene, start_periods, step_periods, n):
    """Shifts (rows) of frames whose stripes sit ``start + i·step`` periods on, wrapped into ±P/2."""
    period_rows = 2.0 / (scene.link.clock_hz * scene.camera.row_time_us * 1e-6)
    return list(wrapped(start_periods + step_periods * np.arange(n)) * period_rows)


def test_the_timing_that_explains_the_shifts_is_found_in_closed_form():
    scene = hidden_scene(CAMERA)
    wave_s = 2.0 / scene.link.clock_hz
    timed = matched_timing(scene, _shifts_rows(scene, 0.3, -0.27, 6))
    # δ = −0.27 W is taken as 0.73 W, so that the frame period grows.
    assert 1.0 / timed.camera.frame_rate_hz == pytest.approx(1.0 / scene.camera.frame_rate_hz + 0.73 * wave_s,
                                                             rel=1e-12)
    assert timed.link.start_offset_us == pytest.approx(scene.link.start_offset_us - 0.3 * wave_s * 1e6, abs=1e-9)
    # Nothing else moves.
    assert timed.camera.row_time_us == scene.camera.row_time_us
    assert timed.camera.exposure_us == scene.camera.exposure_us
    assert timed.effects == scene.effects


def test_frames_taken_at_no_one_rate_are_left_as_they_are():
    scene = hidden_scene(CAMERA)
    period_rows = 2.0 / (scene.link.clock_hz * scene.camera.row_time_us * 1e-6)
    phases = np.array([0.0, 0.31, -0.12, 0.45, 0.2, -0.36])  # no start and step within 0.1 period
    assert matched_timing(scene, list(phases * period_rows)) is None
    # One frame always fits; none gives nothing to fit.
    assert matched_timing(scene, [0.4 * period_rows]) is not None
    assert matched_timing(scene, []) is None
    assert MAX_TIMING_RESIDUAL_PERIODS < 0.25  # random phases must not pass as one rate


def _profiles(scene, n):
    images, _ = render_frames(scene, n)
    return [np.asarray(im, dtype=np.float64)[20:220, 100:220].mean(axis=1) for im in images]


def test_a_render_at_another_frame_rate_is_retimed_onto_the_frames_stripes():
    frames_scene = hidden_scene(CAMERA)
    # The same camera rendered at another frame rate and with other noise: its
    # stripes sit at other phases, frame by frame.
    other = frames_scene.model_copy(update={
        "camera": frames_scene.camera.model_copy(update={"frame_rate_hz": 23.7}),
        "seed": frames_scene.seed + 1})
    n = 4
    period_rows = 2.0 / (CAMERA.clock_hz * CAMERA.row_time_us * 1e-6)
    frames = _profiles(frames_scene, n)
    before = [aligned_shift(a, b, period_rows) for a, b in zip(frames, _profiles(other, n))]
    assert max(abs(s) for _, s in before) > 0.5  # fractions of a period apart
    timed = matched_timing(other, [s for _, s in before])
    after = [aligned_shift(a, b, period_rows) for a, b in zip(frames, _profiles(timed, n))]
    # Within the shift search's step of the frames' own phases, and no longer
    # blurred by interpolation.
    assert all(abs(s) <= 0.15 for _, s in after)
    assert min(r for r, _ in after) > 0.99
    assert min(r for r, _ in after) > min(r for r, _ in before)


def test_the_shift_search_keeps_the_unshifted_profile_on_a_tie():
    wave = (np.sin(2 * math.pi * np.arange(200) / 10.0) > 0).astype(float)
    r, shift = aligned_shift(wave, wave, 10.0)
    assert r == pytest.approx(1.0) and shift == 0.0
    r, shift = aligned_shift(wave, np.roll(wave, 3), 10.0)  # b's stripes 3 rows later
    assert r == pytest.approx(1.0) and shift == pytest.approx(3.0)

