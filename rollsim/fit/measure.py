"""Measurements on real frames: the LED's disk, the background, and the noise.

Every function takes 8-bit grey frames as float arrays (H, W), or a stack
of them (N, H, W), and returns numbers in 8-bit levels or pixels; none of
them knows the camera. The LED is found on the brightest frame of the set
(the pixelwise maximum, where the stripes of different frames fill each
other in), its disk from the chord each row cuts: a circle of centre
(cx, cy) and radius R cuts the chord w(y) with (w/2)² = R² − (y − cy)²,
which is linear in (R² − cy², cy) once y² is moved to the left. Temporal
noise comes from differences of consecutive frames (fixed patterns
cancel), spatial noise from the mean frame's flat background.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np


@dataclass(frozen=True)
class LedDisk:
    """The LED's image: centre (x, y) and radius, in pixels."""

    centre_x_px: float
    centre_y_px: float
    radius_px: float
    rows_used: int


def background_level(frame: np.ndarray, mask: np.ndarray) -> float:
    """Median level of the pixels outside ``mask`` (8-bit levels)."""
    return float(np.median(frame[~mask]))


def find_led_disk(brightest: np.ndarray, background: float) -> LedDisk:
    """The LED's disk on the pixelwise maximum of the frames.

    Each row's lit run (above half-way between the background and the row's
    own peak) gives a chord; the chords' squared half-widths are fitted by
    the circle's equation, by least squares.

    Raises
    ------
    ValueError
        Too few rows show the LED to place a disk.
    """
    peak = brightest.max(axis=1)
    contrast = peak - background
    if not contrast.max() > 0:
        raise ValueError("no pixel is above the background: no LED in the frames")
    lit = contrast > 0.5 * contrast.max()
    threshold = background + 0.5 * contrast
    above = (brightest > threshold[:, None]) & lit[:, None]
    counts = above.sum(axis=1)
    rows_ok = counts >= 2
    if rows_ok.sum() < 5:
        raise ValueError("fewer than 5 rows show the LED: no disk to fit")
    # A row's chord: its pixels above half-way between the background and
    # the row's peak (the edge's half-level crossing for a symmetric blur).
    xs = np.arange(brightest.shape[1]) + 0.5
    ys = np.flatnonzero(rows_ok) + 0.5
    halves = counts[rows_ok] / 2.0
    mids = (above[rows_ok] * xs).sum(axis=1) / counts[rows_ok]
    y = np.asarray(ys)
    h2 = np.asarray(halves) ** 2
    # (w/2)² + y² = (R² − cy²) + 2·cy·y
    design = np.column_stack([np.ones_like(y), 2 * y])
    (k, cy), *_ = np.linalg.lstsq(design, h2 + y**2, rcond=None)
    radius2 = k + cy**2
    # A chord through a dim row (a stripe's OFF) can be short: the disk is the
    # envelope, so refit on the rows whose chords reach it.
    model_h2 = np.clip(radius2 - (y - cy) ** 2, 0.0, None)
    keep = h2 >= 0.8 * model_h2
    if keep.sum() >= 5:
        (k, cy), *_ = np.linalg.lstsq(design[keep], (h2 + y**2)[keep], rcond=None)
        radius2 = k + cy**2
    cx = float(np.median(np.asarray(mids)))
    return LedDisk(cx, float(cy), float(np.sqrt(max(radius2, 0.25))), int(keep.sum()))


# The LED fills the frame when this much of the frame's border is lit (a
# disk inside the frame lights none of it).
FILLS_BORDER_FRACTION = 0.5
# The box the frames are averaged over before the border's lit pixels are
# read (:func:`_border_envelope`): a quarter of a stripe period of rows (within
# an ON stripe's half period, so its level is kept) by 9 columns.
BORDER_BOX_ROWS = 0.25
BORDER_BOX_COLUMNS = 9
# The row profiles keep the rows this far from the background to the LED's peak.
CORE_FRACTION = 0.6
# A background block smaller than this (pixels) gives no background statistic.
MIN_BACKGROUND_PIXELS = 256
# Frames at most this many columns wide are used whole for the row profile.
NARROW_COLUMNS = 64


@dataclass(frozen=True)
class LedRegion:
    """Where the LED is, and what of the frame is background.

    Attributes
    ----------
    disk : LedDisk or None
        The LED's disk; None when the LED fills the frame (no edge to place it).
    band : (slice, slice)
        Rows and columns of the row profiles (the LED's central band).
    block : (slice, slice) or None
        A background rectangle clear of the LED's halo; None when there is none.
    """

    disk: LedDisk | None
    band: tuple[slice, slice]
    block: tuple[slice, slice] | None


def _border_envelope(stack: np.ndarray, period_rows: float) -> np.ndarray:
    """The frame's border pixels (top row, bottom row, then the left and right
    columns between them) of the brightest envelope: each frame averaged over
    a box of :data:`BORDER_BOX_ROWS` of a stripe period by
    :data:`BORDER_BOX_COLUMNS`, the pixelwise maximum over frames, then the
    maximum over a stripe period of rows (as :func:`lit_border_fraction`).

    Averaging before the maximum keeps pixel noise from lighting the border:
    the maximum of six noisy frames stands about 1.3 noise σ above their
    mean (the expected greatest of six normal draws), and the darkest
    frame stands as far below it: as far as a faint LED's stripes reach above
    the background. Only strips along the edges are averaged (the whole frame's
    box would cost seconds on 4K frames); the values are those of the whole
    frame's.
    """
    from scipy.ndimage import maximum_filter1d, uniform_filter

    h, w = stack.shape[1:]
    size = max(1, int(np.ceil(period_rows))) | 1
    box = (1, max(1, int(BORDER_BOX_ROWS * period_rows)) | 1, BORDER_BOX_COLUMNS)
    # Rows from an edge that its line's envelope reaches, through the box.
    reach = min(h, size // 2 + box[1] // 2 + 1)
    strip = min(w, box[2] // 2 + 1)

    def across(rows: np.ndarray) -> np.ndarray:  # a top (or flipped bottom) strip: its first row's envelope
        return uniform_filter(rows, box, mode="nearest").max(axis=0)[: size // 2 + 1].max(axis=0)

    def down(cols: np.ndarray) -> np.ndarray:  # a left (or flipped right) strip: its first column's envelope
        line = uniform_filter(cols, box, mode="nearest").max(axis=0)[:, 0]
        return maximum_filter1d(line, size=size, mode="nearest")

    return np.concatenate([across(stack[:, :reach]), across(stack[:, ::-1][:, :reach]),
                           down(stack[:, :, :strip])[1:-1], down(stack[:, :, ::-1][:, :, :strip])[1:-1]])


def lit_border_fraction(stack: np.ndarray, brightest: np.ndarray, darkest: np.ndarray, period_rows: float) -> float:
    """Fraction of the frame's border pixels lit: the brightest envelope
    (:func:`_border_envelope`: a row the stripes left dark in every frame is
    still the LED's) above half-way from the darkest frame's 1st percentile
    (OFF rows, or the background) to the LED's peak.

    ``stack`` holds the frames (N, H, W); ``brightest`` and ``darkest`` are
    its pixelwise maximum and minimum.
    """
    from scipy.ndimage import maximum_filter1d, median_filter

    envelope = maximum_filter1d(brightest, size=max(1, int(np.ceil(period_rows))) | 1, axis=0, mode="nearest")
    # The LED's peak, robust to a hot pixel: the largest 3×3 median.
    low, high = float(np.percentile(darkest, 1)), float(median_filter(envelope, size=3).max())
    if not high > low:
        return 0.0
    return float(np.mean(_border_envelope(stack, period_rows) > 0.5 * (low + high)))


def background_block(shape: tuple[int, int], disk: LedDisk, margin_radii: float) -> tuple[slice, slice] | None:
    """The largest rectangle of whole rows or whole columns clear of the LED and its halo
    (``margin_radii`` radii from its centre), or None when it is under
    :data:`MIN_BACKGROUND_PIXELS`."""
    h, w = shape
    top = int(max(0, np.floor(disk.centre_y_px - margin_radii * disk.radius_px)))
    bottom = int(min(h, np.ceil(disk.centre_y_px + margin_radii * disk.radius_px)))
    left = int(max(0, np.floor(disk.centre_x_px - margin_radii * disk.radius_px)))
    right = int(min(w, np.ceil(disk.centre_x_px + margin_radii * disk.radius_px)))
    candidates = [((slice(0, top), slice(0, w)), top * w), ((slice(bottom, h), slice(0, w)), (h - bottom) * w),
                  ((slice(0, h), slice(0, left)), h * left), ((slice(0, h), slice(right, w)), h * (w - right))]
    block, area = max(candidates, key=lambda c: c[1])
    return block if area >= MIN_BACKGROUND_PIXELS else None


# Nearer margins (radii from the LED's centre) tried, widest first, where the
# frame holds no background block beyond the halo's assumed reach (a large
# LED): each is taken only where the mean frame shows no halo in it
# (:func:`halo_free`), and only clear of the LED's blurred edge by
# MIN_EDGE_GAP_PX.
NEARER_MARGINS_RADII = (1.5, 1.3, 1.15)
MIN_EDGE_GAP_PX = 8
# The most halo a background block may hold: HALO_LEVELS 8-bit levels and
# HALO_FRACTION of its level, as the fall of its level away from the LED
# tells it (:func:`halo_free`).
HALO_LEVELS = 1.0
HALO_FRACTION = 0.02
# A glare halo's wings fall at least as fast as the distance squared (a
# Moffat profile's fall as the distance to the power −2β, β > 1).
HALO_FALL_POWER = 2.0


def _halves(block: tuple[slice, slice], shape: tuple[int, int], disk: LedDisk) -> tuple[tuple, tuple]:
    """The block's half nearer the LED and its half farther, split across the direction away from it."""
    rows, cols = block
    if cols.start == 0 and cols.stop == shape[1]:  # a band of whole rows, above or below the LED
        mid = (rows.start + rows.stop) // 2
        upper, lower = (slice(rows.start, mid), cols), (slice(mid, rows.stop), cols)
        return (lower, upper) if rows.stop <= disk.centre_y_px else (upper, lower)
    mid = (cols.start + cols.stop) // 2
    left, right = (rows, slice(cols.start, mid)), (rows, slice(mid, cols.stop))
    return (right, left) if cols.stop <= disk.centre_x_px else (left, right)


def _mean_distance_px(half: tuple[slice, slice], disk: LedDisk) -> float:
    rows, cols = half
    y = np.arange(rows.start, rows.stop) + 0.5 - disk.centre_y_px
    x = np.arange(cols.start, cols.stop) + 0.5 - disk.centre_x_px
    return float(np.mean(np.hypot(x[None, :], y[:, None])))


def halo_free(mean_frame: np.ndarray, block: tuple[slice, slice], disk: LedDisk) -> bool:
    """Whether a background block holds less halo than :data:`HALO_LEVELS` and :data:`HALO_FRACTION`.

    A halo h(d) falling as d^−n (n ≥ :data:`HALO_FALL_POWER`, d the distance
    from the LED's centre) makes the block's half nearer the LED brighter than
    its far half by h(d_far)·((d_far/d_near)^n − 1): the difference of the
    halves' mean levels, so scaled, bounds the halo in the far half (from
    above: a steeper fall holds less). A flat background leaves only the
    means' noise; a background brightening towards the LED for other reasons
    (vignetting around an LED at the frame's centre) is refused with it.
    """
    near, far = _halves(block, mean_frame.shape, disk)
    near_level, far_level = float(np.mean(mean_frame[near])), float(np.mean(mean_frame[far]))
    ratio = _mean_distance_px(far, disk) / max(_mean_distance_px(near, disk), 1e-9)
    fall = ratio**HALO_FALL_POWER - 1.0
    if not fall > 0:
        return False
    return (near_level - far_level) / fall <= HALO_LEVELS + HALO_FRACTION * far_level


def clear_background_block(mean_frame: np.ndarray, disk: LedDisk, halo_radii: float) -> tuple[slice, slice] | None:
    """The background block beyond ``halo_radii`` radii of the LED's centre (:func:`background_block`);
    where the frame holds none (a large LED), the widest of :data:`NEARER_MARGINS_RADII`
    whose block shows no halo (:func:`halo_free`); None when none does."""
    shape = mean_frame.shape
    block = background_block(shape, disk, halo_radii)
    if block is not None:
        return block
    for margin in NEARER_MARGINS_RADII:
        if margin >= halo_radii or (margin - 1.0) * disk.radius_px < MIN_EDGE_GAP_PX:
            continue
        block = background_block(shape, disk, margin)
        if block is not None and halo_free(mean_frame, block, disk):
            return block
    return None


# Swings (means over the stripes' rows or the LED's columns) within this
# fraction of their peak are all the LED's: lit columns differ by its
# profile and their averaged noise (a few per cent), the background's swing
# is its noise alone, well below the stripes' where they are read.
FLAT_SWING = 0.1


def _half_run(values: np.ndarray, at: int) -> tuple[int, int]:
    """The run of ``values`` above half-way from their 5th percentile to their
    peak that holds index ``at`` (or the peak, when ``at`` is not above it): [start, stop).

    All of them when they lie within :data:`FLAT_SWING` of their peak: all
    lit (an LED that fills the crop), where half-way would split their noise.
    """
    low, high = float(np.percentile(values, 5)), float(values.max())
    if high - low <= FLAT_SWING * high:
        return 0, values.size
    above = values > 0.5 * (low + high)
    at = at if 0 <= at < values.size and above[at] else int(np.argmax(values))
    below = np.flatnonzero(~above)
    start = int(below[below < at].max()) + 1 if np.any(below < at) else 0
    stop = int(below[below > at].min()) if np.any(below > at) else values.size
    return start, stop


def disk_from_swing(brightest: np.ndarray, darkest: np.ndarray, stripes: tuple[slice, float],
                    period_rows: float) -> LedDisk | None:
    """The LED's disk from where the frames swing (brightest less darkest) around its stripes.

    ``stripes`` are the rows and the centre column where the stripes move
    between frames (:func:`decoder.stripe_region.stripe_region`). Across
    those rows the swing's half-height run of columns is the LED's width;
    down those columns (each row's swing the most over a stripe period, so
    that a row the stripes left dark counts), its run of rows is its height.
    A run cut by the frame's edge gives no extent; None when both are cut
    (the LED fills the frame, or the crop).
    """
    from scipy.ndimage import maximum_filter1d

    swing = np.asarray(brightest, dtype=np.float64) - np.asarray(darkest, dtype=np.float64)
    rows, centre_col = stripes
    x0, x1 = _half_run(swing[rows].mean(axis=0), int(centre_col))
    down = maximum_filter1d(swing[:, x0:x1].mean(axis=1), size=max(1, int(np.ceil(period_rows))) | 1,
                            mode="nearest")
    y0, y1 = _half_run(down, (rows.start + rows.stop) // 2)
    return _disk_of_runs((x0, x1), (y0, y1), swing.shape)


def _disk_of_runs(columns: tuple[int, int], rows: tuple[int, int], shape: tuple[int, int]) -> LedDisk | None:
    """The disk whose lit runs of columns and of rows, [start, stop), are these in a frame of ``shape``.

    A run clear of both of its edges is a diameter (the longer where both
    are); a run that spans its whole axis is centred on it; a run cut by one
    edge is centred a radius from the other. None when neither run is clear.
    """
    (x0, x1), (y0, y1), (h, w) = columns, rows, shape
    clear_x, clear_y = x0 > 0 and x1 < w, y0 > 0 and y1 < h
    if not (clear_x or clear_y):
        return None
    radius = 0.5 * max((x1 - x0) if clear_x else 0, (y1 - y0) if clear_y else 0)

    def centre(start: int, stop: int, size: int, clear: bool) -> float:
        if clear or (start == 0 and stop == size):
            return 0.5 * (start + stop)
        return stop - radius if start == 0 else start + radius  # cut by one edge: from the other

    return LedDisk(centre(x0, x1, w, clear_x), centre(y0, y1, h, clear_y), float(radius), int(y1 - y0))


def _disk_agrees(disk: LedDisk | None, stripes: tuple[slice, float], period_rows: float) -> bool:
    """Whether a disk is centred on the stripes: its centre row within a
    quarter of their rows' span (and a stripe period) of theirs, and its
    centre column within its radius of theirs."""
    if disk is None:
        return False
    rows, centre_col = stripes
    centre_row = 0.5 * (rows.start + rows.stop)
    return (abs(disk.centre_y_px - centre_row) <= 0.25 * (rows.stop - rows.start) + period_rows
            and abs(disk.centre_x_px - centre_col) <= disk.radius_px)


def _centre_inside(disk: LedDisk, shape: tuple[int, int]) -> bool:
    """Whether the disk's centre lies in the frame (a disk drawn from noise can lie beyond it)."""
    return 0.0 <= disk.centre_x_px <= shape[1] and 0.0 <= disk.centre_y_px <= shape[0]


def _disk_covers_stripes(disk: LedDisk, stripes: tuple[slice, float]) -> bool:
    """Whether the centre of the stripes' rows, on their centre column, lies in the disk's
    square: a lit run beside the LED (a brighter background) is not its disk."""
    rows, centre_col = stripes
    return (abs(disk.centre_x_px - centre_col) <= disk.radius_px
            and abs(disk.centre_y_px - 0.5 * (rows.start + rows.stop)) <= disk.radius_px)


def disk_from_lit_runs(brightest: np.ndarray, period_rows: float) -> LedDisk | None:
    """The disk of an LED that spans the frame's rows or columns, but not both, by where it is lit; or None.

    Down the frame, each row's mean over the columns of the brightest
    frame, closed over a stripe period (a row the stripes left dark in
    every frame counts, and the run is not widened); across it, each
    column's mean over the lit rows. The LED's runs are the half-height
    runs around the brightest row and column (:func:`_half_run`), and
    the background beside them is darker. A run clear of both of its
    frame's edges is the LED's diameter: in a narrow crop the chord through
    its columns, taken as the diameter (the crop centred on the LED)
    (:func:`_disk_of_runs`). None where neither run is clear (the LED
    fills the frame, or the background outshines it).
    """
    from scipy.ndimage import grey_closing

    brightest = np.asarray(brightest, dtype=np.float64)
    down = grey_closing(brightest.mean(axis=1), size=max(1, int(np.ceil(period_rows))) | 1, mode="nearest")
    y0, y1 = _half_run(down, int(np.argmax(down)))
    across = brightest[y0:y1].mean(axis=0)
    x0, x1 = _half_run(across, int(np.argmax(across)))
    return _disk_of_runs((x0, x1), (y0, y1), brightest.shape)


def find_led_region(stack: np.ndarray, halo_radii: float, period_rows: float,
                    stripes: tuple[slice, float] | None = None) -> LedRegion:
    """The LED's disk (or that it fills the frame), its central band and a background block.

    ``stack`` holds the frames (N, H, W); ``period_rows`` is the stripe
    period (rows).
    ``stripes`` (rows, centre column: where the stripes move between
    frames) checks the answer: a bright background lights the border as
    an LED filling the frame would, and a brighter blob than the LED draws
    the disk; where the stripes disagree, the disk is the one the frames'
    swing draws around them (:func:`disk_from_swing`), when its centre lies
    in the frame. A lit border with no disk drawn is an LED that fills the
    frame unless it spans only the rows or only the columns, where its lit
    runs place it (:func:`disk_from_lit_runs`, over the stripes' centre).

    Raises
    ------
    ValueError
        No LED: nothing is brighter than the rest.
    """
    brightest, darkest, mean_frame = stack.max(axis=0), stack.min(axis=0), stack.mean(axis=0)
    shape = brightest.shape
    h, w = shape
    fills = lit_border_fraction(stack, brightest, darkest, period_rows) >= FILLS_BORDER_FRACTION
    background = float(np.median(mean_frame))
    disk = None if fills else find_led_disk(brightest, background)
    if stripes is not None and not _disk_agrees(disk, stripes, period_rows):
        swung = disk_from_swing(brightest, darkest, stripes, period_rows)
        if swung is not None and _centre_inside(swung, shape):
            disk = swung
    if disk is None and fills:
        lit = disk_from_lit_runs(brightest, period_rows)
        if lit is not None and (stripes is None or _disk_covers_stripes(lit, stripes)):
            disk = lit
    if disk is None:
        c0, c1 = (0, w) if w <= NARROW_COLUMNS else (int(0.2 * w), int(np.ceil(0.8 * w)))
        return LedRegion(None, (slice(0, h), slice(c0, c1)), None)
    block = clear_background_block(mean_frame, disk, halo_radii)
    rows, cols = central_band(disk, shape)
    return LedRegion(disk, (bright_core_rows(brightest[rows, cols].mean(axis=1), rows, background), cols), block)


def bright_core_rows(levels: np.ndarray, rows: slice, background: float) -> slice:
    """The run of ``rows`` around its brightest row whose ``levels`` (the band's
    brightest-frame means) reach :data:`CORE_FRACTION` of the way from the
    background to the peak: the LED itself, not the halo that glare or blur
    spread around it (whose stripes are not the LED's)."""
    peak = int(np.argmax(levels))
    lit = levels >= background + CORE_FRACTION * (float(levels[peak]) - background)
    dark = np.flatnonzero(~lit)
    start = int(dark[dark < peak].max()) + 1 if np.any(dark < peak) else 0
    stop = int(dark[dark > peak].min()) if np.any(dark > peak) else levels.size
    if stop - start < 0.25 * levels.size:  # a narrow spike: keep the band
        return rows
    return slice(rows.start + start, rows.start + stop)


def disk_mask(shape: tuple[int, int], disk: LedDisk, scale: float = 1.0) -> np.ndarray:
    """Pixels within ``scale`` radii of the disk's centre."""
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    r2 = (xx + 0.5 - disk.centre_x_px) ** 2 + (yy + 0.5 - disk.centre_y_px) ** 2
    return r2 <= (scale * disk.radius_px) ** 2


def central_band(disk: LedDisk, shape: tuple[int, int], half_width: float = 0.3,
                 height: float = 0.85) -> tuple[slice, slice]:
    """The rows and columns of the band through the LED's centre that lies inside it.

    Raises
    ------
    ValueError
        A disk whose band lies outside the frame (a disk found wrongly:
        no row or column of it to read).
    """
    r = disk.radius_px
    c0 = max(0, int(np.floor(disk.centre_x_px - half_width * r)))
    c1 = min(shape[1], int(np.ceil(disk.centre_x_px + half_width * r)))
    r0 = max(0, int(np.floor(disk.centre_y_px - height * r)))
    r1 = min(shape[0], int(np.ceil(disk.centre_y_px + height * r)))
    c1 = max(c1, c0 + 1)
    if r1 <= r0 or c1 > shape[1]:
        raise ValueError(f"the LED's disk found at ({disk.centre_x_px:.0f}, {disk.centre_y_px:.0f}) px, radius "
                         f"{r:.0f} px, has no band of rows inside the {shape[1]}x{shape[0]} px frame")
    return slice(r0, r1), slice(c0, c1)


@dataclass(frozen=True)
class TemporalNoise:
    """Temporal noise of a region, from differences of consecutive frames (8-bit levels)."""

    pixel_std: float  # per pixel, each row's common offset removed
    row_std: float  # of the rows' common offset (row temporal noise), pixel noise removed
    pairs: int


def temporal_noise(frames: Sequence[np.ndarray], rows: slice, cols: slice) -> TemporalNoise:
    """Temporal noise of a static region, from consecutive frame differences.

    A difference of two frames holds twice each frame's variance and no
    fixed pattern. Within a row the common offset (row noise) is removed
    first; the row means' variance, less the pixels' share σ²/n, gives the
    row noise.
    """
    pixel_var, row_var = [], []
    for a, b in zip(frames[:-1], frames[1:]):
        d = a[rows, cols] - b[rows, cols]
        row_means = d.mean(axis=1, keepdims=True)
        within = d - row_means
        n = d.shape[1]
        var_pixel = float(within.var()) * n / max(n - 1, 1) / 2.0
        pixel_var.append(var_pixel)
        row_var.append(max(0.0, float(row_means.var()) / 2.0 - var_pixel / n))
    return TemporalNoise(float(np.sqrt(np.mean(pixel_var))), float(np.sqrt(np.mean(row_var))), len(pixel_var))


# Frame pairs whose same rows are compared for the temporal noise: every
# pair up to this many (a free-running camera's stripes move between frames,
# so a row holds one level in both frames only now and then).
MAX_NOISE_PAIRS = 30


def frame_pairs(n_frames: int, limit: int = MAX_NOISE_PAIRS) -> list[tuple[int, int]]:
    """Pairs (i, j), i < j, of frame indices: neighbours first, at most ``limit``."""
    pairs = [(i, i + gap) for gap in range(1, n_frames) for i in range(n_frames - gap)]
    return pairs[:limit]


def level_noise_pairs(frames: Sequence[np.ndarray], rows: slice, cols: slice) -> tuple[np.ndarray, np.ndarray]:
    """Per-row (mean level, temporal variance) in a band whose level changes from frame to frame.

    For two frames a and b, each pixel's deviation from its row's mean in
    a, less the same in b, holds the temporal variance of a's level plus
    b's, and no fixed pattern (the same pixels). Rows are paired with the
    mean of their two levels; the variance is half the sum, exact where the
    two levels agree, and rows are kept only where they agree within 5 % (or
    1 level). Frame pairs are :func:`frame_pairs`'s.
    """
    levels, variances = [], []
    for i, j in frame_pairs(len(frames)):
        ba, bb = frames[i][rows, cols], frames[j][rows, cols]
        ma, mb = ba.mean(axis=1), bb.mean(axis=1)
        d = (ba - ma[:, None]) - (bb - mb[:, None])
        n = d.shape[1]
        if n < 2:
            continue
        close = np.abs(ma - mb) <= np.maximum(1.0, 0.05 * 0.5 * (ma + mb))
        levels.append(0.5 * (ma + mb)[close])
        variances.append((d[close].var(axis=1) * n / (n - 1) / 2.0))
    if not levels:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(levels), np.concatenate(variances)


def column_pattern_std(mean_frame: np.ndarray, rows: slice, cols: slice, n_frames: int,
                       pixel_std: float) -> float:
    """Standard deviation of the column offsets in a flat region of the mean frame.

    A column's mean over the region's rows and the frames still carries the
    temporal and per-pixel noise, σ²/(rows·frames) and less; the spatial
    noise of the pixels (PRNU, DSNU) is left in, σ_s²/rows, and is small.
    """
    block = mean_frame[rows, cols]
    col_means = block.mean(axis=0)
    var = float(col_means.var()) - pixel_std**2 / (block.shape[0] * n_frames)
    return float(np.sqrt(max(var, 0.0)))
