"""The Gilbert-Elliott channel for the event simulator: a two-state Markov chain per emission.

State S1 (capturing) succeeds with probability 1 − p_e, S2 (the gap)
never; S2 → S1 with probability p and S1 → S2 with q per emission (the
convention of :mod:`rollsim.channel.analytic`), a run starting from the
stationary distribution. Sojourns are geometric, so a block of states is
built from run lengths (:func:`ge_path`): no loop per emission.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rollsim.channel.channels import ChannelModel, _outcomes
from rollsim.plumbing.validation import as_positive, as_probability


def ge_path(p: float, q: float, n: int, rng: np.random.Generator, first_in_s1: bool) -> np.ndarray:
    """States of n emissions (True in S1), the first in S1 when ``first_in_s1``.

    Sojourns are drawn in blocks: S1 is left with probability q per
    emission, S2 with p; an even block keeps the states alternating across
    blocks. Runs are cut at n before expanding (a sojourn can be far longer
    than n when q is near 0).
    """
    runs, states, total = [], [], 0
    while total < n:
        block = 2 * max(8, int(n * min(p, q) + 8))
        leave = np.where(np.arange(block) % 2 == 0, q if first_in_s1 else p, p if first_in_s1 else q)
        lengths = rng.geometric(np.clip(leave, 1e-12, 1.0))
        runs.append(lengths)
        states.append((np.arange(block) % 2 == 0) == first_in_s1)
        total += int(lengths.sum())
    lengths, in_s1 = np.concatenate(runs), np.concatenate(states)
    ends = np.cumsum(lengths)
    last = int(np.searchsorted(ends, n))
    lengths = lengths[: last + 1].copy()
    lengths[-1] -= int(ends[last]) - n
    return np.repeat(in_s1[: last + 1], lengths)


@dataclass(frozen=True)
class GeChannel(ChannelModel):
    """Gilbert-Elliott (p, q, p_e) as a channel of the event simulator.

    Parameters
    ----------
    p, q : float
        S2 → S1 and S1 → S2 probabilities per emission, in (0, 1].
    p_e : float
        Error probability in S1, in [0, 1].
    sdu_duration_s : float
        Clock advance per emission, seconds.
    """

    p: float
    q: float
    p_e: float
    sdu_duration_s: float

    kind = "ge"

    def __post_init__(self):
        for name in ("p", "q"):
            value = as_probability(getattr(self, name), name)
            if value <= 0.0:
                raise ValueError(f"{name} = {value}: must be > 0 (a chain that never leaves a state)")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "p_e", as_probability(self.p_e, "p_e"))
        object.__setattr__(self, "sdu_duration_s", as_positive(self.sdu_duration_s, "sdu_duration_s"))

    @property
    def emission_duration_s(self) -> float:
        """Clock advance per emission, seconds."""
        return self.sdu_duration_s

    def parameters(self) -> dict:
        """JSON-ready parameters of the channel."""
        return {"kind": self.kind, "p": self.p, "q": self.q, "p_e": self.p_e, "sdu_duration_s": self.sdu_duration_s}

    def open_run(self, seed_sequence: np.random.SeedSequence) -> "_GeRun":
        """Start one broadcast in a state drawn from the stationary distribution."""
        return _GeRun(self, np.random.default_rng(seed_sequence))


class _GeRun:
    def __init__(self, channel: GeChannel, rng: np.random.Generator):
        self._channel = channel
        self._rng = rng
        self._next_in_s1 = bool(rng.random() < channel.p / (channel.p + channel.q))

    def next_block(self, count: int) -> np.ndarray:
        c = self._channel
        path = ge_path(c.p, c.q, count, self._rng, self._next_in_s1)
        # The next block's first state follows the last one by one transition.
        stay = 1.0 - c.q if path[-1] else 1.0 - c.p
        self._next_in_s1 = bool(path[-1]) == bool(self._rng.random() < stay)
        return _outcomes(path, self._rng.random(count), c.p_e)
