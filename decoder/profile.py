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

from decoder.kernels import column_means_u8, frame_words
from decoder.order_stats import median, percentiles
from decoder.region import COMMON_BAND_BLOCKS, BlockImage, Region, band_means, common_stripes_z, horizontal_noise

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


# Bands whose shared-stripes z-score is below this get no weight.
MIN_BAND_Z = 1.0


def stripe_weighted_profile(image: BlockImage, region: Region, rows_per_chip: float,
                            channel: int | None = None) -> RowProfile | None:
    """The region's row profile with its column bands weighted by their stripes.

    A plain mean over the region gives every column the same weight, also
    those where the LED is faint or absent (a disk's sides, a region that
    spans the frame): they add noise and no stripes. Here each band of
    columns (:data:`~decoder.region.COMMON_BAND_BLOCKS` blocks) is weighted,
    row by row, by how strongly it shares the other bands' stripes
    (:func:`~decoder.region.common_stripes_z`, less :data:`MIN_BAND_Z`): an
    estimate of the matched filter across columns. The level of a row then
    depends on which bands carry it, slowly along the profile; a detector
    that fits its levels along the profile (:mod:`decoder.equalise`) reads
    it, thresholding need not.

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
    crop = crop.astype(np.float64, copy=False)
    band_px = COMMON_BAND_BLOCKS * image.factor
    n_bands = crop.shape[1] // band_px
    if n_bands < 3:
        return None
    bands = band_means(crop, band_px)
    weights = np.clip(common_stripes_z(bands, rows_per_chip) - MIN_BAND_Z, 0.0, None)
    total = weights.sum(axis=1)
    if not np.any(total > 0):
        return None
    plain = bands.mean(axis=1)
    values = np.where(total > 0, np.sum(weights * bands, axis=1) / np.where(total > 0, total, 1.0), plain)
    sigma = max(horizontal_noise(crop), INTEGER_NOISE_FLOOR if image.integer else 1e-6)
    effective = np.where(total > 0, total**2 / np.maximum(np.sum(weights**2, axis=1), 1e-300), n_bands) * band_px
    return RowProfile(region.rows.start, values, sigma / np.sqrt(effective), channel)
