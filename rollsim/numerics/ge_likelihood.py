"""The Gilbert-Elliott log-likelihood of a trace's gaps, compiled and in numpy.

:class:`rollsim.calibrate.ge.GeTrace` reduces a 0/1 trace to the powers
of A = T D₀ its likelihood needs (the opening run, each distinct gap
length, the closing run). A fit evaluates that likelihood thousands of
times, each on a few dozen powers: in numpy, the per-call overhead of a
loop over the exponents' bits was most of a calibration's time, so the
evaluation is one compiled kernel (:mod:`rollsim.numerics.jit`) with a
numpy twin that performs the same IEEE-754 operations in the same order.

A^L is taken by squaring. Every entry of A is non-negative, so the products
only add non-negative terms (no cancellation). After each product the
matrix is scaled by a power of two that brings its largest entry into
[1/2, 1) (``frexp`` and ``ldexp``, exact), and the powers of two are
counted in an integer: A^L = M · 2^E with no overflow or underflow of the
scale, however long the trace, and only the final likelihood terms take a
logarithm (``math.log``: the C library's, the same in both twins).
"""

from __future__ import annotations

import math

import numpy as np

from rollsim.numerics.jit import kernel

LN2 = math.log(2.0)
# Bits of the largest exponent the squaring covers (gaps are counted in int64).
MAX_BITS = 63


def _log_or_minus_inf(x: float) -> float:
    """ln x for x ≥ 0, −inf at 0 (``math.log`` refuses 0)."""
    return math.log(x) if x > 0.0 else -math.inf


@kernel
def _ge_loglik_kernel(p, q, p_e, exponents, counts, head, n_gaps, closing, none):  # pragma: no cover - compiled
    t00, t01, t10, t11 = 1.0 - q, q, p, 1.0 - p
    pi0, pi1 = p / (p + q), q / (p + q)
    # A = T D0: a transition, then a failure (D0 = diag(p_e, 1)).
    a00, a01, a10, a11 = t00 * p_e, t01, t10 * p_e, t11
    k = exponents.size
    # The matrices M and scales E of each exponent: A^L = M · 2^E.
    m00 = np.ones(k)
    m01 = np.zeros(k)
    m10 = np.zeros(k)
    m11 = np.ones(k)
    scale = np.zeros(k, dtype=np.int64)
    largest = 0
    for i in range(k):
        largest = max(largest, exponents[i])
    # A^(2^j), scaled: the power's matrix and its scale.
    b00, b01, b10, b11 = a00, a01, a10, a11
    top = max(max(b00, b01), max(b10, b11))
    fraction, shift = math.frexp(top)
    b00, b01, b10, b11 = (math.ldexp(b00, -shift), math.ldexp(b01, -shift), math.ldexp(b10, -shift),
                          math.ldexp(b11, -shift))
    b_scale = np.int64(shift)
    bit = 0
    while bit < MAX_BITS and (largest >> bit) > 0:
        for i in range(k):
            if (exponents[i] >> bit) & 1:
                c00 = m00[i] * b00 + m01[i] * b10
                c01 = m00[i] * b01 + m01[i] * b11
                c10 = m10[i] * b00 + m11[i] * b10
                c11 = m10[i] * b01 + m11[i] * b11
                top = max(max(c00, c01), max(c10, c11))
                fraction, shift = math.frexp(top)
                m00[i] = math.ldexp(c00, -shift)
                m01[i] = math.ldexp(c01, -shift)
                m10[i] = math.ldexp(c10, -shift)
                m11[i] = math.ldexp(c11, -shift)
                scale[i] += b_scale + shift
        c00 = b00 * b00 + b01 * b10
        c01 = b00 * b01 + b01 * b11
        c10 = b10 * b00 + b11 * b10
        c11 = b10 * b01 + b11 * b11
        top = max(max(c00, c01), max(c10, c11))
        fraction, shift = math.frexp(top)
        b00, b01, b10, b11 = (math.ldexp(c00, -shift), math.ldexp(c01, -shift), math.ldexp(c10, -shift),
                              math.ldexp(c11, -shift))
        b_scale = 2 * b_scale + shift
        bit += 1
    if none:
        # No success at all: π D0 A^(n-1) 1.
        v0, v1 = pi0 * p_e, pi1
        value = (v0 * m00[0] + v1 * m10[0]) + (v0 * m01[0] + v1 * m11[0])
        return (math.log(value) if value > 0.0 else -math.inf) + np.float64(scale[0]) * LN2
    total = 0.0
    if head:
        # Opening: stationary start, failures, then a success in S1: π D0 A^(opening-1) T D1.
        v0, v1 = pi0 * p_e, pi1
        w0 = v0 * m00[0] + v1 * m10[0]
        w1 = v0 * m01[0] + v1 * m11[0]
        value = (w0 * t00 + w1 * t10) * (1.0 - p_e)
        total += (math.log(value) if value > 0.0 else -math.inf) + np.float64(scale[0]) * LN2
    else:
        value = pi0 * (1.0 - p_e)
        total += math.log(value) if value > 0.0 else -math.inf
    # Gaps between successes: g(L) = [A^L T]_11 (1 - p_e), once per distinct length, times its count.
    gaps = 0.0
    for i in range(head, head + n_gaps):
        value = (m00[i] * t00 + m01[i] * t10) * (1.0 - p_e)
        gaps += np.float64(counts[i - head]) * ((math.log(value) if value > 0.0 else -math.inf)
                                                + np.float64(scale[i]) * LN2)
    total += gaps
    if closing:
        # Closing: from S1, more failures: e1 A^closing 1.
        value = m00[k - 1] + m01[k - 1]
        total += (math.log(value) if value > 0.0 else -math.inf) + np.float64(scale[k - 1]) * LN2
    return total


def _scaled(c00, c01, c10, c11):
    """The four entries scaled so that the largest lies in [1/2, 1), and the power of two taken out."""
    shift = np.frexp(np.maximum(np.maximum(c00, c01), np.maximum(c10, c11)))[1].astype(np.int64)
    return np.ldexp(c00, -shift), np.ldexp(c01, -shift), np.ldexp(c10, -shift), np.ldexp(c11, -shift), shift


def scaled_powers(a: tuple[float, float, float, float], exponents: np.ndarray):
    """A^L = M · 2^E for each L of ``exponents``, in numpy (the kernel's operations, vectorised over L).

    Returns the four entries of each M (arrays) and E (int64).
    """
    k = exponents.size
    m00, m01, m10, m11 = np.ones(k), np.zeros(k), np.zeros(k), np.ones(k)
    scale = np.zeros(k, dtype=np.int64)
    b00, b01, b10, b11, b_scale = _scaled(*(np.float64(v) for v in a))
    largest = int(exponents.max(initial=0))
    bit = 0
    while bit < MAX_BITS and (largest >> bit) > 0:
        use = ((exponents >> bit) & 1).astype(bool)
        if use.any():
            c = (m00[use] * b00 + m01[use] * b10, m00[use] * b01 + m01[use] * b11,
                 m10[use] * b00 + m11[use] * b10, m10[use] * b01 + m11[use] * b11)
            m00[use], m01[use], m10[use], m11[use], shift = _scaled(*c)
            scale[use] += b_scale + shift
        b00, b01, b10, b11, shift = _scaled(b00 * b00 + b01 * b10, b00 * b01 + b01 * b11,
                                            b10 * b00 + b11 * b10, b10 * b01 + b11 * b11)
        b_scale = 2 * b_scale + shift
        bit += 1
    return (m00, m01, m10, m11), scale


def _ge_loglik_numpy(p, q, p_e, exponents, counts, head, n_gaps, closing, none) -> float:
    """:data:`_ge_loglik_kernel` in numpy: the same operations, the powers vectorised over the exponents."""
    t00, t10 = 1.0 - q, p
    pi0, pi1 = p / (p + q), q / (p + q)
    (m00, m01, m10, m11), scale = scaled_powers((t00 * p_e, q, t10 * p_e, 1.0 - p), exponents)
    k = exponents.size
    if none:
        v0, v1 = pi0 * p_e, pi1
        value = (v0 * m00[0] + v1 * m10[0]) + (v0 * m01[0] + v1 * m11[0])
        return _log_or_minus_inf(value) + float(scale[0]) * LN2
    total = 0.0
    if head:
        v0, v1 = pi0 * p_e, pi1
        w0 = v0 * m00[0] + v1 * m10[0]
        w1 = v0 * m01[0] + v1 * m11[0]
        total += _log_or_minus_inf((w0 * t00 + w1 * t10) * (1.0 - p_e)) + float(scale[0]) * LN2
    else:
        total += _log_or_minus_inf(pi0 * (1.0 - p_e))
    gaps = 0.0
    values = (m00[head:head + n_gaps] * t00 + m01[head:head + n_gaps] * t10) * (1.0 - p_e)
    for value, count, shift in zip(values.tolist(), counts.tolist(), scale[head:head + n_gaps].tolist()):
        gaps += float(count) * (_log_or_minus_inf(value) + float(shift) * LN2)
    total += gaps
    if closing:
        total += _log_or_minus_inf(m00[k - 1] + m01[k - 1]) + float(scale[k - 1]) * LN2
    return float(total)


def ge_loglik_of_powers(p: float, q: float, p_e: float, exponents: np.ndarray, counts: np.ndarray,
                        head: bool, n_gaps: int, closing: bool, none: bool) -> float:
    """Log-likelihood of a trace reduced to its powers (:class:`rollsim.calibrate.ge.GeTrace`).

    Parameters
    ----------
    p, q, p_e : float
        P(S2 → S1), P(S1 → S2) and the failure probability in S1, each in [0, 1], p + q > 0.
    exponents : ndarray of int64
        The powers of T D₀ needed: the opening run's (when ``head``), each
        distinct gap length's, the closing run's (when ``closing``); the
        one of a trace without success (when ``none``).
    counts : ndarray of int64
        How many gaps have each distinct length (``n_gaps`` of them).

    Returns
    -------
    float
        Natural log; −inf where the trace is impossible under the parameters.
    """
    exponents = np.ascontiguousarray(exponents, dtype=np.int64)
    counts = np.ascontiguousarray(counts, dtype=np.int64)
    args = (float(p), float(q), float(p_e), exponents, counts, int(head), int(n_gaps), bool(closing), bool(none))
    compiled = _ge_loglik_kernel.compiled
    if compiled is not None:
        return float(compiled(*args))
    return _ge_loglik_numpy(*args)
