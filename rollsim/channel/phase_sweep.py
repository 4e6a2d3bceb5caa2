"""Exact MMBP phase averages whose cost depends on the emissions, not on the cycle.

The MMBP results of :mod:`rollsim.channel.analytic` average a
phase-conditioned quantity over the ``C = M + N`` phases of the cycle. Their
dense form costs O(C) memory, which a cycle of 10**9 slots cannot afford.
This module computes the same averages from the ``T`` emissions involved
(``r`` copies of a packet, or the ``r * n_packets`` emissions of a round) in
O(T log T) time and O(T) memory, whatever ``C``.

Emission ``j`` at offset ``e_j`` from the first is in an ON slot at phase
``s`` iff ``(s + e_j) mod C < M``: it turns ON at ``s = (-e_j) mod C`` and
OFF at ``s = (M - e_j) mod C``. Between consecutive such events nothing
changes, so the ``C`` phases fall into at most ``2T + 1`` runs of equal
state, each weighted by its length. Sweeping the events in order keeps, per
packet, its number of ON copies ``m_k`` and so the phase-conditioned log
probability, updated in O(1) per event.
"""

from __future__ import annotations

import math

import numpy as np

# Memory of the sweep per emission: two events of six int64/float64 arrays,
# with their sort orders.
SWEEP_BYTES_PER_EMISSION = 160


def _events(M: int, C: int, offsets: np.ndarray):
    """State at phase 0 and the ON/OFF events at phases 1 .. C-1.

    Returns
    -------
    on0 : ndarray of bool
        Emission ON at phase 0.
    position, emission, delta : ndarray of int64
        Phase of each event, its emission, +1 (turns ON) or -1 (turns OFF).
    """
    e = offsets % C
    on0 = e < M
    if M == 0 or M == C:  # every phase alike: no event
        empty = np.zeros(0, dtype=np.int64)
        return on0, empty, empty, empty
    t = np.arange(offsets.size, dtype=np.int64)
    position = np.concatenate([(C - e) % C, (M - e) % C])
    emission = np.concatenate([t, t])
    delta = np.concatenate([np.ones(t.size, np.int64), -np.ones(t.size, np.int64)])
    keep = position > 0  # an event at phase 0 is already in on0
    return on0, position[keep], emission[keep], delta[keep]


def _segments(position: np.ndarray, C: int):
    """Start phase, length and last-event index of each run of equal state.

    ``position`` must be sorted. Run 0 starts at phase 0 (before any event);
    run ``i > 0`` starts at the ``i``-th distinct event phase.
    """
    if position.size == 0:
        return np.array([C], dtype=np.int64), np.zeros(0, dtype=np.int64)
    last = np.flatnonzero(np.append(position[1:] != position[:-1], True))
    starts = np.concatenate([[0], position[last]])
    lengths = np.diff(np.append(starts, C))
    return lengths, last


def _log1m_pow(p_e: float, m: np.ndarray) -> np.ndarray:
    """``log(1 - p_e**m)`` for ``m >= 1`` (finite for p_e < 1)."""
    a = m * math.log(p_e)
    return np.where(a < -math.log(2.0), np.log1p(-np.exp(a)), np.log(-np.expm1(a)))


def mean_loss(M: int, C: int, offsets, p_e: float) -> float:
    """``(1/C) sum_s p_e**m(s)``: the probability that every copy of one packet is lost.

    Parameters
    ----------
    M, C : int
        ON slots and cycle length.
    offsets : array_like of int
        Offsets (in slots) of the packet's copies from the first.
    p_e : float
        Loss probability of a copy in an ON slot.
    """
    offsets = np.asarray(offsets, dtype=np.int64)
    on0, position, _, delta = _events(M, C, offsets)
    order = np.argsort(position, kind="stable")
    position, delta = position[order], delta[order]
    lengths, last = _segments(position, C)
    m = np.concatenate([[int(on0.sum())], int(on0.sum()) + np.cumsum(delta)[last]])
    if p_e == 0.0:
        return float(lengths[m == 0].sum()) / C
    # Terms p_e**m may underflow: sum them in log space.
    log_terms = np.log(lengths.astype(np.float64)) + m * math.log(p_e)
    top = log_terms.max()
    return float(math.exp(top + math.log(np.exp(log_terms - top).sum()) - math.log(C)))


def log_mean_message(M: int, C: int, offsets, packets, n_packets: int, p_e: float) -> float:
    """``log((1/C) sum_s prod_k (1 - p_e**m_k(s)))``: every packet received at least once.

    Parameters
    ----------
    M, C : int
        ON slots and cycle length.
    offsets : array_like of int
        Offset of each emission of the round from the first.
    packets : array_like of int
        Packet (0 .. n_packets - 1) each emission carries.
    n_packets : int
    p_e : float
        Loss probability of an emission in an ON slot.

    Returns
    -------
    float
        The log probability; ``-inf`` when some packet is lost at every phase.
    """
    offsets = np.asarray(offsets, dtype=np.int64)
    packets = np.asarray(packets, dtype=np.int64)
    if p_e == 1.0:
        return -math.inf
    on0, position, emission, delta = _events(M, C, offsets)
    m0 = np.bincount(packets[on0], minlength=n_packets)

    def finite(m):  # log(1 - p_e**m) where m > 0; a lost packet (m = 0) is counted apart
        out = np.zeros(m.shape)
        alive = m > 0
        if p_e > 0.0:
            out[alive] = _log1m_pow(p_e, m[alive])
        return out

    if position.size == 0:  # every phase alike
        return -math.inf if (m0 == 0).any() else min(0.0, float(finite(m0).sum()))
    packet = packets[emission]
    # Per packet in phase order, turning ON before OFF at one phase, so that a
    # running count never dips below zero.
    by_packet = np.lexsort((-delta, position, packet))
    counts = np.cumsum(delta[by_packet])
    group_first = np.flatnonzero(np.append(True, packet[by_packet][1:] != packet[by_packet][:-1]))
    before_group = np.where(group_first > 0, counts[group_first - 1], 0)
    sizes = np.diff(np.append(group_first, by_packet.size))
    m_after = m0[packet[by_packet]] + counts - np.repeat(before_group, sizes)
    m_before = m_after - delta[by_packet]
    d_log = finite(m_after) - finite(m_before)
    d_dead = (m_after == 0).astype(np.int64) - (m_before == 0).astype(np.int64)
    # Back to phase order; within one phase the changes telescope, so only
    # the state after a phase's last event is read.
    in_phase = np.argsort(position[by_packet], kind="stable")
    lengths, last = _segments(position[by_packet][in_phase], C)
    log_value = np.concatenate([[finite(m0).sum()], finite(m0).sum() + np.cumsum(d_log[in_phase])[last]])
    dead = np.concatenate([[(m0 == 0).sum()], (m0 == 0).sum() + np.cumsum(d_dead[in_phase])[last]])
    alive = dead == 0
    if not alive.any():
        return -math.inf
    log_terms = np.log(lengths[alive].astype(np.float64)) + log_value[alive]
    top = log_terms.max()
    return min(0.0, float(top + math.log(np.exp(log_terms - top).sum()) - math.log(C)))
