"""Veiling glare: the long tails of a camera lens's point-spread function.

A lens does not put all the light of a source into its image. A fraction η
is scattered (by surface roughness and dust, at the cover glass, in the
coatings, off the barrel and the sensor) into a halo that reaches far across
the sensor; ISO 18844 measures it as flare. Measured glare spread functions
fall off as a power of the angle from the source, with a flat core; rollsim
uses the Moffat profile of field angle θ,

    G(θ) = η (β − 1) / (π θ₀²) · (1 + θ²/θ₀²)^−β,      ∫ G dΩ = η,

with the unscattered 1 − η left to the lens's own PSF. θ₀ sets the halo's
core and β its wings (∝ θ^−2β). In the sensor plane θ ↦ r = f·tan θ ≈ f·θ,
so the kernel is fixed in pixels whatever the source's distance: a nearer LED
lights a wider region above any level because its image carries more light
(∝ 1/d², through the lens's solid angle) over a larger area (∝ 1/d).

Only the LED's light is convolved. Ambient light reaches the sensor from a
uniform background, which a kernel of unit mass leaves uniform; the halo of
an LED, thousands of times brighter than its surroundings, is what the
camera shows.

Exactness. The halo is computed by one linear (zero-padded) FFT convolution
of the LED's light with the kernel over every offset the frame needs, in
float32 (the halo's relative error is ~1e-7); the unscattered part is added
apart, at full precision, so the LED's sharp image is untouched. The
kernel's mass within its radius R is 1 − η (1 + R²/r₀²)^(1−β): the light
scattered further out is lost past the frame's edge, as on a sensor.
The kernel spans every offset between a lit pixel and the frame: at 1080p
about 2161 × 3841 pixels, convolved once per scene in about 0.1 s.

The frames carry these float32 bits: a convolution that is as exact but
rounds differently (another FFT library, a shorter circular convolution,
numpy's fused complex product) moves a few pixels of a glare scene's frames
by one level. The transforms are therefore SciPy's pocketfft, as scipy.fft
runs them, loaded without scipy.fft's 0.3 s of imports, and the spectra's
product and the kernel's powers are computed alike on every CPU
(:func:`fft_convolve_full`, :mod:`rollsim.portable_math`).
"""

from __future__ import annotations

import functools
import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from rollsim.optics.footprint import Footprint
from rollsim.portable_math import power
from rollsim.validation import as_positive


def glare_core_px(core_angle_deg: float, focal_length_m: float, pixel_pitch_m: float) -> float:
    """The halo's core radius r₀ in pixels: f·tan θ₀ over the pixel pitch (θ₀ in (0, 90) degrees, f and pitch in m)."""
    angle = as_positive(core_angle_deg, "core_angle_deg")
    if not angle < 90.0:
        raise ValueError(f"core_angle_deg must be below 90, got {core_angle_deg!r}")
    as_positive(focal_length_m, "focal_length_m")
    as_positive(pixel_pitch_m, "pixel_pitch_m")
    return focal_length_m * math.tan(math.radians(core_angle_deg)) / pixel_pitch_m


def moffat_mass_beyond(radius_px: float, core_px: float, exponent: float) -> float:
    """Fraction of a unit-mass Moffat halo beyond ``radius_px``: (1 + R²/r₀²)^(1−β).

    ``radius_px`` >= 0, ``core_px`` > 0, ``exponent`` β > 1 (a finite mass).
    """
    as_positive(radius_px, "radius_px", allow_zero=True)
    as_positive(core_px, "core_px")
    if not as_positive(exponent, "exponent") > 1.0:
        raise ValueError(f"exponent must be > 1 (a halo of finite mass), got {exponent!r}")
    return (1.0 + (radius_px / core_px) ** 2) ** (1.0 - exponent)


# Rows of the kernel's quadrant whose power is taken at once.
_POWER_BLOCK_ROWS = 256


def _inside(radius: int, ry: int, rx: int) -> np.ndarray:
    """Offsets (±ry, ±rx) within the disk of ``radius``, by exact integers: a boolean array."""
    # The disk in exact integers: row dy holds |dx| <= isqrt(R^2 - dy^2).
    room = radius**2 - np.arange(-ry, ry + 1, dtype=np.int64) ** 2
    half_widths = np.floor(np.sqrt(np.maximum(room, 0))).astype(np.int64)
    half_widths -= half_widths**2 > room  # the float root may round across an integer
    half_widths += (half_widths + 1) ** 2 <= room
    half_widths[room < 0] = -1
    return np.abs(np.arange(-rx, rx + 1))[None, :] <= half_widths[:, None]


def moffat_kernel(core_px: float, exponent: float, radius_rows: int, radius_cols: int) -> np.ndarray:
    """The scattered part of the glare kernel, on pixel offsets (±rows, ±cols).

    Sampled at pixel offsets, and scaled so that its samples within the
    inscribed disk (radius R = min(rows, cols)) sum to the analytic mass of
    a unit Moffat halo within R; the samples beyond (the rectangle's
    corners) carry the same scale.

    Parameters
    ----------
    core_px : float
        r₀, the core radius in pixels, > 0.
    exponent : float
        β, > 1 (the wings fall as r^−2β).
    radius_rows, radius_cols : int
        Half-sizes of the kernel; the array is (2·rows + 1) × (2·cols + 1).

    Returns
    -------
    ndarray of float32
    """
    if not core_px > 0:
        raise ValueError(f"core_px must be > 0, got {core_px}")
    if not exponent > 1:
        raise ValueError(f"exponent must be > 1, got {exponent}")
    ry, rx = int(radius_rows), int(radius_cols)
    # float32 where it spans ~4 frames of pixels: the halo is convolved in
    # float32 anyway. The profile depends on |dy| and |dx| alone (the same
    # float32 operations on −d as on d), so its powers, the costly part, are
    # taken on one quadrant and mirrored: the same values. The power is the
    # portable one (numpy's float32 power differs in the last bit between
    # CPUs), in float64 rounded once to float32.
    dy = np.arange(ry + 1, dtype=np.float32)[:, None] / np.float32(core_px)
    dx = np.arange(rx + 1, dtype=np.float32)[None, :] / np.float32(core_px)
    quadrant = dy**2 + dx**2  # (r / r0)^2, then the profile in place
    quadrant += np.float32(1.0)
    for first in range(0, quadrant.shape[0], _POWER_BLOCK_ROWS):  # float64 temporaries a block at a time
        block = quadrant[first:first + _POWER_BLOCK_ROWS]
        block[...] = power(block, -exponent)
    rows, cols = np.abs(np.arange(-ry, ry + 1)), np.abs(np.arange(-rx, rx + 1))
    kernel = np.take(np.take(quadrant, rows, axis=0), cols, axis=1)
    inscribed = min(ry, rx)
    # The scale from the whole kernel's disk, summed in its own order: the
    # kernel's bits do not depend on how its samples were computed.
    scale = (1.0 - moffat_mass_beyond(inscribed, core_px, exponent)) / kernel[_inside(inscribed, ry, rx)].sum(
        dtype=np.float64)
    kernel *= np.float32(scale)
    return kernel


@functools.lru_cache(maxsize=1)
def _pocketfft() -> Any:
    """SciPy's pocketfft extension module (scipy.fft's compiled transforms), or None.

    Importing scipy.fft imports SciPy's array-API layer, and with it
    numpy.testing and numpy.f2py: about 0.3 s of every glare scene's
    start-up, for three transforms that take less. The extension behind
    scipy.fft (``scipy/fft/_pocketfft/pypocketfft``) needs none of that: it
    is loaded from its file under its own name, as the import system would
    load it (a later ``import scipy.fft`` finds that same module). None where
    SciPy keeps it elsewhere: scipy.fft is then imported (the same numbers).
    """
    import importlib.machinery
    import importlib.util

    name = "scipy.fft._pocketfft.pypocketfft"
    if name in sys.modules:
        return sys.modules[name]
    scipy_spec = importlib.util.find_spec("scipy")  # finds the package without importing it
    if scipy_spec is None or not scipy_spec.submodule_search_locations:
        return None
    folder = Path(next(iter(scipy_spec.submodule_search_locations))) / "fft" / "_pocketfft"
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = folder / f"pypocketfft{suffix}"
        if path.is_file():
            loader = importlib.machinery.ExtensionFileLoader(name, str(path))
            spec = importlib.util.spec_from_file_location(name, str(path), loader=loader)
            if spec is None:
                return None
            module = importlib.util.module_from_spec(spec)
            loader.exec_module(module)
            wanted = ("r2c", "c2r", "good_size")
            return module if all(hasattr(module, attribute) for attribute in wanted) else None
    return None


def _zero_padded(x: np.ndarray, shape: list[int], axes: list[int]) -> np.ndarray:
    """``x`` in a zero array of ``shape`` along ``axes`` (no shorter), as scipy.fft pads its input."""
    out_shape = list(x.shape)
    for n, axis in zip(shape, axes, strict=True):
        out_shape[axis] = n
    out = np.zeros(out_shape, x.dtype)
    out[tuple(slice(0, n) for n in x.shape)] = x
    return out


def spectrum_product(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The product of two complex spectra (broadcast), (ac − bd) + i(ad + bc).

    Each product and sum rounded on its own: numpy's complex product fuses
    them into multiply-adds on CPUs that have them, which rounds
    differently, and moved a few pixels of a glare scene by a level between
    machines.
    """
    real = x.real * y.real
    real -= x.imag * y.imag
    imag = x.real * y.imag
    imag += x.imag * y.real
    out = np.empty(real.shape, dtype=np.result_type(x, y))
    out.real, out.imag = real, imag
    return out


def fft_convolve_full(a: np.ndarray, b: np.ndarray, workers: int = 1) -> np.ndarray:
    """The full linear convolution of two real arrays of equal dimension, by FFT.

    ``scipy.signal.fftconvolve(a, b, mode="full")`` with SciPy's transforms
    and sizes, the spectra multiplied by :func:`spectrum_product` so that
    the bits are the same on every CPU (tests/render/test_emitter_light.py
    compares them): scipy.signal takes about a second to import (it imports
    scipy.stats), longer than a frame's render, and scipy.fft 0.3 s. The
    transforms are scipy.fft's ``rfftn`` and ``irfftn`` as they reach
    pocketfft for float32 arrays (norm "backward": 1/n on the inverse,
    inorm 2), called on the extension itself (:func:`_pocketfft`).

    Parameters
    ----------
    a, b : ndarray of float32 (or float64)
        Same number of dimensions.
    workers : int, default 1
        Threads of the transforms. pocketfft shares whole one-dimensional
        transforms out among them: the same bits for any number.

    Returns
    -------
    ndarray, shape ``a.shape + b.shape − 1``
    """
    shape = [n1 + n2 - 1 for n1, n2 in zip(a.shape, b.shape, strict=True)]
    # Axes of length 1 broadcast in the product, as in SciPy: no transform.
    axes = [axis for axis in range(a.ndim) if a.shape[axis] != 1 and b.shape[axis] != 1]
    if not axes:
        return a * b
    cut = tuple(slice(n) for n in shape)
    pocketfft = _pocketfft()
    if pocketfft is None:
        from scipy import fft  # another SciPy layout: the public functions, the same numbers

        fast_shape = [fft.next_fast_len(shape[axis], True) for axis in axes]
        spectrum = spectrum_product(fft.rfftn(a, fast_shape, axes=axes, workers=workers),
                                    fft.rfftn(b, fast_shape, axes=axes, workers=workers))
        return fft.irfftn(spectrum, fast_shape, axes=axes, workers=workers)[cut]
    fast_shape = [pocketfft.good_size(shape[axis], True) for axis in axes]  # scipy.fft.next_fast_len
    spectrum = spectrum_product(pocketfft.r2c(_zero_padded(a, fast_shape, axes), axes, True, 0, None, workers),
                                pocketfft.r2c(_zero_padded(b, fast_shape, axes), axes, True, 0, None, workers))
    return pocketfft.c2r(spectrum, axes, fast_shape[-1], False, 2, None, workers)[cut]


def glared_light(light: Footprint, frame_shape: tuple[int, int], fraction: float, core_px: float,
                 exponent: float) -> Footprint:
    """The LED's light on the sensor with veiling glare: (1 − η)·L + η·(L ⊗ M).

    Parameters
    ----------
    light : Footprint
        The LED's light before glare (coverage, or coverage weighted by a
        radiance profile), on its bounding box within the frame.
    frame_shape : (int, int)
        ``(H, W)``.
    fraction : float
        η, the fraction of the light scattered into the halo, in [0, 1].
    core_px, exponent : float
        r₀ and β of :func:`moffat_kernel`.

    Returns
    -------
    Footprint
        The light over the whole frame (the halo reaches every pixel).
    """
    height, width = frame_shape
    out = np.zeros(frame_shape)
    if light.coverage.size == 0:
        return Footprint(slice(0, height), slice(0, width), out)
    out[light.rows, light.cols] = (1.0 - fraction) * light.coverage
    if fraction > 0:
        # The kernel reaches from any lit pixel to every pixel of the frame.
        ry = max(light.rows.stop, height - light.rows.start)
        rx = max(light.cols.stop, width - light.cols.start)
        kernel = moffat_kernel(core_px, exponent, ry, rx)
        # Two threads at most: the one convolution of the scene's setup, on
        # a machine whose cores may all be rendering (the bits do not change).
        halo = fft_convolve_full(light.coverage.astype(np.float32), kernel, workers=min(2, os.cpu_count() or 1))
        # halo[i, j] lies at frame row light.rows.start - ry + i, column light.cols.start - rx + j.
        top, left = ry - light.rows.start, rx - light.cols.start
        # η·halo in float64 (the float32 halo widened first), one frame-sized temporary.
        out += np.multiply(halo[top : top + height, left : left + width], fraction, dtype=np.float64)
    np.maximum(out, 0.0, out=out)  # FFT round-off can dip a hair below 0 where the halo is faint
    return Footprint(slice(0, height), slice(0, width), out)
