"""scipy.special's functions that every render needs, without importing scipy.special.

Importing any part of SciPy 1.17 (scipy.special, scipy.fft, …) loads its
array-API layer, which imports numpy.testing and numpy.f2py: about 0.3 s of
every command's start-up on a small machine, more than a one-frame render's
noise. The functions here follow scipy's own algorithm (cephes) for the
arguments rollsim passes, with the logarithm of :mod:`rollsim.numerics.portable_math`,
so that they give the same bits on every CPU: within 2 ulp of scipy, which
takes the C library's logarithm (tested). Any other argument goes to scipy
itself.
"""

from __future__ import annotations

import numpy as np

from rollsim.numerics.portable_math import log

# cephes lgam (scipy.special.gammaln): log √(2π), and Stirling's series in
# 1/x² for 13 <= x < 1000 (highest power first), as cephes writes them.
_LOG_SQRT_2PI = 0.91893853320467274178
_STIRLING = (8.11614167470508450300e-4, -5.95061904284301438324e-4, 7.93650340457716943945e-4,
             -2.77777777730099687205e-3, 8.33333333333331927722e-2)
# Above 1e8 cephes drops the series; rollsim's integers stay far below.
_LARGEST = 1.0e8


def _log_factorials() -> np.ndarray:
    """log((n − 1)!) for n = 0 … 12 as cephes takes it: the log of the exact product (n = 0 unused)."""
    products = [1.0, 1.0, 1.0]
    for n in range(3, 13):
        products.append(products[-1] * (n - 1))
    return log(np.array(products))


_SMALL = _log_factorials()


def gammaln(x) -> np.ndarray:
    """log Γ(x), as ``scipy.special.gammaln`` computes it, the same bits on every CPU.

    Positive integers below 1e8 (the Poisson tables' ``k + 1``) are computed
    here as cephes' ``lgam`` computes them: the log of the exact factorial
    below 13, Stirling's series above, with the portable logarithm (within
    2 ulp of scipy's values). Any other argument is passed to scipy.special,
    imported then.

    Parameters
    ----------
    x : array_like of float
        Arguments (dimensionless).

    Returns
    -------
    ndarray of float64
        log Γ(x), shape of ``x``.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.size and not (x.min() >= 1.0 and x.max() < _LARGEST and np.array_equal(x, np.floor(x))):
        from scipy.special import gammaln as scipy_gammaln  # here: arguments rollsim's renders never pass

        return scipy_gammaln(x)
    out = np.empty_like(x)
    small = x < 13.0
    out[small] = _SMALL[x[small].astype(np.int64)]
    large = x[~small]
    # cephes: q = (x − ½) log x − x + log √(2π), plus the series over x
    # (a shorter one from 1000 on), in its order of operations.
    q = (large - 0.5) * log(large) - large + _LOG_SQRT_2PI
    p = 1.0 / (large * large)
    far = large >= 1000.0
    pf = p[far]
    q[far] += ((7.9365079365079365079365e-4 * pf - 2.7777777777777777777778e-3) * pf
               + 0.0833333333333333333333) / large[far]
    pn = p[~far]
    series = np.full_like(pn, _STIRLING[0])
    for c in _STIRLING[1:]:
        series = series * pn + c
    q[~far] += series / large[~far]
    out[~small] = q
    return out
