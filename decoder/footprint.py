"""Which columns of a striped band the LED covers, from the level image.

The stripe-weighted profile (:func:`decoder.profile.stripe_weighted_profile`)
weighs bands of :data:`~decoder.region.COMMON_BAND_BLOCKS` blocks (32 pixels
on a 1080p frame) by how well they follow the stripes. Where a footprint's
edge crosses a band, the band holds LED and background columns alike, and
its background adds noise and no stripes. Near a disk's top and bottom the
chord is a few bands wide and its edges cross most of them. On
paper-geometric's SNR map at 10.3 dB of stripe SNR (16 frames, 52 PHY-SDUs),
the sequence detector reads 44 on a profile of 32-pixel bands weighted by
their true coverage, 50 on one of 16-pixel bands, and 51 on the genie's
pixel-wise matched filter.

Stripes alone cannot place an edge within a band at such an SNR: the
correlations that weigh the bands need windows of hundreds of rows, over
which a disk's chord widens by several bands. The *level* of the pixels
often can: the LED's face and the LED's mean light differ from the
background around it (paper-geometric's dark face: 25 DN against a 60 DN
wall). So, row by row:

* the background's level is the median over the bands of no weight;
* the LED's level is that of the block column least like the background
  among the bands of weight and their neighbours (the columns the stripes
  point to);
* where the two differ by :data:`FOOTPRINT_LEVEL_SIGMA` times the noise of
  a block column's level (averaged over :data:`FOOTPRINT_LEVEL_ROWS` rows),
  the row is *told*: its LED columns are those nearer the LED's level than
  the background's, and they weigh alike, as the matched filter of a
  uniform emitter does;
* a row within :data:`FOOTPRINT_FILL_CHIPS` chips of a told row takes the
  nearest one's columns (an ON chip as bright as the wall cannot be told,
  but the footprint has not moved).

A profile whose told rows are fewer than :data:`FOOTPRINT_TOLD_FRACTION` of
its rows with stripes keeps the bands' weights throughout: the LED's columns
and the bands differ in level, and a switch from one to the other inside the
LED would be a step in the profile, read as a chip.
"""

from __future__ import annotations

import cv2
import numpy as np

# Rows over which a block column's level is averaged. Near a disk's ends the
# chord's edge moves two pixels a row; on paper-geometric's SNR map (10.3 dB,
# 16 frames) 9 rows read 50 PHY-SDUs of 52, 27 rows 48.
FOOTPRINT_LEVEL_ROWS = 9
# How far apart (in noise sigmas of one block column's level) the LED's and
# the background's levels must lie for the level to tell them apart. Halfway
# between them a column is misjudged once in 700; a row of 500 columns of
# background passes by chance once in a million rows.
FOOTPRINT_LEVEL_SIGMA = 6.0
# Least fraction of the rows with stripes the level must tell for the LED's
# columns to be read at all.
FOOTPRINT_TOLD_FRACTION = 0.9
# Chips from a told row within which a row takes its columns: longer than a
# PHY-SDU's runs of equal chips.
FOOTPRINT_FILL_CHIPS = 6.0


def block_column_levels(crop: np.ndarray, block_px: int, n_blocks: int, level_rows: int = FOOTPRINT_LEVEL_ROWS):
    """Row means of each block column of ``crop`` and those means averaged down ``level_rows`` rows.

    Parameters
    ----------
    crop : ndarray of float32, shape (n_rows, n_cols)
        Gray pixels (DN), ``n_cols ≥ n_blocks · block_px``.
    block_px : int
        Columns per block.
    n_blocks : int
        Block columns, from the left (the rest is dropped).
    level_rows : int
        Rows of the running mean (odd: centred; the ends repeat the end rows).

    Returns
    -------
    means, levels : ndarray of float32, shape (n_rows, n_blocks)
        DN.
    """
    n_rows = crop.shape[0]
    # An area resize by a whole factor is the blocks' exact means, and
    # OpenCV's box filter the running mean: a tenth of numpy's time on a
    # 1080p region.
    means = cv2.resize(np.ascontiguousarray(crop[:, : n_blocks * block_px], dtype=np.float32), (n_blocks, n_rows),
                       interpolation=cv2.INTER_AREA)
    return means, cv2.blur(means, (1, int(level_rows)), borderType=cv2.BORDER_REPLICATE)


def background_levels(band_levels: np.ndarray, weightless: np.ndarray) -> np.ndarray:
    """Each row's median level over its weightless bands; NaN in a row that has none.

    Parameters
    ----------
    band_levels : ndarray of float64, shape (n_rows, n_bands)
    weightless : ndarray of bool, shape (n_rows, n_bands)

    Returns
    -------
    ndarray of float64, shape (n_rows,)
    """
    count = weightless.sum(axis=1)
    ordered = np.sort(np.where(weightless, band_levels, np.inf), axis=1)
    rows = np.arange(band_levels.shape[0])
    low = ordered[rows, np.maximum(count - 1, 0) // 2]
    high = ordered[rows, np.maximum(count, 1) // 2 - (count == 0)]
    return np.where(count > 0, 0.5 * (low + high), np.nan)


def footprint_weights(band_weights: np.ndarray, levels: np.ndarray, level_noise: float, fill_rows: int) -> np.ndarray:
    """Block-column weights of a row profile: the bands' weights, with each row's LED columns told by their level.

    Parameters
    ----------
    band_weights : ndarray of float64, shape (n_rows, n_bands)
        Non-negative; each row sums to 1 or is all 0
        (:func:`decoder.profile.stripe_band_weights`).
    levels : ndarray of float, shape (n_rows, n_bands · k)
        Level of each block column, ``k`` to a band (DN,
        :func:`block_column_levels`).
    level_noise : float
        Noise sigma of one block column's level (DN).
    fill_rows : int
        Rows from a told row within which a row takes its columns.

    Returns
    -------
    ndarray of float64, shape (n_rows, n_bands · k)
        Non-negative; each row sums to 1 or is all 0. In a told row (or one
        near it) the LED's columns weigh alike and the others 0; elsewhere,
        and everywhere in a profile with too few told rows, each band's
        weight is spread evenly over its columns.
    """
    n_rows, n_bands = band_weights.shape
    per_band = levels.shape[1] // n_bands
    band_levels = levels.reshape(n_rows, n_bands, per_band).mean(axis=2)
    background = background_levels(band_levels, band_weights <= 0)
    weighted = band_weights.sum(axis=1) > 0
    known = np.isfinite(background) & weighted
    background = np.where(known, background, 0.0)
    # A band of weight, or beside one: the stripes' weights are smoothed
    # over many rows and may fall a band short of the edge.
    padded = np.pad(band_weights, ((0, 0), (1, 1)))
    near = np.repeat(np.maximum(np.maximum(padded[:, :-2], padded[:, 1:-1]), padded[:, 2:]) > 0, per_band, axis=1)
    striped = _most_unlike(levels, background, near)
    told = known & (np.abs(striped - background) > FOOTPRINT_LEVEL_SIGMA * level_noise)
    # Nearer the LED's level than the background's: past the midpoint
    # between them, on the LED's side.
    midpoint, side = 0.5 * (striped + background), np.sign(striped - background)
    led = near & ((levels - midpoint[:, None]) * side[:, None] > 0)
    chosen = np.repeat(band_weights / per_band, per_band, axis=1)
    if np.count_nonzero(told) < FOOTPRINT_TOLD_FRACTION * np.count_nonzero(weighted):
        return rows_summing_to_one(chosen)
    source = nearest_told(told, int(fill_rows))
    taken = source >= 0
    chosen[taken] = led[source[taken]]
    return rows_summing_to_one(chosen)


def rows_summing_to_one(weights: np.ndarray) -> np.ndarray:
    """Non-negative weights (n_rows, n) scaled so that each row sums to 1; rows of zeros stay 0."""
    total = weights.sum(axis=1, keepdims=True)
    return np.divide(weights, total, out=np.zeros_like(weights), where=total > 0)


def nearest_told(told: np.ndarray, reach_rows: int) -> np.ndarray:
    """For each row, the nearest told row within ``reach_rows`` (itself if told), or -1.

    Parameters
    ----------
    told : ndarray of bool, shape (n_rows,)
    reach_rows : int

    Returns
    -------
    ndarray of int64, shape (n_rows,)
    """
    n_rows = told.size
    rows = np.arange(n_rows)
    before = np.maximum.accumulate(np.where(told, rows, -1))
    after = np.minimum.accumulate(np.where(told, rows, n_rows)[::-1])[::-1]
    gap_before = np.where(before >= 0, rows - before, n_rows + 1)
    gap_after = np.where(after < n_rows, after - rows, n_rows + 1)
    nearest = np.where(gap_before <= gap_after, before, after)
    return np.where(np.minimum(gap_before, gap_after) <= reach_rows, nearest, -1)


def _most_unlike(levels: np.ndarray, background: np.ndarray, near: np.ndarray) -> np.ndarray:
    """Each row's level farthest from ``background`` among its ``near`` block columns (DN; the background where none).

    The most heavily weighted band may lie off a narrow chord (a disk's
    first rows, under weights smoothed over many rows); the column least
    like the background among those the stripes point to is the LED's.
    """
    distance = np.where(near, np.abs(levels - background[:, None]), -1.0)
    pick = np.argmax(distance, axis=1)
    rows = np.arange(levels.shape[0])
    return np.where(near[rows, pick], levels[rows, pick], background)
