"""Broadcast strategies: the endless emission schedule.

Emissions are numbered by their tx index i (any integer: the broadcast is
periodic, so negative indices are the emissions before tx 0). A strategy maps
i to the sequence number of the packet sent.

RP(r), Repeat Packet
    Each packet r times in a row, then the next, cycling over the message:
    seq(i) = (i // r) mod N_p.
RS(r), Repeat Sequence
    The N_p packets in order, r times, cycling. As an endless schedule this
    is seq(i) = i mod N_p for every r; r sets the round, r·N_p emissions, in
    which each packet has been sent r times.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STRATEGIES = ("rp", "rs")


@dataclass(frozen=True)
class Schedule:
    """Emission schedule of a strategy.

    Parameters
    ----------
    strategy : {"rp", "rs"}
    n_packets : int
        N_p, packets in the message.
    repeats : int
        r, copies of each packet per round.
    """

    strategy: str
    n_packets: int
    repeats: int = 1

    def __post_init__(self):
        if self.strategy not in STRATEGIES:
            raise ValueError(f"unknown strategy {self.strategy!r}; expected one of {list(STRATEGIES)}")
        if self.n_packets < 1:
            raise ValueError(f"n_packets must be >= 1, got {self.n_packets}")
        if self.repeats < 1:
            raise ValueError(f"repeats must be >= 1, got {self.repeats}")

    @property
    def n_sequences(self) -> int:
        """Distinct sequence numbers sent: N_p."""
        return self.n_packets

    @property
    def emissions_per_round(self) -> int:
        """r·N_p: after one round every packet has been sent r times."""
        return self.repeats * self.n_packets

    @property
    def _run(self) -> int:
        # Consecutive emissions of the same packet: r for RP, 1 for RS.
        return self.repeats if self.strategy == "rp" else 1

    def sequence_numbers(self, tx) -> np.ndarray:
        """Sequence number sent at each tx index (int64 array)."""
        tx = np.asarray(tx, dtype=np.int64)
        return (tx // self._run) % self.n_packets

    def copy_index(self, tx) -> np.ndarray:
        """Which of its r copies within the current round each emission is (0..r-1)."""
        tx = np.asarray(tx, dtype=np.int64)
        if self.strategy == "rp":
            return tx % self.repeats
        return (tx // self.n_packets) % self.repeats

    def round_index(self, tx) -> np.ndarray:
        """Round (block of r·N_p emissions) each emission belongs to."""
        return np.asarray(tx, dtype=np.int64) // self.emissions_per_round

    def cumulative(self, tx, weights) -> np.ndarray:
        """Sum of ``weights[seq(k)]`` over emissions k in [0, tx).

        For negative ``tx`` this is minus the sum over [tx, 0), so that
        ``cumulative(b) - cumulative(a)`` is the sum over [a, b) for any a <= b.
        Exact for integer weights; O(1) per element, whatever the horizon.

        Parameters
        ----------
        tx : array_like of int
        weights : array_like, shape (n_packets,)
            A value per packet, e.g. its number of ON chips.
        """
        tx = np.asarray(tx, dtype=np.int64)
        w = np.asarray(weights)
        if w.shape != (self.n_packets,):
            raise ValueError(f"weights must have shape ({self.n_packets},), got {w.shape}")
        prefix = np.concatenate([np.zeros(1, dtype=w.dtype), np.cumsum(w)])
        total = prefix[-1]
        run = self._run
        block, within = tx // run, tx % run

        def over_packets(j):  # sum of w over packets j' in [0, j) of the cycling order
            return (j // self.n_packets) * total + prefix[j % self.n_packets]

        return run * over_packets(block) + within * w[block % self.n_packets]


@dataclass(frozen=True)
class RlncSchedule:
    """Emission schedule of random linear coding (rateless): every emission a fresh combination.

    Emission i carries the coded PHY-SDU of seed i mod ``seed_space``
    (:func:`rollsim.protocol.rlnc.combinations` draws its subset of the K
    source packets from that seed); the header carries the seed, so a
    header of h bits gives 2^h seeds before they repeat, and a repeated seed
    repeats a combination, which adds no rank.

    Parameters
    ----------
    n_packets : int
        K, source packets in the message.
    seed_space : int
        Distinct seeds, e.g. 2 ** header_bits.
    """

    n_packets: int
    seed_space: int

    strategy = "rlnc"
    repeats = 1

    def __post_init__(self):
        if self.n_packets < 1:
            raise ValueError(f"n_packets must be >= 1, got {self.n_packets}")
        if self.seed_space < self.n_packets:
            raise ValueError(f"seed_space must be >= n_packets ({self.n_packets}): fewer seeds cannot "
                             f"reach rank K, got {self.seed_space}")

    @property
    def n_sequences(self) -> int:
        """Distinct sequence numbers (seeds) sent."""
        return self.seed_space

    @property
    def emissions_per_round(self) -> int:
        """K: a round is as many emissions as source packets (the least that can decode)."""
        return self.n_packets

    def sequence_numbers(self, tx) -> np.ndarray:
        """The seed each emission carries (int64 array)."""
        return np.asarray(tx, dtype=np.int64) % self.seed_space

    def cumulative(self, tx, weights) -> np.ndarray:
        """Sum of ``weights[seed(k)]`` over emissions k in [0, tx) (see :meth:`Schedule.cumulative`).

        ``weights`` has one value per seed: the seeds cycle as RS cycles its
        packets.
        """
        return Schedule("rs", self.seed_space).cumulative(tx, weights)


def schedule_for(strategy: str, n_packets: int, repeats: int, header_bits: int) -> Schedule | RlncSchedule:
    """The emission schedule of a link: RP or RS with ``repeats``, or rlnc over the seeds its header cycles through.

    The rlnc seed space is :func:`rollsim.protocol.rlnc.seed_space` of
    ``header_bits`` (the largest prime the header holds).
    """
    if strategy == "rlnc":
        from rollsim.protocol.rlnc import seed_space

        return RlncSchedule(n_packets, seed_space(header_bits))
    return Schedule(strategy, n_packets, repeats)
