"""Elementary functions that give the same bits on every CPU.

numpy computes ``exp``, ``log``, ``arcsin``, ``power`` and their kin with
the widest SIMD code the CPU offers (AVX-512, AVX2 or the libm fallback),
and the three disagree in the last bit of many results: a render that used
them gave a few different pixels per frame on an AVX-512 machine and an
AVX2 one. The functions here use only what IEEE 754 rounds exactly
(``+``, ``−``, ``×``, ``÷``, ``sqrt``, ``rint``) and the exact ``frexp`` and
``ldexp``, in a fixed order, so a scene renders the same frames on every
machine. They are accurate to a couple of units in the last place (tested
against the C library); the render's physics asks far less.

Every function takes and returns float64 (a float32 argument is widened
exactly, so that the caller rounds once, at the end), and gives no
RuntimeWarning: arguments outside the domain give NaN, as numpy's do, and
results beyond float64's range inf or 0.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

__all__ = ["arcsin", "exp", "log", "power"]

# ln 2 in two parts (fdlibm's): the high part has 32 trailing zero bits, so
# k · LN2_HI is exact for every exponent k of a float64.
LN2_HI = 6.93147180369123816490e-01
LN2_LO = 1.90821492927058770002e-10
INV_LN2 = 1.44269504088896338700e00
# π/2 in two parts: PIO2_HI is the float64 nearest π/2, PIO2_LO the rest.
PIO2_HI = 1.57079632679489655800e00
PIO2_LO = 6.12323399573676603587e-17
SQRT_HALF = 0.70710678118654752440

# exp(r) for |r| <= ln2/2 by its Taylor series to r^13 (the next term is
# below 4e-18 of the result), highest power first.
_EXP_TAYLOR = tuple(1.0 / math.factorial(n) for n in range(13, -1, -1))
# log(1 + f) = f − s·(f − R(s²)) with s = f / (2 + f) and
# R(z) = 2z/3 + 2z²/5 + … : its coefficients 2/(2n + 1), n = 1 … 12, highest first.
# |s| <= 0.172 here, so z^12 < 1e-18.
_LOG_SERIES = tuple(2.0 / (2 * n + 1) for n in range(12, 0, -1))
# arcsin(a) = a + a·z·P(z), z = a², |a| <= 1/2: P's coefficients are the
# series' (2n)! / (4^n (n!)² (2n + 1)), n = 1 … 27, highest first; the
# first omitted term is below 1e-18.
_ASIN_SERIES = tuple(math.comb(2 * n, n) / (4.0**n * (2 * n + 1)) for n in range(27, 0, -1))
# Beyond these exp overflows to inf or underflows to 0.
_EXP_MAX = 709.782712893384
_EXP_MIN = -745.1332191019412
# power() takes x^y by products for y a multiple of 1/2 up to this |y|: each
# squaring doubles the relative error it carries, 4 ulp at most up to here.
_LARGEST_MULTIPLIED_POWER = 4
# Elements per piece of a large argument: the temporaries of a piece stay in
# the cache and memory stays flat (each element is computed alone, so the
# pieces change no bit).
_PIECE = 1 << 15


def _piecewise(kernel: Callable[[np.ndarray], np.ndarray], x) -> np.ndarray:
    """The element-wise ``kernel`` over float64 ``x``, a piece at a time."""
    x = np.asarray(x, dtype=np.float64)
    if x.size <= _PIECE:
        return kernel(x)
    flat = x.ravel()
    out = np.empty(flat.size)
    for first in range(0, flat.size, _PIECE):
        out[first:first + _PIECE] = kernel(flat[first:first + _PIECE])
    return out.reshape(x.shape)


def _horner(coefficients: tuple[float, ...], x: np.ndarray) -> np.ndarray:
    """Σ c_i x^i by Horner's rule, coefficients highest power first."""
    out = np.full_like(x, coefficients[0])
    for c in coefficients[1:]:
        out *= x
        out += c
    return out


def _exp(x: np.ndarray) -> np.ndarray:
    ok = (x >= _EXP_MIN) & (x <= _EXP_MAX)
    xs = np.where(ok, x, 0.0)
    # x = k·ln2 + r with |r| <= ln2/2; k·LN2_HI is exact, so r is exact to
    # the last bits of LN2_LO.
    k = np.rint(xs * INV_LN2)
    r = (xs - k * LN2_HI) - k * LN2_LO
    out = np.ldexp(_horner(_EXP_TAYLOR, r), k.astype(np.int32))
    if not ok.all():
        out[x > _EXP_MAX] = np.inf
        out[x < _EXP_MIN] = 0.0
        out[np.isnan(x)] = np.nan
    return out


def exp(x) -> np.ndarray:
    """e^x, the same bits on every CPU.

    Parameters
    ----------
    x : array_like of float
        Exponents (dimensionless).

    Returns
    -------
    ndarray of float64
        e^x, shape of ``x``: inf above ~709.78, 0 below ~−745.13, NaN for NaN.
    """
    return _piecewise(_exp, x)


def _log(x: np.ndarray) -> np.ndarray:
    ok = (x > 0.0) & (x < np.inf)
    m, e = np.frexp(np.where(ok, x, 1.0))  # x = m·2^e, m in [1/2, 1), exact
    low = m < SQRT_HALF
    m = np.where(low, m * 2.0, m)  # now m in [√½, √2): f = m − 1 is exact
    e = (e - low).astype(np.float64)
    f = m - 1.0
    s = f / (2.0 + f)
    log_m = f - s * (f - s * s * _horner(_LOG_SERIES, s * s))
    out = e * LN2_HI + (log_m + e * LN2_LO)
    if not ok.all():
        out[x == 0.0] = -np.inf
        out[x == np.inf] = np.inf
        out[(x < 0.0) | np.isnan(x)] = np.nan
    return out


def log(x) -> np.ndarray:
    """The natural logarithm, the same bits on every CPU.

    Parameters
    ----------
    x : array_like of float
        Arguments.

    Returns
    -------
    ndarray of float64
        ln x, shape of ``x``: −inf at 0, inf at inf, NaN below 0 and for NaN.
    """
    return _piecewise(_log, x)


def _arcsin(x: np.ndarray) -> np.ndarray:
    a = np.abs(x)
    ok = a <= 1.0
    a = np.where(ok, a, 0.0)
    far = a > 0.5
    # arcsin a = π/2 − 2·arcsin √((1 − a)/2) brings a > 1/2 back under 1/2;
    # 1 − a is exact there.
    w = np.where(far, np.sqrt((1.0 - a) * 0.5), a)
    z = w * w
    near_value = w + w * (z * _horner(_ASIN_SERIES, z))
    out = np.where(far, PIO2_HI - (2.0 * near_value - PIO2_LO), near_value)
    out = np.copysign(out, x)
    if not ok.all():
        out[~ok] = np.nan
    return out


def arcsin(x) -> np.ndarray:
    """The inverse sine (radians), the same bits on every CPU.

    Parameters
    ----------
    x : array_like of float
        Sines, in [−1, 1].

    Returns
    -------
    ndarray of float64
        arcsin x in [−π/2, π/2], shape of ``x``; NaN outside [−1, 1].
    """
    return _piecewise(_arcsin, x)


def _integer_power(x: np.ndarray, n: int) -> np.ndarray:
    """x^n for an integer n >= 0, by squaring (a fixed order of products)."""
    out = np.ones_like(x)
    square = x.copy()
    while n:
        if n & 1:
            out *= square
        n >>= 1
        if n:
            square *= square
    return out


def _power(x: np.ndarray, y: float) -> np.ndarray:
    bad = ~(x >= 0.0)
    xs = np.where(bad, 1.0, x)
    twice = 2.0 * abs(y)
    if twice == math.floor(twice) and abs(y) <= _LARGEST_MULTIPLIED_POWER:
        with np.errstate(over="ignore"):  # a product past float64's range is inf, as x^y is
            out = _integer_power(xs, int(abs(y)))
            if twice % 2:
                out *= np.sqrt(xs)
            if y < 0:
                zero = out == 0.0
                out = np.divide(1.0, out, out=np.full_like(out, np.inf), where=~zero)
    else:
        positive = xs > 0.0
        out = _exp(y * _log(np.where(positive, xs, 1.0)))
        out[~positive] = 0.0 if y > 0 else np.inf
    if bad.any():
        out[bad] = np.nan
    return out


def power(x, y: float) -> np.ndarray:
    """x^y for non-negative ``x`` and a scalar ``y``, the same bits on every CPU.

    A ``y`` that is a multiple of 1/2 up to 4 in size is taken by products,
    a square root and a division, within 4 ulp (−3.5 the worst); any other
    ``y`` as e^(y·ln x), whose error grows with |y·ln x| (about 16 ulp at
    2.2·ln 100). A result beyond float64's range is inf (or 0), without a
    warning.

    Parameters
    ----------
    x : array_like of float
        Bases, >= 0 (NaN for negative ones).
    y : float
        The exponent.

    Returns
    -------
    ndarray of float64
        x^y, shape of ``x``. 0^y is 0 for y > 0, 1 for y = 0 and inf for y < 0.

    Raises
    ------
    ValueError
        A NaN or infinite exponent.
    """
    y = float(y)
    if not math.isfinite(y):
        raise ValueError(f"power: the exponent must be finite, got {y!r}")
    return _piecewise(lambda piece: _power(piece, y), x)
