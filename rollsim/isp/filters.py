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

from rollsim.numerics.jit import kernel
from rollsim.numerics.portable_math import exp  # numpy's differs in the last bit between CPUs

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


# The filters' weights are multiples of 2^-WEIGHT_BITS (see _blurred).
WEIGHT_BITS = 16


def integer_weights(kernel: np.ndarray) -> np.ndarray:
    """``kernel``'s weights in units of 2^-WEIGHT_BITS, rounded, their sum exactly 2^WEIGHT_BITS (int64).

    Each weight moves by at most 2^-17 (7.6e-6) but the centre one, which
    takes the rounding's remainder too (6e-5 at σ = 1.75, 2e-4 at σ = 20).
    """
    scale = 1 << WEIGHT_BITS
    weights = np.rint(np.asarray(kernel, dtype=np.float64) * scale).astype(np.int64)
    weights[weights.size // 2] += scale - weights.sum()
    return weights


def fixed_point_kernel(kernel: np.ndarray) -> np.ndarray:
    """``kernel``'s weights rounded to multiples of 2^-WEIGHT_BITS, their sum exactly 1 (float64, exact)."""
    return integer_weights(kernel) / float(1 << WEIGHT_BITS)


def _blurred(image: np.ndarray, sigma_rows_px: float, sigma_cols_px: float) -> np.ndarray:
    """8-bit ``image`` convolved with the separable Gaussian, exactly, as float64 (edges mirrored).

    Exact, so the same bits on every CPU: OpenCV's float filters fuse
    multiply-adds where the CPU has them, which rounds differently. With
    integer pixels up to 255 and weights that are multiples of 2^-16
    summing to 1, every product and partial sum of both passes is a
    multiple of 2^-32 below 2^40, exact in float64 in any order.
    """
    import cv2

    return cv2.sepFilter2D(image, cv2.CV_64F, fixed_point_kernel(gaussian_kernel(sigma_cols_px)),
                           fixed_point_kernel(gaussian_kernel(sigma_rows_px)), borderType=cv2.BORDER_REFLECT_101)


def _to_uint8(values: np.ndarray) -> np.ndarray:
    """float64 values rounded half to even and clipped to 0…255, as uint8 (OpenCV's saturating cast)."""
    rounded = np.rint(values, out=values)
    np.clip(rounded, 0.0, 255.0, out=rounded)
    return rounded.astype(np.uint8)


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
    return _filtered(image, sigma_rows_px, sigma_cols_px, None)


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
    return _filtered(image, sigma_px, sigma_px, float(amount))


def _filtered(image: np.ndarray, sigma_rows_px: float, sigma_cols_px: float, amount: float | None) -> np.ndarray:
    """Smoothing, or with ``amount`` unsharp masking: compiled where numba runs, else OpenCV and numpy (same bytes)."""
    if image.dtype != np.uint8:
        raise ValueError(f"the ISP filters take 8-bit images, got {image.dtype}")
    compiled = _filter_kernel.compiled
    if compiled is not None:
        return _filter_compiled(compiled, image, sigma_rows_px, sigma_cols_px, amount)
    values = _blurred(image, sigma_rows_px, sigma_cols_px)
    if amount is not None:
        # I + a·(I − G) in float64: the detail I − G is exact, then two roundings.
        values = np.subtract(image, values)
        values *= amount
        values += image
    return _to_uint8(values)


# --------------------------------------------------------------- compiled


def _filter_compiled(compiled, image: np.ndarray, sigma_rows_px: float, sigma_cols_px: float,
                     amount: float | None) -> np.ndarray:
    """The compiled filter, channel by channel: smoothing, or with ``amount`` unsharp masking."""
    rows, cols = integer_weights(gaussian_kernel(sigma_rows_px)), integer_weights(gaussian_kernel(sigma_cols_px))
    out = np.empty_like(image)
    channels = [(image, out)] if image.ndim == 2 else [(image[..., k], out[..., k]) for k in range(image.shape[2])]
    for source, target in channels:
        result = np.empty(source.shape, dtype=np.uint8)
        compiled(np.ascontiguousarray(source), rows, cols, amount, result)
        target[...] = result
    return out


@kernel
def _filter_kernel(image, rows, cols, amount, out):
    # The separable filter in integers, exact as the twin's float64 (sums of
    # k·2^-32 below 2^40), then the twin's float64 arithmetic and its
    # rounding half to even with saturation (OpenCV's saturate_cast):
    # the same bytes. Row by row: a column pass into ``column_sums``,
    # mirrored at the ends into ``padded``, then the row pass into
    # ``blurred_row``. Edges are reflected without repeating the edge pixel
    # (OpenCV's BORDER_REFLECT_101), however far a tap reaches.
    height, width = image.shape
    ry, rx = rows.size // 2, cols.size // 2
    # The column pass in int32 (sums below 255·2^16 < 2^31), the row pass in
    # float64, where every product and sum (below 2^40) is exact too: both
    # vectorise better than int64 products.
    rows32 = rows.astype(np.int32)
    column_sums = np.empty(width, dtype=np.int32)
    padded = np.empty(width + 2 * rx, dtype=np.float64)
    blurred_row = np.empty(width, dtype=np.float64)
    scale = 1.0 / float(1 << (2 * WEIGHT_BITS))
    row_period, column_period = max(2 * (height - 1), 1), max(2 * (width - 1), 1)
    for y in range(height):
        for x in range(width):
            column_sums[x] = 0
        for i in range(rows.size):
            # Reflect-101 folded onto its period 2(H − 1) (a single row reflects onto itself).
            source = abs(y + i - ry) % row_period if height > 1 else 0
            source = row_period - source if source >= height else source
            weight, pixels = rows32[i], image[source]
            for x in range(width):
                column_sums[x] += weight * np.int32(pixels[x])
        for x in range(width):
            padded[rx + x] = np.float64(column_sums[x])
        for x in range(rx):  # the ends, mirrored
            for target in (x, rx + width + x):
                source = abs(target - rx) % column_period if width > 1 else 0
                source = column_period - source if source >= width else source
                padded[target] = np.float64(column_sums[source])
        for x in range(width):
            blurred_row[x] = 0.0
        for j in range(cols.size):  # taps outside, pixels inside: a loop LLVM vectorises
            weight = np.float64(cols[j])
            for x in range(width):
                blurred_row[x] += weight * padded[x + j]
        pixels, result = image[y], out[y]  # 1-D rows: loops LLVM vectorises
        for x in range(width):
            blurred = blurred_row[x] * scale  # exact: the scale is a power of two
            if amount is not None:
                pixel = np.float64(pixels[x])
                blurred = (pixel - blurred) * amount + pixel
            # Half to even, then saturated, as OpenCV's cast.
            blurred_row[x] = min(max(np.rint(blurred), 0.0), 255.0)
        for x in range(width):
            result[x] = np.uint8(np.int32(blurred_row[x]))
    return 0
