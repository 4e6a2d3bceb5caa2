"""A rateless broadcast over the MMBP: expected emissions and goodput of random linear coding.

With random linear coding over GF(2) (:mod:`rollsim.protocol.rlnc`) the
receiver needs any n coded PHY-SDUs whose subsets reach rank K, n drawn
from the rank chain's distribution, not one copy of each of K given
packets. Under the MMBP (conventions of :mod:`rollsim.channel.analytic`:
a cycle of C = M + N slots, slots 0 … M−1 ON, emission k in slot
(s + k) mod C, s uniform, each ON emission received with probability
1 − p_e independently) the n-th reception happens at the S-th ON emission,
S − n negative-binomial, and the S-th ON emission's index depends only on
S and the phase. So

    E[T] = Σ_n P(full rank at n) Σ_S P(S | n) E_s[k_S(s) + 1],

each factor exact (the tails summed until below 1e-15), where T counts the
emissions up to and including the one that completes the rank.
"""

from __future__ import annotations

import functools
import math
from typing import Callable

import numpy as np

from rollsim.protocol.rlnc import receptions_to_full_rank_pmf

# Probability mass left out of each truncated sum.
TAIL = 1e-15
# Largest cycle (M + N slots) enumerated phase by phase.
MAX_CYCLE = 10**6


@functools.lru_cache(maxsize=1)
def negative_binomial() -> tuple[Callable, Callable]:
    """``(pmf, isf)`` of the negative binomial, as ``scipy.stats.nbinom`` gives them.

    ``scipy.stats.nbinom`` evaluates both with Boost ufuncs that SciPy keeps,
    private, in ``scipy.special._ufuncs``: for valid arguments its pmf is the
    ufunc clipped to [0, 1] and its isf the ufunc itself. Calling them here
    gives the same numbers (tests/channel/test_rateless.py compares them)
    without importing ``scipy.stats``, which took about a second of
    ``rollsim describe``'s start-up. A SciPy that keeps them elsewhere gets
    ``scipy.stats.nbinom``.
    Arguments as ``nbinom.pmf(k, n, p)`` and ``nbinom.isf(q, n, p)``: k
    failures before the n-th success of probability p.
    """
    try:
        from scipy.special._ufuncs import _nbinom_isf, _nbinom_pmf
    except ImportError:  # pragma: no cover - SciPy moved its private ufuncs
        from scipy.stats import nbinom

        return nbinom.pmf, nbinom.isf

    def pmf(k, n, p):
        return np.clip(_nbinom_pmf(k, n, p), 0, 1)

    def isf(q, n, p):
        with np.errstate(over="ignore"):  # as scipy.stats.nbinom (SciPy gh-17432)
            return _nbinom_isf(q, n, p)

    return pmf, isf


def _check(M: int, N: int, p_e: float, k: int) -> None:
    if not (isinstance(M, (int, np.integer)) and isinstance(N, (int, np.integer)) and M >= 1 and N >= 0):
        raise ValueError(f"M must be an integer >= 1 and N >= 0, got M={M}, N={N}")
    if M + N > MAX_CYCLE:
        raise ValueError(f"M + N = {M + N} slots: at most {MAX_CYCLE} are enumerated")
    if not (0.0 <= p_e < 1.0):
        raise ValueError(f"p_e must be in [0, 1), got {p_e}")
    if k < 1:
        raise ValueError(f"k must be >= 1, got {k}")


def on_emission_index_mean(M: int, N: int, j_max: int) -> np.ndarray:
    """E_s[k_j(s)] for j = 1 … j_max: the mean index of the j-th ON emission over the phase.

    Counting ON slots in absolute slot time u = s + k, the m-th one
    (1-based) is at u_m = ⌊(m−1)/M⌋·C + (m−1) mod M; before emission 0
    there are min(s, M) of them, so the j-th ON emission is
    k_j(s) = u_{min(s, M) + j} − s.
    """
    C = M + N
    j = np.arange(1, j_max + 1, dtype=np.int64)

    def u(m):
        return ((m - 1) // M) * C + (m - 1) % M

    s_on = np.arange(M, dtype=np.int64)
    # Phases inside the ON arc: m = s + j; the N phases after it: m = M + j.
    inside = np.sum(u(s_on[:, None] + j[None, :]), axis=0, dtype=np.float64) - s_on.sum()
    after = N * u(M + j).astype(np.float64) - float(np.sum(np.arange(M, C, dtype=np.float64)))
    return (inside + after) / C


def rlnc_expected_emissions(M: int, N: int, p_e: float, k: int) -> float:
    """E[T]: emissions until K source packets are decodable from random GF(2) combinations.

    Parameters
    ----------
    M, N : int
        ON and OFF slots per cycle.
    p_e : float
        PHY-SDU error probability in an ON slot, in [0, 1).
    k : int
        Source packets of the message.

    Returns
    -------
    float
    """
    _check(M, N, p_e, k)
    # Receptions to full rank: the chain's support until the tail is negligible.
    n_max = k + 8
    while True:
        pmf = receptions_to_full_rank_pmf(k, n_max)
        if 1.0 - pmf.sum() < TAIL:
            break
        n_max *= 2
    q = 1.0 - p_e
    nbinom_pmf, nbinom_isf = negative_binomial()
    # ON emissions needed for n receptions: S = n + F, F ~ NegBin(n, q).
    f_max = int(nbinom_isf(TAIL, n_max, q)) + 1 if p_e > 0 else 0
    mean_index = on_emission_index_mean(M, N, n_max + f_max) + 1.0
    n = np.flatnonzero(pmf)[:, None]
    f = np.arange(f_max + 1)[None, :]
    weights = nbinom_pmf(f, n, q) if p_e > 0 else np.ones((n.size, 1))
    return float(np.sum(pmf[n[:, 0]] * np.sum(weights * mean_index[n - 1 + f], axis=1)))


def rlnc_expected_goodput_bps(M: int, N: int, p_e: float, k: int, payload_bits: float, sdu_duration_s: float) -> float:
    """Expected goodput (bit/s): K packets' payload over the expected time to decode them.

    ``payload_bits · K / (E[T] · sdu_duration_s)``, the convention of
    :func:`rollsim.channel.analytic.mmbp_expected_goodput_bps`.
    """
    return _goodput_bps(rlnc_expected_emissions(M, N, p_e, k), k, payload_bits, sdu_duration_s)


def rlnc_figures(M: int, N: int, p_e: float, k: int, payload_bits: float, sdu_duration_s: float) -> tuple[float, float]:
    """``(E[T], goodput_bps)`` of random linear coding under the MMBP, for any slots and p_e.

    A cycle without an ON slot, or p_e = 1, never decodes: (inf, 0.0), as
    :func:`rollsim.channel.analytic.mmbp_expected_goodput_bps` gives 0 for a
    message that can never complete.
    """
    if M < 1 or p_e >= 1.0:
        return float("inf"), 0.0
    expected = rlnc_expected_emissions(M, N, p_e, k)
    return expected, _goodput_bps(expected, k, payload_bits, sdu_duration_s)


def _goodput_bps(expected_emissions: float, k: int, payload_bits: float, sdu_duration_s: float) -> float:
    if not (payload_bits > 0 and sdu_duration_s > 0 and math.isfinite(sdu_duration_s)):
        raise ValueError(f"payload_bits and sdu_duration_s must be > 0, got {payload_bits}, {sdu_duration_s}")
    return payload_bits * k / (expected_emissions * sdu_duration_s)
