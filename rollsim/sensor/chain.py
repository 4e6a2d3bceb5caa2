"""The sensor chain from shot noise to the output image, in one pass per frame.

After the mean electrons of a frame are known, the EMVA 1288 chain is
pixel by pixel: shot noise, the full-well clip, read noise, the ADC and the
output table (black clip, tone curve, 8 bits). numpy needs a pass over the
whole frame for each step of each stage (a hash, a lookup, a multiply, a
clip, a cast); one compiled loop does them all while the pixel is in a
register. :func:`run_chain` runs any contiguous part of the chain that starts
with shot noise, or with read noise on electrons already noisy:

* ``shot``: ``"poisson"`` (:mod:`rollsim.sensor.poisson`), ``"gaussian"``
  (N(λ, λ), λ + √λ·z in float32) or None;
* ``full_well_e``: the clip to [0, full well], or None;
* ``read_sigma_e``: Gaussian read noise (the word table of
  :func:`rollsim.gaussian.normal_from_word`), or None;
* ``adc``: conversion gain, black level and bits, or None to stop at
  electrons (float32);
* ``lut``: the output table of each DN (gray8), or None for raw DN (uint16).

Each stage's random words come from its own counter stream (its key), so
the chain's result is the same whether it runs in one pass or stage by
stage. The compiled kernel (:mod:`rollsim.jit`) and the numpy twin compute
the same IEEE-754 operations in the same order, float32 where the staged
effects work in float32, and give identical bytes (tested).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, Optional

import numpy as np

from rollsim.counter_rng import GAMMA, LOW32, MIX1, MIX2, WORD_SCALE, words
from rollsim.gaussian import normal_from_words, normal_tables
from rollsim.jit import kernel
from rollsim.sensor.adc import electrons_to_dn
from rollsim.sensor.poisson import (
    BIN_SHIFT,
    CLASS_BITS,
    CLASS_MASK,
    CLASS_MEANS,
    EXP_NEG_COEFFICIENTS,
    EXPONENT_BIAS,
    EXPONENT_SHIFT,
    GAUSSIAN_ABOVE_E,
    K_MASK,
    MANTISSA_SHIFT,
    MAX_SMALL_K,
    N_CLASSES,
    STRADDLE,
    TABLE_BINS,
    TABLES,
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
    """

    kind: str
    value: Any = None
    stream: Optional[str] = None

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


def pixel_normals(key: np.uint64, n: int) -> np.ndarray:
    """One standard normal (float32) per pixel: from the high half of the word of counter 2i."""
    return normal_from_words(words(key, np.arange(n, dtype=np.uint64) * np.uint64(2)) >> np.uint64(32),
                             *normal_tables())


def shot_numpy(lam: np.ndarray, key: np.uint64, method: str) -> np.ndarray:
    """Shot noise of flat means ``lam`` (float64), as float32 electrons."""
    if method == "poisson":
        return poisson_numpy(lam, key)
    mean = lam.astype(np.float32)
    noise = pixel_normals(key, lam.size)
    noise *= np.sqrt(mean)
    noise += mean
    return noise


def read_noise_numpy(electrons: np.ndarray, key: np.uint64, sigma_e: float) -> np.ndarray:
    """``electrons`` (float32) plus Gaussian read noise of σ ``sigma_e`` from counter stream ``key``."""
    noise = pixel_normals(key, electrons.size)
    noise *= np.float32(sigma_e)
    noise += electrons
    return noise


def _chain_numpy(lam, shot, keys, full_well_e, read_sigma_e, adc, lut):
    electrons = lam.astype(np.float32) if shot is None else shot_numpy(lam, keys.shot, shot)
    if full_well_e is not None:
        np.clip(electrons, 0.0, full_well_e, out=electrons)
    if read_sigma_e is not None:
        electrons = read_noise_numpy(electrons, keys.read, read_sigma_e)
    if adc is None:
        return electrons
    dn = electrons_to_dn(electrons, adc.gain_dn_per_e, adc.black_level_dn, adc.bits)
    return dn if lut is None else lut[dn]


# --------------------------------------------------------------- compiled


# Pixels per block of the compiled chain: its shot-noise results (float32)
# and the pixels left for the exact path stay in L1 between the loops.
BLOCK_PIXELS = 4096
_TWO_32 = 4294967296.0


@kernel
def _chain_kernel(lam, start, shot_key, guide, full_well, read_sigma, read_key, adc, lut, out,
                  cdf, slot, cdf_start, cdf_size, k_lo, class_means, exp_coefficients, z_body, z_low, z_high):
    # One flat body: numba passes array arguments to a called function with
    # reference counting, which cost several times the work itself. A step
    # the chain does not take is passed as None (no shot noise, Gaussian shot
    # noise without the Poisson tables in ``guide``, no clip, no read noise, no
    # ADC, raw DN without ``lut``): numba compiles one version per pattern of
    # Nones with the dead steps pruned, not one loop that tests every flag at
    # every pixel.
    #
    # A block of pixels goes through three loops. (1) Shot noise where it is
    # one table lookup: a mean below 256 (one class), a guide entry without a
    # CDF step inside its bin and a remainder that draws 0 (u < 1 − r); about
    # 95 % of a frame's pixels on paper-geometric and paper-default. (2) Every
    # other pixel by the general method, exactly as the numpy twin does it.
    # (3) Full well, read noise, ADC and output. Kept apart, the short common
    # loop ran about three times faster than one loop carrying the rare
    # branches; the bytes are the same, since each pixel's words depend only
    # on its index.
    bits_of = lam.view(np.uint64)
    electrons_of = np.empty(BLOCK_PIXELS, dtype=np.float32)
    general = np.empty(BLOCK_PIXELS, dtype=np.int64)
    last_mean = -1.0
    one_lookup = False
    row = np.int64(-1)  # guide row of the last mean's class; -1: a mean below 1, no table
    last_ident = np.int64(-1)  # the last class met, with its guide row, mean and lowest count
    class_row = np.int64(0)
    class_mean = 0.0
    class_k_lo = np.int64(0)
    zero_below = np.uint64(0)  # words below this draw 0 from the last mean's remainder
    for first in range(start, lam.size, BLOCK_PIXELS):
        last = min(first + BLOCK_PIXELS, lam.size)
        # -------------------------------------- (1) shot noise, common case
        n_general = 0
        for i in range(first, last):
            mean = lam[i]
            if shot_key is None:
                electrons_of[i - first] = np.float32(mean)
                continue
            if not (mean >= 0.0 and mean < np.inf):
                return -1 - i  # NaN, inf or negative: refused by the caller
            if guide is None or mean >= GAUSSIAN_ABOVE_E:
                # Gaussian shot noise, and Poisson means beyond the tables.
                z = (np.uint64(i) * np.uint64(2) + np.uint64(1)) * GAMMA + shot_key
                z = (z ^ (z >> np.uint64(30))) * MIX1
                z = (z ^ (z >> np.uint64(27))) * MIX2
                word = (z ^ (z >> np.uint64(31))) >> np.uint64(32)
                top = word >> np.uint64(16)
                if top == 0:
                    normal = z_low[word & np.uint64(0xFFFF)]
                elif top == 0xFFFF:
                    normal = z_high[word & np.uint64(0xFFFF)]
                else:
                    normal = z_body[top]
                if guide is not None:
                    electrons_of[i - first] = np.float32(max(0.0, mean + np.sqrt(mean) * np.float64(normal)))
                else:
                    mean32 = np.float32(mean)
                    electrons_of[i - first] = normal * np.sqrt(mean32) + mean32
                continue
            if mean != last_mean:  # runs of equal means (a uniform background) skip this
                last_mean = mean
                one_lookup = mean < 256.0  # from 256 on, the remainder is split again
                rest = mean
                row = -1
                if one_lookup and mean >= 1.0:
                    ident = ((np.int64(bits_of[i] >> EXPONENT_SHIFT) - EXPONENT_BIAS) << CLASS_BITS) | np.int64(
                        (bits_of[i] >> MANTISSA_SHIFT) & CLASS_MASK)
                    if ident != last_ident:  # a smooth gradient (glare, vignetting) keeps its class a while
                        if slot[ident] < 0:
                            return first  # a class without its table: built, then this block again
                        last_ident = ident
                        class_row = slot[ident] * TABLE_BINS
                        class_mean = class_means[ident]
                        class_k_lo = k_lo[ident]
                    row = class_row
                    rest = mean - class_mean
                # u >= 1 - r, as words: u = w·2^-32 is exact, so it is w >= ceil((1 - r)·2^32).
                zero_below = np.uint64(math.ceil((1.0 - rest) * _TWO_32)) if rest > 0.0 else np.uint64(_TWO_32)
            if one_lookup:
                # Pixel i's 32-bit words: the halves of the words of counters 2i and 2i + 1.
                z = (np.uint64(i) * np.uint64(2) + np.uint64(1)) * GAMMA + shot_key
                z = (z ^ (z >> np.uint64(30))) * MIX1
                z = (z ^ (z >> np.uint64(27))) * MIX2
                word64 = z ^ (z >> np.uint64(31))
                if row >= 0:
                    entry = guide[row + np.int64((word64 >> np.uint64(32)) >> BIN_SHIFT)]
                    if entry < STRADDLE and (word64 & LOW32) < zero_below:
                        electrons_of[i - first] = np.float32(class_k_lo + np.int64(entry))
                        continue
                elif (word64 >> np.uint64(32)) < zero_below:  # a mean below 1 drawing 0
                    electrons_of[i - first] = np.float32(0.0)
                    continue
            general[n_general] = i
            n_general += 1
        # -------------------------------------- (2) shot noise, general method
        if guide is not None:
            for j in range(n_general):
                i = general[j]
                mean = lam[i]
                z = (np.uint64(i) * np.uint64(2) + np.uint64(1)) * GAMMA + shot_key
                z = (z ^ (z >> np.uint64(30))) * MIX1
                z = (z ^ (z >> np.uint64(27))) * MIX2
                word64 = z ^ (z >> np.uint64(31))
                word = word64 >> np.uint64(32)
                total = 0
                part = 0
                rest = mean
                while rest >= 1.0:  # once for means below 256, up to three times above
                    if part > 0:  # a remainder: its class by frexp (no bit view of a scalar)
                        fraction, exponent = math.frexp(rest)
                        ident = np.int64(exponent - 1) * (1 << CLASS_BITS) + np.int64(
                            (fraction * 2.0 - 1.0) * (1 << CLASS_BITS))
                    else:
                        ident = ((np.int64(bits_of[i] >> EXPONENT_SHIFT) - EXPONENT_BIAS) << CLASS_BITS) | np.int64(
                            (bits_of[i] >> MANTISSA_SHIFT) & CLASS_MASK)
                    if slot[ident] < 0:
                        return first  # a class without its table: built, then this block again
                    entry = guide[slot[ident] * TABLE_BINS + np.int64(word >> BIN_SHIFT)]
                    k = k_lo[ident] + np.int64(entry & K_MASK)
                    if entry & STRADDLE:
                        u = np.float64(word) * WORD_SCALE
                        base = cdf_start[ident]
                        lo = np.int64(entry & K_MASK)
                        hi = cdf_size[ident] - 1
                        while lo < hi:
                            mid = (lo + hi) // 2
                            if cdf[base + mid] <= u:
                                lo = mid + 1
                            else:
                                hi = mid
                        k = k_lo[ident] + lo
                    total += k
                    rest -= class_means[ident]
                    part += 1
                    if part == 2:
                        z = (np.uint64(i) * np.uint64(2) + np.uint64(2)) * GAMMA + shot_key
                        z = (z ^ (z >> np.uint64(30))) * MIX1
                        z = (z ^ (z >> np.uint64(27))) * MIX2
                        word64 = z ^ (z >> np.uint64(31))
                        word = word64 >> np.uint64(32)
                    else:
                        word = word64 & LOW32
                if rest > 0.0 and word >= np.uint64(math.ceil((1.0 - rest) * _TWO_32)):
                    # Sequential inversion of the remainder's Poisson CDF.
                    u = np.float64(word) * WORD_SCALE
                    p = exp_coefficients[0]
                    for c in range(1, exp_coefficients.size):
                        p = p * rest + exp_coefficients[c]
                    running = p
                    for step in range(1, MAX_SMALL_K + 1):
                        if u < running:
                            break
                        total += 1
                        p = p * rest / np.float64(step)
                        running = running + p
                electrons_of[i - first] = np.float32(total)
        # -------------------------------------- (3) full well, read noise, ADC, output
        for i in range(first, last):
            electrons = electrons_of[i - first]
            if full_well is not None:
                electrons = min(max(electrons, np.float32(0.0)), full_well)
            if read_sigma is not None:
                z = (np.uint64(i) * np.uint64(2) + np.uint64(1)) * GAMMA + read_key
                z = (z ^ (z >> np.uint64(30))) * MIX1
                z = (z ^ (z >> np.uint64(27))) * MIX2
                word = (z ^ (z >> np.uint64(31))) >> np.uint64(32)
                top = word >> np.uint64(16)
                if top == 0:
                    normal = z_low[word & np.uint64(0xFFFF)]
                elif top == 0xFFFF:
                    normal = z_high[word & np.uint64(0xFFFF)]
                else:
                    normal = z_body[top]
                electrons = normal * read_sigma + electrons
            if adc is None:
                out[i] = electrons
            else:
                level = electrons * adc[0] + adc[1]
                level = min(max(level, np.float32(0.0)), adc[2])
                if lut is None:
                    out[i] = np.uint16(level)
                else:
                    out[i] = lut[np.uint16(level)]
    return lam.size


def _chain_compiled(compiled, lam, shot, keys, full_well_e, read_sigma_e, adc, lut):
    n = lam.size
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
            lam, start,
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


def build_classes_from(lam: np.ndarray, start: int) -> None:
    """Build the table of every class that pixels ``start`` on of flat means ``lam`` need (one compiled pass)."""
    needed = np.zeros(N_CLASSES, dtype=np.bool_)
    compiled = _classes_kernel.compiled
    if compiled is None:
        raise RuntimeError("the class-marking pass runs only where the compiled chain does")
    compiled(lam, start, CLASS_MEANS, needed)
    TABLES.build(np.flatnonzero(needed))


# ------------------------------------------------------------------ public


def run_chain(lam: np.ndarray, shot: Optional[Literal["poisson", "gaussian"]], keys: ChainKeys,
              full_well_e: Optional[float] = None, read_sigma_e: Optional[float] = None,
              adc: Optional[Adc] = None, lut: Optional[np.ndarray] = None) -> np.ndarray:
    """Shot noise and the chain after it, on a frame of electrons.

    Parameters
    ----------
    lam : ndarray of float, shape (H, W)
        Mean electrons per pixel (finite and non-negative) when ``shot`` is
        given; else the electrons as they are (float32 values).
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
    flat = np.ascontiguousarray(lam, dtype=np.float64).ravel()
    compiled = _chain_kernel.compiled
    if compiled is None or flat.size == 0:
        if shot is not None and flat.size and not (np.isfinite(flat).all() and flat.min() >= 0.0):
            raise ValueError(_BAD_MEANS)
        out = _chain_numpy(flat, shot, keys, full_well_e, read_sigma_e, adc, lut)
    else:
        out = _chain_compiled(compiled, flat, shot, keys, full_well_e, read_sigma_e, adc, lut)
    return out.reshape(np.shape(lam))


def warm_up() -> None:
    """Compile (or load from the cache) the chain's kernels now, e.g. before worker processes fork and inherit them.

    Builds no table a render would not: the tiny frame's class is the one of
    a mean of 1.
    """
    if _chain_kernel.compiled is None:
        return
    lam = np.full(8, 1.0)
    keys = ChainKeys(np.uint64(0), np.uint64(0))
    run_chain(lam, "poisson", keys, full_well_e=1.0, read_sigma_e=1.0, adc=Adc(1.0, 0, 8), lut=np.zeros(256, np.uint8))
    build_classes_from(lam, 0)


def shot_poisson(key: np.uint64, lam: np.ndarray) -> np.ndarray:
    """Poisson deviates of means ``lam`` from counter stream ``key``, float32 (see :mod:`rollsim.sensor.poisson`)."""
    return run_chain(lam, "poisson", ChainKeys(shot=key))


__all__ = ["Adc", "CHAIN_ORDER", "ChainKeys", "ChainStep", "SHOT_METHODS", "run_chain", "shot_poisson", "warm_up"]
