"""The PHY-SDU: SYNC, then the line-coded header, payload and check bits.

A PHY-SDU is ``SYNC + line_code(header | payload | check)``. The SYNC chip
pattern is ``1`` repeated ``R + 1`` times followed by one ``0``, where R is the
longest run of equal chips that the line code can produce
(:func:`rollsim.protocol.linecode.max_run_length`): ``1110`` for Manchester
(4 chips, as CamComSim counts it), ``111110`` for 4B6B. No other place of a
stream of back-to-back PHY-SDUs holds the pattern: an occurrence needs R + 1
ON chips in a row ending just before an OFF chip, coded data never has R + 1
equal chips in a row, so the run must contain the SYNC's own ON chips and its
closing OFF chip is the SYNC's.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from rollsim.protocol import checks, linecode
from rollsim.protocol.packets import bits_to_int, int_to_bits


# Invalid line-code symbols a PHY-SDU may have and still be repaired from
# its chips' reliabilities (PhyFormat.decode_coded). One: a single chip
# error is the commonest error at low SNR, and a random codeword of 26
# Manchester pairs then passes the line code with probability at most
# 27·2^-26 (2^-26 without repair), before the check.
REPAIRABLE_SYMBOLS = 1
# The replacement must beat the next best by more than this fraction of the
# reliability of the chips where they differ: the chip flipped less than
# half as reliable as the one kept (2(a − b)/(a + b) > 2/3). An equal pair
# of two sure chips is not one noisy chip but a misplaced symbol (a
# PHY-SDU's end past the LED, a slipped grid): on stress-low-snr, repairing
# a pair of confidences 0.99 and 0.94 gave an undetected error under parity2.
REPAIR_MARGIN = 2.0 / 3.0


def sync_pattern(code: str) -> np.ndarray:
    """SYNC chips of line code ``code``: R + 1 ON chips, then one OFF chip."""
    run = linecode.max_run_length(code) + 1
    return np.array([1] * run + [0], dtype=np.uint8)


def camcomsim_sdu_duration_s(header_bits: int, payload_bits: int, clock_hz: float, line_code: str = "manchester") -> float:
    """PHY-SDU duration by CamComSim's formula, (4 + k·(H + P)) / f.

    k = 2 for Manchester and 1.5 for 4B6B. Note that this formula leaves out
    the two parity bits the paper counts in the PHY-SDU size (§6.2.2), and
    4B6B padding; :meth:`PhyFormat.sdu_duration_s` counts both.
    """
    k = {"manchester": 2.0, "4b6b": 1.5}[line_code]
    return (4 + k * (header_bits + payload_bits)) / clock_hz


@dataclass(frozen=True)
class DecodedSdus:
    """PHY-SDUs decoded from coded chips (one entry per row).

    Attributes
    ----------
    sequence : ndarray of int64
        Sequence number from the header.
    payload : ndarray of uint8, shape (n, payload_bits)
    check_ok : ndarray of bool
        The line code was valid and the check bits match.
    code_ok : ndarray of bool
        Every line-code symbol was valid.
    """

    sequence: np.ndarray
    payload: np.ndarray
    check_ok: np.ndarray
    code_ok: np.ndarray


@dataclass(frozen=True)
class PhyFormat:
    """Layout of a PHY-SDU.

    Parameters
    ----------
    header_bits : int
        H, the sequence-number header length in bits.
    payload_bits : int
        P, the payload length in bits.
    check : {"parity2", "crc8"}
        Check bits appended to header and payload.
    line_code : {"manchester", "4b6b"}
    """

    header_bits: int
    payload_bits: int
    check: str = "parity2"
    line_code: str = "manchester"

    def __post_init__(self):
        if self.header_bits < 0:
            raise ValueError(f"header_bits must be >= 0, got {self.header_bits}")
        if self.payload_bits < 1:
            raise ValueError(f"payload_bits must be >= 1, got {self.payload_bits}")
        if self.check not in checks.CHECK_BITS:
            raise ValueError(f"unknown check {self.check!r}; expected one of {sorted(checks.CHECK_BITS)}")
        if self.line_code not in linecode.LINE_CODES:
            raise ValueError(f"unknown line code {self.line_code!r}; expected one of {list(linecode.LINE_CODES)}")

    @property
    def data_bits(self) -> int:
        """Header plus payload bits, H + P."""
        return self.header_bits + self.payload_bits

    @property
    def check_bits(self) -> int:
        return checks.CHECK_BITS[self.check]

    @property
    def codeword_bits(self) -> int:
        """Bits that are line-coded: header, payload and check."""
        return self.data_bits + self.check_bits

    @cached_property
    def sync(self) -> np.ndarray:
        return sync_pattern(self.line_code)

    @property
    def sync_chips(self) -> int:
        return int(self.sync.size)

    @property
    def coded_chips(self) -> int:
        """Chips of the line-coded codeword (after the SYNC)."""
        return linecode.coded_chips(self.codeword_bits, self.line_code)

    @property
    def sdu_chips(self) -> int:
        """Chips of a whole PHY-SDU, SYNC included."""
        return self.sync_chips + self.coded_chips

    def sdu_duration_s(self, clock_hz: float) -> float:
        """Duration of one PHY-SDU in seconds at chip rate ``clock_hz``."""
        if clock_hz <= 0:
            raise ValueError(f"clock_hz must be > 0, got {clock_hz}")
        return self.sdu_chips / clock_hz

    def codewords(self, sequence, payload) -> np.ndarray:
        """Header, payload and check bits of each packet.

        Parameters
        ----------
        sequence : array_like of int, shape (n,)
            Sequence numbers, each < 2**header_bits.
        payload : array_like of {0, 1}, shape (n, payload_bits)

        Returns
        -------
        ndarray of uint8, shape (n, codeword_bits)
        """
        payload = np.atleast_2d(np.asarray(payload, dtype=np.uint8))
        if payload.shape[1] != self.payload_bits:
            raise ValueError(f"payload rows must have {self.payload_bits} bits, got {payload.shape[1]}")
        header = int_to_bits(sequence, self.header_bits)
        if header.shape[0] != payload.shape[0]:
            raise ValueError("sequence and payload must have the same number of packets")
        data = np.concatenate([header, payload], axis=1)
        return np.concatenate([data, checks.check_bits(data, self.check)], axis=1)

    def encode(self, sequence, payload) -> np.ndarray:
        """Chips of whole PHY-SDUs (SYNC included), one row per packet."""
        coded = linecode.encode(self.codewords(sequence, payload), self.line_code)
        sync = np.broadcast_to(self.sync, (coded.shape[0], self.sync_chips))
        return np.concatenate([sync, coded], axis=1)

    def decode_coded(self, chips, reliability=None) -> DecodedSdus:
        """Decode the chips that follow a SYNC (``coded_chips`` per row).

        Given each chip's ``reliability`` (same shape, >= 0: what flipping
        it would cost), a row with at most :data:`REPAIRABLE_SYMBOLS`
        invalid line-code symbols has them replaced by the most likely
        valid ones first (:func:`rollsim.protocol.linecode.repair`); the
        check code then judges the result.
        """
        if reliability is not None:
            chips, _ = linecode.repair(chips, reliability, self.line_code, REPAIRABLE_SYMBOLS, REPAIR_MARGIN)
        bits, code_ok = linecode.decode(chips, self.line_code, self.codeword_bits)
        check_ok = code_ok & checks.verify(bits, self.check)
        return DecodedSdus(
            sequence=bits_to_int(bits[:, : self.header_bits]),
            payload=bits[:, self.header_bits : self.data_bits].copy(),
            check_ok=check_ok,
            code_ok=code_ok,
        )

    def decode(self, chips) -> DecodedSdus:
        """Decode whole PHY-SDUs (SYNC included); a wrong SYNC fails the check."""
        rows = np.atleast_2d(np.asarray(chips, dtype=np.uint8))
        if rows.shape[1] != self.sdu_chips:
            raise ValueError(f"expected {self.sdu_chips} chips per PHY-SDU, got {rows.shape[1]}")
        decoded = self.decode_coded(rows[:, self.sync_chips :])
        sync_ok = np.all(rows[:, : self.sync_chips] == self.sync, axis=1)
        return DecodedSdus(decoded.sequence, decoded.payload, decoded.check_ok & sync_ok, decoded.code_ok & sync_ok)

    def bit_index_of_chip(self, chip_in_sdu) -> np.ndarray:
        """Codeword bit carried by each chip offset within a PHY-SDU.

        Returns -1 for SYNC chips. For 4B6B a chip carries a whole nibble; the
        index of the nibble's first bit is returned. Pad bits of 4B6B have
        indices >= ``codeword_bits``.
        """
        offset = np.asarray(chip_in_sdu, dtype=np.int64) - self.sync_chips
        chips, bits = linecode.chips_per_symbol(self.line_code)
        return np.where(offset < 0, -1, (offset // chips) * bits)
