"""LED region detection.

The LED's footprint is cut into bands by the OFF stripes, so it is found on
a block-averaged copy of the frame (which also averages the pixel noise
away), further averaged along rows (stripes are horizontal): threshold it
(Otsu), close the gaps between the bright bands with a vertical closing
taller than the longest OFF run, and take the connected components (outer
contours, filled). Each region then grows up and down over fainter blocks,
where the footprint's top and bottom only partly cover a block.

An LED too dim for its ON bands to clear the noise may still show a mean
level above the background: failing the first split, the threshold is sought
again on blocks averaged over the closing height as well (whole chips).

A frame without an LED (black, saturated, pure noise, a flat wall) yields no
region: Otsu's two classes must be separated by several times the noise,
measured from horizontal pixel differences, which cancel the stripes
(stripes are constant along a row).

Where the chip pitch is known, blocks are also found by modulation rather
than level: the LED's stripes are an alternation down the columns at the
chip pitch, which a smooth background (or an LED's own glow, which fades
over hundreds of rows) does not have. Each block's stripe power (its step
to the next block row, squared and averaged over a few chips) is compared
with the local power of noise alone (from the same steps' differences along
the row, where stripes cancel); blocks clearly above it join the level-found
ones. The stripes of a faint halo round a bright LED, which
never clear Otsu's split of the frame, are found so, as far as they stand out
of the noise.

Coordinates: ``block`` quantities are on the grid of ``factor`` × ``factor``
pixel blocks; rows of a :class:`Region` are full-resolution frame rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.ndimage import uniform_filter1d

from decoder.bridging import Part, bridged
from decoder.kernels import block_means_u8, frame_words, noise_power_f32
from decoder.order_stats import median

# Otsu's two classes must lie this many noise standard deviations apart
# (of block means) before the bright one counts as an LED. Pure Gaussian
# noise splits into classes about 1.6 sigma apart.
MIN_SEPARATION_SIGMA = 5.0
# Blocks averaged along a row before thresholding.
SMOOTH_BLOCKS = 5
# Blocks averaged along a row before the stripe power is measured: wider
# than for the level (a halo is wide), narrow enough for a small LED.
MODULATION_SMOOTH_BLOCKS = 9
# Stripe power, in multiples of the local power of noise alone, above which
# a block is modulated. On 1080p frames of pure noise (σ 0.5 to 40 DN, 3 to
# 20 rows per chip, 45 frames) blocks first pass at 2.5, none at 3 (see tests).
MIN_MODULATION_POWER = 5.0
# The local noise power is capped at this multiple of the frame's median
# (shot noise at full scale is a few times that of a dim background).
MAX_NOISE_POWER_RATIO = 8.0
# Least height (blocks) over which the stripe power is averaged.
MODULATION_WINDOW_BLOCKS = 15
# MAD of a normal distribution -> standard deviation.
MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True)
class BlockImage:
    """A frame and its block-averaged copy.

    Attributes
    ----------
    frame : ndarray
        The frame, ``(H, W)`` or ``(H, W, 3)`` (not copied).
    blocks : ndarray of float32, shape (H // factor, W // factor[, 3])
        Means over ``factor`` × ``factor`` pixel blocks: detection runs on
        these (16 times fewer pixels, 4 times less noise).
    factor : int
        Block size in pixels.
    """

    frame: np.ndarray
    blocks: np.ndarray
    factor: int

    @property
    def height(self) -> int:
        return int(self.frame.shape[0])

    @property
    def integer(self) -> bool:
        """Whether the frame holds integers (values quantised to 1)."""
        return self.frame.dtype.kind in "ui"

    def block_row_of(self, rows) -> np.ndarray:
        """Block row holding each full-resolution row."""
        n_block_rows = self.blocks.shape[0]
        return np.minimum(np.asarray(rows) * n_block_rows // self.height, n_block_rows - 1)

    def block_col_span(self, block_cols: slice) -> slice:
        """Frame columns of a range of block columns."""
        width, n_block_cols = self.frame.shape[1], self.blocks.shape[1]
        start = block_cols.start * width // n_block_cols
        stop = -(-block_cols.stop * width // n_block_cols)
        return slice(start, min(width, stop))


@dataclass(frozen=True)
class Region:
    """A bright region (an LED footprint) of a frame.

    Attributes
    ----------
    rows : slice
        Full-resolution rows [start, stop) covered by the region.
    block_cols : slice
        Block columns [start, stop) of its bounding box.
    weights : ndarray of float32, shape (rows, block columns)
        1 where a block of the row belongs to the region, else 0.
    area_blocks : int
        Blocks in the region.
    """

    rows: slice
    block_cols: slice
    weights: np.ndarray
    area_blocks: int


def choose_factor(shape: tuple[int, int], requested: int = 4) -> int:
    """Block size: ``requested`` unless the frame is too small for it."""
    factor = max(1, int(requested))
    while factor > 1 and min(shape[0], shape[1]) < 16 * factor:
        factor //= 2
    return factor


def block_means(frame: np.ndarray, factor: int) -> BlockImage:
    """Average a frame over square blocks of ``factor`` pixels.

    Parameters
    ----------
    frame : ndarray
        ``(H, W)`` or ``(H, W, 3)``, as from :func:`decoder.io.as_frame_array`.
    factor : int
        Block size in pixels.
    """
    words = frame_words(frame, factor)
    if words is not None:
        # The same numbers as the resize below, several times faster.
        return BlockImage(frame, block_means_u8(words), factor)
    height, width = frame.shape[:2]
    size = (max(1, width // factor), max(1, height // factor))
    # INTER_AREA with an integer ratio is an exact block mean (rounded to an
    # integer for integer frames: 16 pixels are averaged, the error is small).
    blocks = frame if factor == 1 else cv2.resize(frame, size, interpolation=cv2.INTER_AREA)
    return BlockImage(frame, blocks.astype(np.float32), factor)


def horizontal_noise(values: np.ndarray, row_step: int = 1, mask=None, max_samples: int = 20000) -> float:
    """Noise standard deviation from differences of horizontal neighbours.

    Stripes are constant along a row, so the differences hold noise only
    (and a few footprint edges, which the median ignores).

    Parameters
    ----------
    values : ndarray, shape (rows, cols)
    row_step : int
        Use every ``row_step``-th row.
    mask : ndarray of bool, shape (rows, cols), optional
        Use only pairs of neighbours that are both inside the mask.
    max_samples : int
        Subsample the differences to about this many (speed; the median
        of 20 000 is good to 1 %).

    Returns
    -------
    float
        Estimated sigma of one value (0 if there are no pairs).
    """
    step = max(1, int(row_step))
    n_rows = -(-values.shape[0] // step)
    step *= max(1, int(n_rows * values.shape[1] // max_samples))
    sub = values[::step]
    diff = np.abs(sub[:, 1:] - sub[:, :-1])
    if mask is not None:
        m = mask[::step]
        diff = diff[m[:, 1:] & m[:, :-1]]
    diff = diff.ravel()
    if diff.size == 0:
        return 0.0
    middle = diff.size // 2
    return float(MAD_TO_SIGMA * np.partition(diff, middle)[middle] / np.sqrt(2.0))


def otsu_threshold(values: np.ndarray) -> tuple[float, float, float] | None:
    """Otsu's threshold of ``values`` (256 levels) and the two class means.

    Returns
    -------
    (threshold, mean_low, mean_high) or None
        None when all values are equal.
    """
    lo, hi = float(values.min()), float(values.max())
    if not hi > lo:
        return None
    scale = 255.0 / (hi - lo)
    # cv2's Otsu works on 8 bits: map [lo, hi] onto 0..255.
    levels = cv2.convertScaleAbs(values, alpha=scale, beta=-lo * scale)
    t8, bright = cv2.threshold(levels, 0, 1, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    n_high = int(cv2.countNonZero(bright))
    if n_high == 0 or n_high == values.size:
        return None
    total = float(values.sum(dtype=np.float64))
    high = float(cv2.mean(values, mask=bright)[0])
    low = (total - high * n_high) / (values.size - n_high)
    return lo + (t8 + 0.5) / scale, low, high


# Parts of footprints, per region kept, that may join across flat bands
# (the largest by bounding box first).
BRIDGED_PARTS_PER_REGION = 4


def detect_regions(
    image: BlockImage,
    close_rows: float,
    max_regions: int = 8,
    min_area_blocks: int = 4,
    min_separation: float = MIN_SEPARATION_SIGMA,
    rows_per_chip: float | None = None,
    bridge_rows: float = 0.0,
) -> list[Region]:
    """Find the LED footprints of a block-averaged frame.

    Parameters
    ----------
    image : BlockImage
    close_rows : float
        Height in rows of the vertical closing: more than the longest OFF
        run of the line code (a few chips).
    max_regions : int
        Keep at most this many regions, largest first.
    min_area_blocks : int
        Smaller components are noise.
    min_separation : float
        Otsu's class means must differ by this many noise sigmas.
    rows_per_chip : float, optional
        The chip pitch in rows, if known: blocks whose stripe power clearly
        exceeds the noise's then join the regions (see
        :func:`modulated_mask`).
    bridge_rows : float
        Most rows by which each part of a footprint grows over a lit band
        without stripes, joining the parts that then meet
        (:mod:`decoder.bridging`: a long exposure flattens runs of equal
        bits); 0 grows and joins none.

    Returns
    -------
    list of Region
        Largest first; empty when the frame shows no LED.
    """
    blocks = image.blocks
    gray = blocks @ np.full(blocks.shape[2], 1.0 / blocks.shape[2], np.float32) if blocks.ndim == 3 else blocks
    noise = max(horizontal_noise(gray, row_step=2), _noise_floor(image, gray))
    # Odd, so that the kernel is centred and the closing never removes pixels.
    kernel_rows = 2 * int(np.ceil(0.5 * min(close_rows / image.factor, gray.shape[0]))) + 1
    found = bright_mask(gray, noise, kernel_rows, 1, min_separation)
    if found is None:
        # A dim LED in noise: its ON bands may not clear the background by
        # enough, while its mean level over a few chips still does.
        found = bright_mask(gray, noise, kernel_rows, kernel_rows, min_separation)
    modulated = None
    if rows_per_chip is not None and rows_per_chip > 0:
        modulated = modulated_mask(gray, rows_per_chip / image.factor, kernel_rows, _block_quantisation(image, gray))
    if found is None:
        if rows_per_chip is not None and rows_per_chip > 0:
            # Neither the level nor the blocks' own stripe power shows an
            # LED: look for stripes common to many columns.
            common = common_stripes_mask(image, rows_per_chip, kernel_rows)
            if common.sum() > (0 if modulated is None else modulated.sum()):
                modulated = common
        if modulated is None or not modulated.any():
            return []
        found = (modulated, gray, np.inf)
    elif modulated is not None:
        # Between a bright core (found by level) and its halo's stripes (by
        # modulation) lies a band that neither test passes (next to the core
        # the noise estimate sees its sides): close it down the columns, so
        # that an LED stays one region. Side by side LEDs stay apart.
        joined = close_vertically(found[0] | modulated, 3 * kernel_rows)
        found = (joined, found[1], found[2])
    bright, smooth, faint = found
    # Outer contours are much faster than labelled components with stats;
    # filling them also closes any holes left inside a footprint.
    contours, _ = cv2.findContours(bright, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    boxes = [cv2.boundingRect(c) for c in contours]
    order = sorted(range(len(boxes)), key=lambda i: -boxes[i][2] * boxes[i][3])
    bridge_blocks = int(bridge_rows // image.factor)
    parts: list[Part] = []
    for i in order:
        x, y, w, h = boxes[i]
        if w * h < min_area_blocks:
            break
        mask = np.zeros((h, w), np.uint8)
        cv2.drawContours(mask, contours, i, 1, thickness=cv2.FILLED, offset=(-x, -y))
        area = int(cv2.countNonZero(mask))
        if area >= min_area_blocks:
            mask, y = _extend_ends(smooth, mask, x, y, faint, kernel_rows)
            parts.append(Part(mask, x, y, area))
        # Parts beyond the largest few may still join one of them; past a
        # few per region they are specks, and the pairwise join stays cheap.
        if len(parts) == (max_regions if bridge_blocks == 0 else BRIDGED_PARTS_PER_REGION * max_regions):
            break
    parts = bridged(gray, parts, bridge_blocks, kernel_rows)[:max_regions]
    return [_region_from_mask(image, p.mask, p.x, p.y, p.area) for p in parts]


def bright_mask(gray: np.ndarray, noise: float, kernel_rows: int, average_rows: int, min_separation: float):
    """Candidate LED blocks: Otsu's bright class, its bands closed vertically.

    Parameters
    ----------
    gray : ndarray, shape (rows, cols)
        Block means.
    noise : float
        Noise sigma of one block mean.
    kernel_rows : int
        Height of the vertical closing, in blocks (odd).
    average_rows : int
        Blocks averaged down columns first (odd): 1 keeps the stripes, so
        that ON bands are thresholded; more averages whole chips into the
        LED's mean level, for an LED too dim for its bands to stand out.
    min_separation : float
        Otsu's class means must lie this many sigmas (of the averaged
        blocks) apart.

    Returns
    -------
    (mask, smooth, faint) or None
        The uint8 mask; the averaged image and a lower threshold, which grow
        a region over the footprint's fainter ends. None when the two classes
        are not clearly apart.
    """
    width = SMOOTH_BLOCKS if gray.shape[1] >= 2 * SMOOTH_BLOCKS else 1
    height = max(1, min(int(average_rows), 2 * ((gray.shape[0] - 1) // 2) + 1))
    # Stripes are horizontal: averaging along rows cuts the noise and keeps them.
    smooth = cv2.blur(gray, (width, height), borderType=cv2.BORDER_REFLECT) if width * height > 1 else gray
    sigma = noise / np.sqrt(width * height)
    split = otsu_threshold(smooth)
    if split is None:
        return None
    threshold, mean_low, mean_high = split
    if mean_high - mean_low < min_separation * sigma:
        return None
    bright: np.ndarray = (smooth > threshold).astype(np.uint8)
    if width > 1:
        # The row average spreads the footprint's sides by up to two blocks;
        # take one back so the mask mixes in less background.
        bright = cv2.erode(bright, np.ones((1, 3), np.uint8))
    # Blocks straddling the footprint's top or bottom edge are dimmer; a
    # lower threshold picks them up (near a region only).
    faint = min(threshold, max(mean_low + 0.5 * (threshold - mean_low), mean_low + 4.0 * sigma))
    return close_vertically(bright, kernel_rows), smooth, faint


def modulated_mask(gray: np.ndarray, chip_blocks: float, kernel_rows: int, floor_sigma: float,
                   min_power: float = MIN_MODULATION_POWER) -> np.ndarray:
    """Blocks where stripes at the chip pitch stand out of the noise.

    Parameters
    ----------
    gray : ndarray, shape (rows, cols)
        Block means.
    chip_blocks : float
        Chip pitch in block rows, > 0.
    kernel_rows : int
        Height (blocks, odd) of the vertical closing: more than the longest
        run of equal chips. The power is averaged over at least this.
    floor_sigma : float
        Least noise sigma of one block mean (its quantisation).
    min_power : float
        Threshold on the stripe power over the local power of noise alone.

    Returns
    -------
    ndarray of uint8, shape (rows, cols)
        1 on modulated blocks, closed vertically like the level mask.
    """
    rows, cols = gray.shape
    width = MODULATION_SMOOTH_BLOCKS if cols >= 4 * MODULATION_SMOOTH_BLOCKS else 1
    # Two chips (a Manchester symbol) hold at least one change of level.
    mean_rows = max(3, 2 * int(round(chip_blocks)) + 1)
    window = max(MODULATION_WINDOW_BLOCKS, int(kernel_rows))
    if rows < 2 * window or cols < 2:
        return np.zeros(gray.shape, np.uint8)
    smooth = cv2.blur(gray, (width, 1), borderType=cv2.BORDER_REFLECT)
    # The step to the next block row: stripes change level there, a smooth
    # background barely does, and a footprint's edge spills into one block
    # only (a deviation from a local mean would spill half its window).
    ac = np.empty_like(smooth)
    np.subtract(smooth[1:], smooth[:-1], out=ac[:-1])
    ac[-1] = 0.0
    box = (2 * width + 1, window)
    # A lower bound: the quantisation of one smoothed block (a step, the
    # difference of two, has twice it where the rounding errors are independent).
    floor_power = floor_sigma**2 / width
    noise_power = cv2.blur(_noise_power(ac, width), box, borderType=cv2.BORDER_REFLECT)
    # Across a footprint narrower than two lags both differences straddle
    # its sides and measure stripes, not noise: cap the local estimate at
    # a multiple of the frame's typical noise power.
    typical = median(noise_power[:: max(1, rows // 64), :: max(1, cols // 64)])
    np.clip(noise_power, floor_power, max(floor_power, MAX_NOISE_POWER_RATIO * typical), out=noise_power)
    # The threshold on the stripe power, in the noise power's place.
    threshold = np.multiply(noise_power, min_power, out=noise_power)
    squared = np.square(ac, out=ac)
    # Significant over a few chips and columns, and present locally (over a
    # Manchester symbol, in the block's own smoothed column): the long window
    # alone would spread a footprint's top and bottom by half its height,
    # and its sides into a neighbouring LED's.
    significant = cv2.blur(squared, box, borderType=cv2.BORDER_REFLECT) > threshold
    local = cv2.blur(squared, (1, mean_rows), borderType=cv2.BORDER_REFLECT) > threshold
    modulated: np.ndarray = np.logical_and(significant, local, out=significant).view(np.uint8)
    # The step spills one block above a footprint's top: take it back.
    modulated = cv2.erode(modulated, np.ones((3, 1), np.uint8))
    if width > 1:
        # The row smoothing spreads a footprint's sides by half its width.
        modulated = cv2.erode(modulated, np.ones((1, width), np.uint8))
    return close_vertically(modulated, kernel_rows)


# Columns per band (blocks) of the common-stripes detector, rows per chip of
# its high-pass, and its significance threshold (correlation z-score). Pure
# Gaussian noise frames reach about 4.5 at most (1080p, 2 to 20 rows per chip).
COMMON_BAND_BLOCKS = 8
COMMON_HIGHPASS_CHIPS = 3.0
COMMON_WINDOW_CHIPS = 24.0
MIN_COMMON_Z = 6.0


def band_profiles(image: BlockImage, band_blocks: int = COMMON_BAND_BLOCKS) -> np.ndarray:
    """Row means of the frame over bands of ``band_blocks`` block columns, at full row resolution.

    Returns
    -------
    ndarray of float64, shape (height, n_bands)
    """
    frame = image.frame.astype(np.float32, copy=False)
    if frame.ndim == 3:
        frame = frame.mean(axis=2)
    return band_means(frame, band_blocks * image.factor)


def band_means(gray: np.ndarray, band_px: int) -> np.ndarray:
    """Row means of a gray image over whole bands of ``band_px`` columns (the rest dropped).

    Returns
    -------
    ndarray of float64, shape (rows, n_bands)
    """
    n_bands = gray.shape[1] // band_px
    return gray[:, : n_bands * band_px].reshape(gray.shape[0], n_bands, band_px).mean(axis=2, dtype=np.float64)


def stripe_highpass(profiles: np.ndarray, rows_per_chip: float) -> np.ndarray:
    """Band profiles less their running mean over :data:`COMMON_HIGHPASS_CHIPS` chips (down the rows)."""
    window = max(3, int(COMMON_HIGHPASS_CHIPS * rows_per_chip))
    return profiles - uniform_filter1d(profiles, window, axis=0, mode="nearest")


def common_stripes_z(profiles: np.ndarray, rows_per_chip: float) -> np.ndarray:
    """How strongly each band's stripes follow the other bands', row by row (a z-score).

    An LED's stripes are the same in every column it covers (the rolling
    shutter makes them a function of the row), while noise is independent
    from one band of columns to the next. Each band's profile is high-passed
    (less its running mean over a few chips), then correlated, over windows
    of several chips, with the mean of the other bands' weighted by how well
    they followed it in a first pass; the correlation times the square root
    of the window is about N(0, 1) for a band of noise.

    Returns
    -------
    ndarray of float64, shape (height, n_bands)
    """
    n_rows, n_bands = profiles.shape
    if n_bands < 3 or n_rows < 8:
        return np.zeros(profiles.shape)
    high = stripe_highpass(profiles, rows_per_chip)
    window = max(8, int(COMMON_WINDOW_CHIPS * rows_per_chip))
    held = uniform_filter1d(np.ones(n_rows), window, mode="constant") * window
    weights = np.ones(n_bands)
    z = np.zeros(profiles.shape)
    for _ in range(2):
        total = high @ weights
        # Leave each band out of the signal it is compared with.
        others = total[:, None] - high * weights[None, :]
        # Zeros beyond the frame's ends (not repeated edge rows): the rows a
        # window really holds set its z-score.
        cross = uniform_filter1d(high * others, window, axis=0, mode="constant")
        # Running sums of squares can round a hair below zero.
        own = np.maximum(uniform_filter1d(high * high, window, axis=0, mode="constant"), 0.0)
        ref = np.maximum(uniform_filter1d(others * others, window, axis=0, mode="constant"), 0.0)
        denominator = np.sqrt(own * ref)
        correlation = np.divide(cross, denominator, out=np.zeros_like(cross), where=denominator > 0)
        z = correlation * np.sqrt(held)[:, None]
        weights = np.clip(np.median(z, axis=0), 0.0, None)
        if not weights.any():
            break
    return z


# The common signal's power density below the chip rate must be this many
# times its density above it (white row noise: about 1).
MIN_STRIPE_SPECTRUM_RATIO = 3.0


def has_stripe_spectrum(profiles: np.ndarray, weights: np.ndarray, rows_per_chip: float) -> bool:
    """Whether the signal the bands share looks like chips, not like row noise.

    Row noise (an offset per row, the same in every column) is shared by the
    bands as an LED's stripes are, but it is white: its power reaches the
    Nyquist frequency evenly. Chips of P rows put theirs below 1/P cycles
    per row (a box of P rows has its first null there), and the exposure
    smooths them further. So the weighted common signal's mean power density
    between 1/(2P) and 1/P must exceed its density above 1.25/P by
    :data:`MIN_STRIPE_SPECTRUM_RATIO`. With fewer than 2.5 rows per chip the
    bands overlap and the test cannot tell; it passes.
    """
    if rows_per_chip < 2.5:
        return True
    if not np.any(weights > 0):
        return False
    common = stripe_highpass(profiles, rows_per_chip) @ weights
    power = np.abs(np.fft.rfft(common)) ** 2
    frequency = np.fft.rfftfreq(common.size)
    low = (frequency >= 0.5 / rows_per_chip) & (frequency < 1.0 / rows_per_chip)
    high = frequency >= 1.25 / rows_per_chip
    if not low.any() or not high.any():
        return True
    return bool(np.mean(power[low]) > MIN_STRIPE_SPECTRUM_RATIO * np.mean(power[high]))


def common_stripes_mask(image: BlockImage, rows_per_chip: float, kernel_rows: int) -> np.ndarray:
    """Blocks whose column band shows the stripes the other bands show.

    The detector of last resort for an LED whose mean level does not clear
    the background and whose stripes are too weak in any one block
    (:func:`common_stripes_z`). Returns a uint8 mask on the block grid,
    closed vertically like the others.
    """
    n_block_rows, n_block_cols = image.blocks.shape[:2]
    profiles = band_profiles(image)
    z = common_stripes_z(profiles, rows_per_chip)
    mask = np.zeros((n_block_rows, n_block_cols), np.uint8)
    if z.size == 0 or not has_stripe_spectrum(profiles, np.clip(np.median(z, axis=0), 0.0, None), rows_per_chip):
        return mask
    rows = np.minimum(np.arange(image.height) // image.factor, n_block_rows - 1)
    strong = np.zeros((n_block_rows, z.shape[1]))
    np.maximum.at(strong, rows, z)
    bands = (strong > MIN_COMMON_Z).astype(np.uint8)
    mask[:, : bands.shape[1] * COMMON_BAND_BLOCKS] = np.repeat(bands, COMMON_BAND_BLOCKS, axis=1)
    return close_vertically(mask, kernel_rows)


# E[min(a², b²)] / E[a²] for the differences a, b of a value with its left
# and right neighbours ``lag`` apart (independent noise: correlation −1/2);
# by simulation of 4 million pairs.
MIN_OF_TWO_DIFFERENCES = 0.4486


def _noise_power(values: np.ndarray, lag: int) -> np.ndarray:
    """Per-block noise power of ``values`` from differences ``lag`` columns apart.

    Stripes are constant along a row and cancel; with ``lag`` at least the
    horizontal smoothing, a value and its neighbours have independent noise,
    so half a squared difference estimates one value's noise variance
    (locally: noise grows with the signal, and saturation removes it). Of
    the left and right differences the smaller is taken (and the bias that
    brings divided out), so that next to a footprint's side, where stripes
    meet background, the side away from it still measures noise.
    """
    lag = min(max(1, int(lag)), values.shape[1] - 1)
    compiled = noise_power_f32(values, lag, MIN_OF_TWO_DIFFERENCES)
    if compiled is not None:
        return compiled
    power = np.empty_like(values)
    if lag < 1:
        power[:] = 0.0
        return power
    # In place: one temporary instead of four (the same numbers).
    half = values[:, lag:] - values[:, :-lag]
    np.square(half, out=half)
    half *= 0.5
    # Within ``lag`` of the frame's sides a value has one neighbour only.
    power[:, :lag] = half[:, :lag]
    power[:, -lag:] = half[:, -lag:]
    if values.shape[1] > 2 * lag:
        inner = power[:, lag:-lag]
        np.minimum(half[:, :-lag], half[:, lag:], out=inner)
        np.divide(inner, inner.dtype.type(MIN_OF_TWO_DIFFERENCES), out=inner)
    return power


def close_vertically(mask: np.ndarray, kernel_rows: int) -> np.ndarray:
    """Vertical closing of a 0/1 uint8 mask with a ``kernel_rows`` × 1 line.

    It joins bright bands less than ``kernel_rows`` apart in a column.
    """
    if kernel_rows <= 1:
        return mask
    # Pad with dark rows: cv2's default border would count as bright for the
    # erosion and smear a footprint up to the frame's edge.
    pad = kernel_rows
    padded = cv2.copyMakeBorder(mask, pad, pad, 0, 0, cv2.BORDER_CONSTANT, value=0)
    kernel = np.ones((kernel_rows, 1), np.uint8)
    return cv2.morphologyEx(padded, cv2.MORPH_CLOSE, kernel)[pad:-pad]


def _extend_ends(gray, mask, x, y, faint, kernel_rows) -> tuple[np.ndarray, int]:
    """Grow a region's mask up and down over faint blocks within reach.

    Returns the new mask and its first block row.
    """
    h, w = mask.shape
    top, bottom = max(0, y - kernel_rows), min(gray.shape[0], y + h + kernel_rows)
    grown = (gray[top:bottom, x : x + w] > faint).astype(np.uint8)
    inner = slice(y - top, y - top + h)
    grown[inner] = mask
    grown = close_vertically(grown, kernel_rows)
    grown[inner] |= mask
    # Keep the rows joined to the region without a gap.
    filled = np.asarray(grown.any(axis=1))
    first, last = y - top, y - top + h - 1
    empty_above = np.flatnonzero(~filled[:first])
    empty_below = np.flatnonzero(~filled[last + 1 :])
    first = empty_above[-1] + 1 if empty_above.size else 0
    last = last + empty_below[0] if empty_below.size else filled.size - 1
    return grown[first : last + 1], top + first


def _noise_floor(image: BlockImage, gray: np.ndarray) -> float:
    # Quantisation of integer frames; a relative floor for float frames so
    # that an exactly flat float image is never "infinitely clean".
    if image.integer:
        return 0.3 / image.factor
    return 1e-6 * max(1.0, float(np.max(np.abs(gray))))


def _block_quantisation(image: BlockImage, gray: np.ndarray) -> float:
    # cv2's INTER_AREA rounds the block means of an integer frame to
    # integers: a uniform error of sigma 1/sqrt(12) DN.
    if image.integer and image.factor > 1:
        return float(np.sqrt(1.0 / 12.0))
    return _noise_floor(image, gray)


def _region_from_mask(image: BlockImage, mask: np.ndarray, x: int, y: int, area: int) -> Region:
    n_block_rows = image.blocks.shape[0]
    height = image.height
    # One more block row above and below: a block straddling the footprint's
    # top or bottom edge is too dark to pass the threshold, but its rows may
    # hold the first or last chips of a PHY-SDU. Their mask repeats the
    # nearest row's.
    top, bottom = max(0, y - 1), min(n_block_rows, y + mask.shape[0] + 1)
    first = -(-top * height // n_block_rows)
    stop = height if bottom >= n_block_rows else -(-bottom * height // n_block_rows)
    block_row = np.clip(image.block_row_of(np.arange(first, stop)) - y, 0, mask.shape[0] - 1)
    return Region(slice(first, stop), slice(x, x + mask.shape[1]), mask.astype(np.float32)[block_row], area)


def full_height(region: Region, height: int) -> Region:
    """The region over every row of the frame (``height`` rows), in its columns.

    Rows outside it take every column any of its rows holds.
    """
    columns = (region.weights.max(axis=0) > 0).astype(np.float32)
    weights = np.repeat(columns[None, :], height, axis=0)
    weights[region.rows] = region.weights
    return Region(slice(0, height), region.block_cols, weights, region.area_blocks)


def extended(region: Region, above: int, below: int) -> Region:
    """The region with ``above`` rows added over its first row and ``below`` under its last.

    Added rows repeat the columns of the end row they grow from.
    """
    if above == 0 and below == 0:
        return region
    weights = np.concatenate([np.repeat(region.weights[:1], above, axis=0), region.weights,
                              np.repeat(region.weights[-1:], below, axis=0)])
    rows = slice(region.rows.start - above, region.rows.stop + below)
    return Region(rows, region.block_cols, weights, region.area_blocks)


def _shares_columns(a: Region, b: Region) -> bool:
    return a.block_cols.start < b.block_cols.stop and b.block_cols.start < a.block_cols.stop


def room_to_grow(regions: list[Region], height: int, rows: int) -> list[tuple[int, int]]:
    """Rows each region may grow (above, below): at most ``rows``, within the frame's ``height``,
    and at most half the gap to another region in shared columns (two LEDs one above the other
    share the rows between them, not each other's stripes)."""
    room = []
    for region in regions:
        above, below = min(rows, region.rows.start), min(rows, height - region.rows.stop)
        for other in regions:
            if other is region or not _shares_columns(region, other):
                continue
            if other.rows.stop <= region.rows.start:
                above = min(above, (region.rows.start - other.rows.stop) // 2)
            elif other.rows.start >= region.rows.stop:
                below = min(below, (other.rows.start - region.rows.stop) // 2)
        room.append((above, below))
    return room
