"""A frame's mean electrons as its separable parts, written into a frame in one pass.

Before any noise, the default render's mean electrons are a few simple
parts: the LED's light on its box, its coverage times each row's exposure
to the LED's waveform; the ambient light on the background, one level for
the whole frame; and the light the LED's face reflects, a fixed map on the
footprint's box. Written stage by stage (a frame of zeros, the LED's box,
the background added to the frame, the face's correction to its box) that
is four passes over a float64 frame; :func:`materialize` writes the same
values in one, row by row. Stages that need the frame itself get it
through ``FrameState.electrons``, which writes it on first use.

Each value is computed with the same IEEE-754 operations in the same order
as the stages one by one: in the LED's box (coverage · row signal) +
background, elsewhere 0 + background, then + correction in the face's box.
The compiled kernel (:mod:`rollsim.jit`) and the numpy twin give the same
bytes (tested).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional

import numpy as np

from rollsim.jit import kernel


@dataclass(frozen=True)
class SeparableMeans:
    """Mean electrons (e⁻) of a frame of shape ``shape``, as parts.

    Attributes
    ----------
    shape : (int, int)
        (H, W) of the frame.
    rows, cols : slice
        The LED's box in the frame.
    coverage : ndarray of float64, shape (rows, cols)
        The LED's light on its box (relative; per-pixel rates folded in).
    row_signal : ndarray of float64, shape (rows,)
        Electrons per unit of coverage in each row of the box.
    background : float, ndarray of float64 of shape ``shape``, or None
        Electrons of the ambient light on each pixel (one level, or a map:
        vignetting, a colour filter), or None without ambient light.
    face_rows, face_cols : slice or None
        The box of ``correction``.
    correction : ndarray of float64 or None
        Electrons added on the face's box (the face's reflected light minus
        the background it hides), or None.
    """

    shape: tuple[int, int]
    rows: slice
    cols: slice
    coverage: np.ndarray
    row_signal: np.ndarray
    background: Optional[float | np.ndarray] = None
    face_rows: Optional[slice] = None
    face_cols: Optional[slice] = None
    correction: Optional[np.ndarray] = None

    def with_ambient(self, background: float | np.ndarray, face_rows: slice, face_cols: slice,
                     correction: np.ndarray) -> SeparableMeans:
        """These means plus a background (a level or a map) and a correction on the face's box."""
        if self.background is not None:
            raise ValueError("the means already hold an ambient background")
        if np.ndim(background) == 0:
            background = float(background)
        elif np.shape(background) != self.shape:
            raise ValueError(f"a background map of shape {np.shape(background)} on a frame of {self.shape}")
        return replace(self, background=background, face_rows=face_rows, face_cols=face_cols, correction=correction)


def materialize(means: SeparableMeans) -> np.ndarray:
    """The frame of mean electrons (float64, shape ``means.shape``), in one pass where compiled."""
    compiled = _fill_kernel.compiled
    if compiled is None:
        return _materialize_numpy(means)
    out = np.empty(means.shape)
    box = _box(means.rows, means.cols, means.coverage)
    face, correction = (0, 0, 0, 0), None
    if means.correction is not None and means.face_rows is not None and means.face_cols is not None:
        face = _box(means.face_rows, means.face_cols, means.correction)
        correction = np.ascontiguousarray(means.correction, dtype=np.float64)
    level, level_map = means.background, None
    if isinstance(level, np.ndarray):
        level, level_map = None, np.ascontiguousarray(level, dtype=np.float64)
    compiled(out, box, np.ascontiguousarray(means.coverage, dtype=np.float64),
             np.ascontiguousarray(means.row_signal, dtype=np.float64), level, level_map, face, correction)
    return out


def _box(rows: slice, cols: slice, values: np.ndarray) -> tuple[int, int, int, int]:
    """(first row, rows, first column, columns) of a box, checked against its values' shape."""
    height, width = rows.stop - rows.start, cols.stop - cols.start
    if values.shape != (height, width):
        raise ValueError(f"a box of {height} x {width} holds values of shape {values.shape}")
    return rows.start, height, cols.start, width


def _materialize_numpy(means: SeparableMeans) -> np.ndarray:
    # The stages' own operations, in their order.
    out = np.zeros(means.shape)
    np.multiply(means.coverage, means.row_signal[:, None], out=out[means.rows, means.cols])
    if means.background is not None:
        out += means.background
    if means.correction is not None:
        out[means.face_rows, means.face_cols] += means.correction
    return out


@kernel
def _fill_kernel(out, box, coverage, row_signal, level, level_map, face, correction):
    # Row by row (a row stays in the cache): the base level (0, or 0 + the
    # background, one level or a map's), the LED's box, then the face's
    # correction, each element with the stages' operations.
    first_row, n_rows, first_col, n_cols = box
    height, width = out.shape
    for y in range(height):
        if level_map is not None:
            for x in range(width):
                out[y, x] = 0.0 + level_map[y, x]
        elif level is not None:
            for x in range(width):
                out[y, x] = 0.0 + level
        else:
            for x in range(width):
                out[y, x] = 0.0
        r = y - first_row
        if 0 <= r < n_rows:
            signal = row_signal[r]
            if level_map is not None:
                for x in range(n_cols):
                    out[y, first_col + x] = coverage[r, x] * signal + level_map[y, first_col + x]
            elif level is not None:
                for x in range(n_cols):
                    out[y, first_col + x] = coverage[r, x] * signal + level
            else:
                for x in range(n_cols):
                    out[y, first_col + x] = coverage[r, x] * signal
        if correction is not None:
            face_row = y - face[0]
            if 0 <= face_row < face[1]:
                for x in range(face[3]):
                    out[y, face[2] + x] += correction[face_row, x]
    return 0
