"""A camera fit checked by rendering it: row profiles and noise, frames against the fit."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from rollsim.fit.measure import column_pattern_std, level_noise_pairs, temporal_noise
from rollsim.fit.noise import unclipped
from rollsim.fit.refine import CameraFit


def bright_rows_noise(levels: np.ndarray, variances: np.ndarray) -> float:
    """Temporal noise (8-bit levels) of the brightest quarter of the points; 0 without points."""
    if levels.size == 0:
        return 0.0
    top = levels >= np.percentile(levels, 75)
    return float(np.sqrt(np.mean(variances[top])))


def aligned_correlation(a: np.ndarray, b: np.ndarray, period_rows: float, step: float = 0.1) -> float:
    """Pearson correlation of two row profiles, ``b`` shifted by the best fraction of a
    stripe period in [−P/2, P/2] (a free-running camera's stripes sit at any phase).

    The ends, P/2 rows each, are left out so that every shift compares the same rows.
    """
    margin = int(math.ceil(period_rows / 2)) + 1
    if a.size <= 2 * margin + 2:
        raise ValueError("the row profiles are shorter than a stripe period")
    rows = np.arange(a.size, dtype=np.float64)
    inner = rows[margin:-margin]
    best = -1.0
    fixed = a[margin:-margin] - a[margin:-margin].mean()
    for shift in np.arange(-period_rows / 2, period_rows / 2 + step, step):
        moved = np.interp(inner + shift, rows, b)
        moved = moved - moved.mean()
        norm = float(np.sqrt(np.sum(fixed**2) * np.sum(moved**2)))
        # A flat profile correlates with nothing (0, not NaN).
        r = float(np.sum(fixed * moved)) / norm if norm > 0 else 0.0
        best = max(best, r)
    return best


@dataclass(frozen=True)
class Comparison:
    """The frames beside frames rendered from the fit."""

    correlations: tuple  # per frame pair, aligned Pearson r of the row profiles
    noise: dict  # name -> (frames, rendered), 8-bit levels
    profile_pair: tuple  # (frames' first profile, rendered first profile), for the report's plot
    frame_pair: tuple  # (frames' first, rendered first) cropped at the LED, 8-bit, for the report's picture


# The report's crops: the LED's disk and this much around it, at most MAX_CROP_PX on a side.
CROP_RADII = 1.4
MAX_CROP_PX = 480


def led_crop(fit: CameraFit, shape: tuple[int, int]) -> tuple[slice, slice]:
    """Rows and columns of a crop around the LED (the whole frame when it fills it),
    strided to at most :data:`MAX_CROP_PX` on a side."""
    h, w = shape
    disk = fit.measured.region.disk
    if disk is None:
        r0, r1, c0, c1 = 0, h, 0, w
    else:
        reach = CROP_RADII * disk.radius_px
        r0, r1 = max(0, int(disk.centre_y_px - reach)), min(h, int(math.ceil(disk.centre_y_px + reach)))
        c0, c1 = max(0, int(disk.centre_x_px - reach)), min(w, int(math.ceil(disk.centre_x_px + reach)))
    step = max(1, int(math.ceil(max(r1 - r0, c1 - c0) / MAX_CROP_PX)))
    return slice(r0, r1, step), slice(c0, c1, step)


def output_noise(frames: Sequence[np.ndarray], fit: CameraFit) -> dict:
    """The temporal and fixed-pattern noise of frames in the fit's regions, 8-bit levels: the LED's
    brightest unclipped rows that hold one level in two frames, and the background where there is one."""
    levels, variances = level_noise_pairs(frames, *fit.band)
    keep = unclipped(levels)
    out = {"temporal_led_bright": bright_rows_noise(levels[keep], variances[keep])}
    if fit.background_block is not None:
        bg = temporal_noise(frames, *fit.background_block)
        mean_frame = np.mean(frames, axis=0)
        out.update(temporal_background=bg.pixel_std, row_temporal_background=bg.row_std,
                   column_pattern_background=column_pattern_std(mean_frame, *fit.background_block, len(frames),
                                                                bg.pixel_std))
    return out


def compare(frames: Sequence[np.ndarray], fit: CameraFit) -> Comparison:
    """Render the fitted scene (as many frames) and set it beside the frames."""
    from rollsim.render import render_frames

    frames = fit.grey(frames)
    from rollsim.fit.refine import one_gop

    images, _ = render_frames(one_gop(fit.scene, len(frames)), len(frames))
    rendered = fit.grey(images)
    rows, cols = fit.band
    real = [f[rows, cols].mean(axis=1) for f in frames]
    sim = [f[rows, cols].mean(axis=1) for f in rendered]
    correlations = tuple(aligned_correlation(a, b, fit.period_rows) for a, b in zip(real, sim))
    ours, theirs = output_noise(frames, fit), output_noise(rendered, fit)
    crop = led_crop(fit, frames[0].shape)
    pair = (np.clip(frames[0][crop], 0, 255).astype(np.uint8), np.clip(rendered[0][crop], 0, 255).astype(np.uint8))
    return Comparison(correlations, {k: (ours[k], theirs[k]) for k in ours}, (real[0], sim[0]), pair)
