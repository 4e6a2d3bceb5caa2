"""A camera fit checked by rendering it: row profiles and noise, frames against the fit."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from rollsim.fit.measure import column_pattern_std, level_noise_pairs, temporal_noise
from rollsim.fit.noise import unclipped
from rollsim.fit.refine import CameraFit


def bright_level_floor(levels: np.ndarray) -> float:
    """The least level (8-bit) of the brightest quarter of the points; +inf without points."""
    return float(np.percentile(levels, 75)) if levels.size else math.inf


def bright_rows_noise(levels: np.ndarray, variances: np.ndarray, floor: float | None = None) -> float:
    """Temporal noise (8-bit levels) of the points at or above ``floor``: RMS over them; 0 without any.

    ``floor`` defaults to the points' own :func:`bright_level_floor`. Frames
    and a render of them are compared at the frames' floor: through a tone
    curve the noise in output levels depends on the level (sRGB's toe
    multiplies a dark row's noise), so a render's own brightest quarter,
    whose rows hold one level in two frames at other places, can reach down
    into its dark rows and mix their noise in.
    """
    if floor is None:
        floor = bright_level_floor(levels)
    top = levels >= floor
    if not np.any(top):
        return 0.0
    return float(np.sqrt(np.mean(variances[top])))


def aligned_shift(a: np.ndarray, b: np.ndarray, period_rows: float, step: float = 0.1) -> tuple[float, float]:
    """Pearson correlation of two row profiles, ``b`` shifted by the best fraction of a
    stripe period in [−P/2, P/2] (a free-running camera's stripes sit at any phase), and that shift.

    ``b`` is read at rows r + shift (linear interpolation) beside ``a`` at rows r.
    The ends, P/2 rows each, are left out so that every shift compares the same rows.

    Returns
    -------
    (correlation, shift_rows) : (float, float)
    """
    margin = int(math.ceil(period_rows / 2)) + 1
    if a.size <= 2 * margin + 2:
        raise ValueError("the row profiles are shorter than a stripe period")
    rows = np.arange(a.size, dtype=np.float64)
    inner = rows[margin:-margin]
    best, best_shift = -1.0, 0.0
    fixed = a[margin:-margin] - a[margin:-margin].mean()
    # Searched from the unshifted profile outwards, so that a tie keeps the
    # smallest shift (an interpolated profile is blurred).
    shifts = np.arange(0.0, period_rows / 2 + step, step)
    for shift in np.concatenate([[0.0], np.ravel(np.column_stack([shifts[1:], -shifts[1:]]))]):
        moved = np.interp(inner + shift, rows, b)
        moved = moved - moved.mean()
        norm = float(np.sqrt(np.sum(fixed**2) * np.sum(moved**2)))
        # A flat profile correlates with nothing (0, not NaN).
        r = float(np.sum(fixed * moved)) / norm if norm > 0 else 0.0
        if r > best:
            best, best_shift = r, float(shift)
    return best, best_shift


def aligned_correlation(a: np.ndarray, b: np.ndarray, period_rows: float, step: float = 0.1) -> float:
    """The correlation of :func:`aligned_shift`."""
    return aligned_shift(a, b, period_rows, step)[0]


# The frames' stripe phases, measured against a render, fit one frame period
# and one start to within this fraction of a stripe period (a shift read off
# a noisy profile of a few periods is good to a row or so; frames taken at
# random times leave residuals anywhere in ±P/2). Frames that do not (stills
# of a free-running camera) are compared at their interpolated shifts.
MAX_TIMING_RESIDUAL_PERIODS = 0.1


def wrapped(x: np.ndarray) -> np.ndarray:
    """Fractions of a period wrapped into [−0.5, 0.5)."""
    x = np.asarray(x, dtype=np.float64)
    return x - np.floor(x + 0.5)


def matched_timing(scene, shifts_rows: Sequence[float]):
    """``scene`` timed so that its frames' stripes fall where the frames' do, or None.

    Frame i of the render shows the frames' stripes ``shifts_rows[i]`` rows
    later (:func:`aligned_shift`): its waveform is read s_i·t_row early. A
    square wave repeats every W = 2 / f, so frame i of a render whose frame
    period is T + δ and whose waveform starts c earlier (``link.start_offset_us``
    less c) reads it as the frames do when s_i·t_row ≡ c + i·δ (mod W) for
    every i. δ and c are the circular means of the frames' steps and starts;
    δ is taken in [0, W), so that the frame period only grows (the rows and
    the exposure still fit in it).

    Returns
    -------
    Scene or None
        None when the shifts do not fit one period and start within
        :data:`MAX_TIMING_RESIDUAL_PERIODS` (frames not taken at one rate).
    """
    if len(shifts_rows) == 0:
        return None
    row_time_s, wave_s = scene.camera.row_time_us * 1e-6, 2.0 / scene.link.clock_hz
    d = np.asarray(shifts_rows, dtype=np.float64) * row_time_s / wave_s  # periods
    i = np.arange(d.size)
    step = float(np.angle(np.mean(np.exp(2j * np.pi * wrapped(np.diff(d))))) / (2 * np.pi)) if d.size > 1 else 0.0
    start = float(np.angle(np.mean(np.exp(2j * np.pi * (d - i * step)))) / (2 * np.pi))
    if float(np.max(np.abs(wrapped(d - start - i * step)))) > MAX_TIMING_RESIDUAL_PERIODS:
        return None
    frame_period_s = 1.0 / scene.camera.frame_rate_hz + (step % 1.0) * wave_s
    camera = scene.camera.model_copy(update={"frame_rate_hz": 1.0 / frame_period_s})
    link = scene.link.model_copy(update={"start_offset_us": scene.link.start_offset_us - start * wave_s * 1e6})
    return scene.model_copy(update={"camera": camera, "link": link})


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


def led_noise_points(frames: Sequence[np.ndarray], fit: CameraFit) -> tuple[np.ndarray, np.ndarray]:
    """(level, temporal variance) of the LED's rows that hold one level in two frames, clear of the clips."""
    levels, variances = level_noise_pairs(frames, *fit.band)
    keep = unclipped(levels)
    return levels[keep], variances[keep]


def background_noise(frames: Sequence[np.ndarray], fit: CameraFit) -> dict:
    """The background's temporal, row and column-pattern noise (8-bit levels); empty without a background."""
    if fit.background_block is None:
        return {}
    bg = temporal_noise(frames, *fit.background_block)
    mean_frame = np.mean(frames, axis=0)
    return {"temporal_background": bg.pixel_std, "row_temporal_background": bg.row_std,
            "column_pattern_background": column_pattern_std(mean_frame, *fit.background_block, len(frames),
                                                            bg.pixel_std)}


def output_noise(frames: Sequence[np.ndarray], fit: CameraFit, bright_floor: float | None = None) -> dict:
    """The temporal and fixed-pattern noise of frames in the fit's regions, 8-bit levels: the LED's
    brightest unclipped rows that hold one level in two frames (those at or above ``bright_floor``,
    by default their own brightest quarter: :func:`bright_rows_noise`), and :func:`background_noise`."""
    return {"temporal_led_bright": bright_rows_noise(*led_noise_points(frames, fit), bright_floor),
            **background_noise(frames, fit)}


def noise_beside(frames: Sequence[np.ndarray], other: Sequence[np.ndarray], fit: CameraFit) -> dict:
    """name -> (frames' noise, the other frames'), :func:`output_noise`'s, the LED's rows of both
    taken at or above the frames' :func:`bright_level_floor`."""
    levels, variances = led_noise_points(frames, fit)
    floor = bright_level_floor(levels)
    ours = {"temporal_led_bright": bright_rows_noise(levels, variances, floor), **background_noise(frames, fit)}
    theirs = output_noise(other, fit, floor)
    return {k: (ours[k], theirs[k]) for k in ours}


def compare(frames: Sequence[np.ndarray], fit: CameraFit) -> Comparison:
    """Render the fitted scene (as many frames) and set it beside the frames."""
    from rollsim.render import render_frames

    frames = fit.grey(frames)
    from rollsim.fit.refine import one_gop

    rows, cols = fit.band
    real = [f[rows, cols].mean(axis=1) for f in frames]

    def rendered_profiles(scene):
        images, _ = render_frames(scene, len(frames))
        grey = fit.grey(images)
        return grey, [f[rows, cols].mean(axis=1) for f in grey]

    scene = one_gop(fit.scene, len(frames))
    rendered, sim = rendered_profiles(scene)
    aligned = [aligned_shift(a, b, fit.period_rows) for a, b in zip(real, sim)]
    # Rendered again at the frames' own stripe phases where one frame rate
    # gives them: a profile shifted by a fraction of a row is interpolated,
    # which blurs stripes a few rows wide.
    timed = matched_timing(scene, [shift for _, shift in aligned])
    if timed is not None:
        rendered, sim = rendered_profiles(timed)
        aligned = [aligned_shift(a, b, fit.period_rows) for a, b in zip(real, sim)]
    correlations = tuple(r for r, _ in aligned)
    crop = led_crop(fit, frames[0].shape)
    pair = (np.clip(frames[0][crop], 0, 255).astype(np.uint8), np.clip(rendered[0][crop], 0, 255).astype(np.uint8))
    return Comparison(correlations, noise_beside(frames, rendered, fit), (real[0], sim[0]), pair)
