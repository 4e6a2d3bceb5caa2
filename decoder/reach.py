"""How far past a region's found rows its LED's stripes reach.

The block tests of :mod:`decoder.region` stop short of a footprint's ends:
where its stripes fade into the block noise (its dim rim, a thinning glare
halo), and a block row short of the frame's edge, where the LED runs on
past the sensor. A PHY-SDU there is lost although the row profile, which
averages a whole row of the footprint, still shows its stripes: on
paper-default with CRC-8 (300 frames), 10 of 767 fully visible PHY-SDUs,
all the first or last of a frame. So the profile is read on past each
end of the rows found as far as its stripes stand out of the noise without
a break: the squared differences over half a chip, in units of their noise
variance, summed over a window that always holds an edge of the LED's
stripes (the longest run of equal chips and one more), exceed what noise
alone exceeds once in 10 000 windows (:data:`STRIPE_FALSE_ALARM`).

Rows past that reach are not read. There the profile is background, whose
noise a sequence detector reads as chips (a background at a level between
the LED's OFF and ON levels reads as a run of confident chips), and a weak
check lets some through: reading every region 16 chips further, whatever
its rows held, read paper-default's about as well but turned the noise
above a small LED into a parity-2 undetected error (a sweep cell at 20 cm,
480 columns). So an OFF chip past the LED's last edge inside the frame is
still not claimed; at the frame's edge the stripes run on to it.

The stripe rows measured for the ROI (:func:`decoder.pipeline.inspect_frame`)
stay those of the rows found, as the emitter was fitted to them.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.special import gammainccinv

from decoder.profile import RowProfile, profile_rows

# Chips past each end of the rows found at most looked at (the rows whose
# profile is computed to find the reach): more than the 9 chips the block
# tests were seen to stop short by.
REACH_CHIPS = 16.0
# Probability that noise alone marks a window as striped. A window's sum
# of squared differences is then close to a scaled chi-square (below).
STRIPE_FALSE_ALARM = 1e-4


def striped_rows(profile: RowProfile, rows_per_chip: float, window_rows: int) -> np.ndarray:
    """Whether each row of ``profile`` lies where its stripes stand out of the noise.

    Parameters
    ----------
    profile : RowProfile
    rows_per_chip : float
        Chip pitch, rows; the differences are taken over half of it.
    window_rows : int
        Rows summed round each row.

    Returns
    -------
    ndarray of bool, shape (len(profile),)
        All False when the profile is shorter than a window and half a chip.
    """
    values, noise = profile.values, profile.noise
    lag = max(1, int(round(rows_per_chip / 2)))
    striped = np.zeros(values.size, dtype=bool)
    if values.size <= lag + window_rows:
        return striped
    variance = np.maximum(noise[lag:] ** 2 + noise[:-lag] ** 2, 1e-12)
    z2 = (values[lag:] - values[:-lag]) ** 2 / variance
    box = np.ones(window_rows)
    sums = np.convolve(z2, box, mode="same")
    # Near the ends a window holds fewer differences: at most a window's
    # worth of distinct counts, whose thresholds are computed once.
    counts = np.rint(np.convolve(np.ones(z2.size), box, mode="same")).astype(np.int64)
    over = sums > _thresholds(window_rows, lag)[counts]
    # The difference at r spans rows r to r + lag: it marks their middle,
    # and the rows at the ends no middle falls on take the nearest mark.
    offset = lag // 2
    striped[offset : offset + over.size] = over
    striped[:offset] = over[0]
    striped[offset + over.size :] = over[-1]
    return striped


@lru_cache(maxsize=64)
def _thresholds(window_rows: int, lag: int) -> np.ndarray:
    """:func:`noise_sum_threshold` of 0 to ``window_rows`` differences, by count (read-only)."""
    thresholds = noise_sum_threshold(np.arange(window_rows + 1), lag)
    thresholds.flags.writeable = False
    return thresholds


def noise_sum_threshold(counts: np.ndarray, lag: int) -> np.ndarray:
    """Level a sum of ``counts`` squared unit differences over ``lag`` rows exceeds with
    probability :data:`STRIPE_FALSE_ALARM` in white noise alone.

    Each squared difference is chi-square with one degree of freedom, and
    one ``lag`` rows on shares a row with it (correlation -1/2, so their
    squares' covariance is 1/2): the sum of m of them has mean m and
    variance 3m - lag. It is taken as a·chi-square(k) with that mean and
    variance (Satterthwaite): a = var / 2m, k = 2m² / var.
    """
    m = np.maximum(np.asarray(counts, dtype=np.float64), 1.0)
    variance = np.maximum(3.0 * m - lag, 2.0 * m)
    scale, dof = variance / (2.0 * m), 2.0 * m * m / variance
    return scale * 2.0 * gammainccinv(dof / 2.0, STRIPE_FALSE_ALARM)


def striped_ends(profile: RowProfile, rows_per_chip: float, window_rows: int) -> tuple[bool, bool]:
    """Whether the stripes reach the first and the last whole window of ``profile``.

    Where they do not, the LED's stripes end inside the rows found, and no
    row past that end is worth reading (so its profile is not computed).
    Only the rows the two windows need are looked at.
    """
    half, n = window_rows // 2, len(profile)
    if n <= 4 * window_rows:
        striped = striped_rows(profile, rows_per_chip, window_rows)
        return (bool(striped[min(half, n - 1)]), bool(striped[max(n - 1 - half, 0)])) if n else (False, False)
    first, last = profile.first_row, profile.first_row + n
    top = striped_rows(profile_rows(profile, slice(first, first + 2 * window_rows)), rows_per_chip, window_rows)
    bottom = striped_rows(profile_rows(profile, slice(last - 2 * window_rows, last)), rows_per_chip, window_rows)
    return bool(top[half]), bool(bottom[-1 - half])


def striped_reach(profile: RowProfile, found_rows: slice, rows_per_chip: float, window_rows: int) -> tuple[int, int]:
    """Rows (above, below) past ``found_rows`` (frame rows) over which ``profile`` still shows stripes.

    The striped rows (:func:`striped_rows`) that run on without a break
    from each end of the rows found, within the profile; each end's rows
    are looked at with two windows' rows of the found ones for context.
    """
    start, stop = profile.first_row, profile.first_row + len(profile)
    above = found_rows.start - start
    below = stop - found_rows.stop
    # Two windows of context: every window centred on a row looked at lies
    # inside, and the part is longer than striped_rows's least.
    context = 2 * window_rows
    top = striped_rows(profile_rows(profile, slice(start, found_rows.start + context)), rows_per_chip,
                       window_rows)[:above] if above > 0 else np.zeros(0, dtype=bool)
    bottom = striped_rows(profile_rows(profile, slice(found_rows.stop - context, stop)), rows_per_chip,
                          window_rows)[-below:] if below > 0 else np.zeros(0, dtype=bool)
    return _reach(top[::-1], window_rows), _reach(bottom, window_rows)


def _reach(striped: np.ndarray, window_rows: int) -> int:
    """Rows reached over ``striped`` (flags from an end outward).

    A window's sum marks its middle row, so rows marked spill half a window
    past the last edge: a run that ends before the flags do is cut back by
    that much. One that runs to their end (the frame's edge, or the rows
    looked at) has no spill to cut.
    """
    run = _leading_true(striped)
    return run if run == striped.size else max(0, run - window_rows // 2)


def _leading_true(flags: np.ndarray) -> int:
    """Count of the True values ``flags`` starts with."""
    breaks = np.flatnonzero(~flags)
    return int(breaks[0]) if breaks.size else int(flags.size)
