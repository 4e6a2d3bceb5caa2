"""MMBP fit of a success/failure trace: integer M and N, phase, p_e.

Under the MMBP an emission in an OFF slot never succeeds, and one in an ON
slot succeeds with probability 1 − p_e. For a given cycle, the ON slots must
therefore cover every success; adding ON slots that hold only failures can
only lower the maximised likelihood, so the maximum-likelihood ON set is the
shortest circular arc that covers every success. p_e is then the failure
fraction among ON emissions, with a Clopper-Pearson 95% interval.

Two ways to place emissions on the cycle:

``fit_mmbp_cycle``
    a pure trace: emission k sits in slot (k + φ) mod C; every cycle length
    C from 1 to n/20 is tried and the best likelihood wins (ties go to the
    shortest C). Each slot must be seen at least 20 times: with fewer, a
    slot whose emissions all failed by chance would be excluded from the ON
    set and a long cycle would overfit.
``fit_mmbp_aligned``
    where frame start times are known (rendered data): each emission's start
    is placed within its frame period, [0, T_f), so the camera's frame clock,
    not a slot count, sets the phase. This is the per-frame alignment that a
    non-integer T_f / T_p needs. The ON set is an arc of start offsets:
    the shortest covering every success, trimmed where that is likelier
    (:func:`leak_trimmed_arc`). The emissions in it, per frame, are the
    fractional mean number of whole PHY-SDUs per frame (a capture window W
    admits starts over W − T_p, so about W / T_p − 1); M = round of it,
    C = round(T_f / T_p), N = C − M.

    A real window's edge is soft: a PHY-SDU whose last chips are OFF is
    read even when they fall past the LED's last row (they look like the
    background). One such success at an offset no other frame reads would
    stretch the covering arc for every frame and turn the emissions it adds
    into failures, so the aligned fit lets emissions outside the arc
    succeed at a rate of their own (a leak, ``off_successes``), and takes
    the arc of greatest likelihood. Where nothing leaks, that is the
    covering arc.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.special import xlogy


# Emissions each slot must hold for the cycle fit (see fit_mmbp_cycle).
MIN_PER_SLOT = 20


@dataclass(frozen=True)
class MmbpFit:
    """A fitted MMBP.

    Attributes
    ----------
    M, N : int
        ON and OFF slots per cycle.
    p_e : float
        PHY-SDU error probability in ON slots.
    p_e_ci95 : (float, float)
        Clopper-Pearson 95% interval of p_e.
    loglik : float
        Maximised log-likelihood of the trace.
    phase : float
        Cycle phase: the slot of emission 0 (cycle fit), or the start of the
        ON arc within the frame in seconds (aligned fit).
    mean_on_per_frame : float
        Fractional mean number of ON (fully received) slots per frame.
    on_emissions, on_failures : int
        Emissions in ON slots and the failures among them.
    method : str
    off_successes : int
        Successes outside the ON slots (aligned fit only: reads past the
        window's soft edge, :func:`leak_trimmed_arc`); 0 under the MMBP.
    """

    M: int
    N: int
    p_e: float
    p_e_ci95: tuple
    loglik: float
    phase: float
    mean_on_per_frame: float
    on_emissions: int
    on_failures: int
    method: str
    off_successes: int = 0

    def as_dict(self) -> dict:
        return {
            "M": self.M,
            "N": self.N,
            "p_e": self.p_e,
            "p_e_ci95": list(self.p_e_ci95),
            "loglik": self.loglik,
            "phase": self.phase,
            "mean_on_per_frame": self.mean_on_per_frame,
            "on_emissions": self.on_emissions,
            "on_failures": self.on_failures,
            "method": self.method,
            "off_successes": self.off_successes,
        }


def beta_ppf(q: float, a: float, b: float) -> float:
    """``scipy.stats.beta.ppf(q, a, b)`` for 0 < q < 1 and a, b > 0, without importing ``scipy.stats``.

    ``beta.ppf`` evaluates SciPy's Boost ufunc ``scipy.special._ufuncs._beta_ppf``
    once its arguments are checked; calling it gives the same numbers
    (tests/calibrate/test_fits.py compares them) without the 0.4 s that
    importing ``scipy.stats`` added to every command that calibrates.
    (``scipy.special.betaincinv`` is another algorithm: it differs in the
    last bit for some arguments.) A SciPy that keeps the ufunc elsewhere
    gets ``scipy.stats.beta``.
    """
    try:
        from scipy.special._ufuncs import _beta_ppf
    except ImportError:  # pragma: no cover - SciPy moved its private ufunc
        from scipy.stats import beta

        return float(beta.ppf(q, a, b))
    return float(_beta_ppf(q, a, b))


def clopper_pearson(failures: int, trials: int, level: float = 0.95) -> tuple[float, float]:
    """Exact two-sided binomial interval of a proportion (0 and 1 handled exactly).

    It covers the true proportion with probability >= ``level`` (tested by
    exact enumeration). With no failures its upper end is the one-sided
    ``(1 + level) / 2`` bound, ≈ 3.7/n at 95 %; :func:`zero_failure_bound`
    gives the one-sided ``level`` bound (≈ 3/n) that a report states then.
    """
    if trials <= 0:
        raise ValueError("trials must be >= 1")
    alpha = 1.0 - level
    low = 0.0 if failures == 0 else beta_ppf(alpha / 2, failures, trials - failures + 1)
    high = 1.0 if failures == trials else beta_ppf(1 - alpha / 2, failures + 1, trials - failures)
    return low, high


def wilson_interval(successes: int, trials: int, level: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion.

    With k successes in n trials, p̂ = k/n and z the normal quantile of
    ``(1 + level) / 2``, the interval is

        (p̂ + z²/2n ± z·sqrt(p̂(1 − p̂)/n + z²/4n²)) / (1 + z²/n),

    which stays inside [0, 1] and is not empty at k = 0 or k = n.

    Parameters
    ----------
    successes : int
        k, 0 ≤ k ≤ n.
    trials : int
        n ≥ 1.
    level : float
        Coverage, in (0, 1).

    Returns
    -------
    (float, float)
        Lower and upper ends, as fractions.
    """
    if trials <= 0:
        raise ValueError(f"trials = {trials}: must be >= 1")
    if not 0 <= successes <= trials:
        raise ValueError(f"successes = {successes}: must be in [0, trials = {trials}]")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level = {level}: must be in (0, 1)")
    from statistics import NormalDist

    z = NormalDist().inv_cdf(0.5 + 0.5 * level)
    n, p = float(trials), successes / trials
    centre = (p + z * z / (2.0 * n)) / (1.0 + z * z / n)
    half = z * math.sqrt(p * (1.0 - p) / n + z * z / (4.0 * n * n)) / (1.0 + z * z / n)
    # Exact ends at k = 0 and k = n (the formula gives them up to rounding).
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    high = 1.0 if successes == trials else min(1.0, centre + half)
    return low, high


def zero_failure_bound(trials: int, level: float = 0.95) -> float:
    """One-sided upper bound of a proportion after 0 failures in ``trials``.

    ``1 - (1 - level)^(1/n)``, ≈ 3/n at 95 % (the "rule of three"):
    a proportion above it gives no failure in n trials with probability
    below ``1 - level``. Computed without cancellation for large n.
    """
    if trials <= 0:
        raise ValueError("trials must be >= 1")
    return -math.expm1(math.log(1.0 - level) / trials)


def p_e_text(mmbp: dict, number=None) -> str:
    """``p_e`` of a fit as a report states it: with its 95 % interval, or,
    with no error in ON slots, as the one-sided 95 % bound (≈ 3/n), never a bare 0.

    Parameters
    ----------
    mmbp : dict
        :meth:`MmbpFit.as_dict`.
    number : callable, optional
        Formats a float (default ``format(x, ".4g")``).
    """
    number = number or (lambda x: format(x, ".4g"))
    if mmbp["on_failures"] == 0 and mmbp["on_emissions"] > 0:
        bound = zero_failure_bound(mmbp["on_emissions"])
        return f"p_e = 0 in {mmbp['on_emissions']} PHY-SDUs: < {number(bound)} (95 %, one-sided)"
    low, high = mmbp["p_e_ci95"]
    return f"p_e = {number(mmbp['p_e'])} (95 % CI {number(low)} .. {number(high)})"


def bernoulli_loglik(failures: int, trials: int) -> float:
    """Maximised log-likelihood of ``failures`` in ``trials`` (0·log 0 = 0)."""
    successes = trials - failures
    total = 0.0
    for count in (failures, successes):
        if count:
            total += count * math.log(count / trials)
    return total


def _shortest_covering_arc(occupied: np.ndarray) -> tuple[int, int]:
    """Start and length of the shortest circular arc of slots covering every True."""
    size = occupied.size
    marks = np.flatnonzero(occupied)
    if marks.size == 0:
        return 0, 0
    # The arc is the circle minus its longest run of unoccupied slots.
    gaps = np.diff(np.r_[marks, marks[0] + size]) - 1
    widest = int(np.argmax(gaps))
    start = int(marks[(widest + 1) % marks.size])
    return start, size - int(gaps[widest])


# Success offsets, at each end of the covering arc, that the aligned fit may
# trim as leaks: a soft edge, not a window of another size.
MAX_TRIMMED_OFFSETS = 32


def leak_trimmed_arc(index: np.ndarray, success: np.ndarray, size: int,
                     max_trimmed: int = MAX_TRIMMED_OFFSETS) -> tuple[int, int, float]:
    """The ON arc of greatest likelihood when emissions outside it may succeed too.

    Inside the arc an emission succeeds with probability 1 − p_e, outside
    with q < 1 − p_e (a leak); both are estimated. Candidate arcs start at one of the
    first ``max_trimmed`` success offsets of the shortest covering arc
    (:func:`_shortest_covering_arc`) and end at one of its last; ties go
    to the longest, so with no leak the covering arc is returned.

    Parameters
    ----------
    index : ndarray of int, shape (n,)
        Each emission's slot on the circle, 0 … size − 1.
    success : ndarray of bool, shape (n,)
    size : int
        Slots on the circle.
    max_trimmed : int

    Returns
    -------
    (int, int, float)
        The arc's first slot and length, and its maximised log-likelihood
        (both rates).
    """
    first, length = _shortest_covering_arc(np.bincount(index[success], minlength=size) > 0)
    offset = np.sort((index - first) % size)
    hits = np.sort((index[success] - first) % size)
    marks = np.unique(hits)
    starts, ends = marks[:max_trimmed], marks[-max_trimmed:]
    start, end = (grid.ravel() for grid in np.meshgrid(starts, ends, indexing="ij"))
    valid = start <= end
    start, end = start[valid], end[valid]

    def between(values):
        return np.searchsorted(values, end, side="right") - np.searchsorted(values, start, side="left")

    trials, wins = between(offset), between(hits)
    outside, leaks = offset.size - trials, hits.size - wins
    score = _bernoulli_logliks(trials - wins, trials) + _bernoulli_logliks(leaks, outside)
    # A leak succeeds less often than the arc does (else the arc is the
    # wrong part of the circle); the covering arc has no leak.
    score = np.where((leaks == 0) | (leaks * trials < wins * outside), score, -np.inf)
    # Longest first, so that a tie keeps the wider arc.
    order = np.lexsort((-(end - start), -np.round(score, 9)))
    best = order[0]
    return int((start[best] + first) % size), int(end[best] - start[best] + 1), float(score[best])


def _bernoulli_logliks(count: np.ndarray, trials: np.ndarray) -> np.ndarray:
    """:func:`bernoulli_loglik` of many (count, trials) pairs; 0 where trials is 0."""
    count, trials = np.asarray(count, dtype=np.float64), np.asarray(trials, dtype=np.float64)
    share = np.divide(count, trials, out=np.zeros_like(count), where=trials > 0)
    return trials * (xlogy(share, share) + xlogy(1.0 - share, 1.0 - share))


def _check_trace(success: np.ndarray) -> np.ndarray:
    success = np.asarray(success, dtype=bool)
    if success.size == 0:
        raise ValueError("the trace is empty")
    if not success.any():
        raise ValueError("the trace has no success: M and p_e cannot be told apart (any M with p_e = 1 fits)")
    return success


def _fit(M, N, failures, trials, phase, mean_on, method) -> MmbpFit:
    return MmbpFit(
        int(M), int(N), failures / trials, clopper_pearson(failures, trials), bernoulli_loglik(failures, trials),
        float(phase), float(mean_on), int(trials), int(failures), method,
    )


def fit_mmbp_cycle(success, max_cycle: int | None = None) -> MmbpFit:
    """Integer-cycle MMBP fit of a pure trace (see the module docstring).

    Parameters
    ----------
    success : array_like of bool
        One entry per emission, in emission order.
    max_cycle : int, optional
        Longest cycle tried; default n // 20 (see the module docstring).
    """
    success = _check_trace(success)
    n = success.size
    max_cycle = max(1, n // MIN_PER_SLOT) if max_cycle is None else int(max_cycle)
    k = np.arange(n)
    best = None
    for cycle in range(1, max_cycle + 1):
        slot = k % cycle
        start, length = _shortest_covering_arc(np.bincount(slot[success], minlength=cycle) > 0)
        on = ((slot - start) % cycle) < length
        trials = int(on.sum())
        failures = trials - int(success.sum())
        loglik = bernoulli_loglik(failures, trials)
        if best is None or loglik > best[0] + 1e-9:
            best = (loglik, cycle, start, length, failures, trials)
    assert best is not None  # max_cycle >= 1: one cycle at least was tried
    _, cycle, start, length, failures, trials = best
    # Emission 0 sits (cycle - start) % cycle slots into the ON arc's cycle.
    return _fit(length, cycle - length, failures, trials, (-start) % cycle, length, "cycle")


def fit_mmbp_aligned(success, start_s, frame_starts_s, frame_period_s: float, sdu_duration_s: float) -> MmbpFit:
    """Per-frame aligned MMBP fit (see the module docstring).

    Parameters
    ----------
    success : array_like of bool
    start_s : array_like of float
        Emission start times, seconds.
    frame_starts_s : array_like of float
        Start of every frame, ascending, seconds.
    frame_period_s, sdu_duration_s : float
        T_f and T_p in seconds.
    """
    success = _check_trace(success)
    start_s = np.asarray(start_s, dtype=np.float64)
    frames = np.asarray(frame_starts_s, dtype=np.float64)
    if frames.size == 0:
        raise ValueError("no frame start times")
    # Offset of each start within the frame period it falls in.
    k = np.clip(np.searchsorted(frames, start_s, side="right") - 1, 0, frames.size - 1)
    offset = np.mod(start_s - frames[k], frame_period_s)
    index, bins = offset_bins(offset, frame_period_s, sdu_duration_s)
    first, length, loglik = leak_trimmed_arc(index, success, bins)
    on = ((index - first) % bins) < length
    trials = int(on.sum())
    failures = trials - int(np.count_nonzero(success & on))
    # The mean count is counted, not inferred from the arc's length: with a
    # rational T_f / T_p the starts visit only a few offsets, and the arc
    # between the extreme ones falls short of the true window.
    mean_on = trials / frames.size
    cycle = max(1, int(round(frame_period_s / sdu_duration_s)))
    M = min(cycle, int(round(mean_on)))
    fit = _fit(M, cycle - M, failures, trials, first * frame_period_s / bins, mean_on, "aligned")
    return replace(fit, loglik=loglik, off_successes=int(np.count_nonzero(success & ~on)))


def offset_bins(offset_s: np.ndarray, frame_period_s: float, sdu_duration_s: float) -> tuple[np.ndarray, int]:
    """Start offsets within the frame as bins of a thousandth of a PHY-SDU: (bin of each, bins per frame)."""
    bins = max(1, int(math.ceil(frame_period_s / (sdu_duration_s * 1e-3))))
    index = np.minimum((np.asarray(offset_s) / frame_period_s * bins).astype(np.int64), bins - 1)
    return index, bins
