"""A frame's mean electrons as its separable parts, which the compiled chain reads block by block.

Before any noise, the default render's mean electrons are a few simple
parts: the LED's light on its box, its coverage times each row's exposure
to the LED's waveform; the ambient light on the background, one level for
the whole frame; and the light the LED's face reflects, a fixed map on the
footprint's box. Written stage by stage (a frame of zeros, the LED's box,
the background added to the frame, the face's correction to its box) that
is four passes over a float64 frame. The compiled sensor chain
(:mod:`rollsim.sensor.chain`) instead writes each block's means from the
parts as it needs them (:func:`kernel_parts`), so the frame is never
written nor read back; stages that need the frame itself get it through
``FrameState.electrons``, which writes it (:func:`materialize`) on first
use.

Each value is computed with the same IEEE-754 operations in the same order
as the stages one by one: in the LED's box (coverage · row signal) +
background, elsewhere 0 + background, then + correction in the face's box.
The chain's blocks and :func:`materialize` give the same bytes (tested).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional

import numpy as np


# The parts that join after the LED's light, in the order their stages apply them.
LATE_PARTS = ("background", "gain", "offset")


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
    background : float, ndarray of float64 of shape ``shape`` or ``(H, 1)``, or None
        Electrons of the ambient light on each pixel: one level, a level
        per row (flicker; a column, so that it broadcasts along the rows),
        or a map (vignetting, a colour filter); None without ambient light.
    face_rows, face_cols : slice or None
        The box of ``correction``.
    correction : ndarray of float64 or None
        Electrons added on the face's box (the face's reflected light minus
        the background it hides), or None.
    gain : ndarray of float32, shape ``shape``, or None
        Each pixel's photo-response gain (PRNU), multiplying the sum above.
    offset : float, ndarray of float32 of shape ``shape``, or None
        Electrons added last (dark current): one level or a map.
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
    gain: Optional[np.ndarray] = None
    offset: Optional[float | np.ndarray] = None

    def accepts(self, part: str) -> bool:
        """Whether ``part`` ("background", "gain" or "offset") may join: it is not held, nor one applied after it.

        The parts apply in :data:`LATE_PARTS`' order, as their stages do.
        """
        return all(getattr(self, later) is None for later in LATE_PARTS[LATE_PARTS.index(part):])

    def with_ambient(self, background: float | np.ndarray, face_rows: slice, face_cols: slice,
                     correction: np.ndarray) -> SeparableMeans:
        """These means plus a background (a level, a level per row or a map) and a correction on the face's box."""
        if not self.accepts("background"):
            raise ValueError("the means already hold an ambient background, or a gain or offset applied after it")
        if np.ndim(background) == 0:
            background = float(background)
        elif np.shape(background) not in (self.shape, (self.shape[0], 1)):
            raise ValueError(f"a background of shape {np.shape(background)} on a frame of {self.shape}")
        return replace(self, background=background, face_rows=face_rows, face_cols=face_cols, correction=correction)

    def with_gain(self, gain: np.ndarray) -> SeparableMeans:
        """These means times a float32 gain map of the frame's shape (PRNU)."""
        if not self.accepts("gain"):
            raise ValueError("the means already hold a gain, or an offset applied after it")
        if not (isinstance(gain, np.ndarray) and gain.dtype == np.float32 and gain.shape == self.shape):
            raise ValueError(f"a gain map must be float32 of shape {self.shape}")
        return replace(self, gain=gain)

    def with_offset(self, offset: float | np.ndarray) -> SeparableMeans:
        """These means plus an offset in electrons: a level, or a float32 map of the frame's shape (dark current)."""
        if not self.accepts("offset"):
            raise ValueError("the means already hold an offset")
        if np.ndim(offset) == 0:
            offset = float(offset)
        elif not (isinstance(offset, np.ndarray) and offset.dtype == np.float32 and offset.shape == self.shape):
            raise ValueError(f"an offset map must be float32 of shape {self.shape}")
        return replace(self, offset=offset)


def materialize(means: SeparableMeans) -> np.ndarray:
    """The frame of mean electrons (float64, shape ``means.shape``), the stages' operations in their order.

    For the stages that read the frame itself; the compiled sensor chain
    takes the parts (:func:`kernel_parts`) and never writes the frame.
    """
    out = np.zeros(means.shape)
    np.multiply(means.coverage, means.row_signal[:, None], out=out[means.rows, means.cols])
    if means.background is not None:
        out += means.background
    if means.correction is not None:
        out[means.face_rows, means.face_cols] += means.correction
    if means.gain is not None:
        out *= means.gain
    if means.offset is not None:
        out += means.offset
    return out


def kernel_parts(means: SeparableMeans) -> tuple:
    """The parts as a compiled kernel reads them, with no None (numba types a tuple by its members).

    ``(shape, box, coverage, row_signal, level_kind, level, level_map, face, correction, gain, offset_kind,
    offset_level, offset_map)``:
    ``box`` and ``face`` are (first row, rows, first column, columns);
    ``level_kind`` is 0 (no background), 1 (the level ``level``), 2 (the
    map ``level_map``) or 3 (a level per row, ``level_map`` of shape
    (H, 1)); an absent map or correction is a 1 × 1 zero array (a face of
    no rows). ``gain`` and ``offset_map`` are flat float32 maps, or empty
    where absent; ``offset_kind`` is 0 (none), 1 (the level
    ``offset_level``) or 2 (the map).
    """
    unused = np.zeros((1, 1))
    level_kind, level, level_map = 0, 0.0, unused
    if isinstance(means.background, np.ndarray):
        level_kind = 3 if means.background.shape[1] == 1 else 2
        level_map = np.ascontiguousarray(means.background, dtype=np.float64)
    elif means.background is not None:
        level_kind, level = 1, float(means.background)
    face, correction = (0, 0, 0, 0), unused
    if means.correction is not None and means.face_rows is not None and means.face_cols is not None:
        face = _box(means.face_rows, means.face_cols, means.correction)
        correction = np.ascontiguousarray(means.correction, dtype=np.float64)
    absent = np.zeros(0, dtype=np.float32)
    gain = absent if means.gain is None else np.ascontiguousarray(means.gain).ravel()
    offset_kind, offset_level, offset_map = 0, 0.0, absent
    if isinstance(means.offset, np.ndarray):
        offset_kind, offset_map = 2, np.ascontiguousarray(means.offset).ravel()
    elif means.offset is not None:
        offset_kind, offset_level = 1, float(means.offset)
    return (tuple(int(n) for n in means.shape), _box(means.rows, means.cols, means.coverage),
            np.ascontiguousarray(means.coverage, dtype=np.float64),
            np.ascontiguousarray(means.row_signal, dtype=np.float64), level_kind, level, level_map, face, correction,
            gain, offset_kind, offset_level, offset_map)


def _box(rows: slice, cols: slice, values: np.ndarray) -> tuple[int, int, int, int]:
    """(first row, rows, first column, columns) of a box, checked against its values' shape."""
    height, width = rows.stop - rows.start, cols.stop - cols.start
    if values.shape != (height, width):
        raise ValueError(f"a box of {height} x {width} holds values of shape {values.shape}")
    return int(rows.start), int(height), int(cols.start), int(width)
