"""Standard normal deviates for per-pixel noise: exact, or from a quantile table.

``exact``
    numpy's Ziggurat sampler in float32.
``table``
    A 16-bit random integer picks one of 65,536 equiprobable bins of the
    standard normal; inside the body the deviate is the bin's median, and in
    the two outermost bins (beyond ±4.17σ) it is drawn exactly from the tail
    by inverting the CDF at a fresh uniform. The law differs from the normal
    by at most 1/131,072 in its CDF (Kolmogorov distance 7.6e-6) and has the
    normal's tails; after the ADC rounds to whole DN the two methods are
    indistinguishable (``rollsim bench accuracy`` measures it). It costs one
    16-bit draw and one table lookup per pixel instead of the Ziggurat's
    rejection steps.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.special import ndtr, ndtri

NORMAL_METHODS = ("exact", "table")
_BINS = 1 << 16


@lru_cache(maxsize=1)
def _bin_medians() -> np.ndarray:
    table = ndtri((np.arange(_BINS) + 0.5) / _BINS).astype(np.float32)
    table.setflags(write=False)
    return table


def standard_normal(rng: np.random.Generator, shape, method: str = "exact") -> np.ndarray:
    """Standard normal deviates as float32 (see the module docstring for ``method``)."""
    if method == "exact":
        return rng.standard_normal(shape, dtype=np.float32)
    if method != "table":
        raise ValueError(f"unknown method {method!r}; expected one of {list(NORMAL_METHODS)}")
    bins = rng.integers(0, _BINS, size=shape, dtype=np.uint16)
    z = _bin_medians()[bins]
    tail = np.flatnonzero((bins == 0) | (bins == _BINS - 1))
    if tail.size:
        u = (bins.ravel()[tail] + rng.random(tail.size)) / _BINS
        z.ravel()[tail] = ndtri(u)
    return z


def truncated_normal(uniform: np.ndarray, sigma: float, bound: float) -> np.ndarray:
    """Normal(0, ``sigma``) truncated to ``[-bound, bound]``, one value per U[0, 1) draw.

    Inverse CDF on the lower half only (``u < 1/2`` gives a negative value,
    ``u >= 1/2`` its mirror image): the quantile of probabilities near 1
    would round to ``inf``, those near 0 stay finite. The result is clipped
    to ``[-bound, bound]`` against the last ulp. ``bound`` may be ``inf``.
    """
    lo = ndtr(-bound / sigma)  # P(Z < -a), may underflow to 0
    half = np.where(uniform < 0.5, uniform, 1.0 - uniform)  # in (0, 1/2]
    p = lo + 2.0 * half * (0.5 - lo)
    z = np.maximum(ndtri(np.maximum(p, np.finfo(float).tiny)), -bound / sigma)
    return np.clip(np.where(uniform < 0.5, z, -z) * sigma, -bound, bound)


# ------------------------------------------------ from 32-bit random words
#
# The render's compiled noise kernels draw their uniforms from a counter-based
# generator (rollsim.counter_rng), one 32-bit word per deviate. The word's top
# 16 bits pick the bin, as ``table`` does; in the two outermost bins its low
# 16 bits place the deviate in the tail by the exact quantile at the word's
# centre, (w + 1/2)/2^32: tails out to ±6.34σ, where the 2^-32 resolution of
# the word ends (the normal has 2.3e-10 of its mass beyond).


@lru_cache(maxsize=1)
def normal_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Body, low-tail and high-tail tables of :func:`normal_from_word`, float32, 65,536 entries each."""
    low = ndtri((np.arange(_BINS, dtype=np.float64) + 0.5) / 2.0**32).astype(np.float32)
    high = (-low[::-1]).copy()
    for table in (low, high):
        table.setflags(write=False)
    return _bin_medians(), low, high


def normal_from_word(word, body, low, high):
    """A standard normal deviate (float32) from one 32-bit random word (scalar; a kernel helper)."""
    top = word >> np.uint64(16)
    if top == 0:
        return low[word & np.uint64(0xFFFF)]
    if top == _BINS - 1:
        return high[word & np.uint64(0xFFFF)]
    return body[top]


def normal_from_words(word: np.ndarray, body: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Standard normal deviates (float32) from 32-bit random words held in uint64 (see :func:`normal_from_word`)."""
    top = (word >> np.uint64(16)).astype(np.int64)
    z = body[top]
    fine = (word & np.uint64(0xFFFF)).astype(np.int64)
    tail = np.flatnonzero((top == 0) | (top == _BINS - 1))
    if tail.size:
        z[tail] = np.where(top[tail] == 0, low[fine[tail]], high[fine[tail]])
    return z
