"""Exact analysis of the MMBP and Gilbert-Elliott LED-to-camera channel models.

This module computes, exactly and in log space where products underflow, the
loss probabilities of the reference paper (sections 4 and 5) for the Repeat
Packet (RP) and Repeat Sequence (RS) strategies, the whole-message success
probability, the expected number of emissions until a message is complete and
the matching goodput. The paper's closed forms are also exposed *as printed*
(``paper_eq6_p0_rp``, ``paper_eq7_p0_rp``) so that tests can check them
against enumeration; they are claims, not the reference.

Conventions
-----------
MMBP (paper §4.1). One camera frame is a cycle of ``C = M + N`` slots, each one
PHY-SDU long. Slots ``0 .. M-1`` are ON: an emission there is received with
probability ``1 - p_e``, independently of every other emission. Slots
``M .. C-1`` are OFF: an emission there is never received. The phase ``s`` of
the transmitter against the camera is uniform on ``0 .. C-1``; emission number
``k`` (``k = 0, 1, ...``) falls in slot ``(s + k) mod C``. Given the phase the
slot pattern is deterministic, so receptions are independent given ``s``; all
"exact" results are averages over ``s`` of phase-conditioned products.

Strategies. RP: packet ``k`` is emitted ``r`` times in a row (emissions
``k*r .. k*r + r - 1`` of a round). RS: the sequence of ``n_packets`` packets
is emitted ``r`` times (packet ``k`` at emissions ``k + j*n_packets``). A round
has ``r * n_packets`` emissions; a broadcast repeats rounds forever.

Gilbert-Elliott (paper §4.1.1, Eq. 1, 3). ``S1`` = capturing (success
probability ``1 - p_e``), ``S2`` = inter-frame gap (never succeeds). The paper
writes that ``p`` is the S1->S2 probability, yet gives ``P_S1 = p / (p + q)``
and ``p = delta_c / delta_f`` (the capture fraction). Those two formulas are
only consistent if ``p = P(S2 -> S1)`` and ``q = P(S1 -> S2)``; this module
uses that reading throughout (see :func:`ge_stationary`). With the paper's
``p + q = 1`` (Eq. 1) the chain is memoryless (the next state does not depend
on the current one) and Eq. 3 is then exact; otherwise it is an approximation.

Paper equation -> function
--------------------------
=====================  =============================================  ==========
Paper                  Function                                       Status
=====================  =============================================  ==========
Eq. 1                  :func:`ge_stationary`                          convention fixed
Eq. 2                  slot pattern inside every ``mmbp_*`` function
Eq. 3                  :func:`ge_p0_rp` (``exact=False``)             approximation
(Eq. 3, chain)         :func:`ge_p0_rp` (``exact=True``)              exact
Eq. 4, 5               :func:`mmbp_p0_rp`                             exact, O(C)
Eq. 6                  :func:`paper_eq6_p0_rp`                        as printed
Eq. 7                  :func:`paper_eq7_p0_rp`                        as printed (wrong)
Eq. 8                  :func:`mmbp_p0_rs`                             exact, O(C)
Fig. 7-9, 12           :func:`mmbp_p_message`,                        exact, O(C)
                       :func:`mmbp_log_p_message`
Fig. 7 (GE curve)      :func:`ge_p_message`, :func:`ge_log_p_message`
Eq. 9, 10              :func:`roi_ratio`
§6.2.2 (M from         :func:`mmbp_slots_from_physics`,
physics)               :func:`capture_window_s`
§6.3 (goodput)         :func:`mmbp_expected_emissions`,
                       :func:`mmbp_expected_goodput_bps`
=====================  =============================================  ==========

Findings about the printed equations (each is asserted by a test in
``tests/channel/test_analytic.py``):

* Eq. 6 (case ``r < M, N``) is correct; it even holds for
  ``r <= min(M, N) + 1``. Its first line labels the events with ``s + r``
  although the last copy is in slot ``s + r - 1`` (the counts on the second
  line use ``s + r - 1``).
* Eq. 7 (case ``N < r < M``), lines 2 and 3: a window that starts in an ON
  slot and spans the whole gap comes back into ON slots, so it holds
  ``max(i, r - N)`` ON slots, not ``i``. The printed form is exact only for
  ``r = N + 1`` and overestimates ``p0`` for ``r >= N + 2``.
* Eq. 7, line 4: ``sum_{i=1}^{N} p_e^(r-i) = p_e^(r-N) (1 - p_e^N)/(1 - p_e)``;
  the printed ``p_e^(r-N) (p_e - p_e^N)/(1 - p_e)`` drops the ``i = N`` term
  ``p_e^(r-N)``, so line 4 disagrees with lines 2-3 (at ``p_e = 1`` it gives
  ``(C - 1)/C`` instead of 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rollsim.plumbing.budget import check_memory
from rollsim.channel import phase_sweep
from rollsim.errors import BudgetError
from rollsim.plumbing.validation import as_count as _as_count
from rollsim.plumbing.validation import as_positive as _as_positive
from rollsim.plumbing.validation import as_probability as _as_probability

__all__ = [
    "MmbpSlots",
    "capture_window_s",
    "ge_log_p_message",
    "ge_p0_rp",
    "ge_p_message",
    "ge_stationary",
    "mmbp_expected_emissions",
    "mmbp_expected_goodput_bps",
    "mmbp_log_p_message",
    "mmbp_p0_rp",
    "mmbp_p0_rs",
    "mmbp_p_message",
    "mmbp_slots_from_physics",
    "paper_eq6_p0_rp",
    "paper_eq7_p0_rp",
    "roi_ratio",
    "throughput_bound_bps",
]

_STRATEGIES = ("rp", "rs")
# Work budget (array elements touched) of mmbp_expected_emissions; beyond it
# the call would take minutes, so it fails fast with an explanation instead.
_EMISSIONS_WORK_BUDGET = 3 * 10**8
_MAX_HYPERPERIOD = 10**7


# ----------------------------------------------------------------------------
# Input validation
# ----------------------------------------------------------------------------






class ExactSumTooCostly(BudgetError, ValueError):
    """The exact expected emissions would take more terms than the work budget.

    A :class:`rollsim.errors.BudgetError` (one line, exit 2, naming what
    makes the sum long) and a ``ValueError`` for callers of the analysis.
    """


def _check_cycle(M, N) -> tuple[int, int, int]:
    M = _as_count(M, "M", 0)
    N = _as_count(N, "N", 0)
    if M + N < 1:
        raise ValueError("the cycle C = M + N must be >= 1 slot, got M = N = 0")
    return M, N, M + N


# Cycles up to this length use the dense O(C) forms (a few MB); longer ones
# use the phase sweep (rollsim.channel.phase_sweep), whose cost follows the
# emissions, whenever it needs less memory.
_DENSE_MAX_CYCLE = 1 << 18
# Memory of the dense forms per slot of the cycle: the orbit walk, its
# doubled copy and cumulative sums, ON counts and log factors.
_DENSE_BYTES_PER_SLOT = 96


def _sweeps(C: int, emissions: int) -> bool:
    """Whether to average over phases by the sweep (True) or densely (False).

    Checks the chosen method's memory against the budget
    (:mod:`rollsim.plumbing.budget`), so that a cycle of 10**9 slots with few
    emissions answers in O(emissions) memory, and one that neither method
    can afford is refused before it allocates.
    """
    if C <= _DENSE_MAX_CYCLE:
        return False
    dense = _DENSE_BYTES_PER_SLOT * C
    sweep = phase_sweep.SWEEP_BYTES_PER_EMISSION * emissions
    use_sweep = sweep < dense
    check_memory(f"M + N = {C} with {emissions} emissions per round", min(dense, sweep))
    return use_sweep


def _check_strategy(strategy) -> str:
    key = str(strategy).lower()
    if key not in _STRATEGIES:
        raise ValueError(f"strategy must be one of {_STRATEGIES}, got {strategy!r}")
    return key


# ----------------------------------------------------------------------------
# Small numerical helpers
# ----------------------------------------------------------------------------
def _on_slots(M: int, C: int) -> np.ndarray:
    """Indicator of ON slots over one cycle (Eq. 2: p0 = p_e on ON, 1 on OFF)."""
    return (np.arange(C) < M).astype(np.int64)


def _orbit_sums(values: np.ndarray, step: int, length: int) -> np.ndarray:
    """``out[s] = sum_{k < length} values[(s + k*step) mod C]`` for every ``s``.

    The walk ``s, s + step, ...`` (mod C) is periodic with period
    ``L = C / gcd(step, C)`` and visits each residue of its coset
    ``s mod gcd`` once per period, so the sum is ``length // L`` full coset
    sums plus a partial walk read off a cumulative sum. Cost O(C), whatever
    ``length``.
    """
    C = values.shape[0]
    step %= C
    g = math.gcd(step, C)  # gcd(0, C) = C: a fixed point, period 1
    period = C // g
    n_full, rem = divmod(length, period)
    j = np.arange(period)
    walk = (np.arange(g)[:, None] + j[None, :] * step) % C  # (g, period): all residues
    v = values[walk]
    full = v.sum(axis=1)
    doubled = np.concatenate([v, v], axis=1)
    zero = np.zeros((g, 1), dtype=values.dtype)
    cums = np.concatenate([zero, np.cumsum(doubled, axis=1)], axis=1)
    partial = cums[:, j + rem] - cums[:, j]
    out = np.empty(C, dtype=np.result_type(values.dtype, np.int64))
    out[walk] = n_full * full[:, None] + partial
    return out


def _log1m_pow(p_e: float, m: np.ndarray) -> np.ndarray:
    """``log(1 - p_e**m)`` for integer ``m >= 0``; ``-inf`` where it is log(0).

    Chooses between ``log1p(-x)`` and ``log(-expm1(.))`` (the "log1mexp"
    trick) so that both ``p_e**m`` near 0 and near 1 keep full relative
    precision, and never evaluates ``log(0)`` (no RuntimeWarning).
    """
    m = np.asarray(m, dtype=np.int64)
    out = np.full(m.shape, -np.inf)
    if p_e == 1.0:
        return out
    positive = m > 0
    if p_e == 0.0:
        out[positive] = 0.0
        return out
    a = m[positive] * math.log(p_e)  # < 0
    # Both branches are safe for a < 0: exp(a) < 1 and -expm1(a) > 0.
    out[positive] = np.where(a < -math.log(2.0), np.log1p(-np.exp(a)), np.log(-np.expm1(a)))
    return out


def _log1mexp(x: float) -> float:
    """``log(1 - exp(x))`` for scalar ``x <= 0``; ``-inf`` at ``x = 0``."""
    # x is a log-probability; a matrix product can round it a few ulp above 0.
    if x >= 0.0:
        return -math.inf
    if x == -math.inf:
        return 0.0
    if x < -math.log(2.0):
        return math.log1p(-math.exp(x))
    return math.log(-math.expm1(x))


def _log_mean_exp(values: np.ndarray) -> float:
    """``log(mean(exp(values)))``, exact ``-inf`` when all terms are ``-inf``."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return -math.inf
    top = finite.max()
    return float(top + math.log(np.exp(finite - top).sum()) - math.log(values.size))


def _pow_ratio(p_e: float, lo: int, hi: int) -> float:
    """``(p_e**lo - p_e**hi) / (1 - p_e)`` with its ``p_e -> 1`` limit ``hi - lo``.

    This is the geometric sum ``sum_{i=lo}^{hi-1} p_e**i`` (negated when
    ``hi < lo``); written with ``expm1`` so that ``p_e`` close to 1 does not
    cancel catastrophically.
    """
    if p_e == 1.0:
        return float(hi - lo)
    if p_e == 0.0:
        if lo < 0 or hi < 0:
            raise ValueError("p_e = 0 with a negative exponent is undefined")
        return float(lo == 0) - float(hi == 0)  # 0**0 = 1
    log_p = math.log(p_e)
    # p^lo - p^hi = p^lo * (1 - p^(hi-lo)) = -p^lo * expm1((hi-lo) log p)
    return -math.exp(lo * log_p) * math.expm1((hi - lo) * log_p) / (-math.expm1(log_p))


# --- 2x2 / 4x4 Markov-chain algebra (Gilbert-Elliott) -----------------------
def _matpow(A: np.ndarray, n: int) -> np.ndarray:
    """``A**n`` by squaring, for (sub)stochastic ``A`` whose powers stay <= 1."""
    result = np.eye(A.shape[0])
    base = A.copy()
    while n:
        if n & 1:
            result = result @ base
        n >>= 1
        if n:
            base = base @ base
    return result


def _log_quadratic_form(left: np.ndarray, A: np.ndarray, n: int, right: np.ndarray) -> float:
    """``log(left @ A**n @ right)`` for nonnegative ``A``, stable for n ~ 1e9.

    Power by squaring where every intermediate matrix is renormalised by its
    largest entry and the scale is carried as a log, so a product that decays
    like ``0.5**1e9`` neither underflows nor loses precision.
    """

    def normalise(X, log_scale):
        top = X.max()
        if top > 0.0:
            return X / top, log_scale + math.log(top)
        return X, log_scale  # an all-zero matrix stays zero; the end result is -inf

    result, log_result = np.eye(A.shape[0]), 0.0
    base, log_base = normalise(A.astype(float), 0.0)
    while n:
        if n & 1:
            result, log_result = normalise(result @ base, log_result + log_base)
        n >>= 1
        if n:
            base, log_base = normalise(base @ base, 2.0 * log_base)
    value = float(left @ result @ right)
    if value <= 0.0:
        return -math.inf
    # Callers pass probabilities: clip the few-ulp rounding above log(1) = 0.
    return min(0.0, math.log(value) + log_result)


def _check_ge(p, q) -> tuple[float, float]:
    p = _as_probability(p, "p")
    q = _as_probability(q, "q")
    if p + q == 0.0:
        raise ValueError("p + q must be > 0 (with p = q = 0 the chain has no unique stationary state)")
    return p, q


def _ge_matrices(p: float, q: float, p_e: float):
    """Stationary row vector, transition matrix and failure diagonal of the GE chain."""
    # Rows are the current state (S1, S2); see ge_stationary for the convention.
    P = np.array([[1.0 - q, q], [p, 1.0 - p]])
    pi = np.array(ge_stationary(p, q))
    B = np.diag([p_e, 1.0])  # probability that an emission in S1 / S2 is lost
    return pi, P, B


# ----------------------------------------------------------------------------
# Gilbert-Elliott
# ----------------------------------------------------------------------------
def ge_stationary(p: float, q: float) -> tuple[float, float]:
    """Stationary probabilities ``(P_S1, P_S2)`` of the Gilbert-Elliott chain.

    Convention: ``p = P(S2 -> S1)`` (gap to capture) and ``q = P(S1 -> S2)``
    (capture to gap), per slot. Then ``P_S1 = p / (p + q)``, as printed in the
    paper (§4.1.1), and the paper's Eq. 1, ``p = 1 - q = delta_c / delta_f``,
    gives ``P_S1 = delta_c / delta_f``, the fraction of time the camera
    captures, as it should.

    The paper's sentence "the transition probability between S1 and S2 is
    denoted p" would mean ``p = P(S1 -> S2)``; under that reading the
    stationary ``P_S1`` is ``q / (p + q)``, i.e. the gap fraction, which
    contradicts both the printed ``P_S1`` and the physical meaning of Eq. 1.
    Hence the reading above.

    Parameters
    ----------
    p : float
        Per-slot probability of going from S2 (gap) to S1 (capture), in [0, 1].
    q : float
        Per-slot probability of going from S1 (capture) to S2 (gap), in [0, 1].
        ``p + q`` must be > 0.

    Returns
    -------
    (float, float)
        ``(p / (p + q), q / (p + q))``.
    """
    p, q = _check_ge(p, q)
    return p / (p + q), q / (p + q)


def ge_p0_rp(p: float, q: float, r, p_e: float, exact: bool = False) -> float:
    """Probability that all ``r`` consecutive copies of a packet are lost (GE).

    Parameters
    ----------
    p, q : float
        Transition probabilities, convention of :func:`ge_stationary`.
    r : int
        Number of consecutive copies, >= 1.
    p_e : float
        PHY-SDU error probability in S1, in [0, 1].
    exact : bool, default False
        ``False``: the paper's Eq. 3, ``((p p_e + q) / (p + q))**r``, which
        treats the ``r`` slots' states as independent draws from the
        stationary law. ``True``: the 2-state Markov chain started in its
        stationary law, ``pi (B P)**r 1`` with ``B = diag(p_e, 1)``.

    Returns
    -------
    float
        Probability in [0, 1].

    Notes
    -----
    The two agree exactly when ``p + q = 1`` (the paper's Eq. 1): then every
    row of the transition matrix equals the stationary law, the chain is
    memoryless and consecutive states are independent. For ``p + q < 1`` the
    states are positively correlated (bursty), the chain value is larger than
    Eq. 3 for ``r >= 2``; for ``p + q > 1`` they alternate and it is smaller.
    """
    p, q = _check_ge(p, q)
    r = _as_count(r, "r", 1)
    p_e = _as_probability(p_e, "p_e")
    if not exact:
        base = (p * p_e + q) / (p + q)
        return float(base**r)  # underflow to 0 is the right answer, not an error
    pi, P, B = _ge_matrices(p, q, p_e)
    return math.exp(_log_quadratic_form(pi, B @ P, r, np.ones(2)))


def ge_log_p_message(
    p: float, q: float, r, p_e: float, n_packets, strategy: str = "rp", exact: bool = True
) -> float:
    """Natural log of :func:`ge_p_message` (``-inf`` when the probability is 0)."""
    p, q = _check_ge(p, q)
    r = _as_count(r, "r", 1)
    p_e = _as_probability(p_e, "p_e")
    n = _as_count(n_packets, "n_packets", 1)
    strategy = _check_strategy(strategy)

    if not exact:
        base = (p * p_e + q) / (p + q)
        log_p0 = r * math.log(base) if base > 0.0 else -math.inf
        return n * _log1mexp(log_p0)

    pi, P, B = _ge_matrices(p, q, p_e)
    if strategy == "rp":
        # Augmented chain over (state, already-received flag): one slot is
        # G = [[B P, (I - B) P], [0, P]]. The top-right block of G**r is
        # P(at least one of r copies received, end state | start state),
        # obtained without the cancellation of P**r - (B P)**r.
        G = np.zeros((4, 4))
        G[:2, :2] = B @ P
        G[:2, 2:] = (np.eye(2) - B) @ P
        G[2:, 2:] = P
        success_block = _matpow(G, r)[:2, 2:]
        return _log_quadratic_form(pi, success_block, n, np.ones(2))

    # RS: copies of a packet are n slots apart, and packets interleave, so the
    # joint law of all packets needs the chain state plus 2**n reception
    # flags. Only the per-packet loss probability is computed exactly; packets
    # are then treated as independent.
    step = B @ _matpow(P, n)
    log_p0 = _log_quadratic_form(pi, step, r, np.ones(2))
    return n * _log1mexp(log_p0)


def ge_p_message(
    p: float, q: float, r, p_e: float, n_packets, strategy: str = "rp", exact: bool = True
) -> float:
    """Probability that all ``n_packets`` packets are received in one round (GE).

    Parameters
    ----------
    p, q : float
        Transition probabilities, convention of :func:`ge_stationary`.
    r : int
        Copies per packet, >= 1.
    p_e : float
        PHY-SDU error probability in S1, in [0, 1].
    n_packets : int
        Packets in the message, >= 1 (up to 2**53).
    strategy : {'rp', 'rs'}
        Emission order within the round, see the module docstring.
    exact : bool, default True
        ``False``: packets independent, each lost with the Eq. 3 probability:
        ``(1 - p0_eq3)**n_packets`` (the spacing of the copies does not matter
        for Eq. 3). ``True``:

        * ``'rp'``: exact for the Markov chain (stationary start), as
          ``pi S**n_packets 1`` with ``S`` the 2x2 "packet received" block of
          the chain over ``r`` slots, by a log-scaled power by squaring.
        * ``'rs'``: **not exact**. The joint law needs ``2**n_packets`` states,
          so only the per-packet loss probability (copies ``n_packets`` slots
          apart) comes from the chain, ``pi (B P**n_packets)**r 1``; packets
          are then treated as independent.

    Returns
    -------
    float
        Probability in [0, 1].
    """
    return math.exp(ge_log_p_message(p, q, r, p_e, n_packets, strategy, exact))


# ----------------------------------------------------------------------------
# MMBP: per-packet loss probabilities (Eq. 4, 5, 8)
# ----------------------------------------------------------------------------
def _on_counts_rp(M: int, C: int, r: int) -> np.ndarray:
    """ON slots in the window of ``r`` consecutive slots starting at each slot."""
    return _orbit_sums(_on_slots(M, C), 1, r)


def _on_counts_rs(M: int, C: int, r: int, spacing: int) -> np.ndarray:
    """ON slots among ``u, u + spacing, ..., u + (r-1) spacing`` for each slot ``u``."""
    return _orbit_sums(_on_slots(M, C), spacing, r)


def mmbp_p0_rp(M, N, r, p_e: float) -> float:
    """Probability that all ``r`` consecutive copies of a packet are lost (Eq. 4, 5).

    ``p0 = (1/C) sum_s p_e**m_s``, where ``m_s`` is the number of ON slots in
    the ``r`` slots starting at slot ``s`` and ``p_e**0 = 1`` (also for
    ``p_e = 0``). ``m_s`` is counted in closed form (``r // C`` full cycles of
    ``M`` ON slots plus the partial window), so the cost is O(C) for any ``r``.

    Parameters
    ----------
    M, N : int
        ON and OFF slots per cycle, >= 0, with ``M + N >= 1``.
    r : int
        Consecutive copies, >= 1 (up to 2**53).
    p_e : float
        PHY-SDU error probability in an ON slot, in [0, 1].

    Returns
    -------
    float
        Probability in [0, 1].
    """
    M, N, C = _check_cycle(M, N)
    r = _as_count(r, "r", 1)
    p_e = _as_probability(p_e, "p_e")
    if _sweeps(C, r):
        return phase_sweep.mean_loss(M, C, np.arange(r, dtype=np.int64), p_e)
    m = _on_counts_rp(M, C, r)
    return float(np.mean(np.power(p_e, m)))


def mmbp_p0_rs(M, N, r, p_e: float, n_packets) -> float:
    """Probability that all ``r`` copies of a packet are lost under RS (Eq. 8).

    Copies are ``n_packets`` slots apart:
    ``p0 = (1/C) sum_s prod_{j<r} p0(s + j n_packets)``. The slots
    ``(s + j n_packets) mod C`` are periodic in ``j`` with period
    ``C / gcd(n_packets, C)``, so ``r`` and ``n_packets`` up to 2**53 cost
    O(C).

    Parameters
    ----------
    M, N : int
        ON and OFF slots per cycle, >= 0, with ``M + N >= 1``.
    r : int
        Repetitions of the sequence, >= 1.
    p_e : float
        PHY-SDU error probability in an ON slot, in [0, 1].
    n_packets : int
        Packets in the sequence (the spacing of the copies), >= 1.

    Returns
    -------
    float
        Probability in [0, 1].

    Notes
    -----
    When ``n_packets`` is a multiple of ``C`` every copy of a packet lands in
    the same slot, so ``1 - p0 = (M / C)(1 - p_e**r)``: at most a fraction
    ``M / C`` of the packets is ever received (the artefact of the paper's
    Fig. 12).
    """
    M, N, C = _check_cycle(M, N)
    r = _as_count(r, "r", 1)
    p_e = _as_probability(p_e, "p_e")
    n = _as_count(n_packets, "n_packets", 1)
    if _sweeps(C, r):
        return phase_sweep.mean_loss(M, C, np.arange(r, dtype=np.int64) * n, p_e)
    m = _on_counts_rs(M, C, r, n)
    return float(np.mean(np.power(p_e, m)))


# ----------------------------------------------------------------------------
# The paper's closed forms, as printed
# ----------------------------------------------------------------------------
def _check_paper_case(M: int, N: int, r: int, ok: bool, case: str, strict: bool) -> None:
    if strict and not ok:
        raise ValueError(
            f"{case} requires {'r < M and r < N' if case == 'Eq. 6' else 'N < r < M'}, "
            f"got M={M}, N={N}, r={r} (pass strict_domain=False to evaluate anyway)"
        )


def paper_eq6_p0_rp(M, N, r, p_e: float, line: int = 3, strict_domain: bool = True) -> float:
    """The paper's Eq. 6 (RP, case ``r < M, N``), exactly as printed.

    Line 2 (sums)::

        (N-r+1)/C + (M-r+1)/C p_e^r + 1/C sum_{i=1}^{r-1} p_e^i
                                    + 1/C sum_{i=1}^{r-1} p_e^(r-i)

    Line 3 (closed form)::

        (N-r+1)/C + (M-r+1)/C p_e^r + 2/C (p_e - p_e^r)/(1 - p_e)

    Line 1 only names the events. The two lines agree; both equal the exact
    :func:`mmbp_p0_rp` on the stated domain and in fact for
    ``r <= min(M, N) + 1``. ``(p_e - p_e^r)/(1 - p_e)`` takes its limit
    ``r - 1`` at ``p_e = 1``.

    Parameters
    ----------
    M, N : int
        ON and OFF slots per cycle.
    r : int
        Consecutive copies, >= 1.
    p_e : float
        PHY-SDU error probability, in [0, 1].
    line : {2, 3}
        Which printed line to evaluate.
    strict_domain : bool, default True
        Raise ValueError outside the paper's case ``r < M and r < N``.

    Returns
    -------
    float
        The printed expression (not clipped; it can leave [0, 1] off-domain).
    """
    M, N, C = _check_cycle(M, N)
    r = _as_count(r, "r", 1)
    p_e = _as_probability(p_e, "p_e")
    _check_paper_case(M, N, r, r < M and r < N, "Eq. 6", strict_domain)
    head = (N - r + 1) / C + (M - r + 1) / C * p_e**r
    if line == 2:
        s1 = sum(p_e**i for i in range(1, r))
        s2 = sum(p_e ** (r - i) for i in range(1, r))
        return head + s1 / C + s2 / C
    if line == 3:
        return head + 2.0 / C * _pow_ratio(p_e, 1, r)
    raise ValueError(f"line must be 2 or 3 for Eq. 6, got {line!r}")


def paper_eq7_p0_rp(M, N, r, p_e: float, line: int = 4, strict_domain: bool = True) -> float:
    """The paper's Eq. 7 (RP, case ``N < r < M``), exactly as printed.

    Line 2 (sums)::

        (M-r+1)/C p_e^r + 1/C sum_{i=1}^{r-1} p_e^i + 1/C sum_{i=1}^{N} p_e^(r-i)

    Line 3::

        (M-r+1)/C p_e^r + 1/C (p_e - p_e^r)/(1 - p_e) + 1/C sum_{i=1}^{N} p_e^(r-i)

    Line 4 (closed form)::

        (M-r+1)/C p_e^r + 1/C (p_e - p_e^r)/(1 - p_e)
                        + 1/C p_e^(r-N) (p_e - p_e^N)/(1 - p_e)

    Both are wrong in general (see the module docstring): lines 2-3 equal the
    exact :func:`mmbp_p0_rp` only for ``r = N + 1``, because the ``r - N - 1``
    windows that start in ON and cross the whole gap hold ``r - N`` ON slots,
    not ``i``; line 4 also drops the term ``p_e^(r-N)/C`` of the last sum, so
    it disagrees with lines 2-3. The ``(p_e^a - p_e^b)/(1 - p_e)`` factors
    take their ``p_e -> 1`` limit ``b - a``.

    Parameters
    ----------
    M, N : int
        ON and OFF slots per cycle.
    r : int
        Consecutive copies, >= 1.
    p_e : float
        PHY-SDU error probability, in [0, 1].
    line : {2, 3, 4}
        Which printed line to evaluate.
    strict_domain : bool, default True
        Raise ValueError outside the paper's case ``N < r < M``.

    Returns
    -------
    float
        The printed expression (not clipped).
    """
    M, N, C = _check_cycle(M, N)
    r = _as_count(r, "r", 1)
    p_e = _as_probability(p_e, "p_e")
    _check_paper_case(M, N, r, N < r < M, "Eq. 7", strict_domain)
    head = (M - r + 1) / C * p_e**r
    gap_sum = sum(p_e ** (r - i) for i in range(1, N + 1))
    if line == 2:
        return head + sum(p_e**i for i in range(1, r)) / C + gap_sum / C
    if line == 3:
        return head + _pow_ratio(p_e, 1, r) / C + gap_sum / C
    if line == 4:
        # p_e^(r-N) (p_e - p_e^N)/(1 - p_e) as printed, multiplied out to
        # (p_e^(r-N+1) - p_e^r)/(1 - p_e) so that p_e = 0 and 1 need no 0**-k
        # or 0/0 (same value, same p_e -> 1 limit N - 1).
        tail = _pow_ratio(p_e, r - N + 1, r)
        return head + _pow_ratio(p_e, 1, r) / C + tail / C
    raise ValueError(f"line must be 2, 3 or 4 for Eq. 7, got {line!r}")


# ----------------------------------------------------------------------------
# MMBP: whole-message probability in one round
# ----------------------------------------------------------------------------
def _log_message_per_phase(M: int, C: int, r: int, p_e: float, n: int, strategy: str) -> np.ndarray:
    """``log P(all n packets received | phase s)`` for every phase ``s``.

    Given the phase, packet ``k`` is received with probability
    ``1 - p_e**m_k(s)`` independently of the others; ``m_k`` depends on the
    packet's first slot only. Packet first slots run ``s, s + r, s + 2r, ...``
    (RP) or ``s, s + 1, ...`` (RS), so the product over ``k`` is an orbit sum
    of per-slot log factors: O(C) for any ``n``.
    """
    if strategy == "rp":
        m, step = _on_counts_rp(M, C, r), r
    else:
        m, step = _on_counts_rs(M, C, r, n), 1
    log_f = _log1m_pow(p_e, m)
    dead = ~np.isfinite(log_f)  # a packet starting here is never received
    # -inf never enters a cumulative sum (it would give NaN); lost packets are
    # counted separately and override the finite part.
    total = _orbit_sums(np.where(dead, 0.0, log_f), step, n)
    n_dead = _orbit_sums(dead.astype(np.int64), step, n)
    return np.where(n_dead > 0, -np.inf, total)


def mmbp_log_p_message(M, N, r, p_e: float, n_packets, strategy: str, exact: bool = True) -> float:
    """Natural log of :func:`mmbp_p_message`; ``-inf`` when the probability is 0.

    Stable for ``n_packets`` and ``r`` up to 2**53 (O(C) work).
    """
    M, N, C = _check_cycle(M, N)
    r = _as_count(r, "r", 1)
    p_e = _as_probability(p_e, "p_e")
    n = _as_count(n_packets, "n_packets", 1)
    strategy = _check_strategy(strategy)
    if exact:
        if _sweeps(C, r * n):
            emissions = np.arange(r * n, dtype=np.int64)
            packets = emissions // r if strategy == "rp" else emissions % n
            return phase_sweep.log_mean_message(M, C, emissions, packets, n, p_e)
        return _log_mean_exp(_log_message_per_phase(M, C, r, p_e, n, strategy))
    p0 = mmbp_p0_rp(M, N, r, p_e) if strategy == "rp" else mmbp_p0_rs(M, N, r, p_e, n)
    return n * math.log1p(-p0) if p0 < 1.0 else -math.inf


def mmbp_p_message(M, N, r, p_e: float, n_packets, strategy: str, exact: bool = True) -> float:
    """Probability that a whole message is received within one round (MMBP).

    One round is ``r * n_packets`` emissions: each packet ``r`` times in a row
    (``'rp'``) or the sequence of packets ``r`` times (``'rs'``). The message
    is received if every packet is received at least once.

    Parameters
    ----------
    M, N : int
        ON and OFF slots per cycle, >= 0, with ``M + N >= 1``.
    r : int
        Copies of each packet, >= 1.
    p_e : float
        PHY-SDU error probability in an ON slot, in [0, 1].
    n_packets : int
        Packets in the message, >= 1.
    strategy : {'rp', 'rs'}
        Emission order.
    exact : bool, default True
        ``True``: the deterministic cycle with a uniform random phase.
        Given the phase, packets are independent, so
        ``P = (1/C) sum_s prod_k (1 - p_e**m_k(s))`` with ``m_k(s)`` the ON
        slots among packet ``k``'s copies (a packet with ``m_k(s) = 0`` is
        lost). Computed in log space, O(C) for any ``n_packets``.
        ``False``: packets treated as independent,
        ``(1 - p0)**n_packets`` with ``p0`` from :func:`mmbp_p0_rp` or
        :func:`mmbp_p0_rs` (what the paper's curves use).

    Returns
    -------
    float
        Probability in [0, 1].

    Notes
    -----
    The exact form shows the artefact of the paper's Fig. 12: under RS with
    ``n_packets`` a multiple of ``C`` every copy of packet ``k`` lands in slot
    ``(s + k) mod C``, so whenever ``N > 0`` some packets are never received
    and the probability is exactly 0 for every ``r``. The independence
    approximation misses this (it gives ``(1 - (N + M p_e**r)/C)**n > 0``).
    """
    return math.exp(mmbp_log_p_message(M, N, r, p_e, n_packets, strategy, exact))


# ----------------------------------------------------------------------------
# MMBP: expected emissions until the message is complete, goodput
# ----------------------------------------------------------------------------
def _packet_ids(r: int, n: int, strategy: str) -> np.ndarray:
    """Packet carried by each emission of one period of the emission order."""
    if strategy == "rp":
        return np.arange(r * n) // r  # period r * n: one round
    return np.arange(n)  # RS: emission t carries packet t mod n, whatever r


def _expected_emissions_given_phase(
    on: np.ndarray, pid: np.ndarray, order: np.ndarray, n: int, p_e: float, chunk_elems: int, work_budget: float
) -> float:
    """``E[T | phase]`` over a hyperperiod ``H``; ``inf`` if some packet never hits ON.

    ``E[T] = sum_{t >= 0} P(T > t)`` and ``P(T <= t) = prod_k (1 - p_e**m_k(t))``.
    Write ``t = j H + tau``: then ``m_k(t) = j a_k + m_k(tau)``, with ``a_k``
    the ON emissions of packet ``k`` per hyperperiod. Within a hyperperiod the
    product changes only at ON emissions, so hyperperiod ``j`` contributes
    ``sum_e w_e (1 - exp(L_j^e))`` over the ON emissions ``e``, where ``w_e``
    is the run length until the next ON emission and ``L_j^e`` a cumulative
    sum of log factors. The sum over ``j`` stops once the union bound of the
    remaining tail, ``H sum_k p_e**(j a_k) / (1 - p_e**a_k)``, is below
    1e-16 of the running total.
    """
    H = on.shape[0]
    per = H // n
    on_g = on[order].reshape(n, per)  # emissions grouped by packet, in time order
    a = on_g.sum(axis=1)
    if np.any(a == 0) or p_e == 1.0:
        return math.inf
    before_g = np.cumsum(on_g, axis=1) - on_g
    m_before = np.empty(H, dtype=np.int64)
    m_before[order] = before_g.ravel()
    idx_on = np.flatnonzero(on)
    k_e = pid[idx_on]
    m_e = m_before[idx_on]
    w = np.diff(np.concatenate(([-1], idx_on, [H - 1]))).astype(float)

    # j = 0: packets not yet hit make the product exactly 0; count them
    # instead of adding -inf into a cumulative sum.
    first = m_e == 0
    delta = _log1m_pow(p_e, m_e + 1) - np.where(first, 0.0, _log1m_pow(p_e, np.maximum(m_e, 1)))
    L = np.concatenate(([0.0], np.cumsum(delta)))
    missing = n - np.concatenate(([0], np.cumsum(first)))
    survival = np.where(missing > 0, 1.0, -np.expm1(L))
    total = float(w @ survival)
    if p_e == 0.0:
        return total

    a_vals, a_mult = np.unique(a, return_counts=True)
    a_e = a[k_e]
    log_pe = math.log(p_e)
    one_minus = -np.expm1(a_vals * log_pe)  # 1 - p_e**a_k > 0
    # Hyperperiods until the tail bound H n p_e**(J a_min)/(1 - p_e**a_min)
    # drops below 1e-16 (E[T | phase] >= 1): the size of the first chunk.
    needed = math.ceil(math.log(1e16 * H * n / one_minus[0]) / (a_vals[0] * -log_pe))
    if needed * idx_on.size > work_budget:
        # Few hyperperiods needed: the hyperperiod itself is what is long.
        cause = (f"p_e = {p_e} is too close to 1 for the exact sum" if needed > 10 else
                 "the hyperperiod of the frame period and the PHY-SDU duration (camera.frame_rate_hz, "
                 "link.clock_hz) is too long for the exact sum")
        raise ExactSumTooCostly(f"{cause} (~{needed} hyperperiods of {H} emissions per phase)")
    chunk = max(1, min(needed, chunk_elems // idx_on.size))
    j0 = 1
    while True:
        jj = np.arange(j0, j0 + chunk, dtype=np.int64)[:, None]
        mm = jj * a_e[None, :] + m_e[None, :]
        delta = _log1m_pow(p_e, mm + 1) - _log1m_pow(p_e, mm)
        L0 = (_log1m_pow(p_e, jj * a_vals[None, :]) * a_mult[None, :]).sum(axis=1)
        L = L0[:, None] + np.concatenate((np.zeros((chunk, 1)), np.cumsum(delta, axis=1)), axis=1)
        total += float((-np.expm1(L) @ w).sum())
        j0 += chunk
        tail = H * float(np.sum(a_mult * np.exp(j0 * a_vals * log_pe) / one_minus))
        if tail <= 1e-16 * total:
            return total


def mmbp_expected_emissions(M, N, r, p_e: float, n_packets, strategy: str) -> float:
    """Expected number of emissions until every packet is received (MMBP).

    The broadcast repeats rounds of ``r * n_packets`` emissions forever (RP:
    each packet ``r`` times in a row, cycling over the message; RS: the
    sequence ``r`` times, cycling) and stops at the emission that completes the
    message; ``T`` counts emissions including that one.

    Exact for the model: a uniform random phase, deterministic slots given the
    phase, independent successes in ON slots. Computed as
    ``E[T] = sum_{t >= 0} P(T > t)`` using the periodicity of the
    (packet, slot) pattern, with period ``H = lcm(period, C)`` where the
    packet-id period is ``r * n_packets`` (RP) or ``n_packets`` (RS). The tail
    is truncated when its rigorous bound falls below 1e-16 of the sum.

    Parameters
    ----------
    M, N : int
        ON and OFF slots per cycle, >= 0, with ``M + N >= 1``.
    r : int
        Copies per packet in a round, >= 1.
    p_e : float
        PHY-SDU error probability in an ON slot, in [0, 1].
    n_packets : int
        Packets in the message, >= 1.
    strategy : {'rp', 'rs'}
        Emission order.

    Returns
    -------
    float
        Expected emissions (>= n_packets), or ``math.inf`` when the message
        can never complete with positive probability: ``p_e = 1``, ``M = 0``,
        or a phase for which some packet never falls in an ON slot (the RS
        artefact of Fig. 12 when ``n_packets`` is a multiple of ``C``, and
        likewise RP when ``r * n_packets`` is a multiple of ``C`` and
        ``r <= N``). ``inf`` here is the true value of the expectation, not a
        numerical failure.

    Raises
    ------
    ValueError
        For invalid inputs.
    ExactSumTooCostly
        When the exact sum would be too expensive (hyperperiod above 1e7
        emissions, or ``p_e`` so close to 1 that millions of hyperperiods
        are needed); a ``ValueError`` too.

    Notes
    -----
    Cost: O(C * H * J) where ``J ~ ln(1e16 H n) / (a_min ln(1/p_e))``
    hyperperiods and ``a_min`` is the fewest ON emissions a packet gets per
    hyperperiod.
    """
    M, N, C = _check_cycle(M, N)
    r = _as_count(r, "r", 1)
    p_e = _as_probability(p_e, "p_e")
    n = _as_count(n_packets, "n_packets", 1)
    strategy = _check_strategy(strategy)
    if M == 0 or p_e == 1.0:
        return math.inf
    period = r * n if strategy == "rp" else n
    H = period * C // math.gcd(period, C)
    if H > _MAX_HYPERPERIOD:
        raise ExactSumTooCostly(
            f"hyperperiod lcm({'r*n_packets' if strategy == 'rp' else 'n_packets'}, C) = {H} "
            f"emissions exceeds {_MAX_HYPERPERIOD}; the exact sum is too expensive"
        )
    pid = np.tile(_packet_ids(r, n, strategy), H // period)
    order = np.argsort(pid, kind="stable")
    tau = np.arange(H)

    chunk_elems = 2**20
    total = 0.0
    for s in range(C):
        on = ((s + tau) % C) < M
        e_s = _expected_emissions_given_phase(on, pid, order, n, p_e, chunk_elems, _EMISSIONS_WORK_BUDGET / C)
        if math.isinf(e_s):
            return math.inf
        total += e_s
    return total / C


def mmbp_expected_goodput_bps(
    M, N, r, p_e: float, n_packets, strategy: str, payload_bits, sdu_duration_s: float
) -> float:
    """Expected goodput of a message broadcast (bit/s) under the MMBP.

    Defined as ``payload_bits * n_packets / (E[T] * sdu_duration_s)``, with
    ``E[T]`` from :func:`mmbp_expected_emissions`: the message's payload over
    the expected time to receive all of it. This is a ratio of expectations,
    not ``E[bits / T]``; by Jensen's inequality it is at most the mean of the
    per-run goodputs.

    Parameters
    ----------
    M, N, r, p_e, n_packets, strategy
        As in :func:`mmbp_expected_emissions`.
    payload_bits : int or float
        Useful (payload) bits per packet, > 0.
    sdu_duration_s : float
        Duration of one PHY-SDU emission (one slot), in seconds, > 0.

    Returns
    -------
    float
        Goodput in bit/s; 0.0 when the message can never complete.
    """
    payload_bits = _as_positive(payload_bits, "payload_bits")
    sdu_duration_s = _as_positive(sdu_duration_s, "sdu_duration_s")
    expected = mmbp_expected_emissions(M, N, r, p_e, n_packets, strategy)
    if math.isinf(expected):
        return 0.0
    return payload_bits * _as_count(n_packets, "n_packets", 1) / (expected * sdu_duration_s)


# ----------------------------------------------------------------------------
# ROI (Eq. 10) and MMBP slots from the physics
# ----------------------------------------------------------------------------
def roi_ratio(distance_mm: float, led_size_mm: float, focal_length_mm: float, sensor_size_mm: float) -> float:
    """Fraction of the picture covered by the LED, paper Eq. 10.

    ``ROI = min(1, l * fc / (d * ss))``: the image of an LED of size ``l`` at
    distance ``d`` through a lens of focal length ``fc`` is ``i = l fc / d``
    (Eq. 9, the pinhole limit of the thin-lens ``l f / (d - f)``), divided by
    the sensor size ``ss``.

    Parameters
    ----------
    distance_mm : float
        LED-to-lens distance ``d`` in mm, > 0.
    led_size_mm : float
        LED size ``l`` in mm, > 0.
    focal_length_mm : float
        Focal length ``fc`` in mm, > 0.
    sensor_size_mm : float
        Sensor size ``ss`` in mm (along the same direction as ``l``), > 0.

    Returns
    -------
    float
        ROI ratio in (0, 1].

    Notes
    -----
    The paper's Fig. 11 uses ``fc = 35``, ``ss = 5.7``, ``l = 10`` for the
    Nexus 5. Its real focal length is 3.97 mm and 5.7 mm is the diagonal of
    its 1/3.2" sensor, so ``fc = 35`` looks like a 35-mm-equivalent focal
    length mixed with the real sensor size. With consistent units (real
    ``fc`` with real ``ss``, or equivalent ``fc`` with the 43.3 mm full-frame
    diagonal) the ROI is about 35 / 3.97 ~ 8.8 times smaller. Pass the
    values you mean; this function does not correct either choice.
    """
    d = _as_positive(distance_mm, "distance_mm")
    size = _as_positive(led_size_mm, "led_size_mm")
    fc = _as_positive(focal_length_mm, "focal_length_mm")
    ss = _as_positive(sensor_size_mm, "sensor_size_mm")
    return min(1.0, size * fc / (d * ss))


@dataclass(frozen=True)
class MmbpSlots:
    """MMBP cycle derived from frame timing.

    Attributes
    ----------
    M : int
        ON slots per cycle (whole PHY-SDUs captured per frame, rounded).
    N : int
        OFF slots per cycle, ``cycle_slots - M``.
    cycle_slots : int
        ``C = M + N``, the frame period in PHY-SDUs, rounded, >= 1.
    mean_whole_sdus_per_frame : float
        Expected number of whole PHY-SDUs inside the capture window,
        ``max(0, W / T_p - 1)``, before rounding.
    """

    M: int
    N: int
    cycle_slots: int
    mean_whole_sdus_per_frame: float


def _round_half_up(x: float) -> int:
    # Python's round() is round-half-even; half-up keeps M monotone in W.
    return int(math.floor(x + 0.5))


def mmbp_slots_from_physics(frame_period_s: float, capture_window_s: float, sdu_duration_s: float) -> MmbpSlots:
    """Integer MMBP parameters ``M``, ``N`` from the frame and PHY-SDU timing.

    PHY-SDUs are sent back to back with period ``T_p``; one counts only if it
    lies wholly inside the capture window ``W`` of a frame. With a uniform
    phase, the expected number of whole PHY-SDUs in ``W`` is
    ``max(0, W / T_p - 1)``. Then ``M = round(max(0, W / T_p - 1))``,
    ``C = max(1, round(T_f / T_p))``, ``M <= C``, ``N = C - M``.

    The MMBP needs an integer cycle of whole slots; the real frame period is
    generally not a multiple of ``T_p`` and the count of whole PHY-SDUs per
    frame varies between ``floor`` and ``ceil`` of its mean. Rounding both
    (half up) is the approximation.

    Parameters
    ----------
    frame_period_s : float
        Frame period ``T_f`` in seconds, > 0.
    capture_window_s : float
        Capture window ``W`` per frame in seconds, >= 0 (see
        :func:`capture_window_s`).
    sdu_duration_s : float
        PHY-SDU duration ``T_p`` in seconds, > 0.

    Returns
    -------
    MmbpSlots
    """
    T_f = _as_positive(frame_period_s, "frame_period_s")
    W = _as_positive(capture_window_s, "capture_window_s", allow_zero=True)
    T_p = _as_positive(sdu_duration_s, "sdu_duration_s")
    mean_whole = max(0.0, W / T_p - 1.0)
    C = max(1, _round_half_up(T_f / T_p))
    M = min(_round_half_up(mean_whole), C)
    return MmbpSlots(M=M, N=C - M, cycle_slots=C, mean_whole_sdus_per_frame=mean_whole)


def throughput_bound_bps(frame_period_s: float, capture_window_s: float, sdu_duration_s: float,
                         bits_per_sdu: float) -> float:
    """Bits per second of a receiver that decodes every whole PHY-SDU in its capture window.

    ``bits_per_sdu * max(0, W / T_p - 1) / T_f``: with PHY-SDUs sent back to
    back and a uniform phase, ``max(0, W / T_p - 1)`` whole PHY-SDUs lie in
    a capture window ``W`` per frame on average (see
    :func:`mmbp_slots_from_physics`). A receiver limited to ``W`` and free
    of errors reaches this; the MMBP, rounding ``M`` up, may pass it.

    Parameters
    ----------
    frame_period_s, capture_window_s, sdu_duration_s : float
        ``T_f`` (> 0), ``W`` (>= 0) and ``T_p`` (> 0) in seconds, as in
        :func:`mmbp_slots_from_physics`.
    bits_per_sdu : float
        Bits a received PHY-SDU counts for (``H + P`` for CamComSim's
        throughput), >= 0.

    Returns
    -------
    float
        Throughput bound in bit/s.

    Examples
    --------
    The paper's testbed at 10 cm: ROI 0.724 of a 30 ms readout at 30 fps,
    PHY-SDUs of 6.5 ms (CamComSim's length for ``H + P = 24``):

    >>> W = capture_window_s(1 / 30, 0.1, 0.724)
    >>> round(throughput_bound_bps(1 / 30, W, 6.5e-3, 24))
    1686
    """
    T_f = _as_positive(frame_period_s, "frame_period_s")
    W = _as_positive(capture_window_s, "capture_window_s", allow_zero=True)
    T_p = _as_positive(sdu_duration_s, "sdu_duration_s")
    bits = _as_positive(bits_per_sdu, "bits_per_sdu", allow_zero=True)
    return bits * max(0.0, W / T_p - 1.0) / T_f


def capture_window_s(frame_period_s: float, ifg_ratio: float, roi: float, exposure_s: float = 0.0) -> float:
    """Time per frame during which the LED's rows are being exposed, in seconds.

    ``W = T_f (1 - ifg_ratio) roi + exposure_s``: the readout lasts
    ``T_f (1 - ifg_ratio)``, the LED covers a fraction ``roi`` of the rows,
    and the last of those rows keeps integrating for one exposure time.

    Parameters
    ----------
    frame_period_s : float
        Frame period ``T_f`` in seconds, > 0.
    ifg_ratio : float
        Inter-frame gap over frame period, in [0, 1).
    roi : float
        Fraction of the rows covered by the LED, in [0, 1] (e.g.
        :func:`roi_ratio`).
    exposure_s : float, default 0
        Row exposure time in seconds, >= 0.

    Returns
    -------
    float
        Capture window in seconds.
    """
    T_f = _as_positive(frame_period_s, "frame_period_s")
    try:
        ifg = float(ifg_ratio)
    except (TypeError, ValueError):
        raise ValueError(f"ifg_ratio must be in [0, 1), got {ifg_ratio!r}") from None
    if not 0.0 <= ifg < 1.0:
        raise ValueError(f"ifg_ratio must be in [0, 1), got {ifg_ratio!r}")
    roi = _as_probability(roi, "roi")
    exposure = _as_positive(exposure_s, "exposure_s", allow_zero=True)
    return T_f * (1.0 - ifg) * roi + exposure
