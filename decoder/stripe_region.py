"""Where a sequence's stripes are: the pixels that change between frames, alike along rows.

A still camera watching a still LED sees the same background, the same
disk edges, halo and vignetting in every frame; only the stripes move (the
LED's waveform starts at another phase in each frame, unless the frame
period is a whole number of the waveform's periods). So each frame less the
sequence's mean holds the stripes and noise, and nothing else. Stripes are
the same all along a row of the LED, noise is not: the product of a pixel's
residual and that of the pixel :data:`COLUMN_LAG` columns away has mean zero
for noise (whatever its level or tone curve; demosaicing's correlations
reach a pixel or two, JPEG's 4:2:0 chroma blocks 16) and the stripes'
variance on the LED. Averaged over
blocks of pixels, the blocks whose mean product is significant form the LED.

This finds a small LED in a large frame, a faint one on a bright or noisy
background, and the channel that carries it, where a brightness threshold
cannot; and it bounds the rows to those the stripes cover, leaving out the
disk's ends and the background, whose envelope would be read as stripes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from decoder.io import as_frame_array
from decoder.profile import RowProfile

# Columns between the two pixels of a product: beyond the reach of
# demosaicing and of the noise a tone curve or a JPEG block shares, odd so
# that it pairs Bayer sites of both kinds.
COLUMN_LAG = 17
# Blocks of pixels (rows × columns, the finest first) over which the
# products are averaged.
BLOCK_SIZES_PX = (16, 32, 64)
# A block is the stripes' when its mean product exceeds this many of its
# standard errors (a quarter of its pixels counted as independent: rows
# within a stripe move together).
MIN_SIGNIFICANCE = 4.0
# Chance that noise alone makes one block of a frame set significant: the
# threshold grows with the blocks tested (24,000 16-px blocks in a 1080p colour
# frame: 4.9 standard errors; 96,000 in a 4K one: 5.2).
FALSE_BLOCK_RATE = 0.01
# Blocks of negative mean needed to measure the noise's spread from them.
MIN_NEGATIVE_BLOCKS = 8
# Columns of the two halves set against each other to measure the profile's
# noise: groups wider than demosaicing's and JPEG's reach.
NOISE_GROUP_COLS = 8
# Least fraction of the LED's block columns holding stripes in a block row
# for its rows to be read.
MIN_ROW_SPAN = 0.5


@dataclass(frozen=True)
class StripeRegion:
    """The rows, column weights and channel of a sequence's stripes.

    Attributes
    ----------
    rows : slice
        Frame rows the stripes cover.
    column_weights : ndarray of float64, shape (width,)
        Weight of each frame column in the row profile (the stripes'
        amplitude in it: a matched filter); zero off the LED.
    channel : int or None
        Channel of a colour frame carrying the stripes best (0 R, 1 G, 2 B),
        None for grey frames.
    block_mask : ndarray of bool, shape (rows // block_rows, width // block_cols), optional
        The blocks of ``rows`` holding stripes: a row's mean is over the
        weighted columns of its blocks only (a disk's chord, not the
        background beside it). None: every weighted column.
    block_rows, block_cols : int
        Rows and columns of a block.
    """

    rows: slice
    column_weights: np.ndarray
    channel: int | None
    block_mask: np.ndarray | None = None
    block_rows: int = 16
    block_cols: int = 16


def _block_means(a: np.ndarray, rows: int, cols: int) -> np.ndarray:
    h, w = a.shape[0] // rows, a.shape[1] // cols
    return a[:h * rows, :w * cols].reshape(h, rows, w, cols).mean(axis=(1, 3))


def lagged_products(frames: np.ndarray, lag: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean over frames of each pixel's residual (the frame less the frames' mean) times that
    ``lag`` columns on, and of its square.

    Parameters
    ----------
    frames : ndarray, shape (frames, rows, cols)
        One channel of the frames, any numeric dtype.
    lag : int
        Columns, at least 1.

    Returns
    -------
    products, squares : ndarray of float64, shape (rows, cols - lag)
    """
    count = frames.shape[0]
    # Residuals in float32 (8-bit levels less a mean: ample), products summed in float64.
    mean = frames.mean(axis=0, dtype=np.float32)
    products = np.zeros(frames.shape[1:2] + (frames.shape[2] - lag,))
    squares = np.zeros_like(products)
    for frame in frames:  # one frame's residual at a time: memory stays at a few frames'
        r = frame.astype(np.float32) - mean
        p = r[:, :-lag].astype(np.float64) * r[:, lag:]
        products += p
        squares += p * p
    # Residuals about the sample mean: T - 1 degrees of freedom.
    return products / max(1, count - 1), squares / max(1, count - 1)


def significance_threshold(blocks: int) -> float:
    """Standard errors a block's mean must exceed: :data:`MIN_SIGNIFICANCE`, or more where so many
    blocks are tested that noise alone would pass one (at most :data:`FALSE_BLOCK_RATE` of frame sets)."""
    from scipy.special import ndtri

    return max(MIN_SIGNIFICANCE, float(-ndtri(FALSE_BLOCK_RATE / max(1, blocks))))


def significant_blocks(products: np.ndarray, squares: np.ndarray, frames: int,
                       block_rows: int, block_cols: int, channels: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Blocks whose mean lagged product is significant, and each block's mean in standard errors.

    The standard error is the larger of the products' own (a quarter of a
    block's pixels counted as independent) and the spread of the blocks
    whose mean is negative: noise alone gives means of either sign alike,
    stripes only positive ones, so the negative side measures what noise
    does, correlations the count leaves out (JPEG's chroma) included.

    Parameters
    ----------
    products, squares : ndarray, shape (rows, cols)
        From :func:`lagged_products`.
    frames : int
        Frames the products are over.
    block_rows, block_cols : int
        Block size, pixels.
    channels : int
        Channels tested alike: the threshold
        (:func:`significance_threshold`) counts all their blocks.
    """
    mean = _block_means(products, block_rows, block_cols)
    spread = _block_means(squares, block_rows, block_cols)
    standard_error = np.sqrt(spread / (frames * block_rows * block_cols / 4.0))
    negative = mean[mean < 0]
    if negative.size >= MIN_NEGATIVE_BLOCKS:
        standard_error = np.maximum(standard_error, float(np.sqrt(np.mean(negative**2))))
    z = mean / np.maximum(standard_error, 1e-12)
    return z > significance_threshold(z.size * channels), z


def led_component(significant: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The connected significant blocks (a block's gap bridged) of the greatest summed significance."""
    from scipy.ndimage import binary_dilation, label

    labels, _ = label(binary_dilation(significant))
    weight = np.bincount(labels.ravel(), np.where(significant, z, 0.0).ravel())
    weight[0] = 0.0
    return (labels == int(np.argmax(weight))) & significant


def stripe_region(frames: Sequence) -> StripeRegion | None:
    """The region of a sequence's moving stripes, or None when nothing moves between frames.

    Parameters
    ----------
    frames : sequence of array_like
        At least two frames of one size, grey ``(H, W)`` or colour ``(H, W, 3)``.

    Returns
    -------
    StripeRegion or None
        None for fewer than two frames, frames too narrow for the column lag,
        or no significant block (the LED's phase the same in every frame,
        or no LED).
    """
    if len(frames) < 2:
        return None
    stack = np.stack([as_frame_array(f) for f in frames])  # their own dtype: uint8 for 8-bit frames
    if stack.ndim == 3:
        stack = stack[..., None]
    count, height, width = stack.shape[:3]
    lag = min(COLUMN_LAG, width // 3)
    if lag < 1:
        return None
    channels = []
    for channel in range(stack.shape[3]):
        channels.append(lagged_products(stack[..., channel], lag))
    # The finest blocks that show the stripes: larger ones average more
    # pixels, for a fainter LED, at a coarser outline.
    for block_rows in BLOCK_SIZES_PX:
        if height < 2 * block_rows:
            break
        block_cols = min(block_rows, max(1, (width - lag) // 2))
        best = None
        for channel, (products, squares) in enumerate(channels):
            significant, z = significant_blocks(products, squares, count, block_rows, block_cols, len(channels))
            if not significant.any():
                continue
            # The channel whose LED stands out most from its noise.
            component = led_component(significant, z)
            score = float(np.sum(z[component]))
            if best is None or score > best[0]:
                best = (score, channel, component)
        if best is not None:
            _, channel, component = best
            return _region_of(component, channels[channel][0], block_rows, block_cols,
                              channel if stack.shape[3] == 3 else None, width)
    return None


def _region_of(component: np.ndarray, products: np.ndarray, block_rows: int, block_cols: int,
               channel: int | None, width: int) -> StripeRegion | None:
    """The :class:`StripeRegion` of the LED's blocks, or None when its rows are not read whole."""
    cols = np.flatnonzero(component.any(axis=0))
    first, stop = int(cols[0] * block_cols), int((cols[-1] + 1) * block_cols)
    # The rows where the stripes span at least MIN_ROW_SPAN of the LED's
    # columns: at a disk's ends the chord is short, the columns' mean is
    # the background's, and its slope would move the stripes' edges.
    span = component[:, cols[0]:cols[-1] + 1].mean(axis=1)
    across = span >= MIN_ROW_SPAN
    if not across.any():  # stripes scattered, in no row across the LED
        return None
    # Only the ends are left out: rows cut from the middle of the stripes
    # may look regular where the whole does not (a stretch of a code whose
    # runs happen to be alike). So the rows across the LED must be one run
    # (a block's gap bridged).
    first_row, last_row = np.flatnonzero(across)[[0, -1]]
    inner = across[first_row:last_row + 1]
    if np.any(~inner[:-1] & ~inner[1:]):  # two blocks in a row not across
        return None
    rows = slice(int(first_row), int(last_row) + 1)
    block_mask = component[rows]
    rows = slice(rows.start * block_rows, rows.stop * block_rows)
    weights = np.zeros(width)
    weights[first:stop] = np.sqrt(np.maximum(products[rows, first:stop].mean(axis=0), 0.0))
    if not weights.any():
        return None
    return StripeRegion(rows=rows, column_weights=weights, channel=channel, block_mask=block_mask,
                        block_rows=block_rows, block_cols=block_cols)


def _weighted_rows(block: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Each row's weighted mean (weights of one shape with ``block``, each row's sum positive)."""
    return np.sum(block * weights, axis=1) / np.sum(weights, axis=1)


def region_profile(image, region: StripeRegion) -> RowProfile:
    """Row profile of a frame over a :class:`StripeRegion` (weighted column mean, DN).

    The noise of each row's mean is measured from the frame: the weighted
    columns are split into alternate groups of :data:`NOISE_GROUP_COLS`,
    whose profiles share the stripes and differ by noise.
    """
    frame = as_frame_array(image)
    width = frame.shape[1]
    # Only the weighted columns: the others add nothing, and a frame's width
    # of float64 rows would be most of the time.
    weighted = np.flatnonzero(region.column_weights)
    cols = slice(int(weighted[0]), int(weighted[-1]) + 1) if weighted.size else slice(0, 0)
    block = frame[region.rows, cols]
    if block.ndim == 3:  # the region's channel, or for a grey region on colour frames their mean
        block = block[..., region.channel] if region.channel is not None else block.mean(axis=2)
    block = block.astype(np.float64)
    weights = np.broadcast_to(region.column_weights[cols], block.shape)
    if region.block_mask is not None:
        inside = np.repeat(np.repeat(region.block_mask, region.block_rows, axis=0), region.block_cols, axis=1)
        mask = np.zeros((block.shape[0], width), dtype=bool)
        mask[:inside.shape[0], :inside.shape[1]] = inside[:block.shape[0], :width]
        masked = np.where(mask[:, cols], weights, 0.0)
        # A block row bridged inside the LED holds no block of its own: its
        # rows take every weighted column.
        weights = np.where(masked.sum(axis=1, keepdims=True) > 0, masked, weights)
    profile = _weighted_rows(block, weights)
    group = (np.arange(cols.start, cols.stop) // NOISE_GROUP_COLS) % 2 == 0  # the frame's columns, as counted
    half_a, half_b = np.where(group, weights, 0.0), np.where(group, 0.0, weights)
    if np.all(half_a.sum(axis=1) > 0) and np.all(half_b.sum(axis=1) > 0):
        difference = _weighted_rows(block, half_a) - _weighted_rows(block, half_b)
        # Row-to-row steps of the difference: the halves' envelopes cancel.
        steps = np.diff(difference)
        sigma_difference = float(np.sqrt(np.mean(steps**2) / 2.0)) if steps.size else 0.0
        # var(difference) = σ²(share_a + share_b); the profile's is σ² · share.
        share_a, share_b, share = (np.mean(np.sum(w**2, axis=1) / np.sum(w, axis=1) ** 2)
                                   for w in (half_a, half_b, weights))
        sigma = sigma_difference * np.sqrt(share / (share_a + share_b))
    else:
        sigma = 0.0
    return RowProfile(first_row=region.rows.start, values=profile, noise=np.full(profile.size, sigma),
                      channel=region.channel)
