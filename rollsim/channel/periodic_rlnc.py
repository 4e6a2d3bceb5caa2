"""Random linear coding over a periodic slot channel: exact figures, and the same replayed over a trace.

The channel is that of :mod:`rollsim.channel.periodic`: profiles ``q`` of
shape ``(P, C)`` with weights ``w``; a run draws profile ``p``, then the
phase ``s`` uniform on ``0 .. C-1``, and emission ``e`` (``e = 0, 1, ...``)
succeeds independently with probability ``q[p, (s + e) mod C]``. With
random linear coding (:mod:`rollsim.protocol.rlnc`) the receiver decodes at
the ``n``-th reception, ``n ~ receptions_to_full_rank_pmf(k)`` independent
of the channel, so ``T = tau_n``, the (1-based) index of the ``n``-th
reception. With ``D_t`` the distribution of the receptions ``N_t`` among
the first ``t`` emissions (a Poisson-binomial given the row: profile and
phase), ``S(m) = P(n > m)`` and ``v(m) = P(n = m + 1)``,

    P(T > t) = <D_t, S>,   P(T = t) = q_slot(t-1) <D_{t-1}, v>,

so ``E[T] = sum_{t >= 0} P(T > t)`` and ``E[1/T; T <= K] = sum_{t <= K} P(T = t) / t``.

Method (:func:`rlnc_periodic_figures`). Counts are kept below
``n_max = k + 56`` (``P(n > k + x) <= 2^-x``: the ``k + x`` combinations
all lie in one of the ``2^k - 1`` hyperplanes); the mass that reaches
``n_max`` receptions is complete and dropped. Any ``C`` consecutive
emissions of a profile see every slot once, so over a *span* of ``L = mC``
emissions (``m`` whole cycles, ``L`` at most about ``n_max`` when the cycle
is short) the count's increment is one Poisson-binomial ``B_p`` for all the
phases of a profile, and ``D_{jL + r} = D_r * B_p^{*j}`` (``*``:
convolution). Moving the convolutions onto the weights,

    <D_{jL + r}, S> = <D_r, S_j>,   S_j(m) = sum_i B_p^{*j}(i) S(m + i),

and likewise ``v_j``, so

    E[T | row] = sum_{r < L} <D_r, sum_j S_j>,
    E[1/T; T <= K | row] = sum_{r < L} q_slot(r) <D_r, W_r>,   W_r = sum_j v_j / (jL + r + 1) (terms <= K).

The per-profile vectors ``S_j``, ``v_j`` come from one correlation with
``B_p`` per span ``j`` (a loop over spans, vectorised over profiles and
counts); the rows (profile x phase) then need their count distributions
``D_r`` over the first span only (a loop over its emissions, vectorised
over rows and counts: the recursion is sequential). ``m`` balances the two
loops: more cycles per span, fewer span steps but longer rows. The tails
are bounded: from any position the wait for the next reception has mean at
most ``b_p = min_L' L' / (1 - pi_L')``, ``pi_L'`` the largest probability
of ``L'`` consecutive failures of the profile, so each count level lasts at
most ``b_p`` emissions on average and

    sum_{t >= t0} P(T > t | row) <= b_p <D_{t0}, S2>,   S2(m) = sum_{i >= m} S(i).

The spans stop when the bound at ``t0 = jL`` (where ``D_{jL} = B_p^{*j}``
for every row) and the rows when the bound at ``t0 = r`` are below 1e-16
of ``E[n] <= E[T]``; the terms of ``1/T`` left out are below the same
bound. The rows also drop the lowest counts once every row holds less than
1e-30 of its mass there (a count that all the rows have left).

:func:`rlnc_replay_goodput_bps` measures the same mean goodput on a 0/1
trace read cyclically, as :func:`rollsim.calibrate.replay.replay_goodput_bps`
does for RP and RS.
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from rollsim.channel.analytic import ExactSumTooCostly
from rollsim.channel.eventsim import DEFAULT_MAX_EMISSIONS
from rollsim.channel.periodic import _check_profiles, _log_failure
from rollsim.plumbing.budget import check_memory
from rollsim.plumbing.validation import as_count, as_positive
from rollsim.protocol.rlnc import receptions_to_full_rank_pmf

__all__ = ["rlnc_periodic_figures", "rlnc_replay_goodput_bps"]

# Receptions beyond k kept: P(n > k + x) <= 2^-x, so the mass left out is below 1.4e-17.
_RANK_MARGIN = 56
# Cells (rows x emissions x counts, and profiles x spans x counts x band) that
# rlnc_periodic_figures may process, each a handful of flops: a few seconds.
_WORK_BUDGET = 10**9
# Rows x counts per batch of the row recursion: a handful of float64 arrays of this size stay in cache.
_CHUNK_ELEMS = 1 << 16
# A sum stops when the bound on its rest is below this fraction of E[n] (<= E[T]).
_TAIL_TOLERANCE = 1e-16
# Mass of the lowest counts, per row, below which they are dropped (once every row has left them).
_NEGLIGIBLE = 1e-30
# Emissions between two checks of the rows' tail bound.
_CHECK_EVERY = 16
# Python overhead of one step of the per-span recursion, in cells.
_STEP_OVERHEAD = 2e4
# Widest span increment applied by shifted adds; wider ones by a (Toeplitz) matrix product.
_SHIFT_BAND = 32


# ----------------------------------------------------------------------------
# Rank distribution and tail bounds
# ----------------------------------------------------------------------------
def _rank_vectors(k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    """``pmf`` (n = 0 .. n_max), ``v``, ``S``, ``S2`` (m = 0 .. n_max - 1) and ``E[n]``."""
    n_max = k + _RANK_MARGIN
    pmf = receptions_to_full_rank_pmf(k, n_max)
    tail = np.cumsum(pmf[::-1])[::-1]  # tail[i] = P(i <= n <= n_max)
    v = pmf[1:].copy()  # v(m) = P(n = m + 1)
    S = tail[1:].copy()  # S(m) = P(n > m)
    S2 = np.cumsum(S[::-1])[::-1]  # S2(m) = sum_{i >= m} S(i)
    return pmf, v, S, S2, float(np.arange(n_max + 1) @ pmf)


def _wait_bounds(q: np.ndarray) -> np.ndarray:
    """Per profile, a bound on the mean emissions to the next reception from any position.

    ``min_L L / (1 - pi_L)`` over ``L = 1, 2, 4, ...`` (up to ``C``) and
    ``L = C``, ``pi_L`` the largest probability of ``L`` consecutive
    failures (windows read cyclically): disjoint windows fail
    independently, each with probability at most ``pi_L``. ``inf`` when
    every window fails surely (or all but 1e-300).
    """
    P, C = q.shape
    window = _log_failure(q)  # log of each window's failure probability, windows of length L
    best = np.full(P, np.inf)

    def consider(log_pi: np.ndarray, length: int) -> None:
        gap = -np.expm1(log_pi)  # 1 - pi_L, accurate when tiny
        ok = gap > 1e-300  # below, no bound (and no overflow)
        best[ok] = np.minimum(best[ok], length / gap[ok])

    length = 1
    while True:
        consider(window.max(axis=1), length)
        if 2 * length > C:
            break
        window = window + np.roll(window, -length, axis=1)  # -inf only added
        length *= 2
    if length < C:
        consider(_log_failure(q).sum(axis=1), C)
    return best


def _span_increment(q: np.ndarray, n: int) -> np.ndarray:
    """``B[p, m]``: P(m receptions over the slots ``q[p]``), m < n (the rest dropped).

    A loop over the slots, each step vectorised over profiles and counts:
    the rows' recursion does the same per row, C x more.
    """
    P, C = q.shape
    B = np.zeros((P, n))
    B[:, 0] = 1.0
    for c in range(C):
        h = min(c + 2, n)
        qc = q[:, c : c + 1]
        moved = B[:, : h - 1] * qc
        B[:, :h] *= 1.0 - qc
        B[:, 1:h] += moved
    return B


class _Correlator:
    """``X -> Y``, ``Y[p, m] = sum_i B[p, i] X[p, m + i]`` (the adjoint of convolving with ``B``)."""

    def __init__(self, B: np.ndarray, span: int):
        P, n = B.shape
        self.band = min(span + 1, n)
        self.B = B
        if self.band > _SHIFT_BAND:
            d = np.arange(n)[None, :] - np.arange(n)[:, None]  # m' - m
            inside = (d >= 0) & (d < self.band)
            self.matrix = np.where(inside[None, :, :], B[:, np.clip(d, 0, n - 1)], 0.0)  # (P, n, n)

    def __call__(self, X: np.ndarray) -> np.ndarray:  # X: (P, n, columns)
        if self.band > _SHIFT_BAND:
            return np.matmul(self.matrix, X)
        n = X.shape[1]
        Y = self.B[:, 0, None, None] * X
        for i in range(1, self.band):
            Y[:, : n - i] += self.B[:, i, None, None] * X[:, i:]
        return Y


class _InverseWeights:
    """``W_r[p] = sum_j v_j[p] / (j L + r + 1)`` over the spans ``j`` with ``j L + r + 1 <= K`` (``L`` the span).

    Kept as the list of ``v_j`` while there are fewer spans than emissions
    in a span (``W_r`` is then summed per emission, ``P J n`` < the rows'
    ``P L n``), else as the table ``W`` of shape ``(P, L, n)``, accumulated
    per span.
    """

    def __init__(self, span: int, cap: int):
        self.span = span
        self.cap = cap
        self.vectors: list = []
        self.stacked: Optional[np.ndarray] = None  # np.stack(self.vectors), cached
        self.table: Optional[np.ndarray] = None

    def _weights(self, j: np.ndarray, r: np.ndarray) -> np.ndarray:
        t = j * self.span + r + 1
        return np.where(t <= self.cap, 1.0 / t, 0.0)

    def add(self, j: int, v_j: np.ndarray) -> None:
        if j * self.span + 1 > self.cap:
            return  # every emission of the span is past the cap (so of the later ones)
        if self.table is None and len(self.vectors) < self.span:
            self.vectors.append(v_j.copy())
            self.stacked = None
            return
        r = np.arange(self.span)
        if self.table is None:
            js = np.arange(len(self.vectors))
            self.table = np.einsum("jr,jpn->prn", self._weights(js[:, None], r[None, :]), np.stack(self.vectors))
            self.vectors, self.stacked = [], None
        self.table += self._weights(np.array(j), r)[None, :, None] * v_j[:, None, :]

    def at(self, r: int, lo: int, hi: int) -> np.ndarray:
        """``W_r`` of the profiles ``lo .. hi - 1``, shape (hi - lo, n)."""
        if self.table is not None:
            return self.table[lo:hi, r]
        if self.stacked is None:
            self.stacked = np.stack(self.vectors)  # (J, P, n)
        coefficients = self._weights(np.arange(len(self.vectors)), np.array(r))
        return np.einsum("j,jpn->pn", coefficients, self.stacked[:, lo:hi])


def _check_rank_cost(k: int) -> None:
    """Refuse a k whose rank distribution alone (k x (k + 56) cells) exceeds the budget."""
    cells = float(k) * (k + _RANK_MARGIN)
    if cells > _WORK_BUDGET:
        raise ExactSumTooCostly(f"k = {k} source packets: the rank distribution alone needs ~{cells:.2g} cells, "
                                f"above the budget of {_WORK_BUDGET:.0e}")


def _too_costly(work: float, rows: int, C: int, n: int, done: bool) -> ExactSumTooCostly:
    what = (f"the tail is still above 1e-16 after {work:.2g} cells" if done
            else f"the exact rlnc periodic-channel sum needs ~{work:.2g} cells")
    return ExactSumTooCostly(
        f"{what} (rows = profiles x phases = {rows}, cycle {C} slots, counts below {n}), above the budget of "
        f"{_WORK_BUDGET:.0e}: success probabilities too close to 0, or too many rows and receptions, for the exact sum"
    )


# ----------------------------------------------------------------------------
# Exact figures
# ----------------------------------------------------------------------------
def _profile_figures(q: np.ndarray, k: int, cap: int):
    """Per row (live profiles only, ``profile * C + phase``): ``E[T]``, ``E[1/T; T <= cap]``, ``P(T > cap)``.

    Every profile of ``q`` must have some ``q > 0``.
    """
    P, C = q.shape
    R = P * C
    _check_rank_cost(k)
    pmf, v, S, S2, mean_n = _rank_vectors(k)
    n = v.size
    tol = _TAIL_TOLERANCE * mean_n
    wait = _wait_bounds(q)
    per_cycle = q.sum(axis=1)
    if not np.all(np.isfinite(wait)):
        raise ExactSumTooCostly(
            f"a profile's success probabilities (at most {float(q.max(axis=1).min()):.3g}) are too close to 0 "
            "for the exact rlnc periodic-channel sum: receptions too rare to bound its tail"
        )
    # A span of m whole cycles (at most about n emissions): the per-span recursion below takes
    # J / m steps, each with a Python overhead worth ~_STEP_OVERHEAD cells, and the rows' recursion
    # runs over one span, P C (m - 1) C n cells more; m balances the two.
    cycles_needed = float((n / per_cycle).max())
    m = math.sqrt(_STEP_OVERHEAD * cycles_needed / (P * C * C * n))
    span = C * int(max(1, min(n // C, round(m))))
    per_span = per_cycle * (span // C)
    # Work expected, an estimate (the work done is checked as it goes): spans until about
    # n_max receptions; the rows over as many emissions, at most a span, at about n / 2 counts each.
    spans_est = float((n / per_span).max())
    band = min(span + 1, n)
    predicted = (float(np.sum(C * np.minimum(span, n / per_span * span))) * n / 2 + spans_est * P * n * band
                 + max(0.0, spans_est - span) * P * span * n)
    if predicted > _WORK_BUDGET:
        raise _too_costly(predicted, R, C, n, False)
    batch = max(1, min(R, _CHUNK_ELEMS // n))
    check_memory(f"{P} profiles x {C} slots, k = {k} (exact rlnc periodic-channel sum)",
                 8.0 * (P * n * (band + 8) + P * min(span, int(spans_est) + 1) * n * 2 + 8 * batch * n))

    # Per-profile span vectors: columns S_j, v_j, S2_j of X (S_j from the convolution power B^{*j}).
    B = _span_increment(np.tile(q, (1, span // C)), n)
    correlate = _Correlator(B, span)
    work = float(P * span * n)
    X = np.repeat(np.stack([S, v, S2], axis=1)[None, :, :], P, axis=0)  # (P, n, 3)
    sum_S = np.zeros((P, n))
    inverse = _InverseWeights(span, cap)
    j_cap, r_cap = divmod(cap, span)
    capped_vector = None  # S_{j_cap}: P(T > cap | row) = <D_{r_cap}, S_{j_cap}>
    j = 0
    while True:
        sum_S += X[:, :, 0]
        inverse.add(j, X[:, :, 1])
        if j == j_cap:
            capped_vector = X[:, :, 0].copy()
        X = correlate(X)
        j += 1
        work += P * n * (band + (span if inverse.table is not None else 0))
        if np.all(wait * X[:, 0, 2] <= tol):  # the rest from t0 = j span: wait * <B^{*j}, S2>
            break
        if work > _WORK_BUDGET:
            raise _too_costly(work, R, C, n, True)
    spans = j

    # The rows over the first span, in batches of rows (profile-major).
    profile_of = np.repeat(np.arange(P), C)
    phase_of = np.tile(np.arange(C), P)
    expected = np.zeros(R)
    mean_inverse = np.zeros(R)
    capped = np.zeros(R)
    if C >= batch:  # pieces of one profile each (W_r is then one vector per batch)
        size = -(-C // -(-C // batch))
        bounds = [(p * C + i, min(p * C + i + size, (p + 1) * C)) for p in range(P) for i in range(0, C, size)]
    else:  # whole profiles
        per = batch // C
        bounds = [(p * C, min(P, p + per) * C) for p in range(0, P, per)]
    for a, b in bounds:
        prof, phase = profile_of[a:b], phase_of[a:b]
        lo, hi = int(prof[0]), int(prof[-1]) + 1
        D = np.zeros((b - a, n))
        D[:, 0] = 1.0
        visited = np.zeros((b - a, n))  # sum of D_r over the emissions r of the first span done
        inv = np.zeros(b - a)
        f = 0  # D[:, :f] = 0: counts every row has left but for a negligible mass (dropped)
        # A loop over the emissions of the first span is needed: each row's count distribution
        # is a recursion, one Bernoulli per emission; it is vectorised over rows x counts, and
        # the spans after the first are folded into the weights above.
        for r in range(span):
            h = min(r + 1, n)  # D_r lives on counts f .. min(r, n - 1)
            if r and r % _CHECK_EVERY == 0:
                if np.all(wait[prof] * (D[:, f:h] @ S2[f:h]) <= tol):
                    break  # the rest, t mod span >= r, is below the bound from t0 = r
                if work > _WORK_BUDGET:
                    raise _too_costly(work, R, C, n, True)
                below = np.cumsum(D[:, f:h], axis=1).max(axis=0) <= _NEGLIGIBLE
                if below.any():
                    f_new = f + int(np.flatnonzero(below)[-1]) + 1
                    D[:, f:f_new] = 0.0
                    f = min(f_new, h - 1)
            Dr = D[:, f:h]
            visited[:, f:h] += Dr
            q_r = q[prof, (phase + r) % C]
            if r + 1 <= cap:
                if spans == 1:  # W_r = v / (r + 1)
                    inv += q_r * (Dr @ v[f:h]) / (r + 1)
                elif hi - lo == 1:
                    inv += q_r * (Dr @ inverse.at(r, lo, hi)[0, f:h])
                else:
                    inv += q_r * np.einsum("ij,ij->i", Dr, inverse.at(r, lo, hi)[prof - lo, f:h])
            if r == r_cap and capped_vector is not None:
                capped[a:b] = np.einsum("ij,ij->i", Dr, capped_vector[prof, f:h])
            h1 = min(r + 2, n)
            moved = D[:, f : h1 - 1] * q_r[:, None]
            D[:, f:h1] *= (1.0 - q_r)[:, None]
            D[:, f + 1 : h1] += moved
            work += (b - a) * (h1 - f)
        expected[a:b] = np.einsum("ij,ij->i", visited, sum_S[prof])
        mean_inverse[a:b] = inv
    return expected, mean_inverse, np.minimum(capped, 1.0)


def rlnc_periodic_figures(q, weights, k, payload_bits, sdu_duration_s, max_emissions=DEFAULT_MAX_EMISSIONS) -> dict:
    """Exact expected emissions and goodput of random linear coding over a periodic slot channel.

    Parameters
    ----------
    q : array_like, shape (P, C) or (C,)
        Success probability of an emission in each slot, per profile, in
        [0, 1] (as :func:`rollsim.channel.periodic.exact_figures`).
    weights : array_like, shape (P,), or None
        Profile probabilities, summing to 1 within 1e-9; ``None``: equal.
    k : int
        Source packets K, >= 1.
    payload_bits : int or float
        Useful bits per source packet, > 0.
    sdu_duration_s : float
        Duration of one emission (slot) ``T_p``, seconds, > 0.
    max_emissions : int, default 50000
        Cap of :func:`rollsim.channel.eventsim.simulate_broadcast`, >= 1.

    Returns
    -------
    dict
        ``expected_emissions``
            ``E[T]``, ``T`` the emissions up to and including the one that
            completes the rank; ``math.inf`` when a profile of positive
            weight never receives (all its ``q = 0``).
        ``expected_goodput_bps``
            ``payload_bits k / (E[T] T_p)``; 0 when ``E[T]`` is infinite.
        ``mean_goodput_bps``
            ``E[payload_bits k / (T T_p); T <= max_emissions]``: the
            expectation of the mean goodput of ``simulate_broadcast`` with an
            ``RlncSchedule`` (seeds not repeating) over
            ``PeriodicChannel(q, weights, T_p)``, capped runs counting 0.
        ``p_capped``
            ``P(T > max_emissions)``.

        Exact up to tails below 1e-15 (see the module docstring).

    Raises
    ------
    ValueError
        For invalid inputs, naming the argument.
    ExactSumTooCostly
        When the sum would take more than ~1e9 cells (rows = profiles x
        phases, times emissions of a span, times counts ~ k + 56; plus the
        spans), a few seconds: success probabilities very close to 0, or
        many rows and a large k. A ``ValueError`` too.
    """
    qa, w = _check_profiles(q, weights, "q")
    k = as_count(k, "k", 1)
    payload = as_positive(payload_bits, "payload_bits")
    duration = as_positive(sdu_duration_s, "sdu_duration_s")
    cap = as_count(max_emissions, "max_emissions", 1)
    used = w > 0.0  # a profile of weight 0 contributes nothing, not even an infinite E[T]
    qa, w = qa[used], w[used]
    C = qa.shape[1]
    live = qa.max(axis=1) > 0.0
    dead_weight = float(w[~live].sum())
    mean_inverse, capped, expected = 0.0, dead_weight, 0.0
    if live.any():
        e_rows, inv_rows, cap_rows = _profile_figures(qa[live], k, cap)
        row_w = np.repeat(w[live] / C, C)
        expected = float(row_w @ e_rows)
        mean_inverse = float(row_w @ inv_rows)
        capped += float(row_w @ cap_rows)
    e_t = math.inf if dead_weight > 0.0 else expected
    scale = payload * k / duration
    return {
        "expected_emissions": e_t,
        "expected_goodput_bps": 0.0 if math.isinf(e_t) else scale / e_t,
        "mean_goodput_bps": scale * mean_inverse,
        "p_capped": min(1.0, capped),
    }


# ----------------------------------------------------------------------------
# Replay over a trace
# ----------------------------------------------------------------------------
def rlnc_replay_goodput_bps(success, k, payload_bits, sdu_duration_s, max_starts=500,
                            max_emissions=DEFAULT_MAX_EMISSIONS) -> dict:
    """Mean goodput of random linear coding replayed over a 0/1 trace read cyclically.

    From each of up to ``max_starts`` starts ``w`` evenly spaced over the
    trace (those of :func:`rollsim.calibrate.replay.replay_goodput_bps`),
    the goodput expected over the rank distribution,
    ``sum_n pmf(n) payload_bits k / (tau_n(w) T_p)``, ``tau_n(w)`` the
    emissions from ``w`` up to and including the ``n``-th success at or
    after ``w`` (the trace read cyclically), a term counting 0 when
    ``tau_n(w) > max_emissions``. On a trace that realises
    ``PeriodicChannel(q, weights, T_p)`` it estimates
    ``rlnc_periodic_figures(q, weights, ...)['mean_goodput_bps']``.

    Parameters
    ----------
    success : array_like of bool or 0/1, 1-D
        Outcome of each emission of the trace, in emission order.
    k : int
        Source packets K, >= 1.
    payload_bits : int or float
        Useful bits per source packet, > 0.
    sdu_duration_s : float
        PHY-SDU duration ``T_p``, seconds, > 0.
    max_starts : int, default 500
        Starts, >= 1, evenly spaced over the trace.
    max_emissions : int, default 50000
        Emissions after which a replay is capped (goodput 0), >= 1.

    Returns
    -------
    dict
        ``goodput_bps`` (mean of ``per_start``; None for an empty trace),
        ``per_start`` (ndarray, each start's expected goodput, in start
        order: the caller's batch-means interval, e.g.
        :func:`rollsim.calibrate.replay.batch_means_interval`, takes it),
        ``mean_length`` (mean over starts of ``sum_n pmf(n) min(tau_n,
        max_emissions)``, capped replays counting ``max_emissions`` as in
        that replay; None for an empty trace), ``replays`` (starts) and
        ``p_capped`` (mean over starts of ``P(tau_n > max_emissions)``; None
        for an empty trace).

    Raises
    ------
    ValueError
        For invalid inputs, naming the argument; ``ExactSumTooCostly`` for
        a k above ~31600, whose rank distribution is too long to compute.
    """
    x = np.asarray(success)
    if x.ndim != 1:
        raise ValueError(f"success must be a 1-D array of outcomes, got shape {x.shape}")
    if x.dtype != bool:
        if not (np.issubdtype(x.dtype, np.number) and np.all((x == 0) | (x == 1))):
            raise ValueError("success must hold booleans or 0/1 values")
        x = x.astype(bool)
    k = as_count(k, "k", 1)
    payload = as_positive(payload_bits, "payload_bits")
    duration = as_positive(sdu_duration_s, "sdu_duration_s")
    max_starts = as_count(max_starts, "max_starts", 1)
    cap = as_count(max_emissions, "max_emissions", 1)
    L = x.size
    if L == 0:
        return {"goodput_bps": None, "per_start": np.zeros(0), "mean_length": None, "replays": 0, "p_capped": None}
    _check_rank_cost(k)
    pmf = receptions_to_full_rank_pmf(k, k + _RANK_MARGIN)
    ranks = np.arange(k, pmf.size)  # pmf(n) = 0 below k
    weights = pmf[k:]
    starts = np.unique(np.linspace(0, L - 1, max_starts).astype(np.int64))
    hits = np.flatnonzero(x)
    scale = payload * k / duration
    if hits.size == 0:
        per_start = np.zeros(starts.size)
        return {"goodput_bps": 0.0, "per_start": per_start, "mean_length": float(cap), "replays": int(starts.size),
                "p_capped": 1.0}
    h = hits.size
    per_start = np.empty(starts.size)
    lengths = np.empty(starts.size)
    capped = np.empty(starts.size)
    step = max(1, _CHUNK_ELEMS // ranks.size)
    for a in range(0, starts.size, step):
        w = starts[a : a + step]
        # Index of the n-th success at or after w among the successes unrolled over laps of the trace.
        index = np.searchsorted(hits, w)[:, None] + (ranks[None, :] - 1)
        tau = hits[index % h] + L * (index // h) - w[:, None] + 1  # >= 1
        within = tau <= cap
        per_start[a : a + step] = scale * (np.where(within, 1.0 / tau, 0.0) @ weights)
        lengths[a : a + step] = np.minimum(tau, cap) @ weights
        capped[a : a + step] = (~within) @ weights
    return {"goodput_bps": float(per_start.mean()), "per_start": per_start, "mean_length": float(lengths.mean()),
            "replays": int(starts.size), "p_capped": float(min(1.0, capped.mean()))}
