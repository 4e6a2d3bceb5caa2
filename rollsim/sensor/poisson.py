"""Exact Poisson sampling, fast where a frame repeats the same mean.

A rendered frame's mean-electron image is mostly made of long runs of equal
values along each row: the uniform background, and the LED's interior, whose
value changes from row to row but not along a row. For pixels in such runs
this sampler inverts the Poisson CDF of the run's mean at a uniform deviate
through a table over 1024 equal bins of the deviate: a 16-bit random integer
picks the bin, which fixes the result unless a step of the CDF lies inside
the bin; then a fresh double-precision uniform places the deviate within the
bin and a binary search finds the exact step. The CDF is summed from the log pmf over
the mean ± (12√λ + 12), outside which the probability is below 1e-30. Pixels
in short runs (the LED's anti-aliased edge), and means above
:data:`MAX_TABLE_MEAN`, go to numpy's Poisson sampler. The law is Poisson in
every case; only the speed differs.

The cost is a few passes over compact (uint16/uint32) arrays instead of
numpy's ~40 ns per deviate; ``rollsim bench render`` measures both.
"""

from __future__ import annotations

import numpy as np
from scipy.special import gammaln

# Runs shorter than this go to numpy: their table rows would cost more than they save.
MIN_RUN = 16
# Table entries are uint16 counts, and long tables are slow to build.
MAX_TABLE_MEAN = 1.0e4
BIN_BITS = 10
TABLE_BINS = 1 << BIN_BITS
# Table entries hold k in the low 15 bits (k < 2**15 for means up to 1e4) and
# the "a CDF step lies inside this bin" flag in bit 15: one lookup gives both.
_STRADDLE = np.uint16(1 << 15)
_MAX_CLASSES = 65535  # class ids are uint16; one id is kept for "no table"


def _runs(lam: np.ndarray):
    """Start, length and value of every run of equal values along rows."""
    height, width = lam.shape
    change = np.empty((height, width), dtype=bool)
    change[:, 0] = True
    np.not_equal(lam[:, 1:], lam[:, :-1], out=change[:, 1:])
    starts = np.flatnonzero(change)
    lengths = np.diff(np.append(starts, lam.size))
    return starts, lengths, lam.ravel()[starts]


def _cdf_segments(means: np.ndarray):
    """Poisson CDF of each mean over k in [k_lo, k_hi], concatenated.

    Returns ``k_lo``, segment ``offsets`` (length n + 1), the ``owner`` class
    of each entry and the ``cdf`` values.
    """
    spread = 12.0 * np.sqrt(means) + 12.0
    k_lo = np.maximum(0.0, np.floor(means - spread)).astype(np.int64)
    k_hi = np.ceil(means + spread).astype(np.int64)
    sizes = k_hi - k_lo + 1
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    owner = np.repeat(np.arange(means.size), sizes)
    k = (k_lo[owner] + np.arange(offsets[-1]) - offsets[owner]).astype(np.float64)
    lam = means[owner]
    positive = lam > 0
    log_pmf = np.where(k == 0, 0.0, -np.inf)  # a zero mean puts all mass on k = 0
    log_pmf[positive] = k[positive] * np.log(lam[positive]) - lam[positive] - gammaln(k[positive] + 1.0)
    pmf = np.exp(log_pmf)
    running = np.cumsum(pmf)
    first = offsets[:-1]
    cdf = running - np.repeat(running[first] - pmf[first], sizes)
    return k_lo, offsets, owner, cdf


def _tables(means: np.ndarray):
    """Lookup table over (class, bin): k at the bin's start, flagged where a CDF step lies inside."""
    k_lo, offsets, owner, cdf = _cdf_segments(means)
    n = means.size
    # hist[c, b]: CDF entries of class c in bin b (bin B holds those at 1).
    bins = np.minimum((cdf * TABLE_BINS).astype(np.int64), TABLE_BINS)
    hist = np.bincount(owner * (TABLE_BINS + 1) + bins, minlength=n * (TABLE_BINS + 1)).reshape(n, TABLE_BINS + 1)
    below = np.cumsum(hist[:, :TABLE_BINS], axis=1) - hist[:, :TABLE_BINS]
    last = (offsets[1:] - offsets[:-1] - 1)[:, None]
    table = (k_lo[:, None] + np.minimum(below, last)).astype(np.uint16)
    table[hist[:, :TABLE_BINS] > 0] |= _STRADDLE
    # The last row is for pixels left to numpy.
    table = np.vstack([table, np.zeros((1, TABLE_BINS), np.uint16)])
    return table, k_lo, offsets, cdf


def _refine(classes, u, k_lo, offsets, cdf) -> np.ndarray:
    """Exact inverse CDF by binary search: k_lo + #{CDF entries ≤ u}."""
    lo = np.zeros(classes.size, dtype=np.int64)
    hi = offsets[classes + 1] - offsets[classes] - 1  # the last entry absorbs the far tail
    base = offsets[classes]
    while True:
        active = lo < hi
        if not active.any():
            break
        mid = (lo + hi) // 2
        right = active & (cdf[base + mid] <= u)
        lo = np.where(right, mid + 1, lo)
        hi = np.where(active & ~right, mid, hi)
    return k_lo[classes] + lo


def poisson(rng: np.random.Generator, lam: np.ndarray) -> np.ndarray:
    """Poisson deviates with means ``lam``, as float32 of the same shape.

    float32 holds every count up to 2**24 exactly. Exact; fast for long runs of equal means along the rows of a 2-D array
    (see the module docstring). The result depends only on ``rng``'s state
    and ``lam``.
    """
    lam = np.asarray(lam, dtype=np.float64)
    if lam.ndim != 2 or lam.size == 0:
        return rng.poisson(lam).astype(np.float32)
    starts, lengths, values = _runs(lam)
    tabled = (lengths >= MIN_RUN) & (values <= MAX_TABLE_MEAN)
    means, inverse = np.unique(values[tabled], return_inverse=True)
    if means.size == 0 or means.size > _MAX_CLASSES:
        return rng.poisson(lam).astype(np.float32)
    no_table = means.size  # the class id of pixels left to numpy
    run_class = np.full(starts.size, no_table, dtype=np.uint16)
    run_class[tabled] = inverse
    class_map = np.repeat(run_class, lengths)
    table, k_lo, offsets, cdf = _tables(means)

    bins = rng.integers(0, 1 << 16, size=lam.size, dtype=np.uint16)
    bins >>= np.uint16(16 - BIN_BITS)
    index = class_map.astype(np.uint32)
    index <<= BIN_BITS
    index |= bins
    entry = table.ravel()[index]
    refine = np.flatnonzero(entry >= _STRADDLE)
    entry &= np.uint16(_STRADDLE - 1)
    out = entry.astype(np.float32)
    if refine.size:
        # The uniform deviate, uniform within its bin: (bin + V) / B.
        u = (bins[refine] + rng.random(refine.size)) / TABLE_BINS
        out[refine] = _refine(class_map[refine].astype(np.int64), u, k_lo, offsets, cdf)
    rest = np.flatnonzero(class_map == no_table)
    if rest.size:
        out[rest] = rng.poisson(lam.ravel()[rest])
    return out.reshape(lam.shape)
