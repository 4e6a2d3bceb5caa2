"""A success probability that steps with a PHY-SDU's start offset in the frame, as periodic slot profiles.

Emissions start every T_p; frames every T_f. With T_f / T_p = C / F in
lowest terms, C emissions span F frames exactly and then the pattern of
start offsets repeats: emission i of a broadcast whose first start sits at
offset φ starts at offset

    φ + ((i · F) mod C) · δ   (mod T_f),   δ = T_f / C,

so the broadcast is a periodic slot channel of C slots
(:mod:`rollsim.channel.periodic`). The frame phase is uniform on [0, T_f):
its whole part in units of δ is the slot phase, uniform on 0 … C − 1, and
its fraction, uniform on [0, δ), moves every start by the same amount.
Across that fraction the slots' probabilities change only where a start
crosses a step's edge, at most once per edge; between those crossings they
are constant. The sub-intervals are the profiles, weighted by their
lengths: the average over a continuous phase is exact.

A T_f / T_p whose lowest terms need more than ``max_cycle`` slots (a real
camera's frame rate against the LED's clock) is replaced by the nearest
fraction with at most that many (:meth:`fractions.Fraction.limit_denominator`);
the relative error of its T_f is returned so that a caller can state it.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

# Slots of the longest cycle built; a longer one is approximated.
MAX_CYCLE = 5000


@dataclass(frozen=True)
class SlotProfiles:
    """Per-slot success probabilities of a step function of the start offset.

    Attributes
    ----------
    success : ndarray, shape (P, C)
        Row p: slot i's success probability in profile p.
    weights : ndarray, shape (P,)
        Probability of each profile (the length of its phase sub-interval over δ).
    frames_per_cycle : int
        F: the C slots span F frames.
    frame_period_error : float
        Relative error of T_f implied by the cycle, C · T_p / F / T_f − 1 (0 when exact).
    """

    success: np.ndarray
    weights: np.ndarray
    frames_per_cycle: int
    frame_period_error: float

    @property
    def cycle_slots(self) -> int:
        """C."""
        return int(self.success.shape[1])


def cycle_of(frame_period_s: float, sdu_duration_s: float, max_cycle: int = MAX_CYCLE) -> tuple[int, int]:
    """(C, F): T_f / T_p as C / F in lowest terms, C at most ``max_cycle``."""
    ratio = Fraction(frame_period_s / sdu_duration_s).limit_denominator(10**9)
    if ratio.numerator > max_cycle:
        # The best fraction whose numerator (slots) fits: limit the inverse's denominator.
        ratio = 1 / (1 / ratio).limit_denominator(max_cycle)
    return max(1, ratio.numerator), max(1, ratio.denominator)


def step_success(offset_s: np.ndarray, edges_s, success, frame_period_s: float) -> np.ndarray:
    """The step function at start offsets: ``success[j]`` on [edges_s[j], edges_s[j + 1]) modulo T_f."""
    edges = np.asarray(edges_s, dtype=np.float64)
    u = np.mod(np.asarray(offset_s, dtype=np.float64) - edges[0], frame_period_s)
    return np.asarray(success, dtype=np.float64)[np.searchsorted(edges[1:-1] - edges[0], u, side="right")]


def slot_profiles(frame_period_s: float, sdu_duration_s: float, edges_s, success,
                  max_cycle: int = MAX_CYCLE) -> SlotProfiles:
    """The periodic slot profiles of a step function of the start offset (see the module docstring).

    Parameters
    ----------
    frame_period_s, sdu_duration_s : float
        T_f and T_p, seconds.
    edges_s : sequence of float
        K + 1 increasing edges, the last one T_f after the first.
    success : sequence of float
        K success probabilities, in [0, 1].
    max_cycle : int
        Most slots per cycle.
    """
    C, F = cycle_of(frame_period_s, sdu_duration_s, max_cycle)
    delta = frame_period_s / C
    lattice = ((np.arange(C, dtype=np.int64) * F) % C) * delta
    edges = np.asarray(edges_s, dtype=np.float64)[:-1]
    # The phase fractions in [0, δ) at which some start crosses an edge.
    cuts = np.unique(np.concatenate(([0.0, delta], np.mod(edges, delta))))
    cuts = cuts[(cuts >= 0.0) & (cuts <= delta)]
    widths = np.diff(cuts)
    keep = widths > delta * 1e-12
    middles = (cuts[:-1] + widths / 2.0)[keep]
    weights = widths[keep] / widths[keep].sum()
    profiles = step_success(lattice[None, :] + middles[:, None], edges_s, success, frame_period_s)
    error = C * sdu_duration_s / F / frame_period_s - 1.0
    return SlotProfiles(profiles, weights, F, float(error))
