"""Chip sources: the endless ON/OFF chip sequence a pattern sends.

A chip source answers two vectorised questions for integer chip indices c
(negative indices are chips before the transmitter's time origin; every
pattern here is periodic, so the past is defined):

``values(c)``
    the chip sent, 1 (ON) or 0 (OFF);
``ones_before(c)``
    the number of ON chips in [0, c), and minus the number in [c, 0) for
    negative c. Differences of it count ON chips over any range exactly,
    which is what makes the exposure integral exact.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from rollsim.transmitter.schedule import RlncSchedule, Schedule


@runtime_checkable
class ChipSource(Protocol):
    """What a waveform needs of its chips (see the module docstring)."""

    def values(self, chip) -> np.ndarray:
        """The chip sent at each index, 1 (ON) or 0 (OFF), as uint8."""
        ...

    def ones_before(self, chip) -> np.ndarray:
        """ON chips in [0, c) (minus those in [c, 0) for c < 0), as int64."""
        ...


@dataclass(frozen=True)
class ConstantChips:
    """Every chip ON (``value=1``, the ``on`` pattern) or OFF (``off``)."""

    value: int

    def values(self, chip) -> np.ndarray:
        return np.full(np.shape(chip), self.value, dtype=np.uint8)

    def ones_before(self, chip) -> np.ndarray:
        return self.value * np.asarray(chip, dtype=np.int64)


@dataclass(frozen=True)
class SquareChips:
    """Alternating chips, ON at even indices: a square wave of period 2 chips."""

    def values(self, chip) -> np.ndarray:
        return (1 - np.asarray(chip, dtype=np.int64) % 2).astype(np.uint8)

    def ones_before(self, chip) -> np.ndarray:
        return (np.asarray(chip, dtype=np.int64) + 1) // 2


def prefix_dtype(chips_per_sdu: int) -> np.dtype:
    """The unsigned integer type of a PHY-SDU's running ON-chip count."""
    return np.min_scalar_type(max(1, int(chips_per_sdu)))


@dataclass(frozen=True)
class DataChips:
    """PHY-SDUs back to back, in the order a schedule gives.

    Parameters
    ----------
    schedule : Schedule
        Maps tx index to sequence number.
    sdu_chips : ndarray of uint8, shape (n_packets, chips_per_sdu)
        Row k holds the chips of the PHY-SDU with sequence number k.
    """

    schedule: Schedule | RlncSchedule
    sdu_chips: np.ndarray
    _prefix: np.ndarray = field(init=False, repr=False, compare=False)
    _totals: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        table = np.asarray(self.sdu_chips, dtype=np.uint8)
        rows = self.schedule.n_sequences
        if table.ndim != 2 or table.shape[0] != rows:
            raise ValueError(f"sdu_chips must have shape ({rows}, chips_per_sdu)")
        # ON chips before each offset of a PHY-SDU: at most its chip count,
        # so the smallest unsigned type that holds it (uint16 for any valid
        # PHY-SDU) keeps a message of millions of packets in memory.
        prefix = np.zeros((table.shape[0], table.shape[1] + 1), dtype=prefix_dtype(table.shape[1]))
        np.cumsum(table, axis=1, out=prefix[:, 1:])
        object.__setattr__(self, "sdu_chips", table)
        object.__setattr__(self, "_prefix", prefix)
        object.__setattr__(self, "_totals", prefix[:, -1].astype(np.int64))

    @property
    def chips_per_sdu(self) -> int:
        return self.sdu_chips.shape[1]

    def split(self, chip) -> tuple[np.ndarray, np.ndarray]:
        """``(tx index, chip offset within its PHY-SDU)`` of each chip."""
        chip = np.asarray(chip, dtype=np.int64)
        return chip // self.chips_per_sdu, chip % self.chips_per_sdu

    def values(self, chip) -> np.ndarray:
        tx, offset = self.split(chip)
        return self.sdu_chips[self.schedule.sequence_numbers(tx), offset]

    def ones_before(self, chip) -> np.ndarray:
        tx, offset = self.split(chip)
        whole = self.schedule.cumulative(tx, self._totals)
        return whole + self._prefix[self.schedule.sequence_numbers(tx), offset].astype(np.int64)
