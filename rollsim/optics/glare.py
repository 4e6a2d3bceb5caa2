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
about 2161 × 3841 pixels, convolved once per scene in well under a second.
"""

from __future__ import annotations

import math

import numpy as np

from rollsim.optics.footprint import Footprint
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
    # float32 throughout: the kernel spans ~4 frames of pixels, and the
    # halo is convolved in float32 anyway.
    dy = np.arange(-ry, ry + 1, dtype=np.float32)[:, None] / np.float32(core_px)
    dx = np.arange(-rx, rx + 1, dtype=np.float32)[None, :] / np.float32(core_px)
    kernel = dy**2 + dx**2  # (r / r0)^2, then the profile in place
    inscribed = min(ry, rx)
    # The disk in exact integers: row dy holds |dx| <= isqrt(R^2 - dy^2).
    room = inscribed**2 - np.arange(-ry, ry + 1, dtype=np.int64) ** 2
    half_widths = np.floor(np.sqrt(np.maximum(room, 0))).astype(np.int64)
    half_widths -= half_widths**2 > room  # the float root may round across an integer
    half_widths += (half_widths + 1) ** 2 <= room
    half_widths[room < 0] = -1
    inside = np.abs(np.arange(-rx, rx + 1))[None, :] <= half_widths[:, None]
    kernel += np.float32(1.0)
    np.power(kernel, np.float32(-exponent), out=kernel)
    scale = (1.0 - moffat_mass_beyond(inscribed, core_px, exponent)) / kernel[inside].sum(dtype=np.float64)
    kernel *= np.float32(scale)
    return kernel


def fft_convolve_full(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The full linear convolution of two real arrays of equal dimension, by FFT.

    ``scipy.signal.fftconvolve(a, b, mode="full")`` through ``scipy.fft``
    alone, with SciPy's transforms, sizes and products, so the same bits
    (tests/render/test_emitter_light.py compares them): scipy.signal takes
    about a second to import (it imports scipy.stats), longer than a
    frame's render.
    """
    from scipy import fft

    shape = [n1 + n2 - 1 for n1, n2 in zip(a.shape, b.shape, strict=True)]
    # Axes of length 1 broadcast in the product, as in SciPy: no transform.
    axes = [axis for axis in range(a.ndim) if a.shape[axis] != 1 and b.shape[axis] != 1]
    if not axes:
        return a * b
    fast_shape = [fft.next_fast_len(shape[axis], True) for axis in axes]
    spectrum = fft.rfftn(a, fast_shape, axes=axes) * fft.rfftn(b, fast_shape, axes=axes)
    return fft.irfftn(spectrum, fast_shape, axes=axes)[tuple(slice(n) for n in shape)]


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
        halo = fft_convolve_full(light.coverage.astype(np.float32), kernel)
        # halo[i, j] lies at frame row light.rows.start - ry + i, column light.cols.start - rx + j.
        top, left = ry - light.rows.start, rx - light.cols.start
        out += fraction * halo[top : top + height, left : left + width].astype(np.float64)
    np.maximum(out, 0.0, out=out)  # FFT round-off can dip a hair below 0 where the halo is faint
    return Footprint(slice(0, height), slice(0, width), out)
