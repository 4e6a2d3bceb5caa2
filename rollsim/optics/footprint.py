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

EDGE_METHODS = ("exact", "supersample1", "supersample4", "supersample16")


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
    return 0.5 * (t * np.sqrt(np.maximum(r * r - t * t, 0.0)) + r * r * np.arcsin(t / r)) + 0.25 * np.pi * r * r


def _disk_corner_area(x: np.ndarray, y: np.ndarray, r: float) -> np.ndarray:
    """Area of the disk of radius r at the origin with X ≤ x and Y ≤ y."""
    x = np.clip(x, -r, r)
    yc = np.clip(y, -r, r)
    a = np.sqrt(np.maximum(r * r - yc * yc, 0.0))  # |t| < a: chord crosses Y = y
    middle = np.clip(x, -a, a)
    H = _chord_primitive
    # Inner band |t| < a: from the bottom of the chord (−h) up to y.
    inner = yc * (middle + a) + H(middle, r) - H(-a, r)
    # Outer bands |t| ≥ a: the whole chord (y ≥ 0) or nothing (y < 0).
    outer = 2.0 * (H(np.minimum(x, -a), r) + np.maximum(H(x, r) - H(a, r), 0.0))
    return inner + np.where(yc >= 0, outer, 0.0)


# Inclusion-exclusion of four corner areas up to πr² loses about
# 4·πr²·2.2e-16 ≈ 3e-15·r² to rounding; coverages that close to 0 or 1 are
# exactly 0 or 1, so that fully covered pixels share one value (the
# shot-noise sampler is fast on runs of equal values).
_SNAP = 1e-14


def _disk_exact(xs: np.ndarray, ys: np.ndarray, r: float) -> np.ndarray:
    # Inclusion-exclusion over the four corners of each pixel.
    G = _disk_corner_area(xs[None, :], ys[:, None], r)
    coverage = np.clip(G[1:, 1:] - G[1:, :-1] - G[:-1, 1:] + G[:-1, :-1], 0.0, 1.0)
    tolerance = _SNAP * max(1.0, r * r)
    coverage[coverage < tolerance] = 0.0
    coverage[coverage > 1.0 - tolerance] = 1.0
    return coverage


def _interval_overlap(lo: np.ndarray, half: float) -> np.ndarray:
    return np.clip(np.minimum(lo + 1.0, half) - np.maximum(lo, -half), 0.0, 1.0)


def _supersample(xs: np.ndarray, ys: np.ndarray, size: float, shape: str, n: int) -> np.ndarray:
    offsets = (np.arange(n) + 0.5) / n
    px = (xs[:-1, None] + offsets[None, :]).ravel()
    py = (ys[:-1, None] + offsets[None, :]).ravel()
    half = 0.5 * size
    if shape == "disk":
        inside = (px[None, :] ** 2 + py[:, None] ** 2) <= half * half
    else:
        inside = (np.abs(px)[None, :] <= half) & (np.abs(py)[:, None] <= half)
    return inside.reshape(len(ys) - 1, n, len(xs) - 1, n).mean(axis=(1, 3))


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
    if not size_px > 0:
        raise ValueError(f"size_px must be > 0, got {size_px}")
    if shape not in ("disk", "square"):
        raise ValueError(f"unknown footprint shape {shape!r}")
    if edge not in EDGE_METHODS:
        raise ValueError(f"unknown edge method {edge!r}; expected one of {list(EDGE_METHODS)}")
    height, width = frame_shape
    cx, cy = centre_px
    rows, cols = _bounding_box(cy, size_px, height), _bounding_box(cx, size_px, width)
    # Pixel edges relative to the centre.
    xs = np.arange(cols.start, cols.stop + 1, dtype=np.float64) - cx
    ys = np.arange(rows.start, rows.stop + 1, dtype=np.float64) - cy
    if len(xs) < 2 or len(ys) < 2:
        return Footprint(rows, cols, np.zeros((len(ys) - 1 if len(ys) else 0, len(xs) - 1 if len(xs) else 0)))
    if edge != "exact":
        n = {"supersample1": 1, "supersample4": 2, "supersample16": 4}[edge]
        return Footprint(rows, cols, _supersample(xs, ys, size_px, shape, n))
    if shape == "disk":
        return Footprint(rows, cols, _disk_exact(xs, ys, 0.5 * size_px))
    half = 0.5 * size_px
    return Footprint(rows, cols, _interval_overlap(ys[:-1], half)[:, None] * _interval_overlap(xs[:-1], half)[None, :])
