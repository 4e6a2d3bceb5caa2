"""Joining the parts of one LED footprint that a stretch without stripes splits.

An exposure of E chips averages each row over E chips, so a pattern whose
period divides E leaves no stripes at all: at 2 chips a run of equal
Manchester bits (chips 0101…, period 2) renders as one flat band at the
LED's mean level, and at 4 chips period-4 patterns do too. Such a band is
lit but not modulated, so where the footprint is dim (its rim, its glare)
neither the level nor the modulation test of :mod:`decoder.region` takes
it, and the footprint falls apart into a part above the band and a part
below. A PHY-SDU across the band is then in neither.

The band lies inside one PHY-SDU (every PHY-SDU holds a SYNC, whose run of
ON chips shows under any exposure the decoder reads), so it is shorter than
a PHY-SDU; and it sits at the LED's mean level, which is above the level of
its OFF stripes. So each part grows up and down over the rows brighter
than the midpoint between the mean and the darkest row of its end (up to a
PHY-SDU's height), and parts that then meet in the same columns are joined:
a gap of background between two LEDs is at their OFF level or below, and
stays a gap.

Masks here are on the block grid of :mod:`decoder.region`: a part is a 0/1
``uint8`` mask, its first block column ``x`` and first block row ``y``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Part:
    """A connected part of a footprint on the block grid.

    Attributes
    ----------
    mask : ndarray of uint8, shape (rows, cols)
        1 on the part's blocks, inside its bounding box.
    x, y : int
        First block column and block row of the bounding box.
    area : int
        Blocks in the part.
    """

    mask: np.ndarray
    x: int
    y: int
    area: int

    @property
    def stop_row(self) -> int:
        """Block row just past the part."""
        return self.y + self.mask.shape[0]

    @property
    def stop_col(self) -> int:
        """Block column just past the part."""
        return self.x + self.mask.shape[1]


def lit_threshold(gray: np.ndarray, rows: slice, cols: slice) -> float:
    """Level (DN) a flat band next to these rows must exceed: midway between their mean and their darkest row.

    Parameters
    ----------
    gray : ndarray, shape (block rows, block columns)
        Block means.
    rows, cols : slice
        The facing end of a part (block rows) and the columns compared.
    """
    means = gray[rows, cols].mean(axis=1)
    return 0.5 * (float(means.mean()) + float(means.min()))


def _shared_cols(upper: Part, lower: Part) -> slice | None:
    """Block columns both parts span, if at least half the narrower one's width."""
    start, stop = max(upper.x, lower.x), min(upper.stop_col, lower.stop_col)
    narrower = min(upper.mask.shape[1], lower.mask.shape[1])
    return slice(start, stop) if 2 * (stop - start) >= narrower else None


def lit_rows(gray: np.ndarray, band: slice, cols: slice, threshold: float, outward: int) -> int:
    """Block rows of ``band`` lit above ``threshold`` without a break, counted from its inner end.

    ``outward`` is +1 for a band below a part (counted from its first row),
    -1 for one above (from its last).
    """
    lit = gray[band, cols].mean(axis=1) > threshold
    if outward < 0:
        lit = lit[::-1]
    dark = np.flatnonzero(~lit)
    return int(dark[0]) if dark.size else int(lit.size)


def grown(gray: np.ndarray, part: Part, max_gap: int, end_rows: int) -> Part:
    """``part`` grown up and down over lit rows (:func:`lit_threshold`), at most ``max_gap`` block rows each way.

    A grown row repeats the mask of the part's row it grows from.
    """
    cols = slice(part.x, part.stop_col)
    top_end = slice(part.y, min(part.stop_row, part.y + end_rows))
    bottom_end = slice(max(part.y, part.stop_row - end_rows), part.stop_row)
    above = slice(max(0, part.y - max_gap), part.y)
    below = slice(part.stop_row, min(gray.shape[0], part.stop_row + max_gap))
    up = lit_rows(gray, above, cols, lit_threshold(gray, top_end, cols), -1) if above.stop > above.start else 0
    down = lit_rows(gray, below, cols, lit_threshold(gray, bottom_end, cols), +1) if below.stop > below.start else 0
    if up == 0 and down == 0:
        return part
    mask = np.concatenate([np.repeat(part.mask[:1], up, axis=0), part.mask, np.repeat(part.mask[-1:], down, axis=0)])
    return Part(mask, part.x, part.y - up, int(np.count_nonzero(mask)))


def joined(upper: Part, lower: Part) -> Part:
    """One part of two whose rows overlap or touch (``upper`` starting first)."""
    x, stop_col = min(upper.x, lower.x), max(upper.stop_col, lower.stop_col)
    mask = np.zeros((max(upper.stop_row, lower.stop_row) - upper.y, stop_col - x), np.uint8)
    mask[: upper.mask.shape[0], upper.x - x : upper.stop_col - x] |= upper.mask
    rows = slice(lower.y - upper.y, lower.stop_row - upper.y)
    mask[rows, lower.x - x : lower.stop_col - x] |= lower.mask
    return Part(mask, x, upper.y, int(np.count_nonzero(mask)))


def _join_one_pair(parts: list[Part]) -> list[Part] | None:
    """``parts`` with the first pair that overlaps down the rows in shared columns joined, or None if none does."""
    for i, upper in enumerate(parts):
        for j, lower in enumerate(parts):
            if i != j and upper.y <= lower.y <= upper.stop_row and _shared_cols(upper, lower) is not None:
                rest = [p for k, p in enumerate(parts) if k not in (i, j)]
                return [joined(upper, lower), *rest]
    return None


def bridged(gray: np.ndarray, parts: list[Part], max_gap: int, end_rows: int) -> list[Part]:
    """Grow the parts over lit bands without stripes, and join those that then meet in shared columns.

    Parameters
    ----------
    gray : ndarray, shape (block rows, block columns)
        Block means (DN).
    parts : list of Part
    max_gap : int
        Most block rows a part grows by each way (a PHY-SDU's height), so
        two parts up to twice that apart may meet; 0 leaves the parts as
        they are.
    end_rows : int
        Block rows at each part's end that set the lit threshold
        (:func:`lit_threshold`): several chips.

    Returns
    -------
    list of Part
        Largest area first.
    """
    if max_gap <= 0:
        return parts
    parts = [grown(gray, p, max_gap, end_rows) for p in parts]
    while (fewer := _join_one_pair(parts)) is not None:
        parts = fewer
    return sorted(parts, key=lambda p: -p.area)
