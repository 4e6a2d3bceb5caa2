"""The LED footprint: the fraction of each pixel's area the LED image covers.

Pixel (x, y) spans [x, x+1) × [y, y+1) in pixel coordinates. The footprint is
a disk of diameter D or an axis-aligned square of side D centred at (cx, cy).
Coverage is computed exactly (closed-form area of a disk or square clipped to
each pixel) or by supersampling n × n points per pixel; that is the fidelity
knob ``edge``. Only the footprint's bounding box is stored, so an LED far
smaller or larger than the frame costs no more than it covers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rollsim.numerics.portable_math import arcsin  # numpy's differs in the last bit between CPUs

EDGE_METHODS = ("exact", "supersample1", "supersample4", "supersample16")
# A row counts as an LED row when the footprint covers at least this much
# pixel area in it: a sliver at the tangent of a disk carries no usable light.
MIN_ROW_COVERAGE_PX = 0.5


@dataclass(frozen=True)
class Footprint:
    """Coverage of a footprint over a frame, stored on its bounding box.

    Attributes
    ----------
    rows, cols : slice
        Bounding box within the frame (may be empty).
    coverage : ndarray of float64, shape (n_rows, n_cols)
        Covered fraction of each pixel's area, in [0, 1].
    """

    rows: slice
    cols: slice
    coverage: np.ndarray

    @property
    def empty(self) -> bool:
        return self.coverage.size == 0 or not np.any(self.coverage > 0)

    def row_coverage(self, frame_height: int) -> np.ndarray:
        """Covered pixel area summed over each frame row (length ``frame_height``)."""
        out = np.zeros(frame_height)
        out[self.rows] = self.coverage.sum(axis=1)
        return out

    def dense(self, shape: tuple[int, int]) -> np.ndarray:
        """Coverage as a full frame-sized array."""
        out = np.zeros(shape)
        out[self.rows, self.cols] = self.coverage
        return out


def _bounding_box(centre: float, size: float, limit: int) -> slice:
    lo = max(0, int(np.floor(centre - 0.5 * size)))
    hi = min(limit, int(np.ceil(centre + 0.5 * size)))
    return slice(lo, max(lo, hi))


def _chord_primitive(t: np.ndarray, r: float) -> np.ndarray:
    """∫_{-r}^{t} √(r² − s²) ds for t in [−r, r]."""
    t = np.clip(t, -r, r)
    return 0.5 * (t * np.sqrt(np.maximum(r * r - t * t, 0.0)) + r * r * arcsin(t / r)) + 0.25 * np.pi * r * r


def _disk_corner_area(x: np.ndarray, y: np.ndarray, r: float) -> np.ndarray:
    """Area of the disk of radius r at the origin with X ≤ x and Y ≤ y (``x`` and ``y`` broadcast together)."""
    x = np.clip(x, -r, r)
    yc = np.clip(y, -r, r)
    a = np.sqrt(np.maximum(r * r - yc * yc, 0.0))  # |t| < a: chord crosses Y = y
    middle = np.clip(x, -a, a)
    # The primitive at x, at −a and at a, each on its own array: the clipped
    # abscissae below are one of these, so their primitives are picked, not
    # recomputed (the same values: equal arguments where the picks meet). On
    # a grid of pixel corners that is one arcsin per column and per row
    # instead of several per corner.
    h_x, h_minus_a, h_a = _chord_primitive(x, r), _chord_primitive(-a, r), _chord_primitive(a, r)
    left = x < -a
    h_middle = np.where(left, h_minus_a, np.where(x > a, h_a, h_x))  # H(clip(x, −a, a))
    h_low = np.where(left, h_x, h_minus_a)  # H(min(x, −a))
    # Inner band |t| < a: from the bottom of the chord (−h) up to y.
    inner = yc * (middle + a) + h_middle - h_minus_a
    # Outer bands |t| ≥ a: the whole chord (y ≥ 0) or nothing (y < 0).
    outer = 2.0 * (h_low + np.maximum(h_x - h_a, 0.0))
    return inner + np.where(yc >= 0, outer, 0.0)


# Inclusion-exclusion of four corner areas up to πr² loses about
# 4·πr²·2.2e-16 ≈ 3e-15·r² to rounding; coverages that close to 0 or 1 are
# exactly 0 or 1, so that fully covered pixels share one value (the
# shot-noise sampler is fast on runs of equal values).
_SNAP = 1e-14


def _snap(coverage: np.ndarray, r: float) -> np.ndarray:
    coverage = np.clip(coverage, 0.0, 1.0)
    tolerance = _SNAP * max(1.0, r * r)
    coverage[coverage < tolerance] = 0.0
    coverage[coverage > 1.0 - tolerance] = 1.0
    return coverage


# Pixel rows per block of _disk_exact: its float64 temporaries (a dozen of
# 32 x 1920) stay in cache; frame-sized ones would not.
_BLOCK_ROWS = 32


def _disk_exact(xs: np.ndarray, ys: np.ndarray, r: float) -> np.ndarray:
    # Inclusion-exclusion over the four corners of each pixel, block of rows
    # by block (each block's corner areas are those of the whole grid).
    coverage = np.empty((ys.size - 1, xs.size - 1))
    for start in range(0, ys.size - 1, _BLOCK_ROWS):
        stop = min(start + _BLOCK_ROWS, ys.size - 1)
        G = _disk_corner_area(xs[None, :], ys[start : stop + 1, None], r)
        coverage[start:stop] = _snap(G[1:, 1:] - G[1:, :-1] - G[:-1, 1:] + G[:-1, :-1], r)
    return coverage


def _interval_overlap(lo: np.ndarray, half: float) -> np.ndarray:
    return np.clip(np.minimum(lo + 1.0, half) - np.maximum(lo, -half), 0.0, 1.0)


def _supersample(xs: np.ndarray, ys: np.ndarray, size: float, shape: str, n: int) -> np.ndarray:
    """n × n samples per pixel. ``xs``: column edges, shape (m+1,), or one row
    of them per pixel row, (rows, m+1); ``ys``: the top edge of each pixel row, (rows,)."""
    offsets = (np.arange(n) + 0.5) / n
    xs = np.atleast_2d(xs)
    px = (xs[:, :-1, None] + offsets).reshape(xs.shape[0], -1)[:, None, :]
    py = (ys[:, None] + offsets)[:, :, None]
    half = 0.5 * size
    if shape == "disk":
        inside = (px**2 + py**2) <= half * half
    else:
        inside = (np.abs(px) <= half) & (np.abs(py) <= half)
    return inside.reshape(len(ys), n, xs.shape[1] - 1, n).mean(axis=(1, 3))


_SAMPLES_PER_SIDE = {"supersample1": 1, "supersample4": 2, "supersample16": 4}


def _check_arguments(size_px: float, shape: str, edge: str) -> None:
    if not size_px > 0:
        raise ValueError(f"size_px must be > 0, got {size_px}")
    if shape not in ("disk", "square"):
        raise ValueError(f"unknown footprint shape {shape!r}")
    if edge not in EDGE_METHODS:
        raise ValueError(f"unknown edge method {edge!r}; expected one of {list(EDGE_METHODS)}")


def footprint(centre_px: tuple[float, float], size_px: float, shape: str, frame_shape: tuple[int, int], edge: str = "exact") -> Footprint:
    """Coverage of a disk or square footprint over a frame.

    Parameters
    ----------
    centre_px : (float, float)
        ``(x, y)`` of the footprint centre, in pixel coordinates (pixel
        (x, y) spans [x, x+1) × [y, y+1)); may lie outside the frame.
    size_px : float
        Diameter (disk) or side (square), in pixels (> 0).
    shape : {"disk", "square"}
    frame_shape : (int, int)
        ``(height, width)`` of the frame.
    edge : {"exact", "supersample1", "supersample4", "supersample16"}
        Exact area, or 1, 4 (2×2) or 16 (4×4) samples per pixel.
    """
    _check_arguments(size_px, shape, edge)
    height, width = frame_shape
    cx, cy = centre_px
    rows, cols = _bounding_box(cy, size_px, height), _bounding_box(cx, size_px, width)
    # Pixel edges relative to the centre.
    xs = np.arange(cols.start, cols.stop + 1, dtype=np.float64) - cx
    ys = np.arange(rows.start, rows.stop + 1, dtype=np.float64) - cy
    if len(xs) < 2 or len(ys) < 2:
        return Footprint(rows, cols, np.zeros((len(ys) - 1 if len(ys) else 0, len(xs) - 1 if len(xs) else 0)))
    if edge != "exact":
        return Footprint(rows, cols, _supersample(xs, ys[:-1], size_px, shape, _SAMPLES_PER_SIDE[edge]))
    if shape == "disk":
        return Footprint(rows, cols, _disk_exact(xs, ys, 0.5 * size_px))
    half = 0.5 * size_px
    return Footprint(rows, cols, _interval_overlap(ys[:-1], half)[:, None] * _interval_overlap(xs[:-1], half)[None, :])


# ------------------------------------------------- a centre for every row


def _ragged_columns(starts: np.ndarray, stops: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(row, column) of every column in [starts[i], stops[i]) of each row i."""
    lengths = np.maximum(stops - starts, 0)
    row = np.repeat(np.arange(starts.size), lengths)
    first = np.repeat(starts - (np.cumsum(lengths) - lengths), lengths)
    return row, first + np.arange(row.size)


def _disk_exact_rows(cols: slice, row_y: np.ndarray, cx: np.ndarray, cy: np.ndarray, r: float) -> np.ndarray:
    """Exact disk coverage with the centre (cx[i], cy[i]) for pixel row i.

    Pixels whose four corners lie inside the disk are fully covered (the disk
    is convex); the closed form runs only on the others that the row's chord
    reaches, O(perimeter) pixels instead of O(area).
    """
    y0, y1 = row_y - cy, (row_y + 1.0) - cy

    def chord(y):
        y = np.clip(y, -r, r)
        return np.sqrt(np.maximum(r * r - y * y, 0.0))

    outer = np.where((y0 < 0.0) & (y1 > 0.0), r, np.maximum(chord(y0), chord(y1)))
    inner = np.where((y0 >= -r) & (y1 <= r), np.minimum(chord(y0), chord(y1)), 0.0)
    lo = np.clip(np.floor(cx - outer), cols.start, cols.stop).astype(np.int64)
    hi = np.clip(np.ceil(cx + outer), cols.start, cols.stop).astype(np.int64)
    # A hair inside the chord, so rounding never calls a cut pixel full.
    margin = 1e-9 * max(1.0, r)
    inner_lo = np.clip(np.ceil(cx - inner + margin), lo, hi).astype(np.int64)
    inner_hi = np.clip(np.floor(cx + inner - margin), inner_lo, hi).astype(np.int64)
    columns = np.arange(cols.start, cols.stop)
    coverage = ((columns >= inner_lo[:, None]) & (columns < inner_hi[:, None])).astype(np.float64)
    row, col = (np.concatenate(pair) for pair in zip(_ragged_columns(lo, inner_lo), _ragged_columns(inner_hi, hi)))
    x0, x1 = col.astype(np.float64) - cx[row], (col + 1).astype(np.float64) - cx[row]
    Y0, Y1 = y0[row], y1[row]
    G = _disk_corner_area
    coverage[row, col - cols.start] = _snap(G(x1, Y1, r) - G(x0, Y1, r) - G(x1, Y0, r) + G(x0, Y0, r), r)
    return coverage


def footprint_per_row(
    centre_x_px, centre_y_px, size_px: float, shape: str, frame_shape: tuple[int, int], edge: str = "exact"
) -> Footprint:
    """Coverage of a footprint whose centre differs from row to row.

    Pixel row y sees the footprint centred at ``(centre_x_px[y],
    centre_y_px[y])``: a moving LED seen through a rolling shutter, each row
    at its own time. With the same centre on every row this is
    :func:`footprint`, to the last bit.

    Parameters
    ----------
    centre_x_px, centre_y_px : array_like of float, shape (height,)
        Footprint centre for each frame row, in pixel coordinates.
    size_px, shape, frame_shape, edge
        As for :func:`footprint`.
    """
    _check_arguments(size_px, shape, edge)
    height, width = frame_shape
    cx_all = np.asarray(centre_x_px, dtype=np.float64)
    cy_all = np.asarray(centre_y_px, dtype=np.float64)
    half = 0.5 * size_px
    y = np.arange(height)
    touched = np.flatnonzero((np.floor(cy_all - half) <= y) & (y < np.ceil(cy_all + half)))
    if touched.size == 0:
        return Footprint(slice(0, 0), slice(0, 0), np.zeros((0, 0)))
    rows = slice(int(touched[0]), int(touched[-1]) + 1)
    cx, cy = cx_all[rows], cy_all[rows]
    lo = max(0, int(np.floor(cx - half).min()))
    cols = slice(lo, max(lo, min(width, int(np.ceil(cx + half).max()))))
    row_y = np.arange(rows.start, rows.stop, dtype=np.float64)
    if cols.stop == cols.start:
        return Footprint(rows, cols, np.zeros((row_y.size, 0)))
    if shape == "disk" and edge == "exact":
        return Footprint(rows, cols, _disk_exact_rows(cols, row_y, cx, cy, half))
    xs = np.arange(cols.start, cols.stop + 1, dtype=np.float64)[None, :] - cx[:, None]
    if edge != "exact":
        return Footprint(rows, cols, _supersample(xs, row_y - cy, size_px, shape, _SAMPLES_PER_SIDE[edge]))
    return Footprint(rows, cols, _interval_overlap(row_y - cy, half)[:, None] * _interval_overlap(xs[:, :-1], half))


def led_rows_from_coverage(row_coverage: np.ndarray) -> tuple[int, int] | None:
    """First and last row whose covered area reaches :data:`MIN_ROW_COVERAGE_PX`.

    Parameters
    ----------
    row_coverage : ndarray, shape (H,)
        Covered pixel area of each row (:meth:`Footprint.row_coverage`), in pixels.

    Returns
    -------
    (int, int) or None
        None if no row reaches it.
    """
    rows = np.flatnonzero(row_coverage >= MIN_ROW_COVERAGE_PX)
    return (int(rows[0]), int(rows[-1])) if rows.size else None
