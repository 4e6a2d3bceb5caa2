"""Lens point-spread functions on the LED's coverage map: blur and defocus.

Why the coverage map, and not the rendered image
------------------------------------------------
At any instant the LED's face is uniformly bright, so the image the lens forms
at time t is PSF ⊗ (c·L·s(t) + background), with c the LED's coverage map.
Row y integrates that image over its own exposure window only, so its value is
(PSF ⊗ c)(y, x) · L · ∫ s dt: the PSF spreads the footprint (and the
background it hides) over the sensor, but it does not mix the exposure
windows of neighbouring rows, and the stripes stay sharp. A lens PSF is
therefore a per-scene constant: the coverage map is convolved once, and a
frame costs only its larger bounding box. (Blurring the stripe image instead
is what a post-capture filter such as demosaicing does, not a lens.)

Exact at the frame edges
------------------------
The coverage is computed on a canvas extended beyond the frame by the PSF's
radius and convolved with zero padding (the linear, "full" convolution):
light of an LED partly outside the frame spills in, and light near an edge
spills out and is lost, as on a real sensor. Nothing is reflected or
replicated at the borders.

Kernels
-------
Both kernels are normalised to sum 1, so a footprint's light is conserved
wherever the frame holds all of it.

* Gaussian (``blur``): sampled at pixel centres over ±⌈truncate·σ⌉ px. The
  coverage already integrates each pixel's area, so point samples of the PSF
  are the right discretisation (pixel-integrated samples would blur by one
  pixel's box twice). By Poisson summation the sampled kernel's variance
  is σ² to a relative error of about 8π²σ²·exp(−2π²σ²): 2e-7 at σ = 1 px,
  2e-3 at 0.7 px, but 14% low at 0.5 px, where a sampled Gaussian no longer
  represents the PSF (it tends to a delta as σ → 0).
* Disk (``defocus``): the thin-lens blur circle of diameter D, anti-aliased
  by the exact area of the disk in each pixel
  (:func:`rollsim.optics.footprint.footprint`). For a point source at a pixel
  centre this is the exact pixel image. Its variance per axis is D²/16 (the
  disk's) plus about 1/12 px² (the pixel's box that the area weighting adds).
  A disk that fits inside one pixel (D ≤ 1 px) gives the identity kernel.

Listing both effects convolves both kernels (in either order: convolution
commutes): the combined PSF's variance is the sum of the two.
"""

from __future__ import annotations

import math

import numpy as np

from rollsim.optics.footprint import Footprint, footprint
from rollsim.numerics.portable_math import exp  # numpy's differs in the last bit between CPUs
from rollsim.plumbing.validation import as_positive

KERNEL_METHODS = ("separable", "full")
# The largest blur circle rollsim convolves, in pixels: a larger one would
# need a canvas of several times the frame's area.
MAX_DISK_DIAMETER_PX = 1000.0
# Convolution by FFT leaves round-off of up to about 1e-15 where the coverage
# is exactly 0 or 1; snapping it back keeps fully covered pixels equal (the
# shot-noise sampler is fast on runs of equal means) and empty ones empty.
_SNAP = 1e-14


def gaussian_kernel_1d(sigma_px: float, truncate_sigma: float = 4.0) -> np.ndarray:
    """Sampled, normalised 1-D Gaussian of standard deviation ``sigma_px``.

    Parameters
    ----------
    sigma_px : float
        Standard deviation in pixels (> 0).
    truncate_sigma : float
        Kernel radius in standard deviations; the radius is
        ⌈truncate_sigma · sigma_px⌉ px (at least 1).

    Returns
    -------
    ndarray of float64, shape (2·radius + 1,)
        Sums to 1.
    """
    if not sigma_px > 0:
        raise ValueError(f"sigma_px must be > 0, got {sigma_px}")
    if not truncate_sigma > 0:
        raise ValueError(f"truncate_sigma must be > 0, got {truncate_sigma}")
    radius = max(1, math.ceil(truncate_sigma * sigma_px))
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    # exp underflows to exactly 0 far out (tiny sigma): a delta, no warning.
    with np.errstate(under="ignore"):
        kernel = exp(-0.5 * (x / sigma_px) ** 2)
    return kernel / kernel.sum()


def disk_kernel(diameter_px: float) -> np.ndarray:
    """Disk of diameter ``diameter_px`` centred on a pixel, anti-aliased by area.

    Parameters
    ----------
    diameter_px : float
        Blur-circle diameter in pixels (≥ 0, at most :data:`MAX_DISK_DIAMETER_PX`).

    Returns
    -------
    ndarray of float64, shape (2·radius + 1, 2·radius + 1)
        Each pixel's share of the disk's area; sums to 1. ``[[1.0]]`` when
        the disk fits inside the centre pixel (D ≤ 1).
    """
    if not 0 <= diameter_px <= MAX_DISK_DIAMETER_PX:
        raise ValueError(f"diameter_px must be in [0, {MAX_DISK_DIAMETER_PX:g}], got {diameter_px}")
    if diameter_px <= 1.0:
        return np.ones((1, 1))
    radius = math.ceil(0.5 * diameter_px - 0.5)
    size = 2 * radius + 1
    area = footprint((radius + 0.5, radius + 0.5), diameter_px, "disk", (size, size)).dense((size, size))
    return area / area.sum()


def _check_beyond_focal_length(focal_length_m: float, distance_m: float, focus_distance_m: float) -> None:
    """A real image needs f > 0 and both distances beyond f (thin lens)."""
    f = as_positive(focal_length_m, "focal_length_m")
    for name, value in (("distance_m", distance_m), ("focus_distance_m", focus_distance_m)):
        if not as_positive(value, name) > f:
            raise ValueError(f"{name} = {value!r} must exceed the focal length {f!r} m")


def circle_of_confusion_m(focal_length_m: float, f_number: float, distance_m: float, focus_distance_m: float) -> float:
    """Thin-lens blur-circle diameter on the sensor, in metres.

    A lens of focal length f and aperture diameter A = f/N focused at d_f
    puts the sensor at v_f = f·d_f/(d_f − f). A point at distance d images at
    v = f·d/(d − f); its cone of light, of base A at the lens, meets the
    sensor in a disk of diameter A·|v − v_f|/v (similar triangles), which
    works out to

        c = A · |d − d_f| / d · f / (d_f − f).

    Parameters
    ----------
    focal_length_m, f_number : float
    distance_m : float
        Object (LED) distance d; must exceed f.
    focus_distance_m : float
        Focus distance d_f; must exceed f.
    """
    _check_beyond_focal_length(focal_length_m, distance_m, focus_distance_m)
    as_positive(f_number, "f_number")
    aperture_m = focal_length_m / f_number
    return aperture_m * abs(distance_m - focus_distance_m) / distance_m * focal_length_m / (focus_distance_m - focal_length_m)


def defocus_image_scale(focal_length_m: float, distance_m: float, focus_distance_m: float) -> float:
    """v_f / v: how much larger the defocused image is than the focused one.

    Blur disks are centred where chief rays (through the lens centre) meet
    the sensor: at height h·v_f/d for an object point at height h, where a
    focused image has h·v/d. The LED's light is the same, spread over
    (v_f/v)² of the area.
    """
    _check_beyond_focal_length(focal_length_m, distance_m, focus_distance_m)
    v = focal_length_m * distance_m / (distance_m - focal_length_m)
    v_f = focal_length_m * focus_distance_m / (focus_distance_m - focal_length_m)
    return v_f / v


def kernel_radius(kernel) -> tuple[int, int]:
    """``(rows, cols)`` radius of a 2-D kernel or of a separable ``(k_y, k_x)`` pair."""
    if isinstance(kernel, tuple):
        return len(kernel[0]) // 2, len(kernel[1]) // 2
    return kernel.shape[0] // 2, kernel.shape[1] // 2


def convolve_full(image: np.ndarray, kernels) -> np.ndarray:
    """Linear ("full", zero-padded) convolution of ``image`` by each kernel in turn.

    Parameters
    ----------
    image : ndarray, shape (n, m)
    kernels : sequence
        2-D arrays, or ``(k_y, k_x)`` pairs of 1-D arrays convolved as two
        separable passes (columns, then rows).

    Returns
    -------
    ndarray, shape (n + 2·R_y, m + 2·R_x)
        R is the sum of the kernels' radii; the output covers the input
        dilated by R.
    """
    # Imported here: an unlisted blur must not cost scipy.signal's import.
    from scipy.ndimage import convolve1d
    from scipy.signal import convolve

    out = image
    for kernel in kernels:
        if isinstance(kernel, tuple):
            # Two 1-D passes on the zero-padded image: the "full" convolution,
            # without the 2-D FFT a generic convolve would pick.
            ry, rx = len(kernel[0]) // 2, len(kernel[1]) // 2
            out = np.pad(out, ((ry, ry), (rx, rx)))
            out = convolve1d(out, kernel[0], axis=0, mode="constant")
            out = convolve1d(out, kernel[1], axis=1, mode="constant")
        else:
            out = convolve(out, kernel, mode="full")
    return out


def _trim(rows: slice, cols: slice, coverage: np.ndarray) -> Footprint:
    """The footprint without its all-zero border rows and columns."""
    nz_rows = np.flatnonzero(coverage.any(axis=1))
    nz_cols = np.flatnonzero(coverage.any(axis=0))
    if nz_rows.size == 0:
        return Footprint(slice(rows.start, rows.start), slice(cols.start, cols.start), np.zeros((0, 0)))
    r0, r1, c0, c1 = nz_rows[0], nz_rows[-1] + 1, nz_cols[0], nz_cols[-1] + 1
    return Footprint(
        slice(rows.start + r0, rows.start + r1), slice(cols.start + c0, cols.start + c1), coverage[r0:r1, c0:c1]
    )


def blurred_footprint(
    centre_px: tuple[float, float],
    size_px: float,
    shape: str,
    frame_shape: tuple[int, int],
    kernels,
    edge: str = "exact",
) -> Footprint:
    """Coverage of a disk or square footprint seen through a PSF.

    The footprint is computed on the frame extended by the PSF's radius,
    convolved (zero-padded, see :func:`convolve_full`) and cropped to the
    frame, so that light crosses the frame edges both ways.

    Parameters
    ----------
    centre_px, size_px, shape, frame_shape, edge
        As for :func:`rollsim.optics.footprint.footprint`.
    kernels : sequence
        The PSF as kernels convolved in turn (see :func:`convolve_full`).

    Returns
    -------
    Footprint
        PSF ⊗ coverage on its bounding box within the frame, in [0, 1].
    """
    ry, rx = total_radius(kernels)
    height, width = frame_shape
    cx, cy = centre_px
    canvas = footprint((cx + rx, cy + ry), size_px, shape, (height + 2 * ry, width + 2 * rx), edge)
    return blur_canvas(canvas, kernels, frame_shape)


def total_radius(kernels) -> tuple[int, int]:
    """``(rows, cols)`` radius of the convolution of every kernel: the canvas margin it needs."""
    radii = [kernel_radius(k) for k in kernels]
    return sum(r for r, _ in radii), sum(c for _, c in radii)


def blur_canvas(canvas: Footprint, kernels, frame_shape: tuple[int, int]) -> Footprint:
    """A footprint computed on the frame extended by :func:`total_radius` on
    every side, convolved by the kernels and cropped to the frame.

    Parameters
    ----------
    canvas : Footprint
        Coverage on the extended canvas (canvas row i is frame row i − R_y).
    kernels : sequence
        See :func:`convolve_full`.
    frame_shape : (int, int)

    Returns
    -------
    Footprint
        PSF ⊗ coverage on its bounding box within the frame, in [0, 1].
    """
    ry, rx = total_radius(kernels)
    height, width = frame_shape
    if canvas.coverage.size == 0:
        return Footprint(slice(0, 0), slice(0, 0), np.zeros((0, 0)))
    blurred = convolve_full(canvas.coverage, kernels)
    # Canvas index i is frame index i − R; the full output starts R earlier still.
    top, left = canvas.rows.start - 2 * ry, canvas.cols.start - 2 * rx
    r0, c0 = max(0, -top), max(0, -left)
    r1 = min(blurred.shape[0], height - top)
    c1 = min(blurred.shape[1], width - left)
    if r1 <= r0 or c1 <= c0:
        return Footprint(slice(0, 0), slice(0, 0), np.zeros((0, 0)))
    coverage = np.clip(blurred[r0:r1, c0:c1], 0.0, 1.0)
    coverage[coverage < _SNAP] = 0.0
    coverage[coverage > 1.0 - _SNAP] = 1.0
    return _trim(slice(top + r0, top + r1), slice(left + c0, left + c1), coverage)
