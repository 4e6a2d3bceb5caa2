"""Row profile of an LED region.

The rolling shutter turns the LED's waveform into a function of the row, so
the decoder reads one number per row: the mean of the region's pixels in
that row. A mean rather than a sum keeps a disk's chord length out of the
level. Each row's mean comes with its noise sigma (pixel noise over the
square root of the pixels averaged), which sets the binariser's erasure
threshold. For colour frames the channel with the best stripe
contrast-to-noise ratio is used.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.ndimage import uniform_filter1d

from decoder.kernels import column_means_u8, frame_words
from decoder.order_stats import median, percentiles
from decoder.region import COMMON_BAND_BLOCKS, BlockImage, Region, band_means, horizontal_noise, stripe_highpass

# Quantisation noise of the column-block means of an integer frame (DN):
# they are rounded to integers, a uniform error of sigma 1/sqrt(12).
INTEGER_NOISE_FLOOR = 0.3


@dataclass(frozen=True)
class RowProfile:
    """Mean level of a region's pixels, row by row.

    Attributes
    ----------
    first_row : int
        Frame row of ``values[0]``.
    values : ndarray of float64, shape (n,)
        Mean pixel value of each row, in the frame's units (DN).
    noise : ndarray of float64, shape (n,)
        Standard deviation of each mean from pixel noise (DN).
    channel : int or None
        Channel used for a colour frame (0 R, 1 G, 2 B), None for gray.
    """

    first_row: int
    values: np.ndarray
    noise: np.ndarray
    channel: int | None = None

    def __len__(self) -> int:
        return int(self.values.size)


def region_columns(image: BlockImage, region: Region) -> np.ndarray:
    """Means over column blocks of the region's rows, at full row resolution.

    Returns
    -------
    ndarray of float32, shape (n_rows, n_block_cols, n_channels)
        The row mean over the region is then a weighted sum over blocks.
    """
    words = frame_words(image.frame, image.factor)
    if words is not None:
        # The same numbers as the resize below, several times faster.
        return column_means_u8(words, region.rows, region.block_cols)[:, :, None]
    cols = image.block_col_span(region.block_cols)
    crop = image.frame[region.rows, cols]
    n_blocks = region.block_cols.stop - region.block_cols.start
    if crop.shape[1] != n_blocks:
        crop = cv2.resize(crop, (n_blocks, crop.shape[0]), interpolation=cv2.INTER_AREA)
    crop = crop.astype(np.float32, copy=False)
    return crop if crop.ndim == 3 else crop[:, :, None]


def channel_profiles(image: BlockImage, region: Region) -> tuple[np.ndarray, np.ndarray]:
    """Row means and row noise of a region, for every channel.

    Returns
    -------
    values : ndarray of float64, shape (n_rows, n_channels)
        Mean pixel value of each row over the region (DN).
    noise : ndarray of float64, shape (n_rows, n_channels)
        Standard deviation of each mean (DN).
    """
    cols = region_columns(image, region)
    weights = region.weights
    # Weights are 0 or 1: their float32 sums are exact counts (and a matrix
    # product takes them ten times faster than a float64 sum does).
    counts = np.maximum(weights @ np.ones(weights.shape[1], np.float32), 1.0).astype(np.float64)
    # One small matrix product per row (far faster than einsum here).
    sums = np.matmul(weights[:, None, :], cols)[:, 0, :]
    values = sums.astype(np.float64) / counts[:, None]
    inside = weights > 0
    floor = INTEGER_NOISE_FLOOR if image.integer else 1e-6 * max(1.0, float(np.max(np.abs(values))))
    sigma = np.array([max(horizontal_noise(cols[:, :, c], mask=inside), floor) for c in range(cols.shape[2])])
    noise = sigma[None, :] / np.sqrt(counts)[:, None]
    return values, noise


def stripe_contrast(values: np.ndarray, noise: np.ndarray) -> float:
    """Contrast-to-noise ratio of a profile: 5–95 % spread over median noise."""
    low, high = percentiles(values, (5.0, 95.0))
    return float((high - low) / max(median(noise), 1e-12))


def row_profile(image: BlockImage, region: Region) -> RowProfile:
    """The row profile of a region, in its best channel.

    Parameters
    ----------
    image : BlockImage
    region : Region

    Returns
    -------
    RowProfile
    """
    values, noise = channel_profiles(image, region)
    if values.shape[1] == 1:
        return RowProfile(region.rows.start, values[:, 0], noise[:, 0], None)
    scores = [stripe_contrast(values[:, c], noise[:, c]) for c in range(values.shape[1])]
    best = int(np.argmax(scores))
    return RowProfile(region.rows.start, values[:, best], noise[:, best], best)


# The band weights' estimate: each band's stripe amplitude is measured over
# windows of these many chips down the rows and this many neighbouring
# bands across (a footprint is smooth), the shortest window whose estimate
# is within this relative standard error (a footprint's edge moves the
# amplitude within a few chips, where the stripes are strong; where they
# are weak only a long window is precise enough to gain anything over the
# plain mean), refined over this many passes of the reference it is
# measured against.
WEIGHT_WINDOWS_CHIPS = (12.0, 24.0, 48.0, 96.0)
WEIGHT_SMOOTH_BANDS = 3
WEIGHT_RELATIVE_ERROR = 0.1
WEIGHT_PASSES = 3


def _windowed(values: np.ndarray, rows: int, bands: int) -> np.ndarray:
    """Running means of an (n_rows, n_bands) array: ``rows`` down (zeros past the ends), ``bands`` across."""
    out = uniform_filter1d(values, rows, axis=0, mode="constant")
    return uniform_filter1d(out, bands, axis=1, mode="nearest") if bands > 1 else out


def band_amplitudes(high: np.ndarray, others: np.ndarray, window_rows: int, smooth_bands: int,
                    floor: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each band's stripe amplitude against a reference, over windows of rows and bands.

    The least-squares slope of ``high`` on ``others`` over each window, the
    variance of the residual, and the slope's own variance.

    Returns
    -------
    amplitude, variance, spread : ndarray of float64, shape (n_rows, n_bands)
    """
    held = uniform_filter1d(np.ones(high.shape[0]), window_rows, mode="constant") * window_rows * smooth_bands
    reference = np.maximum(_windowed(others * others, window_rows, smooth_bands), floor)
    amplitude = _windowed(high * others, window_rows, smooth_bands) / reference
    residual = high - amplitude * others
    variance = np.maximum(_windowed(residual * residual, window_rows, smooth_bands), floor)
    # Correlated rows make the samples fewer than held: the spread is a
    # little optimistic, which keeps the shrinkage below mild.
    return amplitude, variance, variance / (reference * held[:, None])


def matched_band_weights(bands: np.ndarray, rows_per_chip: float, variance_floor: float) -> np.ndarray:
    """Matched-filter weights of column bands, row by row, estimated from the stripes they share.

    A row mean that weighs each band by its stripe amplitude over its noise
    variance (a_b / v_b) has the best stripe SNR any weighting gives (the
    genie's matched filter, on bands). Neither is known: each band's
    high-passed profile (:func:`~decoder.region.stripe_highpass`) is
    regressed on the weighted sum of the *other* bands (leaving a band out
    of its own reference keeps its noise from correlating with itself, so a
    band of noise gets amplitude 0 on average), over the shortest window of
    :data:`WEIGHT_WINDOWS_CHIPS` whose estimate is precise to
    :data:`WEIGHT_RELATIVE_ERROR` (:func:`band_amplitudes`); the
    regression's residual gives v_b. An amplitude within its own estimation
    noise is shrunk towards 0 (positive-part James–Stein: a·max(0, 1 −
    var(a)/a²)), and a negative one is 0. The weights of one pass make the
    reference of the next.

    Parameters
    ----------
    bands : ndarray of float, shape (n_rows, n_bands)
        Row means of the bands.
    rows_per_chip : float
        Chip pitch, rows.
    variance_floor : float
        Least noise variance of a band's row mean (units²; > 0): an 8-bit
        frame's quantisation. It keeps a band clipped flat (where the
        filters leave rounding residue of 1e-13) from looking noiseless.

    Returns
    -------
    ndarray of float64, shape (n_rows, n_bands)
        Non-negative weights; each row sums to 1, or is all 0 where no band
        shows stripes.
    """
    n_rows, n_bands = bands.shape
    high = stripe_highpass(np.asarray(bands, dtype=np.float64), rows_per_chip)
    windows = [max(8, int(chips * rows_per_chip)) for chips in WEIGHT_WINDOWS_CHIPS]
    smooth = min(WEIGHT_SMOOTH_BANDS, n_bands)
    if not variance_floor > 0:
        raise ValueError(f"variance_floor must be > 0, got {variance_floor}")
    floor = float(variance_floor)
    weights = np.full(bands.shape, 1.0 / n_bands)
    for _ in range(WEIGHT_PASSES):
        total = np.sum(high * weights, axis=1)
        others = total[:, None] - high * weights
        # From the longest window to the shortest: a shorter one replaces
        # the estimate wherever it is precise enough.
        amplitude, variance, spread = band_amplitudes(high, others, windows[-1], smooth, floor)
        for window in windows[-2::-1]:
            a, v, e = band_amplitudes(high, others, window, smooth, floor)
            precise = e < (WEIGHT_RELATIVE_ERROR * a) ** 2
            amplitude, variance, spread = (np.where(precise, a, amplitude), np.where(precise, v, variance),
                                           np.where(precise, e, spread))
        square = amplitude * amplitude
        relative = np.divide(spread, square, out=np.full_like(square, np.inf), where=square > 0)
        shrink = np.clip(1.0 - relative, 0.0, None)
        raw = np.clip(amplitude, 0.0, None) * shrink / variance
        row_total = raw.sum(axis=1, keepdims=True)
        weights = np.divide(raw, row_total, out=np.zeros_like(raw), where=row_total > 0)
        if not np.any(row_total > 0):
            break
    return weights


def stripe_weighted_profile(image: BlockImage, region: Region, rows_per_chip: float,
                            channel: int | None = None) -> RowProfile | None:
    """The region's row profile with its column bands weighted as a matched filter.

    A plain mean over the region gives every column the same weight, also
    those where the LED is faint or absent (a disk's sides, a region that
    spans the frame): they add noise and no stripes. Here each band of
    columns (:data:`~decoder.region.COMMON_BAND_BLOCKS` blocks) is weighted,
    row by row, by its estimated stripe amplitude over its noise variance
    (:func:`matched_band_weights`). The level of a row then depends on
    which bands carry it, slowly along the profile; a detector that fits
    its levels along the profile (:mod:`decoder.equalise`) reads it,
    thresholding need not.

    Parameters
    ----------
    image : BlockImage
    region : Region
    rows_per_chip : float
    channel : int, optional
        Channel of a colour frame (:attr:`RowProfile.channel` of the plain
        profile); the first if None.

    Returns
    -------
    RowProfile or None
        None when fewer than three bands fit in the region or none shows
        stripes.
    """
    cols = image.block_col_span(region.block_cols)
    crop = image.frame[region.rows, cols]
    if crop.ndim == 3:
        # The channel the plain profile chose (its best stripe contrast).
        crop = crop[:, :, 0 if channel is None else channel]
    band_px = COMMON_BAND_BLOCKS * image.factor
    n_bands = crop.shape[1] // band_px
    if n_bands < 3:
        return None
    bands = band_means(crop.astype(np.float32, copy=False), band_px)
    sigma = max(horizontal_noise(crop), INTEGER_NOISE_FLOOR if image.integer else 1e-6)
    # Quantisation of a band's row mean (a uniform error of 1/12 DN² per pixel).
    floor = 1.0 / (12.0 * band_px) if image.integer else 1e-12 * max(1.0, float(np.max(np.abs(bands)))) ** 2
    weights = matched_band_weights(bands, rows_per_chip, floor)
    total = weights.sum(axis=1)
    if not np.any(total > 0):
        return None
    plain = bands.mean(axis=1)
    values = np.where(total > 0, np.sum(weights * bands, axis=1), plain)
    effective = np.where(total > 0, 1.0 / np.maximum(np.sum(weights**2, axis=1), 1e-300), n_bands) * band_px
    return RowProfile(region.rows.start, values, sigma / np.sqrt(effective), channel)
