"""The sensor chain from shot noise to the output image, in one pass per frame.

After the mean electrons of a frame are known, the EMVA 1288 chain is
pixel by pixel: shot noise, the full-well clip, read noise, the ADC and the
output table (black clip, tone curve, 8 bits). numpy needs a pass over the
whole frame for each step of each stage (a hash, a lookup, a multiply, a
clip, a cast); the compiled kernel does them all on a block of 1,024 pixels
at a time, in buffers that stay in the cache. :func:`run_chain` runs any
contiguous part of the chain that starts with shot noise, or with read
noise on electrons already noisy:

* ``shot``: ``"poisson"`` (:mod:`rollsim.sensor.poisson`), ``"gaussian"``
  (N(λ, λ), λ + √λ·z in float32) or None;
* ``full_well_e``: the clip to [0, full well], or None;
* ``read_sigma_e``: Gaussian read noise (the word table of
  :func:`rollsim.numerics.gaussian.normal_from_word`), or None;
* ``adc``: conversion gain, black level and bits, or None to stop at
  electrons (float32);
* ``lut``: the output table of each DN (gray8), or None for raw DN (uint16).

Each stage's random words come from its own counter stream (its key), so
the chain's result is the same whether it runs in one pass or stage by
stage. The compiled kernel (:mod:`rollsim.numerics.jit`) and the numpy twin compute
the same IEEE-754 operations in the same order, float32 where the staged
effects work in float32, and give identical bytes (tested).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Literal, NamedTuple, Optional

import numpy as np

from rollsim.numerics.counter_rng import GAMMA, LOW32, MIX1, MIX2, WORD_SCALE, words
from rollsim.numerics.gaussian import normal_from_words, normal_tables
from rollsim.numerics.jit import kernel
from rollsim.sensor.adc import electrons_to_dn
from rollsim.sensor.means import SeparableMeans, kernel_parts, materialize
from rollsim.sensor.poisson import (
    BIN_SHIFT,
    CLASS_BITS,
    CLASS_MASK,
    CLASS_MEANS,
    DIRECT_ABOVE_E,
    DIRECT_EXPONENT,
    EXP_NEG_COEFFICIENTS,
    EXPONENT_BIAS,
    EXPONENT_SHIFT,
    GAUSSIAN_ABOVE_E,
    K_MASK,
    KEEP_CLASS_BITS,
    MANTISSA_SHIFT,
    MAX_SMALL_K,
    N_CLASSES,
    SEVERAL_STEPS,
    STRADDLE,
    TABLE_BINS,
    TABLES,
    TWO_32,
    UNBUILT,
    WITHIN_BIN_MASK,
    poisson_numpy,
)

SHOT_METHODS = ("poisson", "gaussian")


@dataclass(frozen=True)
class Adc:
    """The ADC's settings: conversion gain K (DN/e⁻), black level (DN), bits."""

    gain_dn_per_e: float
    black_level_dn: int
    bits: int


CHAIN_ORDER = ("shot", "full_well", "read", "adc", "output")


@dataclass(frozen=True)
class ChainStep:
    """One render stage's part of the chain.

    Attributes
    ----------
    kind : {"shot", "full_well", "read", "adc", "output"}
    value
        The shot method, the full well (e⁻), the read noise σ (e⁻), the
        :class:`Adc`, or the output table (None for raw DN).
    stream : str or None
        The named random stream whose key the step's noise uses.
    finish : callable or None
        For the output step: what the stage does to the table's image after
        it (a CFA's demosaicing), run after the chain too.
    """

    kind: str
    value: Any = None
    stream: Optional[str] = None
    finish: Optional[Callable[[np.ndarray], np.ndarray]] = None

    def __post_init__(self) -> None:
        if self.kind not in CHAIN_ORDER:
            raise ValueError(f"chain step kind must be one of {list(CHAIN_ORDER)}, got {self.kind!r}")


@dataclass(frozen=True)
class ChainKeys:
    """The counter keys of one frame's noise stages (None where a stage is absent)."""

    shot: Optional[np.uint64] = None
    read: Optional[np.uint64] = None


_BAD_MEANS = "mean electrons must be finite and non-negative"

# ------------------------------------------------------------------ numpy


def pixel_normals(key: np.uint64, n: int, offset: int = 0) -> np.ndarray:
    """One standard normal (float32) per pixel ``offset`` … ``offset + n − 1``: from the high half of the word of counter 2i."""
    counters = (np.arange(n, dtype=np.uint64) + np.uint64(offset)) * np.uint64(2)
    return normal_from_words(words(key, counters) >> np.uint64(32), *normal_tables())


def shot_numpy(lam: np.ndarray, key: np.uint64, method: str, offset: int = 0) -> np.ndarray:
    """Shot noise of flat means ``lam`` (float64; ``lam[0]`` is pixel ``offset``), as float32 electrons."""
    if method == "poisson":
        return poisson_numpy(lam, key, offset)
    mean = lam.astype(np.float32)
    noise = pixel_normals(key, lam.size, offset)
    noise *= np.sqrt(mean)
    noise += mean
    return noise


def read_noise_numpy(electrons: np.ndarray, key: np.uint64, sigma_e: float, offset: int = 0) -> np.ndarray:
    """``electrons`` (float32; ``electrons[0]`` is pixel ``offset``) plus Gaussian read noise of σ ``sigma_e``."""
    noise = pixel_normals(key, electrons.size, offset)
    noise *= np.float32(sigma_e)
    noise += electrons
    return noise


# Pixels the numpy twin takes at once: its temporaries (a dozen arrays of
# 8 bytes a pixel) stay in the cache instead of faulting in fresh pages;
# each pixel's result depends on its index alone, so the parts change no bit.
NUMPY_PART_PIXELS = 1 << 17


def _chain_numpy(lam, shot, keys, full_well_e, read_sigma_e, adc, lut):
    if lam.size <= NUMPY_PART_PIXELS:
        return _chain_numpy_part(lam, 0, shot, keys, full_well_e, read_sigma_e, adc, lut)
    return np.concatenate([_chain_numpy_part(lam[first:first + NUMPY_PART_PIXELS], first, shot, keys, full_well_e,
                                             read_sigma_e, adc, lut) for first in range(0, lam.size, NUMPY_PART_PIXELS)])


def _chain_numpy_part(lam, offset, shot, keys, full_well_e, read_sigma_e, adc, lut):
    electrons = lam.astype(np.float32) if shot is None else shot_numpy(lam, keys.shot, shot, offset)
    if full_well_e is not None:
        np.clip(electrons, 0.0, full_well_e, out=electrons)
    if read_sigma_e is not None:
        electrons = read_noise_numpy(electrons, keys.read, read_sigma_e, offset)
    if adc is None:
        return electrons
    dn = electrons_to_dn(electrons, adc.gain_dn_per_e, adc.black_level_dn, adc.bits)
    return dn if lut is None else lut[dn]


# --------------------------------------------------------------- compiled


# Pixels per block of the compiled chain: the block's buffers (~144 KB) stay
# in the L2 cache between its loops.
BLOCK_PIXELS = 1024
# Means below this take two classes at most, the second a direct one: the
# first class's remainder λ − g lies below λ / 2^CLASS_BITS = 2^DIRECT_EXPONENT.
PAIR_BELOW_E = float(1 << (DIRECT_EXPONENT + CLASS_BITS))


@kernel
def _chain_kernel(lam, parts, start, shot_key, guide, full_well, read_sigma, read_key, adc, lut, out,
                  cdf, slot, cdf_start, cdf_size, k_lo, direct, step_at, class_means, exp_coefficients, z_body,
                  z_low, z_high):
    # One flat body: numba passes array arguments to a called function with
    # reference counting, which cost several times the work itself. A step
    # the chain does not take is passed as None (no shot noise, Gaussian shot
    # noise without the Poisson tables in ``guide``, no clip, no read noise, no
    # ADC, raw DN without ``lut``): numba compiles one version per pattern of
    # Nones with the dead steps pruned.
    #
    # A block of pixels goes through short loops over its buffers, of two
    # kinds. Loops of arithmetic alone (the hashes, the tests, the ADC) read
    # and write contiguous buffers, so LLVM vectorises them; loops that look
    # tables up (class, guide, normal and output tables) do that alone, in
    # scalar code (LLVM cannot prove that the lookups miss the buffers
    # written, so it vectorises no loop that has one). The common case of the
    # shot noise is one table lookup: a mean below 256 (one class), a guide
    # entry without a CDF step inside its bin and a remainder that draws 0
    # (u < 1 − r), about 95 % of a frame's pixels on paper-geometric and
    # paper-default. The others are sorted by what they need (the CDF step
    # inside the bin, the remainder's draw, several classes), so that each
    # loop over them branches alike. The one loop per pixel that carried
    # every step and its rare branches took 1.2× (paper-geometric) to 1.7×
    # (paper-default) as long. Each pixel's words depend only on its index,
    # so the order of the work changes no bit: the numpy twin's bytes. The
    # block's means come from the frame ``lam``, or are written from their
    # parts (rollsim.sensor.means) with the operations that would have
    # written the frame: then no float64 frame is written nor read back.
    n_block = BLOCK_PIXELS
    mean_of = np.empty(n_block, dtype=np.float64)
    bits_of = mean_of.view(np.uint64)
    # Each of lam and parts is tested on its own: numba drops a branch
    # whose condition is on an argument that is None, not one on its partner.
    n_pixels = 0
    if lam is not None:
        n_pixels = lam.size
    if parts is not None:
        height, width = parts[0]
        n_pixels = height * width
    word = np.empty(n_block, dtype=np.uint64)  # the shot noise's 64-bit word (counter 2i)
    ident = np.empty(n_block, dtype=np.int64)  # class id, −1 for a mean outside [1, 256)
    # The class's mean g: the mean with all but its top CLASS_BITS mantissa bits
    # cut off, written as bits and read as float64 (no table to look up).
    class_bits = np.empty(n_block, dtype=np.uint64)
    class_mean = class_bits.view(np.float64)
    entry = np.empty(n_block, dtype=np.int64)
    # Unsigned indices: numba wraps a negative signed index around, a select per lookup.
    index = np.empty(n_block, dtype=np.uint64)
    slow = np.empty(n_block, dtype=np.int64)  # the other pixels' places
    electrons_of = np.empty(n_block, dtype=np.float32)
    read_word = np.empty(n_block, dtype=np.uint64)
    normal = np.empty(n_block, dtype=np.float32)
    level_of = np.empty(n_block, dtype=np.uint64)
    need = np.empty(n_block, dtype=np.int64)  # what a pixel's shot noise needs beyond the common case
    bin_place = np.empty(n_block, dtype=np.int64)  # pixels whose guide bin holds a CDF step
    rest_place = np.empty(n_block, dtype=np.int64)  # pixels whose remainder draws more than 0
    rare_place = np.empty(n_block, dtype=np.int64)  # means of PAIR_BELOW_E or more
    # Means in [256, PAIR_BELOW_E): two classes each, worked through in loops of their own.
    pair_place = np.empty(n_block, dtype=np.int64)
    pair_rest = np.empty(n_block, dtype=np.float64)  # r1 = λ − g1, below 256
    pair_rest_bits = pair_rest.view(np.uint64)
    pair_word = np.empty(n_block, dtype=np.uint64)  # word 2i + 1
    pair_later = np.empty(n_block, dtype=np.uint64)  # the high half of word 2i + 2
    pair_first = np.empty(n_block, dtype=np.int64)  # class of g1
    pair_second = np.empty(n_block, dtype=np.int64)  # class of g2, −1 where r1 < 1
    pair_second_bits = np.empty(n_block, dtype=np.uint64)  # g2 (0 where none), written as bits
    pair_second_mean = pair_second_bits.view(np.float64)
    pair_index = np.empty(n_block, dtype=np.uint64)  # g1's guide and step entries
    pair_index2 = np.empty(n_block, dtype=np.uint64)  # g2's direct entry (class 0's row where none: unused)
    pair_entry = np.empty(n_block, dtype=np.uint16)
    pair_entry2 = np.empty(n_block, dtype=np.uint16)
    pair_step = np.empty(n_block, dtype=np.uint32)
    pair_count = np.empty(n_block, dtype=np.int64)
    several_place = np.empty(n_block, dtype=np.int64)  # those whose g1 bin holds several CDF steps
    rest_of = np.empty(n_block, dtype=np.float64)  # their remainders r, below 1
    u_of = np.empty(n_block, dtype=np.float64)  # and uniforms
    seq_p = np.empty(n_block, dtype=np.float64)  # and e^-r
    for first in range(start, n_pixels, n_block):
        n = min(n_block, n_pixels - first)
        # ------------------------------------------------- the block's means
        if lam is not None:
            for j in range(n):
                mean_of[j] = lam[first + j]
        if parts is not None:
            # Row by row, as rollsim.sensor.means writes a frame: the base
            # level, the LED's box, the face's correction, each element with
            # the same operations.
            (_, box, coverage, row_signal, level_kind, level, level_map, face, correction, gain, offset_kind,
             offset_level, offset_map) = parts
            first_row, n_rows, first_col, n_cols = box
            j = 0
            while j < n:
                y = (first + j) // width
                x = first + j - y * width
                m = min(n - j, width - x)  # the rest of the block on row y
                # Row slices as 1-D views, indexed from 0: plain loops LLVM vectorises.
                into = mean_of[j:j + m]
                row_level = level_map[y, 0] if level_kind == 3 else level  # a level per row, or one
                if level_kind == 2:
                    base = level_map[y, x:x + m]
                    for k in range(m):
                        into[k] = 0.0 + base[k]
                elif level_kind == 1 or level_kind == 3:
                    for k in range(m):
                        into[k] = 0.0 + row_level
                else:
                    for k in range(m):
                        into[k] = 0.0
                r = y - first_row
                lo, hi = max(x, first_col), min(x + m, first_col + n_cols)
                if 0 <= r < n_rows and lo < hi:
                    signal = row_signal[r]
                    lit = mean_of[j + lo - x:j + hi - x]
                    cover = coverage[r, lo - first_col:hi - first_col]
                    if level_kind == 2:
                        base = level_map[y, lo:hi]
                        for k in range(hi - lo):
                            lit[k] = cover[k] * signal + base[k]
                    elif level_kind == 1 or level_kind == 3:
                        for k in range(hi - lo):
                            lit[k] = cover[k] * signal + row_level
                    else:
                        for k in range(hi - lo):
                            lit[k] = cover[k] * signal
                r = y - face[0]
                lo, hi = max(x, face[2]), min(x + m, face[2] + face[3])
                if 0 <= r < face[1] and lo < hi:
                    lit = mean_of[j + lo - x:j + hi - x]
                    extra = correction[r, lo - face[2]:hi - face[2]]
                    for k in range(hi - lo):
                        lit[k] += extra[k]
                j += m
            # Then the gain (PRNU) and the offset (dark current), as their stages apply them to the frame.
            if gain.size > 0:
                block_gain = gain[first:first + n]
                for k in range(n):
                    mean_of[k] = mean_of[k] * np.float64(block_gain[k])
            if offset_kind == 1:
                for k in range(n):
                    mean_of[k] = mean_of[k] + offset_level
            elif offset_kind == 2:
                block_offset = offset_map[first:first + n]
                for k in range(n):
                    mean_of[k] = mean_of[k] + np.float64(block_offset[k])
        # ------------------------------------------------------ shot noise
        if shot_key is None:
            for j in range(n):
                electrons_of[j] = np.float32(mean_of[j])
        else:
            n_bad = 0  # counted, not or-ed: LLVM vectorises a sum, not a boolean reduction
            for j in range(n):  # vectorised: the words, the classes, NaN / inf / negative
                i = first + j
                z = (np.uint64(i) * np.uint64(2) + np.uint64(1)) * GAMMA + shot_key
                z = (z ^ (z >> np.uint64(30))) * MIX1
                z = (z ^ (z >> np.uint64(27))) * MIX2
                w = z ^ (z >> np.uint64(31))
                word[j] = w
                mean = mean_of[j]
                n_bad += np.int64(not ((mean >= 0.0) & (mean < np.inf)))
                bits = bits_of[j]
                c = ((np.int64(bits >> EXPONENT_SHIFT) - EXPONENT_BIAS) << CLASS_BITS) | np.int64(
                    (bits >> MANTISSA_SHIFT) & CLASS_MASK)
                classed = (mean >= 1.0) & (mean < DIRECT_ABOVE_E)
                ident[j] = c if classed else np.int64(-1)
                class_bits[j] = bits & KEEP_CLASS_BITS
                # The direct table's place (class 0's row for an unclassed mean: read, not used).
                index[j] = np.uint64(c if classed else np.int64(0)) * np.uint64(TABLE_BINS) + (
                    (w >> np.uint64(32)) >> BIN_SHIFT)
            if n_bad:
                return -1  # refused by the caller
            if guide is None:
                # Gaussian shot noise, N(λ, λ) in float32: λ + √λ·z.
                n_tail = 0
                for j in range(n):
                    top = word[j] >> np.uint64(48)
                    normal[j] = z_body[top]
                    n_tail += np.int64((top == 0) | (top == 0xFFFF))  # the two outer bins (2 words in 65,536)
                if n_tail:  # their tails
                    for j in range(n):
                        top = word[j] >> np.uint64(48)
                        fine = (word[j] >> np.uint64(32)) & np.uint64(0xFFFF)
                        if top == 0:
                            normal[j] = z_low[fine]
                        elif top == 0xFFFF:
                            normal[j] = z_high[fine]
                for j in range(n):  # vectorised
                    mean32 = np.float32(mean_of[j])
                    electrons_of[j] = normal[j] * np.sqrt(mean32) + mean32
            else:
                for j in range(n):  # the one lookup of the common case: the count, or where to look further
                    entry[j] = direct[index[j]]
                for j in range(n):  # vectorised: the common case's count, and what else each pixel needs
                    mean = mean_of[j]
                    classed = ident[j] >= 0
                    rest = mean - class_mean[j] if classed else mean
                    # u < 1 − r as words: w < ceil((1 − r)·2^32) is w < (1 − r)·2^32 for an integer w.
                    bound = (1.0 - rest) * TWO_32
                    w = word[j]
                    e = entry[j]
                    # 1: a CDF step inside the guide's bin; 2: the remainder draws more than 0;
                    # 4: a mean of PAIR_BELOW_E or more (up to three classes, or beyond the tables);
                    # 8: a mean in [256, PAIR_BELOW_E) (two classes).
                    need[j] = ((classed & (e >= np.int64(STRADDLE))) * 1
                               + ((classed & (np.float64(w & LOW32) >= bound))
                                  | ((mean < 1.0) & (np.float64(w >> np.uint64(32)) >= bound))) * 2
                               + (~classed & (mean >= PAIR_BELOW_E)) * 4
                               + (~classed & (mean >= 1.0) & (mean < PAIR_BELOW_E)) * 8)
                    electrons_of[j] = np.float32(e & np.int64(K_MASK)) if classed else np.float32(0.0)
                m = 0
                for j in range(n):
                    slow[m] = j
                    m += need[j] != 0
                n_bin = n_rest = n_rare = n_pair = 0
                for s in range(m):  # sorted by what they need, so that each loop below branches alike
                    j = slow[s]
                    classed = ident[j] >= 0
                    bin_place[n_bin] = j
                    n_bin += (need[j] & 1) != 0
                    rest_place[n_rest] = j
                    rest_of[n_rest] = mean_of[j] - class_mean[j] if classed else mean_of[j]
                    u_of[n_rest] = np.float64(word[j] & LOW32 if classed else word[j] >> np.uint64(32)) * WORD_SCALE
                    n_rest += (need[j] & 2) != 0
                    rare_place[n_rare] = j
                    n_rare += (need[j] & 4) != 0
                    pair_place[n_pair] = j
                    n_pair += (need[j] & 8) != 0
                for s in range(n_bin):  # the count inside the bin: the first whose CDF exceeds u
                    j = bin_place[s]
                    c = ident[j]
                    base = cdf_start[c]
                    hi = cdf_size[c] - 1
                    # A class not built, or built (in another thread) after the CDFs given were
                    # taken: built, then this block again.
                    if entry[j] == UNBUILT or base + hi >= cdf.size:
                        return first
                    u = np.float64(word[j] >> np.uint64(32)) * WORD_SCALE
                    lo = (entry[j] & np.int64(K_MASK)) - k_lo[c]
                    while lo < hi and cdf[base + lo] <= u:  # a step or two (the end bins hold the tails)
                        lo += 1
                    electrons_of[j] = np.float32(k_lo[c] + lo)
                # Means in [256, PAIR_BELOW_E), a bright scene's: g1 from the mean's bits, and
                # where r1 = λ − g1 ≥ 1 (it lies below 256), g2 from r1's, a direct class; r2 =
                # r1 − g2 < 1 joins the other remainders. The words are the loop below's: part 0
                # (the high half of word 2i + 1) for g1, part 1 (its low half) for g2 or else the
                # remainder, part 2 (the high half of word 2i + 2) after g2. Split by kind of work as
                # the common case is (one scalar loop carrying every step took 1.3x as long on
                # effect-blooming's means), and g1's count read from its bin's step where the bin
                # holds one: a third of g1's bins at λ ≈ 4500 do, and reading the CDF there missed the cache.
                if n_pair:
                    for s in range(n_pair):  # vectorised (gathers): r1, the words, g1's class
                        j = pair_place[s]
                        pair_rest[s] = mean_of[j] - class_mean[j]
                        pair_word[s] = word[j]
                        z = (np.uint64(first + j) * np.uint64(2) + np.uint64(2)) * GAMMA + shot_key
                        z = (z ^ (z >> np.uint64(30))) * MIX1
                        z = (z ^ (z >> np.uint64(27))) * MIX2
                        pair_later[s] = (z ^ (z >> np.uint64(31))) >> np.uint64(32)
                        bits = bits_of[j]
                        pair_first[s] = ((np.int64(bits >> EXPONENT_SHIFT) - EXPONENT_BIAS) << CLASS_BITS) | np.int64(
                            (bits >> MANTISSA_SHIFT) & CLASS_MASK)
                    for s in range(n_pair):  # vectorised: g2's class, where r1 holds one
                        bits = pair_rest_bits[s]
                        two = pair_rest[s] >= 1.0
                        c = ((np.int64(bits >> EXPONENT_SHIFT) - EXPONENT_BIAS) << CLASS_BITS) | np.int64(
                            (bits >> MANTISSA_SHIFT) & CLASS_MASK)
                        pair_second[s] = c if two else np.int64(-1)
                        pair_second_bits[s] = bits & KEEP_CLASS_BITS if two else np.uint64(0)
                        pair_index2[s] = np.uint64(c if two else np.int64(0)) * np.uint64(TABLE_BINS) + (
                            (pair_word[s] & LOW32) >> BIN_SHIFT)
                    n_missing = 0
                    for s in range(n_pair):  # g1's row of the guide
                        c = pair_first[s]
                        row = slot[c]
                        n_missing += np.int64((row < 0) | ((row + 1) * TABLE_BINS > guide.size)
                                              | (cdf_start[c] + cdf_size[c] > cdf.size))
                        pair_index[s] = np.uint64(max(row, 0)) * np.uint64(TABLE_BINS) + (
                            (pair_word[s] >> np.uint64(32)) >> BIN_SHIFT)
                    if n_missing:
                        return first  # a class without its table (in the arrays given): built, then this block again
                    for s in range(n_pair):  # the entries
                        pair_entry[s] = guide[pair_index[s]]
                        pair_step[s] = step_at[pair_index[s]]
                        pair_entry2[s] = direct[pair_index2[s]]
                    n_several = 0
                    for s in range(n_pair):  # vectorised: g1's count, a bin's one step decided by its word
                        g = pair_entry[s]
                        t = pair_step[s]
                        within = (pair_word[s] >> np.uint64(32)) & WITHIN_BIN_MASK
                        straddled = (g & STRADDLE) != 0
                        pair_count[s] = k_lo[pair_first[s]] + np.int64(g & K_MASK) + np.int64(
                            straddled & (t != SEVERAL_STEPS) & (within >= np.uint64(t)))
                        several_place[n_several] = s
                        n_several += straddled & (t == SEVERAL_STEPS)
                    for q in range(n_several):  # bins holding several steps (the tails): the CDF
                        s = several_place[q]
                        c = pair_first[s]
                        lo = np.int64(pair_entry[s] & K_MASK)
                        u = np.float64(pair_word[s] >> np.uint64(32)) * WORD_SCALE
                        base = cdf_start[c]
                        hi = cdf_size[c] - 1
                        while lo < hi and cdf[base + lo] <= u:
                            lo += 1
                        pair_count[s] = k_lo[c] + lo
                    for s in range(n_pair):  # g2's count, where there is one
                        c = pair_second[s]
                        if c < 0:
                            continue
                        e = np.int64(pair_entry2[s])
                        if e == UNBUILT or cdf_start[c] + cdf_size[c] > cdf.size:
                            return first
                        lo = (e & np.int64(K_MASK)) - k_lo[c]
                        if e & STRADDLE:
                            u = np.float64(pair_word[s] & LOW32) * WORD_SCALE
                            base = cdf_start[c]
                            hi = cdf_size[c] - 1
                            while lo < hi and cdf[base + lo] <= u:
                                lo += 1
                        pair_count[s] += k_lo[c] + lo
                    for s in range(n_pair):  # the count, and the remainder r2 (or r1) with the next word
                        j = pair_place[s]
                        rest = pair_rest[s] - pair_second_mean[s]
                        u_word = pair_later[s] if pair_second[s] >= 0 else pair_word[s] & LOW32
                        electrons_of[j] = np.float32(pair_count[s])
                        # u < 1 − r as words, as for the common case.
                        if rest > 0.0 and np.float64(u_word) >= (1.0 - rest) * TWO_32:
                            rest_place[n_rest] = j  # its remainder joins the others'
                            rest_of[n_rest] = rest
                            u_of[n_rest] = np.float64(u_word) * WORD_SCALE
                            n_rest += 1
                for s in range(n_rare):  # means of PAIR_BELOW_E or more: the tables of up to three classes
                    j = rare_place[s]
                    i = first + j
                    mean = mean_of[j]
                    word64 = word[j]
                    if mean >= GAUSSIAN_ABOVE_E:
                        # Poisson means beyond the tables: N(λ, λ).
                        value = word64 >> np.uint64(32)
                        top = value >> np.uint64(16)
                        if top == 0:
                            z_value = z_low[value & np.uint64(0xFFFF)]
                        elif top == 0xFFFF:
                            z_value = z_high[value & np.uint64(0xFFFF)]
                        else:
                            z_value = z_body[top]
                        electrons_of[j] = np.float32(max(0.0, mean + np.sqrt(mean) * np.float64(z_value)))
                        continue
                    u_word = word64 >> np.uint64(32)
                    total = 0
                    part = 0
                    rest = mean
                    while rest >= 1.0:
                        if part > 0:  # a remainder: its class by frexp (no bit view of a scalar)
                            fraction, exponent = math.frexp(rest)
                            c = np.int64(exponent - 1) * (1 << CLASS_BITS) + np.int64(
                                (fraction * 2.0 - 1.0) * (1 << CLASS_BITS))
                        else:
                            c = ((np.int64(bits_of[j] >> EXPONENT_SHIFT) - EXPONENT_BIAS) << CLASS_BITS) | np.int64(
                                (bits_of[j] >> MANTISSA_SHIFT) & CLASS_MASK)
                        if slot[c] < 0 or (slot[c] + 1) * TABLE_BINS > guide.size or (
                                cdf_start[c] + cdf_size[c] > cdf.size):
                            return first  # a class without its table (in the arrays given): built, then this block again
                        g = guide[slot[c] * TABLE_BINS + np.int64(u_word >> BIN_SHIFT)]
                        lo = np.int64(g & K_MASK)
                        if g & STRADDLE:
                            u = np.float64(u_word) * WORD_SCALE
                            base = cdf_start[c]
                            hi = cdf_size[c] - 1
                            while lo < hi and cdf[base + lo] <= u:
                                lo += 1
                        total += k_lo[c] + lo
                        rest -= class_means[c]
                        part += 1
                        if part == 2:
                            z = (np.uint64(i) * np.uint64(2) + np.uint64(2)) * GAMMA + shot_key
                            z = (z ^ (z >> np.uint64(30))) * MIX1
                            z = (z ^ (z >> np.uint64(27))) * MIX2
                            word64 = z ^ (z >> np.uint64(31))
                            u_word = word64 >> np.uint64(32)
                        else:
                            u_word = word64 & LOW32
                    electrons_of[j] = np.float32(total)
                    if rest > 0.0 and u_word >= np.uint64(math.ceil((1.0 - rest) * TWO_32)):
                        rest_place[n_rest] = j  # its remainder joins the others'
                        rest_of[n_rest] = rest
                        u_of[n_rest] = np.float64(u_word) * WORD_SCALE
                        n_rest += 1
                for s in range(n_rest):  # e^-r by the fixed Horner polynomial
                    p = exp_coefficients[0]
                    for k in range(1, exp_coefficients.size):
                        p = p * rest_of[s] + exp_coefficients[k]
                    seq_p[s] = p
                for s in range(n_rest):  # sequential inversion of the remainder's Poisson CDF
                    rest = rest_of[s]
                    u = u_of[s]
                    p = seq_p[s]
                    running = p
                    count = 0
                    for step in range(1, MAX_SMALL_K + 1):
                        if u < running:
                            break
                        count += 1
                        p = p * rest / np.float64(step)
                        running = running + p
                    # The table's count and the remainder's, both below 2^24, add exactly in float32.
                    electrons_of[rest_place[s]] += np.float32(count)
        # ------------------------------- full well, read noise, ADC, output
        if read_sigma is not None:
            n_tail = 0
            for j in range(n):  # vectorised
                z = (np.uint64(first + j) * np.uint64(2) + np.uint64(1)) * GAMMA + read_key
                z = (z ^ (z >> np.uint64(30))) * MIX1
                z = (z ^ (z >> np.uint64(27))) * MIX2
                value = (z ^ (z >> np.uint64(31))) >> np.uint64(32)
                read_word[j] = value
                top = value >> np.uint64(16)
                n_tail += np.int64((top == 0) | (top == 0xFFFF))  # the two outer bins (2 words in 65,536)
            for j in range(n):
                normal[j] = z_body[read_word[j] >> np.uint64(16)]
            if n_tail:  # their tails
                for j in range(n):
                    top = read_word[j] >> np.uint64(16)
                    if top == 0:
                        normal[j] = z_low[read_word[j] & np.uint64(0xFFFF)]
                    elif top == 0xFFFF:
                        normal[j] = z_high[read_word[j] & np.uint64(0xFFFF)]
        for j in range(n):  # vectorised: each step the chain takes, in its order
            electrons = electrons_of[j]
            if full_well is not None:
                electrons = min(max(electrons, np.float32(0.0)), full_well)
            if read_sigma is not None:
                electrons = normal[j] * read_sigma + electrons
            if adc is None:
                out[first + j] = electrons
            else:
                level = electrons * adc[0] + adc[1]
                level_of[j] = np.uint64(np.uint16(min(max(level, np.float32(0.0)), adc[2])))
        if adc is not None:
            if lut is None:
                for j in range(n):
                    out[first + j] = np.uint16(level_of[j])
            else:
                for j in range(n):
                    out[first + j] = lut[level_of[j]]
    return n_pixels


def _chain_compiled(compiled, means, shot, keys, full_well_e, read_sigma_e, adc, lut):
    """The compiled chain over flat means (float64), or over the means' parts (a SeparableMeans)."""
    lam, parts = (None, kernel_parts(means)) if isinstance(means, SeparableMeans) else (means, None)
    n = means.shape[0] * means.shape[1] if lam is None else lam.size
    if adc is None:
        out = np.empty(n, dtype=np.float32)
        adc_constants = None
    else:
        out = np.empty(n, dtype=np.uint16 if lut is None else lut.dtype)
        # electrons_to_dn's float32 constants, exactly.
        adc_constants = (np.float32(adc.gain_dn_per_e), np.float32(adc.black_level_dn + 0.5), np.float32(2**adc.bits - 0.5))
    start = 0
    while start < n:
        guide, *tables = TABLES.arrays()
        stop = int(compiled(
            lam, parts, start,
            None if shot is None else np.uint64(keys.shot),
            guide if shot == "poisson" else None,
            None if full_well_e is None else np.float32(full_well_e),
            None if read_sigma_e is None else np.float32(read_sigma_e),
            np.uint64(keys.read or 0),
            adc_constants,
            None if lut is None else np.ascontiguousarray(lut),
            out, *tables, CLASS_MEANS, EXP_NEG_COEFFICIENTS, *normal_tables()))
        if stop < 0:
            raise ValueError(_BAD_MEANS)
        if stop < n:
            if lam is None:  # finding the classes still missing reads the frame: written once, and read from here on
                lam, parts = materialize(means).ravel(), None
            build_classes_from(lam, stop)
        start = stop
    return out


@kernel
def _classes_kernel(lam, start, class_means, needed):
    # Marks the classes the chain kernel's Poisson steps ask for, from pixel ``start`` on.
    bits_of = lam.view(np.uint64)
    for i in range(start, lam.size):
        rest = lam[i]
        if not (rest >= 1.0 and rest < GAUSSIAN_ABOVE_E):
            continue
        part = 0
        while rest >= 1.0:
            if part == 0:
                ident = ((np.int64(bits_of[i] >> EXPONENT_SHIFT) - EXPONENT_BIAS) << CLASS_BITS) | np.int64(
                    (bits_of[i] >> MANTISSA_SHIFT) & CLASS_MASK)
            else:
                fraction, exponent = math.frexp(rest)
                ident = np.int64(exponent - 1) * (1 << CLASS_BITS) + np.int64((fraction * 2.0 - 1.0) * (1 << CLASS_BITS))
            needed[ident] = True
            rest -= class_means[ident]
            part += 1
    return 0


# Classes built on either side of each class a frame needs: the means of
# the next frames drift (another row signal, another phase of the flicker),
# and a class met for the first time stops the kernel and costs a pass over
# the rest of the frame. A table costs ~30 µs to build.
NEIGHBOUR_CLASSES = 16


def build_classes_from(lam: np.ndarray, start: int) -> None:
    """Build the table of every class that pixels ``start`` on of flat means ``lam`` need (one compiled pass),
    and of its :data:`NEIGHBOUR_CLASSES` neighbours on either side."""
    needed = np.zeros(N_CLASSES, dtype=np.bool_)
    compiled = _classes_kernel.compiled
    if compiled is None:
        raise RuntimeError("the class-marking pass runs only where the compiled chain does")
    compiled(lam, start, CLASS_MEANS, needed)
    ids = np.flatnonzero(needed)
    near = (ids[:, None] + np.arange(-NEIGHBOUR_CLASSES, NEIGHBOUR_CLASSES + 1)).ravel()
    TABLES.build(near[(near >= 0) & (near < N_CLASSES)])


# ------------------------------------------------------------------ public


def run_chain(lam: np.ndarray | SeparableMeans, shot: Optional[Literal["poisson", "gaussian"]], keys: ChainKeys,
              full_well_e: Optional[float] = None, read_sigma_e: Optional[float] = None,
              adc: Optional[Adc] = None, lut: Optional[np.ndarray] = None) -> np.ndarray:
    """Shot noise and the chain after it, on a frame of electrons.

    Parameters
    ----------
    lam : ndarray of float, shape (H, W), or SeparableMeans
        Mean electrons per pixel (finite and non-negative) when ``shot`` is
        given; else the electrons as they are (float32 values). Given as
        parts (:mod:`rollsim.sensor.means`), the compiled chain writes each
        block's means itself, the same values; the numpy twin writes the
        frame first.
    shot : {"poisson", "gaussian"} or None
        Shot noise, or None for a chain that starts later.
    keys : ChainKeys
        Counter keys of the shot noise and the read noise, where present.
    full_well_e : float, optional
        Clip to [0, full well] (electrons).
    read_sigma_e : float, optional
        Read noise σ in electrons.
    adc : Adc, optional
        Convert to DN (:func:`rollsim.sensor.adc.electrons_to_dn`); without
        it the result is float32 electrons.
    lut : ndarray, optional
        The output value of every DN (``adc`` needed).

    Returns
    -------
    ndarray, shape of ``lam``: float32 electrons, uint16 DN, or ``lut`` values

    Raises
    ------
    ValueError
        A mean that is NaN, infinite or negative, or inconsistent arguments.
    """
    if shot is not None and shot not in SHOT_METHODS:
        raise ValueError(f"shot must be one of {list(SHOT_METHODS)} or None, got {shot!r}")
    if shot is not None and keys.shot is None:
        raise ValueError("shot noise needs its key")
    if lut is not None and adc is None:
        raise ValueError("an output table needs the ADC")
    if read_sigma_e is not None and (keys.read is None or not read_sigma_e >= 0):
        raise ValueError("read noise needs its key and a non-negative sigma")
    compiled = _chain_kernel.compiled
    if isinstance(lam, SeparableMeans):
        shape = lam.shape
        if compiled is not None and shape[0] * shape[1] > 0:
            return _chain_compiled(compiled, lam, shot, keys, full_well_e, read_sigma_e, adc, lut).reshape(shape)
        lam = materialize(lam)
    # Shot noise reads a mean's float64 bits; a chain that starts later takes
    # float32 electrons as they are (widening them cost a pass over the frame).
    wide = shot is not None or np.asarray(lam).dtype != np.float32
    flat = np.ascontiguousarray(lam, dtype=np.float64 if wide else np.float32).ravel()
    if compiled is None or flat.size == 0:
        if shot is not None and flat.size and not (np.isfinite(flat).all() and flat.min() >= 0.0):
            raise ValueError(_BAD_MEANS)
        out = _chain_numpy(flat, shot, keys, full_well_e, read_sigma_e, adc, lut)
    else:
        out = _chain_compiled(compiled, flat, shot, keys, full_well_e, read_sigma_e, adc, lut)
    return out.reshape(np.shape(lam))


@kernel
def _noiseless_kernel(electrons, full_well, adc, lut, dn_out, out):  # pragma: no cover - compiled
    # The full-well clip (in place), the ADC and the output table of
    # noiseless float64 electrons, each pixel in one pass: the clip's and
    # electrons_to_dn's float64 operations in their order (multiply, add,
    # clip, truncate).
    for i in range(electrons.size):
        e = electrons[i]
        if full_well is not None:
            e = min(max(e, 0.0), full_well)
            electrons[i] = e
        dn = e * adc[0]
        dn += adc[1]
        level = np.uint16(min(max(dn, 0.0), adc[2]))
        dn_out[i] = level
        if lut is not None:
            out[i] = lut[level]
    return 0


class NoiselessChain(NamedTuple):
    """What the stages of a noiseless chain leave: the clipped electrons, the DN and the output (or None)."""

    electrons: np.ndarray
    dn: np.ndarray
    image: Optional[np.ndarray]


def run_noiseless_chain(electrons: np.ndarray, full_well_e: Optional[float], adc: Adc,
                        lut: Optional[np.ndarray] = None) -> Optional[NoiselessChain]:
    """The chain after the noise on noiseless float64 electrons, compiled; None where the kernels are not used.

    The full-well clip (if given), the ADC and the output table (if given)
    in one pass, with the float64 arithmetic of the stages one by one
    (:func:`rollsim.sensor.adc.electrons_to_dn`): the same electrons, DN
    and output, byte for byte (tested). A render without noise otherwise
    makes a numpy pass per step over the frame.

    Parameters
    ----------
    electrons : ndarray of float64, shape (H, W)
        Mean electrons (finite). Clipped in place when C-contiguous float64,
        as the full-well stage does.
    full_well_e : float, optional
    adc : Adc
    lut : ndarray, optional
        The output value of every DN.

    Returns
    -------
    NoiselessChain or None
        The clipped electrons (float64), the DN (uint16) and the table's
        output (None without ``lut``), each of the shape of ``electrons``.
    """
    compiled = _noiseless_kernel.compiled
    if compiled is None:
        return None
    shape = np.shape(electrons)
    flat = np.ascontiguousarray(electrons, dtype=np.float64).reshape(-1)
    dn = np.empty(flat.size, dtype=np.uint16)
    out = None if lut is None else np.empty(flat.size, dtype=lut.dtype)
    constants = (np.float64(adc.gain_dn_per_e), np.float64(adc.black_level_dn + 0.5), np.float64(2**adc.bits - 0.5))
    # Without a table the kernel writes no output beyond the DN: the DN array stands in for it.
    compiled(flat, None if full_well_e is None else np.float64(full_well_e), constants,
             None if lut is None else np.ascontiguousarray(lut), dn, dn if out is None else out)
    return NoiselessChain(flat.reshape(shape), dn.reshape(shape), None if out is None else out.reshape(shape))


def shot_poisson(key: np.uint64, lam: np.ndarray) -> np.ndarray:
    """Poisson deviates of means ``lam`` from counter stream ``key``, float32 (see :mod:`rollsim.sensor.poisson`)."""
    return run_chain(lam, "poisson", ChainKeys(shot=key))


__all__ = ["Adc", "CHAIN_ORDER", "ChainKeys", "ChainStep", "SHOT_METHODS", "run_chain", "run_noiseless_chain", "shot_poisson"]
