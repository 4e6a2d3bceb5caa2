"""The LED waveform s(t) and its exact cumulative integral S(t).

s(t) is piecewise constant: chip c occupies [t0 + c·T_c, t0 + (c+1)·T_c) with
T_c = 1/f, at level ``on_level`` if the chip is ON and ``off_level`` if OFF
(relative intensity, ON = 1 by default). t0 is the transmitter's phase against
frame 0 (``link.start_offset_us``).

The exposure of a window is ∫ s dt over it. It is computed exactly from the
chip source's integer count of ON chips, never by sampling time, as a
difference of integers plus two fractional chips. The chip position
u = (t - t0)·f is carried as an unevaluated sum of two floats (error-free
TwoSum and TwoProduct), so the fraction of a chip is exact to rounding even
hours into a run, where u alone would lose ten digits: a 100 µs window keeps
12 significant digits at any time.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

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
    """Chip index and elapsed chip fraction of times ``t_s``, exact to rounding.

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


@dataclass(frozen=True)
class Waveform:
    """A chip sequence sent at ``clock_hz`` from time ``start_s``.

    Parameters
    ----------
    chips : chip source
        See :mod:`rollsim.transmitter.chips`.
    clock_hz : float
        Chip rate f in Hz.
    start_s : float
        Time t0 at which chip 0 starts, in seconds.
    on_level, off_level : float
        Relative LED intensity of ON and OFF chips.
    """

    chips: Any
    clock_hz: float
    start_s: float = 0.0
    on_level: float = 1.0
    off_level: float = 0.0

    def __post_init__(self):
        if not self.clock_hz > 0:
            raise ValueError(f"clock_hz must be > 0, got {self.clock_hz}")

    @property
    def chip_period_s(self) -> float:
        return 1.0 / self.clock_hz

    def chip_position(self, t_s) -> tuple[np.ndarray, np.ndarray]:
        """Chip index and the fraction [0, 1) of that chip elapsed at times ``t_s``."""
        return chip_position(t_s, self.start_s, self.clock_hz)

    def chip_index(self, t_s) -> np.ndarray:
        """Index of the chip being sent at times ``t_s`` (int64)."""
        return self.chip_position(t_s)[0]

    def chip_level(self, chip) -> np.ndarray:
        """Relative LED intensity of chips ``chip`` (int64 indices)."""
        return np.where(self.chips.values(chip) == 1, self.on_level, self.off_level)

    def level(self, t_s) -> np.ndarray:
        """s(t): the relative LED intensity at times ``t_s``."""
        return self.chip_level(self.chip_index(t_s))

    def _on_chip_count(self, t_s) -> tuple[np.ndarray, np.ndarray]:
        # Integer part and fractional part of the number of ON chips in [t0, t).
        chip, frac = self.chip_position(t_s)
        return self.chips.ones_before(chip), frac * self.chips.values(chip)

    def integral(self, t_s) -> np.ndarray:
        """S(t) = ∫_{t0}^{t} s(t') dt' in seconds (negative before t0)."""
        t = np.asarray(t_s, dtype=np.float64)
        whole, frac = self._on_chip_count(t)
        return self.off_level * (t - self.start_s) + (self.on_level - self.off_level) * self.chip_period_s * (whole + frac)

    def exposure(self, t_start_s, t_end_s) -> np.ndarray:
        """∫ s dt over [t_start, t_end] for arrays of windows, exactly.

        Parameters
        ----------
        t_start_s, t_end_s : array_like of float
            Window bounds in seconds (broadcast together).

        Returns
        -------
        ndarray of float64
            S(t_end) - S(t_start), in seconds at level 1.
        """
        t1 = np.asarray(t_start_s, dtype=np.float64)
        t2 = np.asarray(t_end_s, dtype=np.float64)
        whole1, frac1 = self._on_chip_count(t1)
        whole2, frac2 = self._on_chip_count(t2)
        on_chips = (whole2 - whole1) + (frac2 - frac1)
        return self.off_level * (t2 - t1) + (self.on_level - self.off_level) * self.chip_period_s * on_chips
