"""Normalisation and binarisation of a row profile.

The ON and OFF levels drift along the profile: vignetting, blooming, an
ambient gradient, the sensor's response. So the threshold is local: the
midpoint of a running upper and lower envelope over a window of a few chips
(long enough that every window holds both levels). The profile is then
normalised to q = (value − mid) / (gap / 2), about +1 on ON rows and −1 on
OFF rows.

Rows whose envelope gap is below ``min_contrast`` noise sigmas carry no
information (outside the LED, a flat area, pure noise): they are erasures
(level −1), never bits. Levels switch with hysteresis at q = ±``hysteresis``
so that noise near the threshold does not make one-row glitches. An ON or
OFF run that stays far from its envelope (mean |q| below
:data:`MIN_RUN_MEAN_Q`) is not chips either and is erased.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d, maximum_filter1d, minimum_filter1d, uniform_filter1d

# Gap between the envelopes, in noise sigmas of one row, below which a row
# is an erasure. The envelopes of pure noise over a 40-row window lie about
# 4.5 sigma apart.
MIN_CONTRAST_SIGMA = 8.0
# Switching threshold on q: low enough that isolated chips seen through an
# exposure of ~1.3 chips (peak |q| ≈ 0.35) still switch.
HYSTERESIS = 0.2
# A run of chips must average at least this |q|. Isolated chips average about
# 0.48 with an exposure of 0.8 chip, 0.3 with 1.2 chips (0.2 with 1.44).
MIN_RUN_MEAN_Q = 0.25
# ON runs averaging at least this q certainly show the LED: they bound the
# rows a whole PHY-SDU must lie in.
CONFIDENT_RUN_MEAN_Q = 0.45


@dataclass(frozen=True)
class Binarized:
    """Levels of a row profile.

    Attributes
    ----------
    level : ndarray of int8, shape (n,)
        1 (ON), 0 (OFF) or -1 (erasure) for each row.
    q : ndarray of float64, shape (n,)
        Normalised profile: +1 at the upper envelope, -1 at the lower one,
        0 on erased rows.
    threshold : ndarray of float64, shape (n,)
        The midpoint of the envelopes each row was compared with, in the
        profile's units.
    half_gap : ndarray of float64, shape (n,)
        Half the gap between the envelopes (profile's units): one unit of q.
    """

    level: np.ndarray
    q: np.ndarray
    threshold: np.ndarray
    half_gap: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        return self.level >= 0


def envelopes(values: np.ndarray, window_rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Smoothed running maximum and minimum of a profile.

    Parameters
    ----------
    values : ndarray, shape (n,)
    window_rows : int
        Window length in rows; should span a few chips, more than twice
        the longest run of equal chips.

    Returns
    -------
    upper, lower : ndarray of float64, shape (n,)
    """
    window = max(1, int(window_rows))
    upper = maximum_filter1d(values, window, mode="nearest")
    lower = minimum_filter1d(values, window, mode="nearest")
    # The running extremes are staircases; a box of the same length
    # smooths them without pulling them past the levels.
    return uniform_filter1d(upper, window, mode="nearest"), uniform_filter1d(lower, window, mode="nearest")


def hysteresis_levels(q: np.ndarray, valid: np.ndarray, threshold: float = HYSTERESIS) -> np.ndarray:
    """Two-level hysteresis of ``q``, vectorised.

    A row is ON once q rose above +threshold, OFF once it fell below
    −threshold, and keeps the last state in between. Invalid rows are −1
    and reset the state; rows before the first decision are −1 too.
    """
    n = q.size
    rows = np.arange(n)
    high = valid & (q > threshold)
    low = valid & (q < -threshold)
    event = high | low | ~valid
    event_value = np.where(high, 1, np.where(low, 0, -1)).astype(np.int8)
    last_event = np.maximum.accumulate(np.where(event, rows, -1))
    return np.where(last_event >= 0, event_value[np.maximum(last_event, 0)], -1).astype(np.int8)


def erase_weak_runs(level: np.ndarray, q: np.ndarray, min_mean: float, min_rows: float) -> np.ndarray:
    """Erase ON/OFF runs that never get near their envelope.

    A run of real chips spends most of its rows near ±1 (its envelope); a run
    whose mean |q| stays below ``min_mean`` is something else, e.g. a
    background about as bright as the midpoint next to the footprint, read
    as bits by noise. Runs shorter than ``min_rows`` are left alone (noise
    glitches, merged later by :func:`decoder.timing.merge_glitches`).

    Returns
    -------
    ndarray of int8
        The levels, with weak runs set to -1.
    """
    if level.size == 0:
        return level
    starts, lengths = _segments(level)
    mean_abs = np.add.reduceat(np.abs(q), starts) / lengths
    weak = (level[starts] >= 0) & (lengths >= min_rows) & (mean_abs < min_mean)
    if not weak.any():
        return level
    return np.where(np.repeat(weak, lengths), -1, level).astype(np.int8)


def _segments(level: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start row and length of each run of equal levels."""
    starts = np.concatenate([[0], np.flatnonzero(level[1:] != level[:-1]) + 1])
    return starts, np.diff(np.concatenate([starts, [level.size]]))


def confident_on_span(level: np.ndarray, q: np.ndarray, min_mean: float = CONFIDENT_RUN_MEAN_Q) -> tuple[int, int] | None:
    """First and last row of the ON runs that clearly reach the ON envelope.

    These bound the rows where the LED is surely seen; outside them, rows
    may be background read as bits.

    Returns
    -------
    (first_row, last_row) or None
        None if no ON run averages at least ``min_mean`` in q.
    """
    if level.size == 0:
        return None
    starts, lengths = _segments(level)
    mean_q = np.add.reduceat(q, starts) / lengths
    confident = np.flatnonzero((level[starts] == 1) & (mean_q >= min_mean))
    if confident.size == 0:
        return None
    first, last = confident[0], confident[-1]
    return int(starts[first]), int(starts[last] + lengths[last] - 1)


def smooth_profile(values: np.ndarray, smooth_rows: float) -> np.ndarray:
    """Gaussian smoothing of a profile, sigma ``smooth_rows`` rows (none below 0.3 row)."""
    if smooth_rows < 0.3:
        return values
    return gaussian_filter1d(values, smooth_rows, mode="nearest", truncate=3.0)


def binarize_profile(
    values: np.ndarray,
    noise: np.ndarray,
    window_rows: int,
    smooth_rows: float = 0.0,
    min_contrast: float = MIN_CONTRAST_SIGMA,
    hysteresis: float = HYSTERESIS,
    min_run_rows: float | None = None,
) -> Binarized:
    """Binarise a row profile against its local envelopes.

    Parameters
    ----------
    values : ndarray, shape (n,)
        Row means.
    noise : ndarray or float
        Noise sigma of each row mean.
    window_rows : int
        Envelope window in rows (see :func:`envelopes`).
    smooth_rows : float
        Sigma in rows of a Gaussian smoothing applied first (about a sixth
        of a chip: it averages noise without moving edges); 0 for none.
    min_contrast : float
        Envelope gap, in noise sigmas, below which a row is erased.
    hysteresis : float
        Switching threshold on the normalised profile.
    min_run_rows : float, optional
        Runs at least this long (rows, about half a chip) whose mean |q| is
        below :data:`MIN_RUN_MEAN_Q` are erased (see :func:`erase_weak_runs`).

    Returns
    -------
    Binarized
    """
    values = np.asarray(values, dtype=np.float64)
    if values.size == 0:
        return Binarized(np.zeros(0, np.int8), np.zeros(0), np.zeros(0), np.zeros(0))
    smooth = smooth_profile(values, smooth_rows)
    upper, lower = envelopes(smooth, window_rows)
    half_gap = 0.5 * (upper - lower)
    valid = 2.0 * half_gap > min_contrast * np.broadcast_to(noise, values.shape)
    q = np.divide(smooth - 0.5 * (upper + lower), half_gap, out=np.zeros_like(smooth), where=valid)
    level = hysteresis_levels(q, valid, hysteresis)
    if min_run_rows is not None:
        level = erase_weak_runs(level, q, MIN_RUN_MEAN_Q, min_run_rows)
    return Binarized(level, np.where(level >= 0, q, 0.0), 0.5 * (upper + lower), half_gap)
