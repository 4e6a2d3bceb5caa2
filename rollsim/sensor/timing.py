"""Rolling-shutter timing.

Frame k starts at t_k = k·T_f (plus ε_k with the ``frame_jitter`` effect).
Row y (0…H−1) of frame k integrates light over
[t_k + y·t_row, t_k + y·t_row + t_exp]. Reading a whole frame takes H·t_row;
the inter-frame gap is T_f − H·t_row.

A time t inside frame k maps to the fractional row (t − t_k − t_exp/2)/t_row:
the row whose exposure window is centred on t. Ground truth and the decoder
both report rows this way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RowTiming:
    """Row timing of a rolling-shutter camera.

    Parameters
    ----------
    frame_period_s : float
        T_f, seconds between frame starts.
    row_time_s : float
        t_row, seconds between the starts of successive rows.
    exposure_s : float
        t_exp, exposure of each row in seconds.
    height_px : int
        H, rows per frame.
    """

    frame_period_s: float
    row_time_s: float
    exposure_s: float
    height_px: int
    binning_rows: int = 1

    def __post_init__(self):
        if self.height_px * self.row_time_s > self.frame_period_s * (1 + 1e-12):
            raise ValueError("H·t_row exceeds the frame period")
        if not self.exposure_s > 0:
            raise ValueError(f"exposure_s must be > 0, got {self.exposure_s}")

    @classmethod
    def from_camera(cls, camera) -> "RowTiming":
        """Timing of a :class:`rollsim.scene.Camera`."""
        return cls(camera.frame_period_s, camera.row_time_s, camera.exposure_s, camera.height_px,
                   camera.binning_rows)

    def frame_start_s(self, frame) -> np.ndarray:
        """Nominal start t_k = k·T_f of frames ``frame`` (no jitter)."""
        return np.asarray(frame, dtype=np.float64) * self.frame_period_s

    def row_windows(self, frame_start_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Start and end times of every row's exposure window in a frame."""
        start = frame_start_s + self.row_offsets_s()
        return start, start + self.exposure_s

    def row_offsets_s(self) -> np.ndarray:
        """Each row's exposure start after the frame's: r·t_row, or with binned
        readout ⌊r/k⌋·k·t_row (the k rows of a group start together)."""
        rows = np.arange(self.height_px)
        k = self.binning_rows
        return (rows - rows % k) * self.row_time_s

    def row_of_time(self, t_s, frame_start_s: float) -> np.ndarray:
        """Fractional row whose exposure window is centred on times ``t_s``."""
        return (np.asarray(t_s, dtype=np.float64) - frame_start_s - 0.5 * self.exposure_s) / self.row_time_s

    def rows_span_s(self, first_row: int, last_row: int, frame_start_s: float) -> tuple[float, float]:
        """Time span [start of row ``first_row``, end of row ``last_row``'s exposure]."""
        k = self.binning_rows
        return (
            frame_start_s + (first_row - first_row % k) * self.row_time_s,
            frame_start_s + (last_row - last_row % k) * self.row_time_s + self.exposure_s,
        )
