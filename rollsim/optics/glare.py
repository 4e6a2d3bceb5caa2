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

Exactness. The halo is one FFT convolution of the LED's light with the
kernel over every offset the frame needs, in float32 (the halo's relative
error is ~1e-7; tested against the linear convolution in float64); the
unscattered part is added apart, at full precision, so the LED's sharp
image is untouched. The kernel's mass within its radius R is
1 − η (1 + R²/r₀²)^(1−β): the light scattered further out is lost past the
frame's edge, as on a sensor. The kernel spans every offset between a lit
pixel and the frame: at 1080p about 1391 × 2231 pixels for paper-default's
LED, convolved once per scene in about 0.06 s.

The frames carry these float32 bits: a convolution that is as exact but
rounds differently (another FFT library, another transform size) moves a
few pixels of a glare scene's frames by one level. The transforms are
therefore SciPy's pocketfft, as scipy.fft runs them, loaded without
scipy.fft's 0.3 s of imports; the kernel's powers are portable
(:mod:`rollsim.numerics.portable_math`), and the kernel, even in both axes, is laid
out around the origin of a circular convolution, so that its transform is
real and the light's spectrum is scaled component by component: one
rounded product each, the same on every CPU, where a complex product's
fused multiply-adds were not (:func:`halo_convolution`).
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
from rollsim.numerics.portable_math import power
from rollsim.plumbing.validation import as_positive


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


def _quadrant_inside(radius: int, ry: int, rx: int) -> np.ndarray:
    """Offsets (0…ry, 0…rx) within the disk of ``radius``, by exact integers: a boolean array."""
    # The disk in exact integers: row dy holds dx <= isqrt(R^2 - dy^2).
    room = radius**2 - np.arange(ry + 1, dtype=np.int64) ** 2
    half_widths = np.floor(np.sqrt(np.maximum(room, 0))).astype(np.int64)
    half_widths -= half_widths**2 > room  # the float root may round across an integer
    half_widths += (half_widths + 1) ** 2 <= room
    half_widths[room < 0] = -1
    return np.arange(rx + 1)[None, :] <= half_widths[:, None]


# The last quadrant is kept: a scene's set-up and its prediction of the readable
# rows (rollsim.channel.scene_channel), or the settings of a sweep that share
# the camera and the LED's place, ask for the same one (about 50 ms at 1080p).
@functools.lru_cache(maxsize=1)
def moffat_quadrant(core_px: float, exponent: float, radius_rows: int, radius_cols: int) -> np.ndarray:
    """The scattered part of the glare kernel on offsets (0…rows, 0…cols): a quarter of :func:`moffat_kernel`.

    The kernel depends on |dy| and |dx| alone; its other three quarters
    mirror this one. Scaled so that the whole kernel's samples within the
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
        Half-sizes of the whole kernel.

    Returns
    -------
    ndarray of float32, shape (rows + 1, cols + 1)
        Read-only: the last one asked for is kept and handed out again.
    """
    if not core_px > 0:
        raise ValueError(f"core_px must be > 0, got {core_px}")
    if not exponent > 1:
        raise ValueError(f"exponent must be > 1, got {exponent}")
    ry, rx = int(radius_rows), int(radius_cols)
    # float32 where it spans a frame of pixels: the halo is convolved in
    # float32 anyway. The power is the portable one (numpy's float32 power
    # differs in the last bit between CPUs), in float64 rounded once to float32.
    dy = np.arange(ry + 1, dtype=np.float32)[:, None] / np.float32(core_px)
    dx = np.arange(rx + 1, dtype=np.float32)[None, :] / np.float32(core_px)
    quadrant = dy**2 + dx**2  # (r / r0)^2, then the profile in place
    quadrant += np.float32(1.0)
    for first in range(0, quadrant.shape[0], _POWER_BLOCK_ROWS):  # float64 temporaries a block at a time
        block = quadrant[first:first + _POWER_BLOCK_ROWS]
        block[...] = power(block, -exponent)
    # The whole disk's sum from its quarter: the centre once, the axes twice,
    # the rest four times.
    inside = np.where(_quadrant_inside(min(ry, rx), ry, rx), quadrant, np.float32(0.0))
    disk = (4.0 * inside[1:, 1:].sum(dtype=np.float64) + 2.0 * inside[1:, 0].sum(dtype=np.float64)
            + 2.0 * inside[0, 1:].sum(dtype=np.float64) + float(inside[0, 0]))
    quadrant *= np.float32((1.0 - moffat_mass_beyond(min(ry, rx), core_px, exponent)) / disk)
    quadrant.flags.writeable = False  # kept and shared (above)
    return quadrant


def moffat_kernel(core_px: float, exponent: float, radius_rows: int, radius_cols: int) -> np.ndarray:
    """The scattered part of the glare kernel on pixel offsets (±rows, ±cols), centred.

    :func:`moffat_quadrant` mirrored into the whole kernel.

    Returns
    -------
    ndarray of float32, shape (2·rows + 1, 2·cols + 1)
    """
    quadrant = moffat_quadrant(core_px, exponent, radius_rows, radius_cols)
    rows, cols = np.abs(np.arange(-int(radius_rows), int(radius_rows) + 1)), np.abs(
        np.arange(-int(radius_cols), int(radius_cols) + 1))
    return np.take(np.take(quadrant, rows, axis=0), cols, axis=1)


def _wrapped_kernel(quadrant: np.ndarray, shape: tuple[int, int], out: np.ndarray | None = None,
                    reach: tuple[int, int] | None = None) -> np.ndarray:
    """The kernel laid out for a circular convolution of ``shape``: offset (dy, dx) at (dy mod H, dx mod W).

    Offsets up to ``reach`` (rows, columns; at most the quadrant's radii, the
    default) in size on either side: the layout stays even, so its transform
    is real. Written into ``out`` (float32, ``shape``) where given, else a
    new array.
    """
    ry, rx = (quadrant.shape[0] - 1, quadrant.shape[1] - 1) if reach is None else reach
    quadrant = quadrant[: ry + 1, : rx + 1]
    if out is None:
        out = np.zeros(shape, dtype=np.float32)
    else:
        out[...] = 0.0
    out[: ry + 1, : rx + 1] = quadrant
    out[: ry + 1, shape[1] - rx:] = quadrant[:, rx:0:-1]
    out[shape[0] - ry:, : rx + 1] = quadrant[ry:0:-1, :]
    out[shape[0] - ry:, shape[1] - rx:] = quadrant[ry:0:-1, rx:0:-1]
    return out


def _transform_reach(window: tuple[int, int], extent: int, radius: int) -> tuple[int, int]:
    """The kernel's reach and the transform's least size along one axis, for output offsets ``window``.

    The outputs at offsets lo … hi from the light's first pixel take the
    kernel at offsets lo − (extent − 1) … hi: the layout holds them (evenly,
    up to the kernel's radius, beyond which the kernel is 0), and the
    transform holds them and the outputs without wrapping one onto
    another, nor an offset beyond the radius onto the layout's entries.
    """
    lo, hi = window
    if hi < lo:
        raise ValueError(f"an empty window of offsets {window}")
    reach = min(radius, max(extent - 1 - lo, hi, 0))
    return reach, max(2 * reach + 1, hi - lo + 1, hi + reach + 1, reach + extent - lo)


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


def _zero_padded(x: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``x`` at the corner of a zero array of ``shape`` (no smaller)."""
    out = np.zeros(shape, x.dtype)
    out[: x.shape[0], : x.shape[1]] = x
    return out


def _scale_by_real(spectrum: np.ndarray, kernel_real: np.ndarray) -> None:
    """``spectrum`` (complex64) times the kernel's real transform, in place: its real and imaginary parts side by
    side, each times ``kernel_real`` (one rounded product per component, the same bits on every CPU)."""
    spectrum.view(np.float32).reshape(*spectrum.shape, 2)[...] *= kernel_real[..., None]


def halo_convolution(light: np.ndarray, quadrant: np.ndarray, workers: int = 1,
                     window: tuple[tuple[int, int], tuple[int, int]] | None = None) -> np.ndarray:
    """The light convolved with the whole kernel of ``quadrant``, circularly.

    Entry (i mod H, j mod W) is the linear convolution's value at offset
    (i, j) from the light's first pixel, for the offsets of ``window``
    (rows, columns; each the first and last offset). By default that is
    every offset the kernel reaches (negative ones down to minus its
    radius), and the transform size (H, W) is the fast one at or above the
    light's extent plus twice the kernel's radius. A window, such as the
    frame's pixels, needs a smaller transform: the kernel's offsets that
    the window's outputs take, laid out evenly, and the window's outputs.

    The kernel is even in both axes and laid out around the origin, so its
    transform is real: the light's spectrum is scaled by that real part,
    one rounded product per component. A complex product's fused
    multiply-adds (numpy's, on CPUs that have them) would round differently
    from one CPU to another; these products give the same bits on every
    CPU. The transforms are scipy.fft's pocketfft (norm "backward").

    Parameters
    ----------
    light : ndarray of float32, shape (R, C)
    quadrant : ndarray of float32, shape (ry + 1, rx + 1)
        A quarter of the kernel (:func:`moffat_quadrant`).
    workers : int
        Threads of the transforms: the same bits for any number.

    Returns
    -------
    ndarray of float32, shape (H, W)
    """
    ry, rx = quadrant.shape[0] - 1, quadrant.shape[1] - 1
    if window is None:
        window = ((-ry, ry + light.shape[0] - 1), (-rx, rx + light.shape[1] - 1))
    (reach_y, wanted_y), (reach_x, wanted_x) = (_transform_reach(w, extent, radius) for w, extent, radius in
                                                zip(window, light.shape, (ry, rx)))
    wanted, reach = (wanted_y, wanted_x), (reach_y, reach_x)
    pocketfft = _pocketfft()
    if pocketfft is None:  # another SciPy layout: the public functions, the same numbers
        from scipy import fft

        shape = (fft.next_fast_len(wanted[0], True), fft.next_fast_len(wanted[1], True))
        spectrum = fft.rfft2(_zero_padded(light, shape), workers=workers)
        _scale_by_real(spectrum, fft.rfft2(_wrapped_kernel(quadrant, shape, reach=reach), workers=workers).real)
        return fft.irfft2(spectrum, shape, workers=workers)
    # The same transforms, with one real buffer of the transforms' size for
    # the light, then the kernel, then the result: a set-up pays more for
    # fresh pages than for the transforms' copies.
    shape = (pocketfft.good_size(wanted[0], True), pocketfft.good_size(wanted[1], True))  # scipy's next_fast_len
    plane = _zero_padded(light, shape)
    spectrum = pocketfft.r2c(plane, (0, 1), True, 0, None, workers)
    kernel_spectrum = pocketfft.r2c(_wrapped_kernel(quadrant, shape, out=plane, reach=reach), (0, 1), True, 0, None,
                                    workers)
    _scale_by_real(spectrum, kernel_spectrum.real)
    del kernel_spectrum
    return pocketfft.c2r(spectrum, (0, 1), shape[1], False, 2, plane, workers)


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
        r₀ and β of :func:`moffat_quadrant`.

    Returns
    -------
    Footprint
        The light over the whole frame (the halo reaches every pixel).
    """
    height, width = frame_shape
    out = np.zeros(frame_shape)
    if light.coverage.size == 0:
        return Footprint(slice(0, height), slice(0, width), out)
    if fraction > 0:
        # The kernel reaches from any lit pixel to every pixel of the frame.
        ry = max(light.rows.stop, height - light.rows.start)
        rx = max(light.cols.stop, width - light.cols.start)
        # Two threads at most: the one convolution of the scene's setup, on
        # a machine whose cores may all be rendering (the bits do not change).
        # Only the frame's pixels are read: offsets from minus the light's first
        # row (column) to the frame's last.
        window = ((-light.rows.start, height - 1 - light.rows.start), (-light.cols.start, width - 1 - light.cols.start))
        halo = halo_convolution(light.coverage.astype(np.float32), moffat_quadrant(core_px, exponent, ry, rx),
                                workers=min(2, os.cpu_count() or 1), window=window)
        _scaled_window(halo, light.rows.start, light.cols.start, fraction, out)
    # (1 − η)·L + η·halo: the sum in either order is the same number.
    out[light.rows, light.cols] += (1.0 - fraction) * light.coverage
    np.maximum(out, 0.0, out=out)  # FFT round-off can dip a hair below 0 where the halo is faint
    return Footprint(slice(0, height), slice(0, width), out)


def _scaled_window(halo: np.ndarray, first_row: int, first_col: int, fraction: float, out: np.ndarray) -> None:
    """``out`` = η·(the circular ``halo`` at offsets (y − first_row, x − first_col)), float32 widened to float64.

    Frame rows above the light lie at negative offsets, which wrap to the
    halo's last rows (and so for columns): four blocks, copied straight.
    """
    height, width = out.shape
    n_rows, n_cols = halo.shape
    for frame_rows, halo_rows in ((slice(0, first_row), slice(n_rows - first_row, n_rows)),
                                  (slice(first_row, height), slice(0, height - first_row))):
        for frame_cols, halo_cols in ((slice(0, first_col), slice(n_cols - first_col, n_cols)),
                                      (slice(first_col, width), slice(0, width - first_col))):
            np.multiply(halo[halo_rows, halo_cols], fraction, out=out[frame_rows, frame_cols], dtype=np.float64)
