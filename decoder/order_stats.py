"""Medians and percentiles of small arrays, numpy's numbers without its overhead.

The decoder takes a handful of medians and percentiles of a profile per
region (its spread, its noise, its runs' lengths). ``np.percentile`` and
``np.median`` spend 10 to 50 µs per call validating and dispatching, more
than the partition itself of a thousand values (4 µs); per 1080p frame
that was about 0.4 ms of the decode. These functions partition and
interpolate as numpy does, with the same floating-point operations in the
same order, so they return the same numbers bit for bit (tested against
numpy on random arrays, ties and tiny sizes included).

They take finite values only (the decoder's arrays are); NaN is not
propagated as numpy would.
"""

from __future__ import annotations

import numpy as np


def median(values) -> float:
    """The median of ``values`` (flattened), as ``np.median``.

    Parameters
    ----------
    values : array_like of float
        Finite, at least one value.

    Returns
    -------
    float
    """
    a = np.asarray(values).ravel()
    if a.dtype.kind != "f":
        a = a.astype(np.float64)
    half = a.size // 2
    if a.size % 2:
        return float(np.partition(a, half)[half])
    part = np.partition(a, (half - 1, half))
    # np.mean of the two middle values: their sum in the array's type, halved.
    return float((part[half - 1] + part[half]) / 2)


def percentiles(values, q) -> np.ndarray:
    """Percentiles ``q`` (0 to 100) of ``values`` (flattened), as ``np.percentile`` (linear).

    Parameters
    ----------
    values : array_like of float64
        Finite, at least one value. Other types go to ``np.percentile``,
        whose type rules for them this does not copy.
    q : sequence of float
        Percentiles in [0, 100].

    Returns
    -------
    ndarray of float64, shape (len(q),)
    """
    a = np.asarray(values).ravel()
    if a.dtype != np.float64:
        return np.asarray(np.percentile(a, list(q)), dtype=np.float64)
    n = a.size
    virtual = (n - 1) * np.true_divide(np.asarray(q, dtype=np.float64), 100)
    previous = np.floor(virtual)
    following = previous + 1
    # At or past the last value: the largest (numpy's index -1).
    top = virtual >= n - 1
    previous[top] = n - 1
    following[top] = n - 1
    low, high = previous.astype(np.intp), following.astype(np.intp)
    part = np.partition(a, np.unique(np.concatenate((low, high))))
    gamma = virtual - previous
    before, after = part[low], part[high]
    # numpy's _lerp: from the nearer end, so that gamma = 1 gives `after` exactly.
    step = after - before
    return np.where(gamma >= 0.5, after - step * (1 - gamma), before + step * gamma)


def percentile(values, q: float) -> float:
    """One percentile ``q`` (0 to 100) of ``values``, as ``np.percentile`` (see :func:`percentiles`)."""
    return float(percentiles(values, (q,))[0])
