"""Gilbert-Elliott fit of a success/failure trace: exact likelihood, MoM and ML.

Convention of :func:`rollsim.channel.analytic.ge_stationary`: S1 captures
(success with probability 1 − p_e), S2 is the gap (never succeeds),
p = P(S2 → S1), q = P(S1 → S2), stationary start.

A success pins the chain to S1, so the likelihood factorises over the gaps
between successes: after a success, L failures and the next success have
probability g(L) = [(T D₀)^L T]₁₁ · (1 − p_e), with T the transition matrix
and D₀ = diag(p_e, 1) the failure emission. The trace's likelihood is the
product of g over its gaps, times the opening segment (stationary start up to
the first success) and the closing one (failures after the last). Powers of
the 2 × 2 matrix are taken by scaled squaring for every distinct gap length
(:mod:`rollsim.numerics.ge_likelihood`, compiled), so a trace of any
length costs O(distinct gaps × log L).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize
from scipy.special import expit, logit

from rollsim.numerics.ge_likelihood import ge_loglik_of_powers

# Parameters are kept this far from 0 and 1 during optimisation.
_EDGE = 1e-9


@dataclass(frozen=True)
class GeFit:
    """Gilbert-Elliott parameters and their log-likelihood on the trace."""

    p: float
    q: float
    p_e: float
    loglik: float
    method: str

    def as_dict(self) -> dict:
        return {"p": self.p, "q": self.q, "p_e": self.p_e, "loglik": self.loglik, "method": self.method}


def _gaps(success: np.ndarray) -> tuple[np.ndarray, int, int, int]:
    """Failure counts between successes, before the first and after the last."""
    idx = np.flatnonzero(success)
    if idx.size == 0:
        return np.zeros(0, dtype=np.int64), -1, -1, success.size
    return np.diff(idx) - 1, int(idx[0]), int(success.size - 1 - idx[-1]), 0


class GeTrace:
    """A 0/1 trace read for :func:`ge_loglik` once: its gaps between successes, counted by length.

    A fit evaluates the likelihood thousands of times on one trace: the
    trace's gaps, and every matrix power the likelihood needs (the opening
    run, each distinct gap, the closing run) in one batch, are prepared once.
    The values are those of evaluating each separately (each power is
    computed on its own, whatever the batch holds).
    """

    def __init__(self, success):
        success = np.asarray(success, dtype=bool)
        gaps, self.opening, self.closing, self.none = _gaps(success)
        self.lengths, self.counts = np.unique(gaps, return_counts=True) if gaps.size else (gaps, gaps)
        # The exponents of (T D0) the likelihood needs, in one batch.
        if self.none:
            self.exponents = np.array([self.none - 1])
        else:
            head = [self.opening - 1] if self.opening > 0 else []
            tail = [self.closing] if self.closing > 0 else []
            self.exponents = np.concatenate([np.array(head, dtype=np.int64), self.lengths.astype(np.int64),
                                             np.array(tail, dtype=np.int64)])
        self._head = 1 if (not self.none and self.opening > 0) else 0

    def loglik(self, p: float, q: float, p_e: float) -> float:
        """Exact log-likelihood of the trace under Gilbert-Elliott (p, q, p_e); −inf where impossible."""
        return ge_loglik_of_powers(p, q, p_e, self.exponents, self.counts, self._head, self.lengths.size,
                                   self.closing > 0, self.none > 0)


def ge_loglik(success, p: float, q: float, p_e: float) -> float:
    """Exact log-likelihood of a 0/1 trace under Gilbert-Elliott (p, q, p_e) (:class:`GeTrace`)."""
    return GeTrace(success).loglik(p, q, p_e)


def ge_method_of_moments(success) -> GeFit:
    """Closed-form moment estimates from P(x=1), P(x_t=x_{t+1}=1), P(x_t=x_{t+2}=1).

    With s = π₁(1 − p_e), λ = 1 − p − q and x = 1 − p_e:
    c₁/s = s + (x − s)λ and c₂/s = s + (x − s)λ², so λ = (c₂/s − s)/(c₁/s − s),
    x = s + (c₁/s − s)/λ, π₁ = s/x, p = π₁(1 − λ), q = (1 − π₁)(1 − λ).
    Estimates are clipped into the parameter space.
    """
    x = np.asarray(success, dtype=float)
    if x.size < 3:
        raise ValueError("the trace needs at least 3 emissions for moment estimates")
    s = x.mean()
    if s == 0 or s == 1:
        p_e = 1.0 if s == 0 else 0.0
        p, q = (_EDGE, 1 - _EDGE) if s == 0 else (1 - _EDGE, _EDGE)
        return GeFit(p, q, p_e, ge_loglik(x > 0, p, q, p_e), "moments")
    c1 = np.mean(x[:-1] * x[1:])
    c2 = np.mean(x[:-2] * x[2:])
    a, b = c1 / s - s, c2 / s - s
    # λ = 0 (a memoryless chain) leaves x undetermined by these moments:
    # take p_e = 0 then.
    lam = float(np.clip(b / a, -1 + _EDGE, 1 - _EDGE)) if a != 0 else 0.0
    x1 = float(np.clip(s + a / lam, s, 1.0)) if lam != 0 else 1.0
    p_e = float(np.clip(1 - x1, 0.0, 1.0))
    pi1 = float(np.clip(s / x1, _EDGE, 1 - _EDGE))
    p = float(np.clip(pi1 * (1 - lam), _EDGE, 1 - _EDGE))
    q = float(np.clip((1 - pi1) * (1 - lam), _EDGE, 1 - _EDGE))
    return GeFit(p, q, p_e, ge_loglik(x > 0, p, q, p_e), "moments")


def _to_unit(z):
    return _EDGE + (1 - 2 * _EDGE) * expit(z)


def _from_unit(u):
    return logit(np.clip((np.asarray(u) - _EDGE) / (1 - 2 * _EDGE), 1e-12, 1 - 1e-12))


def fit_ge(success, start: GeFit | None = None) -> GeFit:
    """Maximum-likelihood Gilbert-Elliott parameters of a 0/1 trace.

    Direct optimisation of :func:`ge_loglik` over logit-transformed (p, q,
    p_e), started from the moment estimates and a few spread points; the
    best optimum is kept. With ``start`` (a fit to a similar trace: the
    held-out likelihood refits each fold from the whole trace's fit), only
    that point is started from.
    """
    success = np.asarray(success, dtype=bool)
    if success.size == 0:
        raise ValueError("the trace is empty")
    rate = success.mean()
    if rate in (0.0, 1.0):
        # All failures or all successes: the likelihood is maximised at the
        # edge (p_e = 1 or p_e = 0 with the chain never leaving S1).
        mom = ge_method_of_moments(success) if success.size >= 3 else None
        p, q, p_e = (_EDGE, 1 - _EDGE, 1.0) if rate == 0 else (1 - _EDGE, _EDGE, 0.0)
        return GeFit(p, q, p_e, ge_loglik(success, p, q, p_e) if mom is None else mom.loglik, "maximum likelihood")

    trace = GeTrace(success)

    def objective(z):
        value = trace.loglik(*_to_unit(z))
        return -value if np.isfinite(value) else 1e300

    starts = [(0.5, 0.5, 0.1), (0.1, 0.1, 0.01), (0.9, 0.1, 0.001), (0.3, 0.05, 0.05)]
    if start is not None:
        starts = [(start.p, start.q, start.p_e)]
    elif success.size >= 3:
        mom = ge_method_of_moments(success)
        starts.insert(0, (mom.p, mom.q, max(mom.p_e, 1e-6)))
    best = None
    for point in starts:
        result = minimize(objective, _from_unit(np.array(point)), method="Nelder-Mead",
                          options={"xatol": 1e-7, "fatol": 1e-9, "maxiter": 4000})
        if best is None or result.fun < best.fun:
            best = result
    assert best is not None  # one start at least
    p, q, p_e = (float(v) for v in _to_unit(best.x))
    return GeFit(p, q, p_e, -float(best.fun), "maximum likelihood")
