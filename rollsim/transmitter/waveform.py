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
12 significant digits at any time (:mod:`rollsim.numerics.clock`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rollsim.numerics.clock import chip_position

if TYPE_CHECKING:
    from rollsim.transmitter.chips import ChipSource


@dataclass(frozen=True)
class Waveform:
    """A chip sequence sent at ``clock_hz`` from time ``start_s``.

    Parameters
    ----------
    chips : ChipSource
        See :mod:`rollsim.transmitter.chips`.
    clock_hz : float
        Chip rate f in Hz.
    start_s : float
        Time t0 at which chip 0 starts, in seconds.
    on_level, off_level : float
        Relative LED intensity of ON and OFF chips.
    """

    chips: ChipSource
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
