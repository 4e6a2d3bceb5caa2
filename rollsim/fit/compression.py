"""A JPEG's quality read back from its decoded frames.

A JPEG quantises each 8×8 block's DCT coefficients with a step per
frequency. Decoded and encoded again with the same steps, a block comes
back unchanged: its coefficients lie on the steps' multiples, off only by
the decoder's rounding to integer pixels, which is less than half a step
(a JPEG's round trip is idempotent). With coarser steps the true multiples
move to other multiples; with finer ones that do not divide them, they
move by up to half a step; frames never compressed change under every
table. The quality read is the one whose round trip changes the fewest
pixels, where that leaves all but :data:`MAX_CHANGED` of them as they
were: a neighbouring quality's steps differ by a fraction of a step, and
the coefficients of flat, low-contrast blocks (one or two steps) come
back alike under both, but not all of them. The tables tried are the IJG
tables of ITU-T T.81 Annex K scaled for a quality, as libjpeg and OpenCV
write them (:func:`rollsim.isp.jpeg_islow.quantisation_table`); a camera's
own tables read as none, and so do qualities from 95 (:data:`QUALITIES`).

Only what the codec left intact is read: blocks aligned with the frame's
top-left corner (a JPEG's own grid; a crop that cuts the grid shows none),
without a pixel at 0 or 255 in any channel (a clipped block's coefficients
are off their multiples) and not flat (a flat block comes back flat under
most tables), on the luminance of colour frames (JPEG's Y,
Rec. 601 weights, rounded; its chroma is subsampled and not read).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from rollsim.fit.channel import plane
from rollsim.isp.jpeg import jpeg_round_trip

BLOCK = 8
# The share of pixels a round trip at the frames' own quality may change
# (blocks whose coefficients the rounding put near half a step; a colour
# frame's luminance, recomputed from rounded RGB, is off by a fraction of a level).
MAX_CHANGED = 0.02
# The fewest blocks that can tell, and the most read (spread evenly over the
# frames' unclipped blocks: a round trip per quality costs their pixels).
MIN_BLOCKS = 64
MAX_BLOCKS = 4096


# The qualities read. From 95 the steps are 1 to 3 (all 1 at 100): a round
# trip there changes few pixels of any flat frame, compressed or not.
QUALITIES = np.arange(1, 95)


def unclipped_blocks(frames: Sequence[np.ndarray]) -> np.ndarray:
    """The luminance of the frames' 8×8 blocks on their JPEG grid without a pixel at 0 or 255, and not flat,
    uint8, (n, 8, 8).

    At most :data:`MAX_BLOCKS`, taken evenly over the frames' blocks.
    """
    blocks = []
    for frame in frames:
        frame = np.asarray(frame)
        h, w = (frame.shape[0] // BLOCK) * BLOCK, (frame.shape[1] // BLOCK) * BLOCK
        if h == 0 or w == 0:
            continue
        # A JPEG's Y: grey as is, RGB by the Rec. 601 weights.
        luma = plane(frame[:h, :w], "luminance") if frame.ndim == 3 else frame[:h, :w]
        tiles = np.clip(np.rint(luma), 0, 255).astype(np.uint8)
        tiles = tiles.reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK).swapaxes(1, 2)
        raw = frame[:h, :w].reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK, -1).swapaxes(1, 2)
        clear = ~((raw <= 0) | (raw >= 255)).any(axis=(2, 3, 4))
        # A flat block comes back flat under most tables: it tells nothing.
        varied = np.ptp(tiles, axis=(2, 3)) > 0
        blocks.append(tiles[clear & varied])
    if not blocks:
        return np.zeros((0, BLOCK, BLOCK), dtype=np.uint8)
    stack = np.concatenate(blocks)
    if stack.shape[0] > MAX_BLOCKS:
        stack = stack[np.linspace(0, stack.shape[0] - 1, MAX_BLOCKS).astype(np.int64)]
    return stack


def mosaic(blocks: np.ndarray) -> np.ndarray:
    """Blocks (n, 8, 8) laid out as one frame of 8 × 8n pixels, each on the JPEG grid."""
    return np.ascontiguousarray(blocks.transpose(1, 0, 2).reshape(BLOCK, -1))


def changed_share(image: np.ndarray, quality: int) -> float:
    """The share of ``image``'s pixels (uint8, grey) that a JPEG round trip at ``quality`` changes."""
    return float(np.mean(jpeg_round_trip(image, quality) != image))


def jpeg_quality(frames: Sequence[np.ndarray]) -> int | None:
    """The JPEG quality (1 … 94) whose round trip leaves the frames as they are, or None.

    The quality whose round trip changes the fewest pixels of
    :data:`MIN_BLOCKS` or more unclipped blocks (the lowest of equals),
    where that is at most :data:`MAX_CHANGED` of them (see the module's
    docstring); None where no quality's is, or where too few blocks are
    clear of the clips and not flat.

    Parameters
    ----------
    frames : sequence of ndarray
        8-bit frames (H, W) or (H, W, 3), as decoded.
    """
    blocks = unclipped_blocks(frames)
    if blocks.shape[0] < MIN_BLOCKS:
        return None
    image = mosaic(blocks)
    shares = np.array([changed_share(image, int(quality)) for quality in QUALITIES])
    if shares.min() > MAX_CHANGED:
        return None
    # Neighbouring qualities' steps differ by a fraction of a step, and
    # coefficients of one or two steps (flat, low-contrast blocks) requantise
    # alike under both: the frames' own tables change the fewest pixels.
    return int(QUALITIES[int(np.argmin(shares))])
