"""Framing: SYNCs, line decoding and checks of recovered chips.

The SYNC is R + 1 ON chips then one OFF chip (``1110`` for Manchester). A
PHY-SDU ending in ON chips runs into its successor's SYNC and makes the ON
run longer, so a SYNC is located by the END of an ON run of at least R + 1
chips: its first chip is R + 1 chips before the OFF chip that closes the
run. Coded data never holds R + 1 equal chips, so clean data has one SYNC
per PHY-SDU. The chips after the SYNC go to
:meth:`rollsim.protocol.PhyFormat.decode_coded`: one invalid Manchester
pair or 4B6B word is repaired from the chips' reliabilities where one
choice is clearly better, more are a code error. A PHY-SDU whose SYNC lost
a chip is still looked for where its neighbours put it: PHY-SDUs are sent
back to back.

All candidates of a chip stream are decoded at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rollsim.protocol import PhyFormat

from decoder.order_stats import median
from decoder.records import STATUSES
from decoder.timing import ChipStream

OK, CHECK_FAILED, CODE_ERROR, ERASURE, TRUNCATED = range(len(STATUSES))


@dataclass(frozen=True)
class SduCandidates:
    """PHY-SDU candidates of one chip stream (one entry each).

    Attributes
    ----------
    first_row, last_row : ndarray of float64
        Row position (profile coordinates) of the start of the SYNC and of
        the end of the last chip.
    sequence : ndarray of int64
    payload : ndarray of uint8, shape (n, payload_bits)
    status : ndarray of int
        Index into :data:`decoder.records.STATUSES`.
    confidence : ndarray of float64
    """

    first_row: np.ndarray
    last_row: np.ndarray
    sequence: np.ndarray
    payload: np.ndarray
    status: np.ndarray
    confidence: np.ndarray

    def __len__(self) -> int:
        return int(self.status.size)

    @property
    def check_ok(self) -> np.ndarray:
        return self.status == OK

    def select(self, keep: np.ndarray) -> "SduCandidates":
        """The candidates where ``keep`` (bool or indices), in that order."""
        return SduCandidates(*(getattr(self, name)[keep] for name in _FIELDS))


_FIELDS = ("first_row", "last_row", "sequence", "payload", "status", "confidence")


def find_sync_starts(chip_values: np.ndarray, phy: PhyFormat) -> np.ndarray:
    """Chip index of the first SYNC chip of every SYNC in a chip stream.

    Parameters
    ----------
    chip_values : ndarray of int8
        1 ON, 0 OFF, -1 erased.
    phy : PhyFormat

    Returns
    -------
    ndarray of int64
        For every OFF chip preceded by at least R + 1 ON chips, the index
        R + 1 chips before it.
    """
    on = phy.sync_chips - 1
    values = np.asarray(chip_values)
    if values.size <= on:
        return np.zeros(0, dtype=np.int64)
    ones = np.concatenate([[0], np.cumsum(values == 1)])
    closing = np.arange(on, values.size)
    is_sync = (values[closing] == 0) & (ones[closing] - ones[closing - on] == on)
    return closing[is_sync] - on


def decode_chip_stream(chips: ChipStream, phy: PhyFormat, row_span: tuple[float, float] | None = None) -> SduCandidates:
    """Find and decode every PHY-SDU candidate of a chip stream.

    Candidates start at every SYNC (:func:`find_sync_starts`), and one
    PHY-SDU before and after each candidate that passed its check, where
    the chips hold the SYNC but for one chip (:func:`neighbour_starts`):
    a chip error in a SYNC hides its PHY-SDU from the search, or moves the
    SYNC found by a chip. Those are kept only if they pass, and their
    neighbours are looked for in turn; a failed candidate within a chip of
    one that passed is the same PHY-SDU misaligned, and is dropped.

    Parameters
    ----------
    chips : ChipStream
    phy : PhyFormat
    row_span : (float, float), optional
        Rows (profile coordinates) the LED is known to cover; a candidate
        reaching outside is truncated.

    Returns
    -------
    SduCandidates
        Candidates in row order, including truncated ones.
    """
    starts = find_sync_starts(chips.values, phy)
    found = decode_at(chips, phy, starts, row_span)
    known = new = starts[found.check_ok]
    hidden, recovered = [], np.zeros(0, dtype=np.int64)
    # Each pass starts from the PHY-SDUs the last one found: rarely more than one.
    while new.size:
        guesses = neighbour_starts(new, known, len(chips), phy.sdu_chips)
        guesses = guesses[sync_mismatches(chips.values, guesses, phy) <= 1]
        read = decode_at(chips, phy, guesses, row_span, sync_known=True)
        hidden.append(read.select(read.check_ok))
        new = guesses[read.check_ok]
        known, recovered = np.concatenate([known, new]), np.concatenate([recovered, new])
    if recovered.size == 0:
        return found
    misaligned = ~found.check_ok & (np.min(np.abs(starts[:, None] - recovered[None, :]), axis=1) <= NEIGHBOUR_TOLERANCE_CHIPS)
    return concatenated([found.select(~misaligned), *hidden])


def concatenated(parts: list[SduCandidates]) -> SduCandidates:
    """Several sets of candidates as one, in row order."""
    merged = SduCandidates(*(np.concatenate([getattr(c, name) for c in parts]) for name in _FIELDS))
    return merged.select(np.argsort(merged.first_row, kind="stable"))


def sync_mismatches(chip_values: np.ndarray, starts: np.ndarray, phy: PhyFormat) -> np.ndarray:
    """How many chips of the SYNC laid at each start differ from it (an erased chip differs), shape (n,)."""
    index = np.minimum(starts[:, None] + np.arange(phy.sync_chips), len(chip_values) - 1)
    return np.sum(np.asarray(chip_values)[index] != phy.sync[None, :], axis=1)


def neighbour_starts(passed: np.ndarray, known: np.ndarray, n_chips: int, sdu_chips: int) -> np.ndarray:
    """Chip indices one PHY-SDU before and after each passed candidate, where no passed one starts.

    The transmitter sends PHY-SDUs back to back, so a PHY-SDU whose SYNC
    lost a chip to noise still starts exactly ``sdu_chips`` after its
    predecessor (and before its successor). A guess within
    :data:`NEIGHBOUR_TOLERANCE_CHIPS` of a candidate that passed is that
    candidate; a SYNC found there that failed may be the guess's PHY-SDU
    misaligned by the wrong chip, so it does not count. A guess running past
    the stream is not made.

    Parameters
    ----------
    passed : ndarray of int64
        First chips of the candidates to look around.
    known : ndarray of int64
        First chips of every candidate that passed.
    n_chips, sdu_chips : int
        Chips in the stream and in a PHY-SDU.

    Returns
    -------
    ndarray of int64
        Sorted, unique.
    """
    guesses = np.unique(np.concatenate([passed - sdu_chips, passed + sdu_chips]))
    guesses = guesses[(guesses >= 0) & (guesses + sdu_chips <= n_chips)]
    if guesses.size == 0 or known.size == 0:
        return guesses
    nearest = np.min(np.abs(guesses[:, None] - known[None, :]), axis=1)
    return guesses[nearest > NEIGHBOUR_TOLERANCE_CHIPS]


# A guessed start this close to a passed candidate (chips) is that candidate.
NEIGHBOUR_TOLERANCE_CHIPS = 1


def decode_at(chips: ChipStream, phy: PhyFormat, starts: np.ndarray, row_span: tuple[float, float] | None,
              sync_known: bool = False) -> SduCandidates:
    """Decode the PHY-SDU candidates starting at the given chips (SYNC included), in that order.

    Parameters
    ----------
    chips : ChipStream
    phy : PhyFormat
    starts : ndarray of int64
        First chip (the SYNC's) of each candidate; >= 0.
    row_span : (float, float) or None
        As :func:`decode_chip_stream`.
    sync_known : bool
        The starts are known otherwise (a neighbour's position): an erased
        SYNC chip does not make the candidate an erasure.

    Returns
    -------
    SduCandidates
    """
    n_chips = phy.sdu_chips
    n = starts.size
    payload = np.zeros((n, phy.payload_bits), dtype=np.uint8)
    if n == 0:
        empty = np.zeros(0)
        return SduCandidates(empty, empty, np.zeros(0, np.int64), payload, np.zeros(0, np.int64), empty)
    total = len(chips)
    inside = starts + n_chips <= total
    # Clip indices so that truncated candidates can be gathered too.
    index = np.minimum(starts[:, None] + np.arange(n_chips), total - 1)
    values = chips.values[index]
    erased = np.any(values[:, phy.sync_chips if sync_known else 0 :] < 0, axis=1)
    exact = np.all(chips.exact[index], axis=1)
    first_row = chips.start[starts]
    # A candidate running past the stream ends where its chips would.
    pitch = median(chips.end - chips.start)
    last_row = np.where(inside, chips.end[index[:, -1]], first_row + n_chips * pitch)
    complete = inside & exact
    if row_span is not None:
        complete &= (first_row >= row_span[0]) & (last_row <= row_span[1])
    coded = np.where(values[:, phy.sync_chips :] > 0, 1, 0).astype(np.uint8)
    # One invalid symbol may be repaired from the chips' reliabilities.
    decoded = phy.decode_coded(coded, chips.flip_costs[index][:, phy.sync_chips :])
    status = np.select(
        [~complete, erased, ~decoded.code_ok, ~decoded.check_ok],
        [TRUNCATED, ERASURE, CODE_ERROR, CHECK_FAILED],
        default=OK,
    )
    confidence = np.where(erased, 0.0, np.min(chips.confidence[index], axis=1))
    return SduCandidates(first_row, last_row, decoded.sequence, decoded.payload, status, confidence)


def merge_readings(primary: SduCandidates, secondary: SduCandidates, sdu_rows: float) -> SduCandidates:
    """Two readings of one profile as one: ``primary``'s, plus what only ``secondary`` read.

    A candidate of ``secondary`` whose check passed is added where
    ``primary`` passed none within half a PHY-SDU (``sdu_rows`` / 2 rows) of
    it; ``primary``'s failed candidates there give way to it.

    Returns
    -------
    SduCandidates
        In row order.
    """
    if len(secondary) == 0:
        return primary
    if len(primary) == 0:
        return secondary
    distance = np.abs(secondary.first_row[:, None] - primary.first_row[None, :])
    near = distance < 0.5 * sdu_rows
    taken = secondary.check_ok & ~np.any(near & primary.check_ok[None, :], axis=1)
    kept = primary.check_ok | ~np.any(near & taken[:, None], axis=0)
    return concatenated([primary.select(kept), secondary.select(taken)])
