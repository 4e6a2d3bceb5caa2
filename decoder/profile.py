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

from decoder.footprint import (FOOTPRINT_FILL_CHIPS, FOOTPRINT_LEVEL_ROWS, block_column_levels, footprint_weights,
                               rows_summing_to_one)
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
    values, counts = _weighted_means(cols, region.weights)
    inside = region.weights > 0
    floor = INTEGER_NOISE_FLOOR if image.integer else 1e-6 * max(1.0, float(np.max(np.abs(values))))
    sigma = np.array([max(horizontal_noise(cols[:, :, c], mask=inside), floor) for c in range(cols.shape[2])])
    noise = sigma[None, :] / np.sqrt(counts)[:, None]
    return values, noise


def _weighted_means(cols: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row means over the blocks ``weights`` holds, per channel, and the blocks counted per row."""
    # Weights are 0 or 1: their float32 sums are exact counts (and a matrix
    # product takes them ten times faster than a float64 sum does).
    counts = np.maximum(weights @ np.ones(weights.shape[1], np.float32), 1.0).astype(np.float64)
    # One small matrix product per row (far faster than einsum here).
    sums = np.matmul(weights[:, None, :], cols)[:, 0, :]
    return sums.astype(np.float64) / counts[:, None], counts


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


# The band weights' estimate: each band's correlation with the other bands'
# stripes is measured over windows of (chips down the rows, neighbouring
# bands across), the narrowest whose sampling error is within this fraction
# of the correlation itself. A footprint's edge moves the correlation within
# a few chips where the stripes are strong; where they are weak only a wide
# window is precise enough to gain anything over the plain mean (at 13.6 dB
# of stripe SNR, 56 of 78 PHY-SDUs read with bands averaged in threes, 37
# without; 16 with no window over 48 chips). Measuring precision against
# the row's strongest band instead read 143 of 156 at 16.2 and 19.2 dB,
# where this reads 149 and 153. The weights are refined over this many
# passes of the reference they are measured against.
WEIGHT_WINDOWS = ((12.0, 1), (24.0, 1), (48.0, 1), (48.0, 3), (96.0, 3))
WEIGHT_RELATIVE_ERROR = 0.1
WEIGHT_PASSES = 3


class WindowSums:
    """Running means of an (n_rows, n_bands) array over windows of rows and bands, from its cumulative sums.

    The five windows of :data:`WEIGHT_WINDOWS` are read from one cumulative
    sum down the rows (two slices and a difference each), where a running
    filter per window would pass over the array five times. Rows past the
    ends count as 0 and bands past the sides repeat the nearest one (as
    ``scipy.ndimage.uniform_filter1d`` with modes ``constant`` and
    ``nearest``).

    Parameters
    ----------
    values : ndarray of float64, shape (n_rows, n_bands)
    max_rows : int
        Longest window down the rows that will be asked for.
    """

    def __init__(self, values: np.ndarray, max_rows: int):
        self.n_rows = values.shape[0]
        self.pad = int(max_rows)
        cumulative = np.cumsum(values, axis=0)
        zeros = np.zeros((self.pad + 1, values.shape[1]))
        ends = np.broadcast_to(cumulative[-1:], (self.pad, values.shape[1]))
        self.cumulative = np.concatenate([zeros, cumulative, ends])

    def mean(self, rows: int, bands: int) -> np.ndarray:
        """Mean over ``rows`` rows (window start at i − rows//2) and ``bands`` bands (odd, centred)."""
        if not 1 <= rows <= self.pad:
            raise ValueError(f"rows must be in 1 … {self.pad}, got {rows}")
        if bands < 1 or bands % 2 == 0:
            raise ValueError(f"bands must be odd and >= 1, got {bands}")
        start = self.pad - rows // 2
        sums = self.cumulative[start + rows : start + rows + self.n_rows] - self.cumulative[start : start + self.n_rows]
        if bands > 1:
            # A few bands: shifted copies of the edge-padded sums, added.
            half = bands // 2
            padded = np.concatenate([np.repeat(sums[:, :1], half, axis=1), sums, np.repeat(sums[:, -1:], half, axis=1)], axis=1)
            width = sums.shape[1]
            sums = padded[:, :width].copy()
            for shift in range(1, bands):
                sums += padded[:, shift : shift + width]
        return sums / (rows * bands)

    def rows_inside(self, rows: int) -> np.ndarray:
        """How many rows of each window of ``rows`` (as :meth:`mean` lays it) lie inside the array, shape (n_rows,)."""
        first = np.arange(self.n_rows) - rows // 2
        return np.minimum(first + rows, self.n_rows) - np.maximum(first, 0)


def band_correlations(own: WindowSums, reference: WindowSums, cross: WindowSums, window_rows: int, smooth_bands: int,
                      floor: float) -> tuple[np.ndarray, np.ndarray]:
    """Each band's correlation with a reference over windows of rows and bands, and its sampling variance.

    Parameters
    ----------
    own, reference, cross : WindowSums
        Of the bands' high-passed profiles squared, of each band's reference
        squared, and of their product (shape (n_rows, n_bands)).
    window_rows, smooth_bands : int
        Window down the rows and across the bands.
    floor : float
        Least mean square of a window (units²): a band clipped flat holds
        only the filters' rounding residue.

    Returns
    -------
    correlation, variance : ndarray of float64, shape (n_rows, n_bands)
        The variance is 1/n for the n samples a window holds (that of a
        correlation near 0; rows correlated by the high-pass make it a
        little optimistic).
    """
    # Samples of each window inside the profile (rows past the ends hold 0).
    held = own.rows_inside(window_rows) * smooth_bands
    own_power = np.maximum(own.mean(window_rows, smooth_bands), floor)
    reference_power = np.maximum(reference.mean(window_rows, smooth_bands), floor)
    correlation = cross.mean(window_rows, smooth_bands) / np.sqrt(own_power * reference_power)
    return correlation, np.broadcast_to(1.0 / held[:, None], correlation.shape)


def stripe_band_weights(bands: np.ndarray, rows_per_chip: float, variance_floor: float) -> np.ndarray:
    """Weights of column bands, row by row, from how well each follows the stripes the others share.

    Each band's high-passed profile (:func:`~decoder.region.stripe_highpass`)
    is correlated with the weighted sum of the *other* bands (leaving a band
    out of its own reference keeps its noise from correlating with itself,
    so a band of noise gets 0 on average), over the narrowest window of
    :data:`WEIGHT_WINDOWS` whose sampling error is within
    :data:`WEIGHT_RELATIVE_ERROR` of the correlation
    (:func:`band_correlations`). A correlation
    within its own sampling noise is shrunk towards 0 (positive-part
    James–Stein: ρ·max(0, 1 − var(ρ)/ρ²)), and a negative one is 0. The
    weights of one pass make the reference of the next.

    For bands of equal noise and weak stripes the correlation is
    proportional to the stripes' amplitude, as the matched filter's weights
    are. On a disk's chord of 30 bands among 60, the weighted mean's stripe
    SNR is 0.1 to 0.25 dB short of the matched filter's from 8 to 30 dB of
    row SNR, and 1.1 dB at 5 dB (with the z-scores of
    :func:`~decoder.region.common_stripes_z` as weights: 3.1 dB at 8 dB).
    For strong stripes the correlation saturates at 1, so no band takes all
    the weight. The matched filter's own estimate (amplitude over noise
    variance) goes wrong on a clipped glare core, whose response is not
    linear: with the regression's residual as the variance it leaves
    the core out, with the pixels' noise it takes the core alone, and on
    paper-default at two chips of exposure (16 frames) the decoder then read
    34 and 22 of 53 PHY-SDUs, where these weights read 49.

    Parameters
    ----------
    bands : ndarray of float, shape (n_rows, n_bands)
        Row means of the bands.
    rows_per_chip : float
        Chip pitch, rows.
    variance_floor : float
        Least noise variance of a band's row mean (units²; > 0): an 8-bit
        frame's quantisation.

    Returns
    -------
    ndarray of float64, shape (n_rows, n_bands)
        Non-negative weights; each row sums to 1, or is all 0 where no band
        shows stripes.
    """
    if not variance_floor > 0:
        raise ValueError(f"variance_floor must be > 0, got {variance_floor}")
    n_bands = bands.shape[1]
    high = stripe_highpass(np.asarray(bands, dtype=np.float64), rows_per_chip)
    # Windows across the bands are centred: an odd number of them.
    widest = n_bands if n_bands % 2 else n_bands - 1
    windows = [(max(8, int(chips * rows_per_chip)), min(n, widest)) for chips, n in WEIGHT_WINDOWS]
    longest = max(rows for rows, _ in windows)
    own = WindowSums(high * high, longest)
    weights = np.full(bands.shape, 1.0 / n_bands)
    for _ in range(WEIGHT_PASSES):
        total = np.sum(high * weights, axis=1)
        others = total[:, None] - high * weights
        sums = own, WindowSums(others * others, longest), WindowSums(high * others, longest)
        # From the widest window to the narrowest: a narrower one replaces
        # the estimate wherever it is precise enough.
        correlation, spread = band_correlations(*sums, *windows[-1], variance_floor)
        for window in windows[-2::-1]:
            shorter, shorter_spread = band_correlations(*sums, *window, variance_floor)
            precise = shorter_spread < (WEIGHT_RELATIVE_ERROR * shorter) ** 2
            correlation, spread = np.where(precise, shorter, correlation), np.where(precise, shorter_spread, spread)
        square = correlation * correlation
        relative = np.divide(spread, square, out=np.full_like(square, np.inf), where=square > 0)
        raw = np.clip(correlation, 0.0, None) * np.clip(1.0 - relative, 0.0, None)
        if not np.any(raw > 0):
            return np.zeros(bands.shape)
        weights = rows_summing_to_one(raw)
    return smooth_weights(weights, windows[0][0])


def smooth_weights(weights: np.ndarray, window_rows: int) -> np.ndarray:
    """Band weights averaged down the rows over ``window_rows`` rows, each row summing to 1 again (or all 0).

    Where the precise window changes from one row to the next, a band's
    weight jumps, and so does the weighted profile's level (bands differ in
    level: a partly covered band, the background beside a disk). The
    detector's levels are splines with a knot every few chips; such a jump
    reads to them as stripes. Averaged over the narrowest window, the
    weights change no faster than their estimate can resolve. On
    paper-geometric's 16 frames of the SNR map (52 PHY-SDUs) it reads 21
    instead of 16 at 10.3 dB of stripe SNR, and 46 instead of 44 at 13.3 dB
    (both with the ends' level steps cut, :func:`decoder.equalise.stepped_ends`).
    """
    # (A running mean of zeros may come out a rounding error below 0.)
    return rows_summing_to_one(np.maximum(uniform_filter1d(weights, int(window_rows), axis=0, mode="nearest"), 0.0))


def stripe_weighted_profile(image: BlockImage, region: Region, rows_per_chip: float,
                            channel: int | None = None) -> RowProfile | None:
    """The region's row profile with its column bands weighted by the stripes they share.

    A plain mean over the region gives every column the same weight, also
    those where the LED is faint or absent (a disk's sides, a region that
    spans the frame): they add noise and no stripes. Here each band of
    columns (:data:`~decoder.region.COMMON_BAND_BLOCKS` blocks) is weighted,
    row by row, by its correlation with the other bands' stripes
    (:func:`stripe_band_weights`). The level of a row then depends on
    which bands carry it, slowly along the profile; a detector that fits
    its levels along the profile (:mod:`decoder.equalise`) reads it,
    thresholding need not. Where the level image tells the LED's columns
    of a band from the background's (a footprint's edge crossing it),
    only those columns are read (:mod:`decoder.footprint`).

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
    # Floats: an 8-bit frame's differences would wrap around.
    crop = crop.astype(np.float32, copy=False)
    bands = band_means(crop, band_px)
    sigma = max(horizontal_noise(crop), INTEGER_NOISE_FLOOR if image.integer else 1e-6)
    # Quantisation of a band's row mean (a uniform error of 1/12 DN² per pixel).
    floor = 1.0 / (12.0 * band_px) if image.integer else 1e-12 * max(1.0, float(np.max(np.abs(bands)))) ** 2
    weights = stripe_band_weights(bands, rows_per_chip, floor)
    if not np.any(weights.sum(axis=1) > 0):
        return None
    means, levels = block_column_levels(crop, image.factor, n_bands * COMMON_BAND_BLOCKS)
    columns = footprint_weights(weights, levels, sigma / np.sqrt(image.factor * FOOTPRINT_LEVEL_ROWS),
                                int(np.ceil(FOOTPRINT_FILL_CHIPS * rows_per_chip)))
    total = columns.sum(axis=1)
    values = np.where(total > 0, np.sum(columns * means, axis=1), bands.mean(axis=1))
    effective = np.where(total > 0, image.factor / np.maximum(np.sum(columns**2, axis=1), 1e-300), n_bands * band_px)
    return RowProfile(region.rows.start, values, sigma / np.sqrt(effective), channel)


def with_end_rows(image: BlockImage, profile: RowProfile, region: Region, above: int, below: int) -> RowProfile:
    """``profile`` (of ``region``) with ``above`` rows over it and ``below`` under it, in its channel.

    The rows added are those :func:`decoder.region.extended` adds (each
    takes the columns of the end row it adjoins), averaged without copying
    the region's own weights; they carry that end row's noise: the pixel
    noise is the region's (a few rows of narrow ends hold too few
    horizontal neighbours to measure their own).
    """
    channel = 0 if profile.channel is None else profile.channel

    def added(rows: slice, end: int) -> np.ndarray:
        if rows.stop == rows.start:
            return np.zeros(0)
        weights = np.repeat(region.weights[[end]], rows.stop - rows.start, axis=0)
        return _weighted_means(region_columns(image, Region(rows, region.block_cols, weights, 0)), weights)[0][:, channel]

    top = added(slice(region.rows.start - above, region.rows.start), 0)
    bottom = added(slice(region.rows.stop, region.rows.stop + below), -1)
    return RowProfile(region.rows.start - above, np.concatenate([top, profile.values, bottom]),
                      np.concatenate([np.full(above, profile.noise[0]), profile.noise, np.full(below, profile.noise[-1])]),
                      profile.channel)


def profile_rows(profile: RowProfile, rows: slice) -> RowProfile:
    """The part of ``profile`` over the frame ``rows`` (within its own)."""
    start = max(rows.start, profile.first_row)
    stop = min(rows.stop, profile.first_row + len(profile))
    part = slice(start - profile.first_row, max(start, stop) - profile.first_row)
    return RowProfile(start, profile.values[part], profile.noise[part], profile.channel)
