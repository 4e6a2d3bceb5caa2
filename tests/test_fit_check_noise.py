"""The fit's check compares the LED's temporal noise of frames and a render at the same levels."""

import math

import numpy as np
import pytest

from rollsim.fit.check import bright_level_floor, bright_rows_noise


def _points(n_bright: int, n_dark: int) -> tuple[np.ndarray, np.ndarray]:
    # One camera's noise through sRGB: bright rows (level 240) 2.5 levels of
    # noise, dark rows (level 12, on the curve's steep toe) 5 levels.
    levels = np.concatenate([np.full(n_bright, 240.0), np.full(n_dark, 12.0)])
    variances = np.concatenate([np.full(n_bright, 2.5**2), np.full(n_dark, 5.0**2)])
    return levels, variances


def test_a_render_is_read_at_the_frames_levels_not_its_own_brightest_quarter():
    frames = _points(40, 80)  # a third of the rows bright: their brightest quarter is all bright
    render = _points(20, 100)  # the same camera, fewer rows holding one bright level in two frames
    assert bright_rows_noise(*frames) == pytest.approx(2.5)
    # Its own brightest quarter reaches down into the dark rows (its 75th
    # percentile is the dark level): every row counts.
    assert bright_rows_noise(*render) == pytest.approx(math.sqrt((20 * 2.5**2 + 100 * 5.0**2) / 120))
    # At the frames' floor the same camera shows the same noise.
    floor = bright_level_floor(frames[0])
    assert floor == 240.0
    assert bright_rows_noise(*render, floor) == pytest.approx(2.5)


def test_no_points_at_the_frames_levels_is_no_noise_there():
    levels, variances = _points(0, 30)
    assert bright_rows_noise(levels, variances, 240.0) == 0.0
    assert bright_level_floor(np.zeros(0)) == math.inf
    assert bright_rows_noise(np.zeros(0), np.zeros(0)) == 0.0
