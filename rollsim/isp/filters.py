"""Linear ISP filters on 8-bit images: Gaussian smoothing and unsharp-mask sharpening.

A phone ISP denoises and sharpens the luma after the tone curve. Both are
separable Gaussian filters here, so their transfer functions have closed
forms that the tests check: on a sinusoid of f cycles per pixel, smoothing
with σ multiplies the amplitude by exp(−2π²σ²f²), and unsharp masking with
amount a by 1 + a·(1 − exp(−2π²σ²f²)). Smoothing only along the columns
(``sigma_cols_px = 0``) is what widens a rolling-shutter stripe's edges, as
the vertical noise filters of real ISPs do.
"""

from __future__ import annotations

import numpy as np

from rollsim.portable_math import exp  # numpy's differs in the last bit between CPUs

TRUNCATE_SIGMA = 4.0  # kernel radius in σ: 6.3e-5 of the mass cut, renormalised


def gaussian_kernel(sigma_px: float) -> np.ndarray:
    """A sampled Gaussian of standard deviation ``sigma_px`` pixels, unit sum, float32.

    σ = 0 gives the identity kernel [1].
    """
    if not (np.isfinite(sigma_px) and sigma_px >= 0):
        raise ValueError(f"sigma_px must be a finite number >= 0, got {sigma_px!r}")
    if sigma_px == 0:
        return np.ones(1, dtype=np.float32)
    radius = max(1, int(np.ceil(TRUNCATE_SIGMA * sigma_px)))
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    kernel = exp(-0.5 * (x / sigma_px) ** 2)
    return (kernel / kernel.sum()).astype(np.float32)


# The filters' weights are multiples of 2^-WEIGHT_BITS (see _filtered).
WEIGHT_BITS = 16


def fixed_point_kernel(kernel: np.ndarray) -> np.ndarray:
    """``kernel``'s weights rounded to multiples of 2^-WEIGHT_BITS, their sum exactly 1 (float64).

    The rounding's remainder goes to the centre weight; each weight moves by
    at most ~1.5e-5.
    """
    scale = float(1 << WEIGHT_BITS)
    weights = np.rint(np.asarray(kernel, dtype=np.float64) * scale)
    weights[weights.size // 2] += scale - weights.sum()
    return weights / scale


def _blurred(image: np.ndarray, sigma_rows_px: float, sigma_cols_px: float) -> np.ndarray:
    """8-bit ``image`` convolved with the separable Gaussian, exactly, as float64 (edges mirrored).

    Exact, so the same bits on every CPU: OpenCV's float filters fuse
    multiply-adds where the CPU has them, which rounds differently. With
    integer pixels up to 255 and weights that are multiples of 2^-16
    summing to 1, every product and partial sum of both passes is a
    multiple of 2^-32 below 2^40, exact in float64 in any order.
    """
    import cv2

    if image.dtype != np.uint8:
        raise ValueError(f"the ISP filters take 8-bit images, got {image.dtype}")
    return cv2.sepFilter2D(image, cv2.CV_64F, fixed_point_kernel(gaussian_kernel(sigma_cols_px)),
                           fixed_point_kernel(gaussian_kernel(sigma_rows_px)), borderType=cv2.BORDER_REFLECT_101)


def _to_uint8(values: np.ndarray) -> np.ndarray:
    """float64 values clipped to 0…255 and rounded half to even, as uint8 (OpenCV's saturating cast, in one pass)."""
    import cv2

    # A scalar second operand (OpenCV's own overload; its stubs know only arrays).
    return np.asarray(cv2.add(values, 0.0, dtype=cv2.CV_8U))  # type: ignore[call-overload]


def smooth(image: np.ndarray, sigma_rows_px: float, sigma_cols_px: float = 0.0) -> np.ndarray:
    """Gaussian smoothing of an 8-bit image, σ along the columns (across rows) and along the rows.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W) or (H, W, 3)
    sigma_rows_px : float
        Standard deviation across rows (down a column), in pixels.
    sigma_cols_px : float
        Standard deviation across columns (along a row), in pixels.

    Returns
    -------
    ndarray of uint8, the shape of ``image``
    """
    return _to_uint8(_blurred(image, sigma_rows_px, sigma_cols_px))


def sharpen(image: np.ndarray, amount: float, sigma_px: float) -> np.ndarray:
    """Unsharp masking of an 8-bit image: I + a·(I − G_σ * I), clipped to 0…255.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W) or (H, W, 3)
    amount : float
        a, the gain on the detail (0 leaves the image as it is).
    sigma_px : float
        σ of the Gaussian that defines the detail, in pixels (both axes).

    Returns
    -------
    ndarray of uint8, the shape of ``image``
    """
    if not (np.isfinite(amount) and amount >= 0):
        raise ValueError(f"amount must be a finite number >= 0, got {amount!r}")
    # I + a·(I − G) in float64: the detail I − G is exact, then two roundings.
    values = np.subtract(image, _blurred(image, sigma_px, sigma_px))
    values *= amount
    values += image
    return _to_uint8(values)
