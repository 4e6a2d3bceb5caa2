"""decoder.binning: binned rows found from their steps; aliased periods refused, binned ones read."""

import numpy as np
import pytest
from synth import profile_from_chips

from decoder.binning import binned_groups, profile_binning
from decoder.profile import RowProfile
from decoder.rowtime import MAX_PERIOD_MISMATCH, _period_mismatch_ratio, period_lags, profile_period_rows, without_envelope


def binned(values: np.ndarray, k: int, offset: int = 0) -> np.ndarray:
    """Each group of k rows (starting at ``offset``) given its first row's value, as a binned readout writes it."""
    out = values.copy()
    starts = np.arange(offset, values.size, k)
    for j in range(1, k):
        rows = starts + j
        rows = rows[rows < values.size]
        out[rows] = values[rows - j]
    return out


def square_profile(period_rows: float, rows: int = 600, exposure_rows: float = 1.5, noise: float = 0.0, seed: int = 0):
    chips = (np.arange(int(2 * rows / period_rows) + 8) % 2 == 0).astype(float)
    rng = np.random.default_rng(seed)
    return profile_from_chips(chips, period_rows / 2, exposure_rows, phase_chips=0.37, on=200.0, off=20.0,
                              noise=noise, rng=rng)[:rows]


@pytest.mark.parametrize("k,offset", [(2, 0), (2, 1), (3, 2), (4, 1)])
def test_groups_and_their_offset_are_found(k, offset):
    values = binned(square_profile(23.7, noise=0.5), k, offset)
    steps = np.abs(np.diff(values))
    assert binned_groups(steps) == (k, offset)
    assert profile_binning(values) == k


def test_unbinned_rows_and_flat_profiles_are_not_binned():
    assert profile_binning(square_profile(23.7, noise=0.5)) == 1
    assert binned_groups(np.zeros(100)) == (1, 0)  # no step anywhere: nothing to tell groups by
    assert profile_binning(np.arange(5.0)) == 1  # too short for a group of two


def _profile(values):
    return RowProfile(first_row=0, values=values, noise=np.full(values.size, 0.5))


@pytest.mark.parametrize("period_rows", [9.1, 13.3, 24.6])
def test_binned_square_waves_are_read(period_rows):
    # Rows compared a whole number of groups apart: an odd lag would set a
    # group's first row against another's second.
    found = profile_period_rows(_profile(binned(square_profile(period_rows, noise=0.5), 2)))
    assert found is not None
    assert found[0] == pytest.approx(period_rows, rel=0.005)


@pytest.mark.parametrize("period_rows,k", [(4.6, 2), (6.9, 3)])
def test_periods_under_two_and_a_half_groups_are_refused(period_rows, k):
    """Sampled fewer than 2.5 times a period, a stripe aliases: no answer rather than a wrong one."""
    assert profile_period_rows(_profile(binned(square_profile(period_rows, noise=0.5), k))) is None


def test_binned_pairs_blurred_past_detection_are_still_read():
    """Demosaicing or JPEG makes a binned pair's rows differ: the binning is not seen, but even shifts still
    set a group against a group."""
    rng = np.random.default_rng(4)
    values = binned(square_profile(9.2, exposure_rows=0.5), 2)  # sharp edges: a group's rows matter
    # A pair's second row partly interpolated from the next group's, as a
    # Bayer mosaic's demosaicing does on the rows of its other colour.
    values[1:-1:2] = 0.6 * values[1:-1:2] + 0.4 * values[2::2][:values[1:-1:2].size]
    values = values + rng.normal(0.0, 0.5, values.size)
    assert profile_binning(values) == 1
    assert 18 in period_lags(9.2, values.size) and 28 in period_lags(9.2, values.size)
    found = profile_period_rows(_profile(values))
    assert found is not None and found[0] == pytest.approx(9.2, rel=0.005)
    # Nine rows on, a group's first row meets a group's second: that shift alone would refuse it.
    detrended = without_envelope(values, 9.2)
    noise_var = 1.5 * 0.5**2
    assert _period_mismatch_ratio(detrended, 9, noise_var) > MAX_PERIOD_MISMATCH
    assert _period_mismatch_ratio(detrended, 18, noise_var) <= MAX_PERIOD_MISMATCH


def test_period_lags_are_whole_groups_within_half_a_row():
    assert period_lags(9.2, 600) == [9, 18, 28, 37]
    assert period_lags(9.2, 600, binning=2) == [18, 28]
    assert period_lags(10.0, 600, binning=4) == [20, 40]
    assert period_lags(9.2, 20) == [9]  # one period: under a third of the rows or not, the nearest
