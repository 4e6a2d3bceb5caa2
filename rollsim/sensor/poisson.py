"""Exact Poisson sampling, fast whether pixels share a mean or each has its own.

A Poisson variable splits exactly into independent parts:
Poisson(λ) = Poisson(g) + Poisson(λ − g) for any 0 ≤ g ≤ λ. Here g is λ with
all but the top :data:`CLASS_BITS` bits of its float64 mantissa cut off, so
g takes few values (256 per octave of λ, its *class*) and λ − g is exact and
below λ/256. Each class has a table, built once per process and kept:

* Poisson(g) is drawn by inverting its CDF at a uniform u = w·2^-32 from one
  32-bit random word w: the word's top 10 bits pick one of 1024 equal bins of
  u, and the table gives the count at the bin's start (16 bits: its offset
  from the class's lowest tabled count, 2 KB per class, so that the tables
  of a frame whose every pixel has its own mean stay in cache), flagged
  where a step of the CDF lies inside the bin; only then does a search over
  the class's CDF find the exact step (binary in numpy, forward from the
  bin's start in the compiled kernel: the same count). Where the bin holds
  one step, a second table gives the word within the bin from which the
  count is one more, and the compiled kernel reads that instead of the CDF
  for the classes of means from 256 on (whose CDFs, 13 KB at 4,500 e⁻, miss
  the cache). The CDF is summed from the log pmf over
  g ± (12√g + 12), outside which the probability is below 1e-30.
* The remainder λ − g is split again the same way while it is at least 1
  (for λ below 256 it already is not), and a remainder r < 1 is drawn by
  sequential inversion with the next word: u < 1 − r ≤ e^-r gives 0 at once
  (most pixels), else the CDF is summed term by term, e^-r from a fixed
  Horner polynomial (error below 1e-12, far under the uniforms' 2^-32) so that the compiled kernel and
  numpy compute the same bits.

The law is Poisson up to the 2^-32 resolution of the uniforms (a Kolmogorov
distance below 3e-10). Means from :data:`GAUSSIAN_ABOVE_E` (2^20 e⁻, far
above any full well) take N(λ, λ) instead, whose skewness error 1/√λ is
below 1e-3 there.

Random words come from a counter-based generator
(:mod:`rollsim.numerics.counter_rng`): pixel i uses the words of counters 2i and
2i + 1 (four 32-bit halves: one per part it needs), so the result depends
only on the key and the means, and the compiled kernel
(:mod:`rollsim.numerics.jit`) equals the numpy twin byte for byte.
"""

from __future__ import annotations

import math
import threading

import numpy as np

from rollsim.numerics.counter_rng import LOW32, WORD_SCALE, stream_key, words
from rollsim.numerics.gaussian import normal_from_words, normal_tables
from rollsim.numerics.portable_math import exp, log
from rollsim.sensor.special import gammaln  # cephes' lgam without scipy.special's 0.3 s import

CLASS_BITS = 8
BIN_BITS = 10
TABLE_BINS = 1 << BIN_BITS
# Classes cover means in [1, 2^MAX_EXPONENT); above, the Gaussian approximation.
MAX_EXPONENT = 20
GAUSSIAN_ABOVE_E = float(2**MAX_EXPONENT)
N_CLASSES = MAX_EXPONENT << CLASS_BITS
# Table entries: k − k_lo in the low 15 bits (below 2·(12·√2^20 + 12) + 2 < 2^15), bit 15
# set where a CDF step lies inside the bin.
STRADDLE = np.uint16(1 << 15)
K_MASK = np.uint16((1 << 15) - 1)
MANTISSA_SHIFT = np.uint64(52 - CLASS_BITS)
CLASS_MASK = np.uint64((1 << CLASS_BITS) - 1)
KEEP_CLASS_BITS = ~np.uint64((1 << (52 - CLASS_BITS)) - 1)
EXPONENT_SHIFT = np.uint64(52)
EXPONENT_BIAS = 1023
BIN_SHIFT_BITS = 32 - BIN_BITS
BIN_SHIFT = np.uint64(BIN_SHIFT_BITS)
# A word's place within its guide bin (its low 22 bits).
WITHIN_BIN_MASK = np.uint64((1 << BIN_SHIFT_BITS) - 1)
# The step table's entry of a bin that holds more than one step of the CDF (or none): searched.
SEVERAL_STEPS = np.uint32(0xFFFFFFFF)
TWO_32 = 4294967296.0  # 2^32: a 32-bit word's uniform is w / 2^32
# Classes of means below 2^DIRECT_EXPONENT (ids below DIRECT_CLASSES, the means of
# most pixels) also keep their guide rows at fixed places, with the counts
# themselves rather than offsets from k_lo: the compiled chain's common case
# then looks up one table for its count, where it would look up three (the
# class's row, its k_lo and the entry), which cost a third of the chain.
DIRECT_EXPONENT = 8
DIRECT_CLASSES = DIRECT_EXPONENT << CLASS_BITS
DIRECT_ABOVE_E = float(1 << DIRECT_EXPONENT)
# A direct row's entries until its class is built; no count of those classes comes near 2^15 − 1.
UNBUILT = np.uint16(0xFFFF)
# Sequential inversion of a remainder below 1 stops here (P(k > 40) < 1e-48).
MAX_SMALL_K = 40
# (-1)^n / n!, n = 0 … 14, highest first: e^-r for 0 ≤ r < 1 by Horner (truncation below 1/15! = 8e-13).
EXP_NEG_COEFFICIENTS = np.array([(-1.0) ** n / float(np.prod(np.arange(1, n + 1, dtype=np.float64))) for n in range(14, -1, -1)])


# ------------------------------------------------------------------ tables


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
    # The same bits on every CPU (numpy's own exp and log are not).
    log_pmf = k * log(means)[owner] - lam - gammaln(k + 1.0)  # every class mean is >= 1
    pmf = exp(log_pmf)
    running = np.cumsum(pmf)
    first = offsets[:-1]
    cdf = running - np.repeat(running[first] - pmf[first], sizes)
    cdf[offsets[1:] - 1] = 1.0  # the last entry absorbs the far tail
    return k_lo, offsets, owner, cdf


def class_mean(ids: np.ndarray) -> np.ndarray:
    """The mean g of each class id: 2^e · (1 + m / 2^CLASS_BITS)."""
    exponent, mantissa = np.divmod(np.asarray(ids, dtype=np.int64), 1 << CLASS_BITS)
    return np.ldexp(1.0 + mantissa / float(1 << CLASS_BITS), exponent.astype(np.int32))


def _guide_tables(means: np.ndarray):
    """Per class: 1024 entries (k − k_lo at the bin's start, flagged where a CDF step lies inside), each
    bin's step within it (:data:`SEVERAL_STEPS` where it holds more than one), and the CDFs."""
    k_lo, offsets, owner, cdf = _cdf_segments(means)
    n = means.size
    # hist[c, b]: CDF entries of class c in bin b (bin B holds those at 1).
    bins = np.minimum((cdf * TABLE_BINS).astype(np.int64), TABLE_BINS)
    hist = np.bincount(owner * (TABLE_BINS + 1) + bins, minlength=n * (TABLE_BINS + 1)).reshape(n, TABLE_BINS + 1)
    below = np.cumsum(hist[:, :TABLE_BINS], axis=1) - hist[:, :TABLE_BINS]
    last = (offsets[1:] - offsets[:-1] - 1)[:, None]
    offset = np.minimum(below, last)
    if offset.max(initial=0) > K_MASK:  # a class mean past the tables' range
        raise ValueError("a Poisson table's count offsets exceed 15 bits")
    guide = offset.astype(np.uint16)
    guide[hist[:, :TABLE_BINS] > 0] |= STRADDLE
    # A bin's one step: u = w·2^-32 reaches CDF value F where w ≥ ceil(F·2^32) (exact: F·2^32 only moves F's
    # exponent), kept as that word's offset from the bin's first word, in [0, 2^22].
    step = np.full((n, TABLE_BINS), SEVERAL_STEPS, dtype=np.uint32)
    owner_of, bin_of = np.nonzero(hist[:, :TABLE_BINS] == 1)
    first_word = np.ceil(cdf[offsets[owner_of] + below[owner_of, bin_of]] * TWO_32) - bin_of * float(1 << BIN_SHIFT_BITS)
    step[owner_of, bin_of] = first_word.astype(np.uint32)
    return guide, step, k_lo, offsets, cdf


class PoissonTables:
    """The tables of the classes met so far, in flat arrays a kernel can read.

    Attributes
    ----------
    guide : ndarray of uint16, shape (n_built · 1024,)
        Per bin, the count at the bin's start minus the class's ``k_lo``,
        with :data:`STRADDLE` set where the CDF steps inside the bin.
    step : ndarray of uint32, shape (n_built · 1024,)
        Per bin of ``guide`` that holds exactly one step of the CDF, the
        offset within the bin (of its 2^22 words) of the first word whose
        uniform reaches that step: the count is the bin's, plus one from
        there on, with no CDF to read. :data:`SEVERAL_STEPS` elsewhere.
    cdf : ndarray of float64
        Every built class's CDF, concatenated.
    slot : ndarray of int64, shape (N_CLASSES,)
        Row of a class in ``guide``, or −1 before it is built.
    cdf_start, cdf_size, k_lo : ndarray of int64, shape (N_CLASSES,)
    direct : ndarray of uint16, shape (DIRECT_CLASSES · 1024,)
        The rows of ``guide`` of the classes below :data:`DIRECT_CLASSES`,
        at row = class id, with the count itself (not its offset from
        ``k_lo``) in the low 15 bits; :data:`UNBUILT` before the class is
        built. It is filled in place, after the arrays above, so that a
        kernel running meanwhile in another thread reads either UNBUILT or
        a row whose class is complete in the arrays it was given (it checks
        the CDF's extent against those).
    """

    def __init__(self) -> None:
        self.guide = np.zeros(0, dtype=np.uint16)
        self.step = np.zeros(0, dtype=np.uint32)
        self.cdf = np.zeros(0, dtype=np.float64)
        self.slot = np.full(N_CLASSES, -1, dtype=np.int64)
        self.cdf_start = np.zeros(N_CLASSES, dtype=np.int64)
        self.cdf_size = np.zeros(N_CLASSES, dtype=np.int64)
        self.k_lo = np.zeros(N_CLASSES, dtype=np.int64)
        self.direct = np.full(DIRECT_CLASSES * TABLE_BINS, UNBUILT, dtype=np.uint16)
        self._lock = threading.Lock()

    def missing(self, ids: np.ndarray) -> np.ndarray:
        """The class ids among ``ids`` (each in [0, N_CLASSES)) not built yet (sorted, unique)."""
        # Ids lie in a small range: one counting pass over a frame's
        # millions of ids instead of sorting them (np.unique).
        present = np.bincount(np.asarray(ids, dtype=np.int64).ravel(), minlength=N_CLASSES) > 0
        return np.flatnonzero(present & (self.slot < 0))

    def build(self, ids: np.ndarray) -> None:
        """Build the tables of class ids ``ids`` (those already built are skipped)."""
        with self._lock:
            ids = self.missing(ids)
            if ids.size == 0:
                return
            guide, step, k_lo, offsets, cdf = _guide_tables(class_mean(ids))
            first_slot = self.guide.size // TABLE_BINS
            self.cdf_start[ids] = self.cdf.size + offsets[:-1]
            self.cdf_size[ids] = np.diff(offsets)
            self.k_lo[ids] = k_lo
            # The step table before the guide, and read after it (arrays()): a kernel
            # given a guide row is given that row's steps.
            self.step = np.concatenate([self.step, step.ravel()])
            self.guide = np.concatenate([self.guide, guide.ravel()])
            self.cdf = np.concatenate([self.cdf, cdf])
            self.slot[ids] = first_slot + np.arange(ids.size)
            near = ids < DIRECT_CLASSES
            counts = (guide[near] & K_MASK).astype(np.int64) + k_lo[near, None]
            if counts.max(initial=0) >= UNBUILT & K_MASK:
                raise ValueError("a direct Poisson table's counts reach 15 bits")
            rows = counts.astype(np.uint16) | (guide[near] & STRADDLE)
            self.direct.reshape(DIRECT_CLASSES, TABLE_BINS)[ids[near]] = rows

    def arrays(self) -> tuple:
        """What a kernel reads, in its argument order."""
        return self.guide, self.cdf, self.slot, self.cdf_start, self.cdf_size, self.k_lo, self.direct, self.step


# The mean of every class id, for kernels (exactly the masked means of split_class).
CLASS_MEANS = class_mean(np.arange(N_CLASSES))

# One store per process: a class's table depends on nothing but the class.
TABLES = PoissonTables()


# ------------------------------------------------------- numpy (whole arrays)


def split_class(lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Class id and class mean g ≤ λ of means in [1, 2^MAX_EXPONENT) (float64)."""
    bits = lam.view(np.uint64)
    exponent = (bits >> EXPONENT_SHIFT).astype(np.int64) - EXPONENT_BIAS
    ids = (exponent << CLASS_BITS) | ((bits >> MANTISSA_SHIFT) & CLASS_MASK).astype(np.int64)
    return ids, (bits & KEEP_CLASS_BITS).view(np.float64)


def exp_neg(r: np.ndarray) -> np.ndarray:
    """e^-r for 0 ≤ r < 1 by a fixed Horner polynomial (the kernel's arithmetic)."""
    out = np.full(r.shape, EXP_NEG_COEFFICIENTS[0])
    for c in EXP_NEG_COEFFICIENTS[1:]:
        out *= r
        out += c
    return out


def _half(word_lo: np.ndarray, word_hi: np.ndarray, part: np.ndarray) -> np.ndarray:
    """32-bit word number ``part`` (0 … 3) of each pixel: halves of its two 64-bit words."""
    out = np.where(part % 2 == 0, word_lo >> np.uint64(32), word_lo & LOW32)
    return np.where(part >= 2, np.where(part % 2 == 0, word_hi >> np.uint64(32), word_hi & LOW32), out)


def _table_counts(tables: PoissonTables, ids: np.ndarray, word: np.ndarray) -> np.ndarray:
    """Poisson(class mean) by the guide table and, in straddled bins, binary search."""
    entry = tables.guide[tables.slot[ids] * TABLE_BINS + (word >> BIN_SHIFT).astype(np.int64)]
    k = tables.k_lo[ids] + (entry & K_MASK).astype(np.int64)
    refine = np.flatnonzero(entry & STRADDLE)
    if refine.size:
        cls = ids[refine]
        u = word[refine].astype(np.float64) * WORD_SCALE
        base = tables.cdf_start[cls]
        lo = (entry[refine] & K_MASK).astype(np.int64)
        hi = tables.cdf_size[cls] - 1
        while True:
            active = lo < hi
            if not active.any():
                break
            mid = (lo + hi) // 2
            right = active & (tables.cdf[base + mid] <= u)
            lo = np.where(right, mid + 1, lo)
            hi = np.where(active & ~right, mid, hi)
        k[refine] = tables.k_lo[cls] + lo
    return k


def _small_counts(r: np.ndarray, word: np.ndarray) -> np.ndarray:
    """Poisson(r) for 0 ≤ r < 1 by sequential inversion at u = w·2^-32."""
    u = word.astype(np.float64) * WORD_SCALE
    k = np.zeros(r.size, dtype=np.int64)
    todo = np.flatnonzero(u >= 1.0 - r)
    if todo.size == 0:
        return k
    r_t, u_t = r[todo], u[todo]
    p = exp_neg(r_t)
    cdf = p.copy()
    k_t = np.zeros(todo.size, dtype=np.int64)
    for step in range(1, MAX_SMALL_K + 1):
        going = u_t >= cdf
        if not going.any():
            break
        k_t += going
        p = p * r_t / float(step)
        cdf = np.where(going, cdf + p, cdf)
        p = np.where(going, p, 0.0)
    k[todo] = k_t
    return k


def poisson_numpy(lam: np.ndarray, key: np.uint64, offset: int = 0) -> np.ndarray:
    """Poisson deviates of the flat float64 means ``lam`` from counter stream ``key`` (float32), in numpy.

    ``lam[0]`` is pixel ``offset`` of the frame (its words are that pixel's).
    """
    n = lam.size
    first = words(key, (np.arange(n, dtype=np.uint64) + np.uint64(offset)) * np.uint64(2))
    out = np.zeros(n, dtype=np.float64)
    rest = lam.astype(np.float64, copy=True)
    big = np.flatnonzero(rest >= GAUSSIAN_ABOVE_E)
    rest[big] = 0.0
    # The first table step, for every mean of 1 or more: word 0 of each pixel.
    tabled_at = np.flatnonzero(rest >= 1.0)
    # Every pixel (a lit frame): a slice, not a gather and a scatter per array.
    tabled: np.ndarray | slice = slice(None) if tabled_at.size == n else tabled_at
    ids, g = split_class(rest[tabled])
    TABLES.build(ids)  # skips the classes already built
    out[tabled] = _table_counts(TABLES, ids, first[tabled] >> np.uint64(32))
    rest[tabled] -= g
    part = np.zeros(n, dtype=np.int8)
    part[tabled] = 1
    # Further steps, for means of 256 or more only (words 1 to 3).
    active = np.flatnonzero(rest >= 1.0)  # only tabled pixels can still hold 1 or more
    if active.size:
        second = np.zeros(n, dtype=np.uint64)
        second[active] = words(key, (active.astype(np.uint64) + np.uint64(offset)) * np.uint64(2) + np.uint64(1))
        while active.size:
            ids, g = split_class(rest[active])
            TABLES.build(ids)  # skips the classes already built
            out[active] += _table_counts(TABLES, ids, _half(first[active], second[active], part[active]))
            rest[active] -= g
            part[active] += 1
            active = active[rest[active] >= 1.0]
    small_at = np.flatnonzero(rest > 0.0)
    if small_at.size:
        # Remainders everywhere (the usual frame): a slice.
        small: np.ndarray | slice = slice(None) if small_at.size == n else small_at
        first_small, part_small = first[small], part[small]
        word = np.where(part_small == 0, first_small >> np.uint64(32), first_small & LOW32)
        later = np.flatnonzero(part_small >= 2)
        if later.size:
            word[later] = _half(first_small[later], second[small_at[later]], part_small[later])
        out[small] += _small_counts(rest[small], word)
    if big.size:
        lam_big = lam[big].astype(np.float64)
        z = normal_from_words(first[big] >> np.uint64(32), *normal_tables()).astype(np.float64)
        out[big] = np.maximum(0.0, lam_big + np.sqrt(lam_big) * z)
    return out.astype(np.float32)


def class_of_remainder(rest: float) -> int:
    """Class id of one mean in [1, 2^MAX_EXPONENT), by frexp (exact; the kernel's way for remainders)."""
    fraction, exponent = math.frexp(rest)  # rest = fraction · 2^exponent, fraction in [1/2, 1)
    return (exponent - 1) * (1 << CLASS_BITS) + int((fraction * 2.0 - 1.0) * (1 << CLASS_BITS))


def poisson(rng: np.random.Generator, lam: np.ndarray) -> np.ndarray:
    """Poisson deviates with means ``lam``, as float32 of the same shape.

    float32 holds every count up to 2**24 exactly. One key is drawn from
    ``rng`` (:func:`rollsim.numerics.counter_rng.stream_key`); the result depends only
    on ``rng``'s state and ``lam`` (see the module docstring). Compiled where
    numba is used (:mod:`rollsim.sensor.chain`), numpy otherwise, with
    identical results.
    """
    from rollsim.sensor.chain import shot_poisson  # the compiled chain builds on this module

    return shot_poisson(stream_key(rng), lam)
