"""Periodic slot channel: a mixture of per-slot success profiles, exactly.

The channel generalises the MMBP of :mod:`rollsim.channel.analytic`. One
cycle has ``C`` slots and slot ``i`` its own success probability ``q[i]``;
emission ``k`` of a broadcast (``k = 0, 1, ...``) falls in slot
``(s + k) mod C`` with the phase ``s`` uniform on ``0 .. C-1`` per run, and
given the phase every emission succeeds independently. The channel may be a
*mixture of profiles*: ``q`` of shape ``(P, C)`` and weights ``w`` summing to
1; a run first draws profile ``p`` with probability ``w[p]``, then the phase.
(A continuous frame phase is averaged exactly this way: the caller cuts it
into sub-phase pieces, one profile each.) The MMBP is ``P = 1``,
``q = [1 - p_e] * M + [0] * N``.

Strategies as in :mod:`rollsim.channel.analytic`: ``'rp'`` sends packet
``(t // r) mod n`` at emission ``t``, ``'rs'`` packet ``t mod n``; a round
has ``r * n`` emissions. ``T`` counts the emissions up to and including the
one that completes the message.

Method (:func:`exact_figures`). A *row* is one (profile, phase) pair, of
weight ``w[p] / C``. Given the row, packet ``k`` is still missing after
``j`` emissions with probability ``exp(L_k(j))``,
``L_k(j) = sum log(1 - q)`` over its emissions so far (``-inf`` once an
emission had ``q = 1``), so ``G(j) = P(T <= j) = prod_k (1 - exp(L_k(j)))``.
Then ``E[T] = sum_{j >= 0} (1 - G(j))`` and, by parts,
``E[1/T; T <= K] = G(K)/K + sum_{j=1}^{K-1} G(j) / (j (j + 1))``.
Time is processed in chunks: a matrix of rows x emissions of the chunk, its
columns sorted by packet (the packet of an emission does not depend on the
row, so one permutation serves all rows), a cumulative sum per packet
segment gives ``L_k`` before and after every emission, and the change of
``log G`` per emission is ``log1mexp(L_after) - log1mexp(L_before)``, with
the packets not hit yet (``L_k = 0``) counted apart instead of carrying
``-inf``; ``log G`` within a chunk is its exact end value minus the changes
still to come (a reverse cumulative sum), which keeps ``1 - G`` accurate
relative to itself once every packet is hit. Between chunks each row keeps its ``L_k``, its per-packet
``log(1 - exp(L_k))`` (whose sum gives ``log G`` afresh at every chunk
boundary, so that rounding does not accumulate over chunks) and its count of
packets not hit. The (packet, slot) pattern repeats with the hyperperiod
``H = lcm(period, C)`` (period ``r n`` for RP, ``n`` for RS), over which
packet ``k`` of a row accumulates a fixed ``A_k``; ``A_k = 0`` means the
packet is never received in that row (``E[T] = inf``), and
``sum_{j' >= j} (1 - G(j')) <= H sum_k exp(L_k(j)) / (1 - exp(A_k))``
bounds the rest of a row's sum: a row stops when that bound is below 1e-16
of its running sum (or, when ``E[T]`` is infinite anyway, at the later of
the round and the cap).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from rollsim.channel.analytic import ExactSumTooCostly
from rollsim.channel.channels import DECODE_ERROR, GAP_LOSS, RECEIVED, ChannelModel
from rollsim.channel.eventsim import DEFAULT_MAX_EMISSIONS
from rollsim.plumbing.budget import check_memory
from rollsim.plumbing.validation import as_count as _as_count
from rollsim.plumbing.validation import as_positive as _as_positive

__all__ = ["PeriodicChannel", "PeriodicFigures", "exact_figures", "goodput_bps"]

_STRATEGIES = ("rp", "rs")
# Rows x emissions that exact_figures may process (each a few dozen flops);
# beyond it the call would take minutes, so it refuses up front instead.
_WORK_BUDGET = 10**8
# Rows x emissions per chunk: a dozen float64 arrays of this size at once.
_CHUNK_ELEMS = 1 << 18
# A row stops when the bound on the rest of its sum is below this fraction.
_TAIL_TOLERANCE = 1e-16
_WEIGHT_TOLERANCE = 1e-9
_LN2 = math.log(2.0)


# ----------------------------------------------------------------------------
# Validation
# ----------------------------------------------------------------------------
def _check_profiles(q, weights, name: str = "q") -> tuple[np.ndarray, np.ndarray]:
    """``q`` as a float64 ``(P, C)`` array and ``weights`` as a ``(P,)`` array summing to 1.

    A 1-D ``q`` is one profile; ``weights=None`` means equal weights.
    """
    try:
        qa = np.array(q, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an array of probabilities, got {type(q).__name__}") from None
    if qa.ndim == 1:
        qa = qa[None, :]
    if qa.ndim != 2 or qa.shape[0] < 1 or qa.shape[1] < 1:
        raise ValueError(f"{name} must be a 1-D (C,) or 2-D (profiles, C) array with C >= 1, got shape {qa.shape}")
    bad = ~(np.isfinite(qa) & (qa >= 0.0) & (qa <= 1.0))
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"{name} must hold probabilities in [0, 1], got {qa[where]!r} at index {where}")
    P = qa.shape[0]
    if weights is None:
        return qa, np.full(P, 1.0 / P)
    try:
        w = np.array(weights, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"weights must be an array of {P} numbers, got {type(weights).__name__}") from None
    if w.ndim == 0 and P == 1:
        w = w[None]
    if w.shape != (P,):
        raise ValueError(f"weights must have shape ({P},), one per profile of {name}, got shape {w.shape}")
    if not np.all(np.isfinite(w) & (w >= 0.0)):
        raise ValueError(f"weights must be finite and >= 0, got {w.tolist()!r}")
    total = float(w.sum())
    if abs(total - 1.0) > _WEIGHT_TOLERANCE:
        raise ValueError(f"weights must sum to 1 (within {_WEIGHT_TOLERANCE:g}), got sum {total!r}")
    return qa, w / total


def _check_strategy(strategy) -> str:
    if not isinstance(strategy, str) or strategy.lower() not in _STRATEGIES:
        raise ValueError(f"strategy must be one of {_STRATEGIES}, got {strategy!r}")
    return strategy.lower()


# ----------------------------------------------------------------------------
# Numerical helpers
# ----------------------------------------------------------------------------
def _log_failure(q: np.ndarray) -> np.ndarray:
    """``log(1 - q)`` elementwise, ``-inf`` where ``q = 1`` (no warning)."""
    out = np.full(q.shape, -np.inf)
    ok = q < 1.0
    out[ok] = np.log1p(-q[ok])
    return out


def _log1mexp(x: np.ndarray) -> np.ndarray:
    """``log(1 - exp(x))`` where ``x < 0`` (0 at ``-inf``), and 0 where ``x = 0``.

    ``x = 0`` is a packet not hit yet, whose factor ``1 - exp(0) = 0`` the
    callers count apart; 0 there keeps every result finite. Uses ``log1p``
    for ``x < -ln 2`` and ``log(-expm1(x))`` above, both accurate.
    """
    out = np.zeros(x.shape)
    far = x < -_LN2
    out[far] = np.log1p(-np.exp(x[far]))
    near = ~far & (x < 0.0)
    out[near] = np.log(-np.expm1(x[near]))
    return out


def _packet_ids(t: np.ndarray, r: int, n: int, strategy: str) -> np.ndarray:
    """Packet sent at each emission index ``t`` (int64)."""
    return (t // r) % n if strategy == "rp" else t % n


def _hyperperiod_logs(log_fail: np.ndarray, r: int, n: int, strategy: str) -> tuple[np.ndarray, int, int]:
    """``A[p * g + u, k]``: sum of ``log(1 - q)`` over packet ``k``'s emissions in one hyperperiod.

    With ``g = gcd(period, C)`` the emissions of one hyperperiod visit each
    slot of a coset mod ``g`` once per emission of the period, so ``A``
    depends on the phase ``s`` only through ``u = s mod g``: the per-packet
    sums of the coset sums ``B[p, (u + t) mod g]`` over one period.

    Returns
    -------
    (ndarray, int, int)
        ``A`` of shape ``(P * g, n)`` (``<= 0``, ``-inf`` where a ``q = 1``
        slot is visited), ``g`` and the hyperperiod ``H`` in emissions.
    """
    P, C = log_fail.shape
    period = r * n if strategy == "rp" else n
    g = math.gcd(period, C)
    H = period // g * C
    B = log_fail.reshape(P, C // g, g).sum(axis=1)  # (P, g): -inf stays -inf, no inf - inf
    u = np.arange(g)
    A = np.zeros((P, g, n))
    per = r if strategy == "rp" else 1  # emissions of a packet per period, consecutive
    # Blocks of packets x copies of at most _CHUNK_ELEMS / (P g) emissions.
    copies = min(per, max(1, _CHUNK_ELEMS // (P * g)))
    packets = max(1, _CHUNK_ELEMS // (P * g * copies))
    for k0 in range(0, n, packets):
        first = np.arange(k0, min(n, k0 + packets)) * per  # first emission of each packet (RS: t = k)
        for c0 in range(0, per, copies):
            t = first[:, None] + np.arange(c0, min(per, c0 + copies))[None, :]  # (packets, copies)
            slots = (u[:, None, None] + t[None, :, :]) % g  # (g, packets, copies)
            A[:, :, k0 : k0 + first.size] += B[:, slots].sum(axis=-1)  # -inf only added
    return A.reshape(P * g, n), g, H


def _segments(pid: np.ndarray):
    """Stable sort of a chunk's emissions by packet, and the segments it forms.

    Returns ``perm`` (sorted order), the packet of each segment, each
    segment's length, and for every sorted emission its segment and its
    position within the segment.
    """
    perm = np.argsort(pid, kind="stable")
    ps = pid[perm]
    starts = np.flatnonzero(np.concatenate(([True], ps[1:] != ps[:-1])))
    lengths = np.diff(np.concatenate((starts, [ps.size])))
    seg = np.repeat(np.arange(starts.size), lengths)
    pos = np.arange(ps.size) - starts[seg]
    return perm, ps[starts], lengths, seg, pos


def _advance(state: "_Rows", log_fail: np.ndarray, t0: int, t1: int, r: int, n: int, strategy: str):
    """Process emissions ``t0 .. t1 - 1`` of every row of ``state``.

    Updates ``state.L``, ``state.lam`` and ``state.missing`` in place and
    returns ``(G, one_minus_G)`` of shape ``(rows, t1 - t0)``: column ``c``
    holds ``G(t0 + c + 1)`` and ``1 - G(t0 + c + 1)``.
    """
    C = log_fail.shape[1]
    t = np.arange(t0, t1, dtype=np.int64)
    perm, seg_packet, lengths, seg, pos = _segments(_packet_ids(t, r, n, strategy))
    R, E = state.L.shape[0], t.size
    slots = (state.phase[:, None] + (t[perm] % C)[None, :]) % C
    values = log_fail[state.profile[:, None], slots]  # (R, E), sorted by packet; <= 0 or -inf
    # Cumulative sums per packet segment, padded to a rectangle: -inf is only
    # ever added, never subtracted.
    padded = np.zeros((R, seg_packet.size, int(lengths.max())))
    padded[:, seg, pos] = values
    csum = np.cumsum(padded, axis=2)
    start = state.L[:, seg_packet]  # (R, segments)
    after = start[:, seg] + csum[:, seg, pos]
    before = start[:, seg] + np.where(pos > 0, csum[:, seg, np.maximum(pos - 1, 0)], 0.0)
    last = start + csum[np.arange(R)[:, None], np.arange(seg_packet.size)[None, :], (lengths - 1)[None, :]]
    # Change of log G per emission (log1mexp(0) = 0 covers a first hit), and
    # the first hits, put back in time order.
    lam_after = _log1mexp(after)
    delta = np.empty((R, E))
    delta[:, perm] = lam_after - _log1mexp(before)
    hits = np.empty((R, E), dtype=np.int64)
    hits[:, perm] = (before == 0.0) & (after < 0.0)
    missing = state.missing[:, None] - np.cumsum(hits, axis=1)
    state.L[:, seg_packet] = last
    state.lam[:, seg_packet] = _log1mexp(last)
    state.missing = missing[:, -1].copy()
    # log G after each emission, from the exact value at the chunk's end
    # backwards: once every packet is hit, log G rises to its end value, so
    # the sum of the changes still to come is at most |log G| and its
    # rounding stays relative (a forward sum from the chunk's start would
    # leave an absolute error ~1e-16 x the first hits' logs on every later
    # 1 - G ~ 0).
    to_come = np.zeros((R, E))
    to_come[:, :-1] = np.cumsum(delta[:, :0:-1], axis=1)[:, ::-1]
    log_g = np.minimum(state.log_g()[:, None] - to_come, 0.0)
    complete = missing == 0
    G = np.where(complete, np.exp(log_g), 0.0)
    one_minus = np.where(complete, -np.expm1(log_g), 1.0)
    return G, one_minus


@dataclass
class _Rows:
    """Running state of the (profile, phase) rows still being summed."""

    index: np.ndarray  # row number among all rows
    profile: np.ndarray
    phase: np.ndarray
    coset: np.ndarray  # row of the hyperperiod table: profile * g + phase mod g
    L: np.ndarray  # (rows, n) cumulative log failure per packet
    lam: np.ndarray  # (rows, n) log(1 - exp(L)), 0 for packets not hit
    missing: np.ndarray  # packets not hit yet
    tail_sum: np.ndarray  # sum_{j' <= j} (1 - G(j'))
    inverse: np.ndarray  # sum of the E[1/T; T <= K] terms so far

    def log_g(self) -> np.ndarray:
        """``log G`` of the packets hit (the missing ones counted apart), summed afresh."""
        return np.minimum(self.lam.sum(axis=1), 0.0)

    def keep(self, mask: np.ndarray) -> None:
        for name in ("index", "profile", "phase", "coset", "L", "lam", "missing", "tail_sum", "inverse"):
            setattr(self, name, getattr(self, name)[mask])


def _log_tail_bound(L: np.ndarray, log1m_a: np.ndarray, H: int) -> np.ndarray:
    """``log(H sum_k exp(L_k) / (1 - exp(A_k)))`` per row: bounds ``sum_{j' >= j} (1 - G(j'))``."""
    x = L - log1m_a  # -inf where the packet is surely received
    top = x.max(axis=1)
    safe = np.where(np.isfinite(top), top, 0.0)
    total = np.exp(x - safe[:, None]).sum(axis=1)
    with np.errstate(divide="ignore"):  # rows whose every packet is received: log(0) = -inf
        return np.where(np.isfinite(top), safe + np.log(total) + math.log(H), -np.inf)


def _remaining_work(state: _Rows, A: np.ndarray, log_bound: np.ndarray, H: int, period: int, j: int,
                    horizon: float) -> float:
    """Rows x emissions still needed, estimated from the per-hyperperiod decay of the bound."""
    a = np.where(state.L > -np.inf, -A[state.coset], np.inf).min(axis=1)  # slowest packet's decay
    log_ratio = log_bound - math.log(_TAIL_TOLERANCE) - np.log(np.maximum(state.tail_sum, 1.0))
    # a = inf: every packet left meets a q = 1 slot, within a hyperperiod at worst; a period is
    # the typical wait (an estimate: the budget is also checked on the work done).
    need = np.where(np.isinf(a), float(min(H, period)),
                    float(H) * np.maximum(log_ratio, 0.0) / np.maximum(a, 1e-300))
    need = np.where(log_ratio > 0.0, need, 0.0)
    return float(np.minimum(need, horizon - j).sum())


def _too_costly(work: float, rows: int, H: int, A: np.ndarray, done: bool) -> ExactSumTooCostly:
    """One-line refusal: predicted work (``done=False``) or work spent (``done=True``) above the budget."""
    finite = A[A > -np.inf]
    slowest = float(-np.expm1(finite.max())) if finite.size else 1.0
    what = (f"the tail is still above 1e-16 after {work:.2g} row-emissions" if done
            else f"the exact periodic-channel sum needs ~{work:.2g} row-emissions")
    return ExactSumTooCostly(
        f"{what} (rows = profiles x phases = {rows}, hyperperiod {H} emissions, slowest packet received "
        f"with probability {slowest:.3g} per hyperperiod), above the budget of {_WORK_BUDGET:.0e}: "
        "success probabilities too close to 0 or too many rows for the exact sum"
    )


def _row_figures(log_fail: np.ndarray, r: int, n: int, strategy: str, cap: int):
    """Per (profile, phase) row: ``G(r n)``, ``E[T]``, ``E[1/T; T <= cap]``, ``P(T > cap)``.

    Rows are numbered ``profile * C + phase``.
    """
    P, C = log_fail.shape
    R = P * C
    round_len = r * n
    period = r * n if strategy == "rp" else n
    if R * period > _WORK_BUDGET:
        raise ExactSumTooCostly(
            f"the exact periodic-channel sum needs {R * period:.2g} row-emissions (rows = profiles x phases = {R}, "
            f"{period} emissions per period) for its hyperperiod table, above the budget of {_WORK_BUDGET:.0e}"
        )
    # Per row and packet: L, log(1 - exp(L)), the hyperperiod sums and their
    # log1mexp, temporaries; about two dozen arrays of one chunk (padding included).
    chunk_elems = min(4 * _CHUNK_ELEMS, max(_CHUNK_ELEMS, R * n))
    check_memory(f"{P} profiles x {C} slots x n_packets = {n} (exact periodic-channel sum)",
                 8.0 * (6 * R * n + 24 * chunk_elems))
    A, g, H = _hyperperiod_logs(log_fail, r, n, strategy)
    dead_coset = (A == 0.0).any(axis=1)  # some packet only ever meets q = 0
    log1m_a = _log1mexp(np.where(dead_coset[:, None], -1.0, A))

    profile = np.repeat(np.arange(P), C)
    phase = np.tile(np.arange(C), P)
    coset = profile * g + phase % g
    dead = dead_coset[coset]
    g_round = np.zeros(R)
    expected = np.where(dead, np.inf, 0.0)
    inverse = np.zeros(R)
    capped = np.where(dead, 1.0, 0.0)
    alive = np.flatnonzero(~dead)
    # With a dead row E[T] is infinite anyway: the others run to the round and the cap only.
    horizon = float(max(round_len, cap)) if dead.any() else math.inf

    ra = alive.size
    state = _Rows(alive, profile[alive], phase[alive], coset[alive], np.zeros((ra, n)), np.zeros((ra, n)),
                  np.full(ra, n, dtype=np.int64), np.ones(ra), np.zeros(ra))
    work = float(R * period)
    j = 0
    size = max(256, 2 * n, min(round_len, 1 << 16))
    log_bound = _log_tail_bound(state.L, log1m_a[state.coset], H)
    while state.index.size:
        rows = state.index.size
        predicted = _remaining_work(state, A, log_bound, H, period, j, horizon)
        if work + predicted > _WORK_BUDGET:
            raise _too_costly(work + predicted, R, H, A, False)
        # Chunks grow from about a round (most rows finish within a few) to
        # the memory bound; at least a packet each when rows are many.
        E = min(size, max(1, _CHUNK_ELEMS // rows, min(n, 4 * _CHUNK_ELEMS // rows)))
        size *= 2
        t1 = j + E
        for mark in (round_len, cap, horizon):
            if j < mark < t1:
                t1 = int(mark)
        work += rows * (t1 - j)
        if work > _WORK_BUDGET:
            raise _too_costly(work, R, H, A, True)

        G, one_minus = _advance(state, log_fail, j, t1, r, n, strategy)
        jj = np.arange(j + 1, t1 + 1, dtype=np.float64)
        weight = np.where(jj < cap, 1.0 / (jj * (jj + 1.0)), np.where(jj == cap, 1.0 / cap, 0.0))
        state.inverse += G @ weight
        state.tail_sum += one_minus.sum(axis=1)
        j = t1

        # Exact G(j) at the chunk boundary (log G summed afresh).
        g_now = np.where(state.missing == 0, np.exp(state.log_g()), 0.0)
        if j == round_len:
            g_round[state.index] = g_now
        if j == cap:
            capped[state.index] = np.where(state.missing == 0, -np.expm1(state.log_g()), 1.0)
        log_bound = _log_tail_bound(state.L, log1m_a[state.coset], H)
        converged = log_bound <= math.log(_TAIL_TOLERANCE) + np.log(state.tail_sum)
        done = converged | (j >= horizon)
        if done.any():
            idx = state.index[done]
            early = g_now[done]
            if j < round_len:
                g_round[idx] = early
            if j < cap:  # G stays within the bound of g_now up to the cap; P(T > cap) ~ 0
                state.inverse[done] += early / (j + 1.0)
            inverse[idx] = state.inverse[done]
            if math.isinf(horizon):
                expected[idx] = state.tail_sum[done]
            state.keep(~done)
            log_bound = log_bound[~done]
    return g_round, expected, inverse, capped


# ----------------------------------------------------------------------------
# Public figures
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class PeriodicFigures:
    """Exact figures of a broadcast over a periodic slot channel.

    Attributes
    ----------
    p_round : float
        Probability that every packet is received within the first round of
        ``r * n_packets`` emissions.
    expected_emissions : float
        ``E[T]``, emissions up to and including the one completing the
        message, not capped; ``math.inf`` when, with positive probability,
        some packet can never be received (the true value, not an error).
    mean_inverse_emissions : float
        ``E[1/T; T <= max_emissions]`` in 1/emission: capped runs count 0.
    p_capped : float
        ``P(T > max_emissions)``.
    """

    p_round: float
    expected_emissions: float
    mean_inverse_emissions: float
    p_capped: float


def exact_figures(q, weights, r, n_packets, strategy, max_emissions=DEFAULT_MAX_EMISSIONS) -> PeriodicFigures:
    """Exact round probability, ``E[T]``, ``E[1/T; T <= cap]`` and ``P(T > cap)`` of a periodic channel.

    Parameters
    ----------
    q : array_like, shape (P, C) or (C,)
        Success probability of an emission in each slot of the cycle, per
        profile, in [0, 1]. A 1-D array is one profile.
    weights : array_like, shape (P,), or None
        Probability of each profile, >= 0, summing to 1 within 1e-9;
        ``None``: equal weights.
    r : int
        Copies per packet in a round, >= 1.
    n_packets : int
        Packets in the message, >= 1.
    strategy : {'rp', 'rs'}
        Emission order (see the module docstring).
    max_emissions : int, default 50000
        Cap of :func:`rollsim.channel.eventsim.simulate_broadcast`, >= 1: a
        run that needs more emissions counts with goodput 0.

    Returns
    -------
    PeriodicFigures
        ``payload_bits * n_packets / sdu_duration_s * mean_inverse_emissions``
        is the mean per-run goodput (bit/s) of the event simulator (see
        :func:`goodput_bps`).

    Raises
    ------
    ValueError
        For invalid inputs, naming the argument.
    ExactSumTooCostly
        When the sum would take more than ~1e8 row-emissions (rows =
        profiles x phases): success probabilities so close to 0 that the
        tail is very long, or many rows with a long hyperperiod. A
        ``ValueError`` too.

    Notes
    -----
    See the module docstring for the method. Cost: (profiles x C) x the
    emissions until every row's tail is below 1e-16 of its sum; memory
    bounded by chunks of ~2.6e5 row-emissions plus the ``rows x n_packets``
    state.
    """
    qa, w = _check_profiles(q, weights, "q")
    r = _as_count(r, "r", 1)
    n = _as_count(n_packets, "n_packets", 1)
    strategy = _check_strategy(strategy)
    cap = _as_count(max_emissions, "max_emissions", 1)
    used = w > 0.0  # a profile of weight 0 contributes nothing, not even an infinite E[T]
    qa, w = qa[used], w[used]
    C = qa.shape[1]
    g_round, expected, inverse, capped = _row_figures(_log_failure(qa), r, n, strategy, cap)
    row_w = np.repeat(w / C, C)
    e_t = math.inf if np.isinf(expected).any() else float(row_w @ expected)
    return PeriodicFigures(
        p_round=min(1.0, float(row_w @ g_round)),
        expected_emissions=e_t,
        mean_inverse_emissions=float(row_w @ inverse),
        p_capped=min(1.0, float(row_w @ capped)),
    )


def goodput_bps(q, weights, r, n_packets, strategy, payload_bits, sdu_duration_s,
                max_emissions=DEFAULT_MAX_EMISSIONS) -> dict:
    """Mean and expected goodput (bit/s) of a broadcast over a periodic slot channel.

    Parameters
    ----------
    q, weights, r, n_packets, strategy, max_emissions
        As in :func:`exact_figures`.
    payload_bits : int or float
        Useful bits per packet ``P``, > 0.
    sdu_duration_s : float
        Duration of one emission (one slot, one PHY-SDU) ``T_p`` in seconds, > 0.

    Returns
    -------
    dict
        ``mean_goodput_bps``
            ``E[P n / (T T_p)]`` with capped runs (``T > max_emissions``)
            counting 0: exactly the expectation of the mean of
            ``simulate_broadcast(PeriodicChannel(q, weights, T_p), ...).goodput_bps``,
            whose runs have goodput ``P n / (emissions x T_p)`` (the
            duration is the emissions times the channel's emission duration,
            no header or gap added) and 0 when capped. The replay of
            :func:`rollsim.calibrate.replay.replay_goodput_bps` uses the same
            per-run goodput ``P n / ((done + 1) T_p)``, ``done + 1 = T``,
            capped replays 0, averaged over start positions of one trace
            instead of over the channel's randomness: it estimates this
            figure when the trace is a realisation of this channel.
        ``expected_goodput_bps``
            ``P n / (E[T] T_p)``, the ratio of expectations of
            :func:`rollsim.channel.analytic.mmbp_expected_goodput_bps`
            (not capped); 0 when ``E[T]`` is infinite. At most the mean
            above when no run is capped (Jensen).
        ``p_capped``
            ``P(T > max_emissions)``.
    """
    payload = _as_positive(payload_bits, "payload_bits")
    duration = _as_positive(sdu_duration_s, "sdu_duration_s")
    n = _as_count(n_packets, "n_packets", 1)
    figures = exact_figures(q, weights, r, n, strategy, max_emissions)
    scale = payload * n / duration
    e_t = figures.expected_emissions
    return {
        "mean_goodput_bps": scale * figures.mean_inverse_emissions,
        "expected_goodput_bps": 0.0 if math.isinf(e_t) else scale / e_t,
        "p_capped": figures.p_capped,
    }


# ----------------------------------------------------------------------------
# Channel model for the event simulator
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class PeriodicChannel(ChannelModel):
    """Periodic slot channel for :func:`rollsim.channel.eventsim.simulate_broadcast`.

    Per run: profile ``p`` with probability ``weights[p]``, then the phase
    ``s`` uniform on ``0 .. C-1``; emission ``i`` falls in slot
    ``(s + i) mod C``. An emission in a slot with ``q = 0`` is a
    :data:`GAP_LOSS`; otherwise it is received if its U[0, 1) draw ``u`` is
    ``< q`` and a :data:`DECODE_ERROR` if ``u >= q``. Every emission consumes
    one draw, whatever its slot. The exact figures are
    :func:`exact_figures` and :func:`goodput_bps`.

    Parameters
    ----------
    success : array_like, shape (P, C) or (C,)
        Success probability per slot and profile, in [0, 1]; stored as a
        tuple of tuples (hashable, picklable).
    weights : array_like, shape (P,), or None
        Profile probabilities, summing to 1; ``None``: equal.
    sdu_duration_s : float
        Duration of one slot (one PHY-SDU emission) in seconds, > 0; the
        simulated clock advances by it at every emission.
    """

    success: tuple
    weights: Optional[tuple]
    sdu_duration_s: float
    _q: np.ndarray = field(init=False, repr=False, compare=False)
    _cumulative: np.ndarray = field(init=False, repr=False, compare=False)

    kind = "periodic"

    def __post_init__(self):
        qa, w = _check_profiles(self.success, self.weights, "success")
        qa.setflags(write=False)
        object.__setattr__(self, "success", tuple(tuple(float(v) for v in row) for row in qa))
        object.__setattr__(self, "weights", tuple(float(v) for v in w))
        object.__setattr__(self, "sdu_duration_s", _as_positive(self.sdu_duration_s, "sdu_duration_s"))
        object.__setattr__(self, "_q", qa)
        object.__setattr__(self, "_cumulative", np.cumsum(w))

    @property
    def cycle_slots(self) -> int:
        """``C``, slots per cycle."""
        return int(self._q.shape[1])

    @property
    def emission_duration_s(self) -> float:
        """Clock advance per emission, seconds."""
        return self.sdu_duration_s

    def parameters(self) -> dict:
        """JSON-ready parameters of the channel."""
        return {"kind": self.kind, "success": [list(row) for row in self.success],
                "weights": list(self.weights or ()), "sdu_duration_s": self.sdu_duration_s}

    def open_run(self, seed_sequence: np.random.SeedSequence) -> "_PeriodicRun":
        """Start one broadcast: draw the profile (if more than one), then the phase."""
        rng = np.random.default_rng(seed_sequence)
        P = self._q.shape[0]
        profile = 0
        if P > 1:
            # side="right": a profile of weight 0 is never drawn.
            u = float(rng.random()) * float(self._cumulative[-1])
            profile = min(P - 1, int(np.searchsorted(self._cumulative, u, side="right")))
        return _PeriodicRun(self._q[profile], int(rng.integers(self.cycle_slots)), rng)


class _PeriodicRun:
    def __init__(self, q: np.ndarray, slot: int, rng: np.random.Generator):
        self._q = q
        self._slot = slot  # slot of the next emission
        self._rng = rng

    def next_block(self, count: int) -> np.ndarray:
        C = self._q.size
        q = self._q[(self._slot + np.arange(count, dtype=np.int64)) % C]
        self._slot = (self._slot + count) % C
        u = self._rng.random(count)
        codes = np.where(u < q, RECEIVED, DECODE_ERROR).astype(np.uint8)
        codes[q == 0.0] = GAP_LOSS
        return codes
