"""Where a time falls in the cycles of a clock, exact to rounding.

A clock of rate f started at t0 is in cycle floor((t - t0)·f) at time t, a
fraction of the way through it. The position u = (t - t0)·f is carried as
an unevaluated sum of two floats (error-free TwoSum and TwoProduct), so the
fraction is exact to rounding even hours into a run, where u alone would
lose ten digits. The LED's chip clock (:mod:`rollsim.transmitter.waveform`)
and the mains flicker (:mod:`rollsim.sensor.flicker`) both count cycles
with it; it depends on nothing else in rollsim.
"""

from __future__ import annotations

import numpy as np

_SPLITTER = 134217729.0  # 2**27 + 1, Veltkamp's constant for float64


def _two_sum(a, b):
    """a + b = s + e exactly (Knuth's TwoSum)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _split(a):
    c = _SPLITTER * a
    hi = c - (c - a)
    return hi, a - hi


def _two_product(a, b):
    """a · b = p + e exactly (Dekker's TwoProduct, no FMA needed)."""
    p = a * b
    a_hi, a_lo = _split(a)
    b_hi, b_lo = _split(b)
    return p, ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo


def chip_position(t_s, start_s: float, clock_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Cycle (chip) index and elapsed fraction of the cycle at times ``t_s``, exact to rounding.

    Parameters
    ----------
    t_s : array_like of float
        Times in seconds.
    start_s : float
        Start of chip 0, in seconds.
    clock_hz : float
        Chip rate in Hz.

    Returns
    -------
    chip : ndarray of int64
        floor((t - start)·f).
    frac : ndarray of float64
        (t - start)·f - chip, in [0, 1), with an absolute error of a few
        units of 1e-16 whatever the size of t.
    """
    x_hi, x_lo = _two_sum(np.asarray(t_s, dtype=np.float64), -float(start_s))
    p, e = _two_product(x_hi, float(clock_hz))
    u_hi, u_lo = _two_sum(p, e + x_lo * clock_hz)
    chip = np.floor(u_hi)
    chip = chip - ((u_hi == chip) & (u_lo < 0))
    frac = (u_hi - chip) + u_lo
    return chip.astype(np.int64), frac
