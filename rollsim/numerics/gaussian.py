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

from rollsim.numerics.portable_math import log  # numpy's differs in the last bit between CPUs

NORMAL_METHODS = ("exact", "table")
_BINS = 1 << 16

# Wichura's AS241 (PPND16, Applied Statistics 37, 1988), the rational
# approximations Python's statistics.NormalDist.inv_cdf evaluates; highest
# power first. Relative error ~1e-16: as float32, the tables below are
# scipy.special.ndtri's, bit for bit (tests/test_gaussian.py checks every entry).
_AS241_CENTRAL = (
    (2.5090809287301226727e+3, 3.3430575583588128105e+4, 6.7265770927008700853e+4, 4.5921953931549871457e+4,
     1.3731693765509461125e+4, 1.9715909503065514427e+3, 1.3314166789178437745e+2, 3.3871328727963666080e+0),
    (5.2264952788528545610e+3, 2.8729085735721942674e+4, 3.9307895800092710610e+4, 2.1213794301586595867e+4,
     5.3941960214247511077e+3, 6.8718700749205790830e+2, 4.2313330701600911252e+1, 1.0),
)
_AS241_INTERMEDIATE = (
    (7.7454501427834140764e-4, 2.2723844989269184583e-2, 2.4178072517745061177e-1, 1.2704582524523683826e+0,
     3.6478483247632046050e+0, 5.7694972214606914055e+0, 4.6303378461565452959e+0, 1.4234371107496835773e+0),
    (1.0507500716444168432e-9, 5.4759380849953445460e-4, 1.5198666563616457197e-2, 1.4810397642748007459e-1,
     6.8976733498510000455e-1, 1.6763848301838038494e+0, 2.0531916266377588219e+0, 1.0),
)
_AS241_FAR = (
    (2.0103343992922881327e-7, 2.7115555687434875782e-5, 1.2426609473880784386e-3, 2.6532189526576123093e-2,
     2.9656057182850489123e-1, 1.7848265399172913358e+0, 5.4637849111641143699e+0, 6.6579046435011037772e+0),
    (2.0442631033899397856e-15, 1.4215117583164458887e-7, 1.8463183175100546818e-5, 7.8686913114561329059e-4,
     1.4875361290850614852e-2, 1.3692988092273580531e-1, 5.9983220655588793769e-1, 1.0),
)


def _rational(coefficients: tuple[tuple[float, ...], tuple[float, ...]], x: np.ndarray) -> np.ndarray:
    """numerator(x) / denominator(x), both by Horner's rule."""
    numerator, denominator = (np.full_like(x, c[0]) for c in coefficients)
    for a, b in zip(coefficients[0][1:], coefficients[1][1:], strict=True):
        numerator = numerator * x + a
        denominator = denominator * x + b
    return numerator / denominator


def normal_quantile(p: np.ndarray) -> np.ndarray:
    """The standard normal quantile Φ⁻¹(p) of probabilities in (0, 1), float64, by AS241.

    For the float32 tables of this module, without importing scipy.special
    (0.3 s of every command's start-up): within ~1e-15 of
    ``scipy.special.ndtri`` (relative), the same float32 values on every
    table entry. Where the float64 value itself must be scipy's (a
    simulation's jitter draws), :func:`truncated_normal` uses scipy.

    Parameters
    ----------
    p : ndarray of float
        Probabilities, strictly between 0 and 1.

    Returns
    -------
    ndarray of float64
        Standard normal deviates (units of σ), shape of ``p``.
    """
    p = np.asarray(p, dtype=np.float64)
    q = p - 0.5
    out = np.empty_like(p)
    central = np.abs(q) <= 0.425
    qc = q[central]
    out[central] = qc * _rational(_AS241_CENTRAL, 0.180625 - qc * qc)
    tails = ~central
    qt = q[tails]
    r = np.sqrt(-log(np.where(qt <= 0.0, p[tails], 1.0 - p[tails])))
    x = np.empty_like(r)
    near = r <= 5.0
    x[near] = _rational(_AS241_INTERMEDIATE, r[near] - 1.6)
    x[~near] = _rational(_AS241_FAR, r[~near] - 5.0)
    out[tails] = np.where(qt < 0.0, -x, x)
    return out


@lru_cache(maxsize=1)
def _bin_medians() -> np.ndarray:
    table = normal_quantile((np.arange(_BINS) + 0.5) / _BINS).astype(np.float32)
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
        from scipy.special import ndtri  # here: the exact tail draw, not worth scipy's import to every command

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
    # Imported here: scipy.special takes 0.3 s to import, and only simulations
    # with frame jitter draw these (scipy's exact float64 values, kept).
    from scipy.special import ndtr, ndtri

    lo = ndtr(-bound / sigma)  # P(Z < -a), may underflow to 0
    half = np.where(uniform < 0.5, uniform, 1.0 - uniform)  # in (0, 1/2]
    p = lo + 2.0 * half * (0.5 - lo)
    z = np.maximum(ndtri(np.maximum(p, np.finfo(float).tiny)), -bound / sigma)
    return np.clip(np.where(uniform < 0.5, z, -z) * sigma, -bound, bound)


# ------------------------------------------------ from 32-bit random words
#
# The render's compiled noise kernels draw their uniforms from a counter-based
# generator (rollsim.numerics.counter_rng), one 32-bit word per deviate. The word's top
# 16 bits pick the bin, as ``table`` does; in the two outermost bins its low
# 16 bits place the deviate in the tail by the exact quantile at the word's
# centre, (w + 1/2)/2^32: tails out to ±6.34σ, where the 2^-32 resolution of
# the word ends (the normal has 2.3e-10 of its mass beyond).


@lru_cache(maxsize=1)
def normal_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Body, low-tail and high-tail tables of :func:`normal_from_word`, float32, 65,536 entries each."""
    low = normal_quantile((np.arange(_BINS, dtype=np.float64) + 0.5) / 2.0**32).astype(np.float32)
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
