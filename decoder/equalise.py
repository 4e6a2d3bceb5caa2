"""Chips seen through an exposure longer than a chip: sequence detection.

With an exposure of E rows, row i of a profile integrates the LED over the
instants whose row position u (the row whose exposure is centred on u, the
convention of :mod:`decoder.records`) lies in [i − E/2, i + E/2]. Over a
chip grid (pitch P rows, chip c from φ + cP to φ + (c + 1)P) the row's mean
is therefore

    y_i = off_i + gap_i · Σ_c w_ic x_c,    w_ic = |[i − E/2, i + E/2] ∩ chip c| / E,

a known, linear smear. Once E exceeds about a chip, isolated chips no longer
reach the threshold (a box of two chips turns ``0101`` into a flat line), so
thresholding fails. But a row touches at most L = ⌈E/P⌉ + 1 chips, so the
most likely chip sequence is found exactly by the Viterbi algorithm over
the 2^(L−1) states of the last L − 1 chips (maximum-likelihood sequence
detection, Gaussian noise on the row means).

What the frame does not say is estimated:

* the grid's phase φ: every phase on a grid of :data:`PHASES` per chip is
  tried, all at once, and the one whose best sequence fits best wins; then
  pitches within ±:data:`PITCH_SPAN` of the nominal one, anchored
  mid-profile (a row time slightly off drifts the grid);
* the levels, y = min(ceiling, off + gap·s + bend·s(1 − s)) (:class:`Levels`):
  off, gap and bend are P-splines along the profile (vignetting, the chord,
  glare; saturation bends and clips the curve), first guessed from the
  profile's running mean and deviation and the line code's smeared
  statistics (:func:`code_statistics`), then refitted by least squares on
  the decided chips, :data:`LEVEL_PASSES` times.

Rows where the fitted stripes do not stand out of the residual noise
(:func:`modulation_sigmas`) are erasures: the detector never lays chips
there (noise alone would always give it *some* best sequence). Its caller
chooses how far out they must stand; :mod:`decoder.pipeline` reads rows
from :data:`WEAK_MODULATION_SIGMA` and keeps what fails its check only
from :data:`MIN_MODULATION_SIGMA`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.ndimage import maximum_filter1d, uniform_filter1d

from rollsim.protocol import PhyFormat
from rollsim.protocol.linecode import encode

from decoder.kernels import viterbi_f64
from decoder.order_stats import percentiles
from decoder.timing import ChipStream

# Phases of the chip grid tried per chip.
PHASES = 16
# Pitches tried about the nominal one (a row time off by up to this
# fraction), in this many steps.
PITCH_SPAN = 0.006
PITCH_STEPS = 9
# Detect, refit the levels on the decisions, detect again: passes.
LEVEL_PASSES = 3
# Longest exposure (chips) handled: 2^(L−1) states with L = ⌈E/P⌉ + 1.
MAX_EXPOSURE_CHIPS = 6.0
# A row is surely read when the fitted stripes stand this many noise sigmas
# out of the fit's residual (modulation_sigmas). Profiles of Gaussian noise
# reached at most 2.3 in 140 profiles of 1080 rows (1.5 to 10 rows per
# chip, 0.3 to 6 chips of exposure), 2.41 in 160 more (1 to 10 rows per
# chip), and once 3.28 (10 rows per chip, 2 chips; none gave a candidate).
MIN_MODULATION_SIGMA = 3.0
# Rows between this and MIN_MODULATION_SIGMA are read too, but a candidate
# that touches one is kept only if it passes its line code and check
# (decoder.pipeline). Noise reaches this level, so chips laid there may be
# noise's: random chips pass Manchester decoding with probability 2^-26 per
# 26-bit codeword (paper-default's 52 chips; at most 27·2^-26 with one pair
# repaired), before the check. In
# Gaussian noise a few chips are read from 2 rows per chip on (mostly at a
# profile's ends), a third at one row per chip; none of their candidates
# passed (tested). On the envelope's SNR map (16 frames of paper-geometric)
# reading from 1.5 rather than 2.0 sigmas took 10.3 dB from 31 to 44 of 52
# and 7.3 dB from 0 to 5, and one row per chip from 238 to 262 of 263, with
# no undetected error (16 frames of the scene's own seed at 10.3 dB: 28 to
# 43); 2.0 had taken 10.3 dB from 0 to 10 of 52, against 2.5.
WEAK_MODULATION_SIGMA = 1.5
# The stripes' significance is measured over this many chips: long enough
# that a stretch the smear flattens (0101… seen through two chips) lies
# between chips that show.
MODULATION_WINDOW_CHIPS = 24
# The levels are splines with a knot every this many chips: a footprint's
# edge (a disk's chord, a glare halo) changes the gap within a few chips.
LEVEL_KNOT_CHIPS = 8.0
# Second-difference penalty of the level splines (P-spline), per row.
LEVEL_SMOOTHING = 1.0
# Window (chips) of the envelopes the levels start from.
ENVELOPE_CHIPS = 12


@dataclass(frozen=True)
class ChipGrid:
    """Chips of a profile on a regular grid.

    Attributes
    ----------
    phase_rows : float
        Row position of the start of chip 0 (may be negative: chip 0 is the
        first chip any row's exposure touches).
    rows_per_chip : float
        Chip pitch P, rows.
    n_chips : int
    """

    phase_rows: float
    rows_per_chip: float
    n_chips: int

    def edges(self) -> np.ndarray:
        """Row position of every chip's start edge and of the last one's end, shape (n_chips + 1,)."""
        return self.phase_rows + self.rows_per_chip * np.arange(self.n_chips + 1)


@dataclass(frozen=True)
class Levels:
    """How a row's mean follows its smeared level s: y = min(ceiling, off + gap·s + bend·s(1 − s)).

    Saturation bends and then clips the curve: once some pixels of a row
    clip, the mean grows more slowly near the ON level (bend > 0 with the
    ends at off and off + gap), and once most of them do it stops at a
    ceiling.

    Attributes
    ----------
    off, gap, bend, ceiling : ndarray of float64, shape (n_rows,)
        Profile units (DN).
    """

    off: np.ndarray
    gap: np.ndarray
    bend: np.ndarray
    ceiling: np.ndarray

    def model(self, smear: np.ndarray) -> np.ndarray:
        """Row means for smeared levels ``smear`` (shape (n,) or (n, m))."""
        if smear.ndim == 2:
            linear = self.off[:, None] + smear * (self.gap[:, None] + self.bend[:, None] * (1.0 - smear))
            return np.minimum(linear, self.ceiling[:, None])
        return np.minimum(self.off + smear * (self.gap + self.bend * (1.0 - smear)), self.ceiling)


def chip_grid(n_rows: int, exposure_rows: float, rows_per_chip: float, phase: float) -> ChipGrid:
    """The grid of chips that rows 0 … n_rows − 1 see, for a phase in [0, P).

    Parameters
    ----------
    n_rows : int
    exposure_rows : float
        Exposure E in rows (exposure / row time).
    rows_per_chip : float
    phase : float
        Row position, modulo P, of a chip's start edge.
    """
    half = 0.5 * exposure_rows
    first = int(np.floor((-half - phase) / rows_per_chip))
    last = int(np.floor((n_rows - 1 + half - phase) / rows_per_chip))
    return ChipGrid(phase + first * rows_per_chip, rows_per_chip, last - first + 1)


def memory_chips(exposure_rows: float, rows_per_chip: float) -> int:
    """L: the most chips one row's exposure can touch, ⌈E/P⌉ + 1."""
    return int(np.ceil(exposure_rows / rows_per_chip - 1e-9)) + 1


def row_weights(n_rows: int, exposure_rows: float, grid: ChipGrid, memory: int) -> tuple[np.ndarray, np.ndarray]:
    """Which chip each row's exposure ends in, and the share of each chip it sees.

    Parameters
    ----------
    n_rows : int
    exposure_rows : float
        E, rows (> 0).
    grid : ChipGrid
    memory : int
        L (:func:`memory_chips`).

    Returns
    -------
    last_chip : ndarray of int64, shape (n_rows,)
        Index (in ``grid``) of the chip holding the end of the row's exposure.
    weights : ndarray of float64, shape (n_rows, memory)
        Column k: the fraction of the exposure spent in chip
        ``last_chip − memory + 1 + k``; each row sums to 1.
    """
    rows = np.arange(n_rows, dtype=np.float64)
    low, high = rows - 0.5 * exposure_rows, rows + 0.5 * exposure_rows
    pitch = grid.rows_per_chip
    last_chip = np.floor((high - grid.phase_rows) / pitch).astype(np.int64)
    last_chip = np.clip(last_chip, 0, grid.n_chips - 1)
    chips = last_chip[:, None] - memory + 1 + np.arange(memory)
    start = grid.phase_rows + chips * pitch
    overlap = np.minimum(high[:, None], start + pitch) - np.maximum(low[:, None], start)
    weights = np.maximum(overlap, 0.0) / exposure_rows
    # Rounding at the grid's ends: renormalise so that each row sums to 1.
    return last_chip, weights / weights.sum(axis=1, keepdims=True)


def combo_bits(memory: int) -> np.ndarray:
    """Bit k of every combination 0 … 2^L − 1 of L chips, shape (2^L, L), oldest chip first."""
    return ((np.arange(2**memory)[:, None] >> np.arange(memory)) & 1).astype(np.float64)


def branch_metrics(values, levels: Levels, inv_var, last_chip, weights, n_chips: int) -> np.ndarray:
    """Squared errors of every chip combination, summed over the rows whose exposure ends in each chip.

    Returns
    -------
    ndarray of float64, shape (n_chips, 2^L)
    """
    memory = weights.shape[1]
    smear = weights @ combo_bits(memory).T                       # (rows, combos)
    residual = values[:, None] - levels.model(smear)
    cost = residual * residual * inv_var[:, None]
    metrics = np.zeros((n_chips, cost.shape[1]))
    # last_chip never decreases along the rows: sum each chip's run of rows.
    starts = np.flatnonzero(np.concatenate([[True], last_chip[1:] != last_chip[:-1]]))
    if starts.size:
        metrics[last_chip[starts]] = np.add.reduceat(cost, starts, axis=0)
    return metrics


def viterbi(metrics: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Most likely chip sequences of several grids at once.

    Parameters
    ----------
    metrics : ndarray, shape (G, n_chips, 2^L)
        Branch metrics (:func:`branch_metrics`) of G grids (phases).

    Returns
    -------
    chips : ndarray of int8, shape (G, n_chips)
        The best sequence of each grid.
    cost : ndarray of float64, shape (G,)
        Its total metric.
    """
    # A loop over the chips: compiled where numba is, numpy's twin otherwise.
    compiled = viterbi_f64(np.ascontiguousarray(metrics, dtype=np.float64))
    return compiled if compiled is not None else _viterbi_numpy(metrics)


def _viterbi_numpy(metrics: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`viterbi` in numpy, one step per chip for all grids at once."""
    n_grids, n_chips, n_combos = metrics.shape
    n_states = n_combos // 2
    combos = np.arange(n_combos)
    previous = combos & (n_states - 1)           # state before the chip: chips c−L+1 … c−1
    cost = np.zeros((n_grids, n_states))
    choice = np.zeros((n_chips, n_grids, n_states), dtype=np.int8)
    for c in range(n_chips):
        # Combination b = 2·state' + (oldest chip): new state' = b >> 1.
        candidates = (cost[:, previous] + metrics[:, c, :]).reshape(n_grids, n_states, 2)
        choice[c] = candidates[:, :, 1] < candidates[:, :, 0]
        cost = np.minimum(candidates[:, :, 0], candidates[:, :, 1])
    state = np.argmin(cost, axis=1)
    best = cost[np.arange(n_grids), state]
    top = max(n_states.bit_length() - 2, 0)
    chips = np.zeros((n_grids, n_chips), dtype=np.int8)
    grids = np.arange(n_grids)
    for c in range(n_chips - 1, -1, -1):
        chips[:, c] = (state >> top) & 1 if n_states > 1 else state
        state = ((2 * state + choice[c, grids, state]) & (n_states - 1))
    return chips, best


def smeared(chips: np.ndarray, last_chip: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The model's row levels s_i = Σ_k w_ik x (in [0, 1]) for decided chips."""
    memory = weights.shape[1]
    index = last_chip[:, None] - memory + 1 + np.arange(memory)
    seen = np.where(index >= 0, chips[np.maximum(index, 0)], 0)
    return np.sum(weights * seen, axis=1)


@dataclass(frozen=True)
class SplineBasis:
    """Cubic B-splines on rows 0 … n − 1, stored by their four non-zero values per row.

    Attributes
    ----------
    columns : ndarray of int64, shape (n_rows, 4)
        The splines that are non-zero on each row.
    values : ndarray of float64, shape (n_rows, 4)
        Their values there.
    n_splines : int
    """

    columns: np.ndarray
    values: np.ndarray
    n_splines: int

    def evaluate(self, coefficients: np.ndarray) -> np.ndarray:
        """Σ_j B_ij c_j for every row."""
        return np.sum(self.values * coefficients[self.columns], axis=1)


def spline_basis(n_rows: int, spacing_rows: float) -> SplineBasis:
    """Cubic B-splines with knots every ``spacing_rows`` rows (about), on rows 0 … n − 1."""
    from scipy.interpolate import BSpline

    last = float(max(n_rows - 1, 1))
    count = max(int(np.ceil(last / spacing_rows)), 1)
    inner = np.linspace(0.0, last, count + 1)
    knots = np.concatenate([[0.0] * 3, inner, [last] * 3])
    matrix = BSpline.design_matrix(np.arange(n_rows, dtype=np.float64).clip(0.0, last), knots, 3).tocsr()
    # Each row has exactly k + 1 = 4 stored entries (zeros included).
    columns = matrix.indices.reshape(n_rows, 4).astype(np.int64)
    return SplineBasis(columns, matrix.data.reshape(n_rows, 4), int(matrix.shape[1]))


def fit_levels(values: np.ndarray, smear: np.ndarray, basis: SplineBasis, weight: np.ndarray, ceiling: np.ndarray,
               smoothing: float = LEVEL_SMOOTHING) -> Levels:
    """Least-squares levels y ≈ off + gap·s + bend·s(1 − s), smooth along the profile.

    off, gap and bend are cubic splines (``basis``); a penalty on their second
    differences (a P-spline) keeps them defined where s never changes (a
    long run of equal chips, the profile's ends). The normal equations are
    accumulated from each row's 12 non-zero design entries.

    Parameters
    ----------
    values : ndarray, shape (n,)
    smear : ndarray, shape (n,)
        The model's s_i in [0, 1] for the chips decided.
    basis : SplineBasis
        :func:`spline_basis`.
    weight : ndarray, shape (n,)
        Weight of each row (0 leaves it out).
    ceiling : ndarray, shape (n,)
        The profile's local ceiling (:func:`profile_ceiling`); rows at it
        say only that the curve reaches it, and are left out.
    smoothing : float
        Penalty weight, relative to the rows' mean weight.

    Returns
    -------
    Levels
    """
    k = basis.n_splines
    weight = np.where(values < ceiling, weight, 0.0)
    factors = np.stack([np.ones_like(smear), smear, smear * (1.0 - smear)], axis=1)       # (n, 3)
    entries = (factors[:, :, None] * basis.values[:, None, :]).reshape(-1, 12)          # (n, 12)
    columns = (np.arange(3)[:, None] * k + basis.columns[:, None, :]).reshape(-1, 12)
    pairs = (columns[:, :, None] * (3 * k) + columns[:, None, :]).ravel()
    products = (weight[:, None, None] * entries[:, :, None] * entries[:, None, :]).ravel()
    normal = np.bincount(pairs, products, (3 * k) ** 2).astype(np.float64).reshape(3 * k, 3 * k)
    rhs = np.bincount(columns.ravel(), (weight[:, None] * entries * values[:, None]).ravel(), 3 * k)
    second = np.diff(np.eye(k), 2, axis=0)
    penalty = smoothing * max(float(np.mean(weight)), 1e-12) * (second.T @ second)
    for block in range(3):
        normal[block * k : (block + 1) * k, block * k : (block + 1) * k] += penalty
    # A tiny ridge keeps the system regular where a block is unidentified.
    ridge = 1e-9 * max(float(np.trace(normal)), 1e-300) / (3 * k)
    coef = np.linalg.solve(normal + ridge * np.eye(3 * k), rhs)
    return Levels(basis.evaluate(coef[:k]), basis.evaluate(coef[k : 2 * k]), basis.evaluate(coef[2 * k :]), ceiling)


def profile_ceiling(values: np.ndarray, window_rows: int, margin: float) -> np.ndarray:
    """The highest a row's mean gets nearby: its running maximum, less ``margin``.

    Saturated rows sit at it; the model's curve is clipped there.
    """
    return maximum_filter1d(values, window_rows, mode="nearest") - margin


@lru_cache(maxsize=64)
def code_statistics(phy: PhyFormat, exposure_rows: float, rows_per_chip: float, n_sdus: int = 64) -> tuple[float, float]:
    """Mean and standard deviation of the smeared level s of a random chip stream.

    PHY-SDUs of random bits (SYNC, then the line code), one after another,
    seen through the exposure on a grid of ``rows_per_chip``; from a fixed
    generator, so the figures are deterministic (and cached: the regions
    and frames of one decode share them).

    Returns
    -------
    mean, std : float
        Of s_i over the rows (s in [0, 1]).
    """
    rng = np.random.default_rng(0)
    bits = rng.integers(0, 2, size=(n_sdus, phy.data_bits + phy.check_bits), dtype=np.uint8)
    coded = encode(bits, phy.line_code)
    sync = np.concatenate([np.ones(phy.sync_chips - 1), [0.0]])
    chips = np.hstack([np.tile(sync, (n_sdus, 1)), coded]).ravel()
    n_rows = int(chips.size * rows_per_chip)
    memory = memory_chips(exposure_rows, rows_per_chip)
    # Every phase of the grid: at a pitch near a whole number of rows, each
    # row sees the chips at nearly the same phase, and which one is unknown.
    smears = []
    for k in range(PHASES):
        grid = chip_grid(n_rows, exposure_rows, rows_per_chip, rows_per_chip * k / PHASES)
        last_chip, weights = row_weights(n_rows, exposure_rows, grid, memory)
        smears.append(smeared(np.resize(chips, grid.n_chips), last_chip, weights))
    smear = np.concatenate(smears)
    return float(smear.mean()), float(smear.std())


def initial_levels(values: np.ndarray, window_rows: int, statistics: tuple[float, float], ceiling: np.ndarray) -> Levels:
    """Off level and gap from the profile's running mean and deviation.

    A long exposure keeps the smeared level s from reaching 0 or 1, so the
    envelopes do not show the levels; its mean and deviation over random
    chips (:func:`code_statistics`) do: gap = std(y) / std(s), off = mean(y)
    − gap · mean(s). Noise inflates the deviation a little; the fits on the
    decisions correct it.
    """
    mean_s, std_s = statistics
    mean = uniform_filter1d(values, window_rows, mode="nearest")
    square = uniform_filter1d(values * values, window_rows, mode="nearest")
    gap = np.sqrt(np.maximum(square - mean * mean, 0.0)) / max(std_s, 1e-6)
    return Levels(mean - gap * mean_s, gap, np.zeros_like(gap), ceiling)


def modulation_sigmas(model: np.ndarray, window_rows: int, rows_per_chip: float, sigma: float) -> np.ndarray:
    """How far the fitted stripes stand out of the noise, row by row.

    The local RMS of the model's deviation from its running mean, times the
    square root of the rows per chip (the evidence one chip gets), in noise
    sigmas of one row mean. The fitted gap alone would not do: where the
    smear keeps s nearly constant, a gap fitted to noise can be anything.
    """
    mean = uniform_filter1d(model, window_rows, mode="nearest")
    deviation = uniform_filter1d((model - mean) ** 2, window_rows, mode="nearest")
    return np.sqrt(np.maximum(deviation, 0.0) * rows_per_chip) / sigma


def robust_sigma(residual: np.ndarray) -> float:
    """Noise sigma of row means from fit residuals (scaled median absolute deviation)."""
    if residual.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(residual - np.median(residual))))


@dataclass(frozen=True)
class Equalised:
    """Chips detected by :func:`detect_chips`, with the fit that found them.

    Attributes
    ----------
    chips : ChipStream
    valid : ndarray of bool, shape (n_rows,)
        Rows whose fitted stripes stand out of the noise (:func:`modulation_sigmas`).
    levels : Levels
        Fitted levels (profile units).
    sigma : float
        Noise of one row mean, from the residuals.
    modulation : ndarray of float64, shape (n_rows,)
        How far the fitted stripes stand out of the noise
        (:func:`modulation_sigmas`); ``valid`` is where it passes the threshold.
    """

    chips: ChipStream
    valid: np.ndarray
    levels: Levels
    sigma: float
    modulation: np.ndarray


def detect_chips(values: np.ndarray, phy: PhyFormat, rows_per_chip: float, exposure_rows: float, window_rows: int | None = None,
                 min_modulation_sigma: float = MIN_MODULATION_SIGMA) -> Equalised:
    """Maximum-likelihood chips of a row profile seen through a long exposure.

    Parameters
    ----------
    values : ndarray, shape (n,)
        Row means (any units).
    phy : PhyFormat
        The PHY-SDU layout (its line code sets the levels' first guess).
    rows_per_chip : float
        Chip pitch P, rows.
    exposure_rows : float
        Exposure E, rows (exposure time / row time).
    window_rows : int, optional
        Window of the envelopes the levels start from; default
        :data:`ENVELOPE_CHIPS` chips.
    min_modulation_sigma : float
        Rows whose fitted stripes stand less than this many residual sigmas out
        of the noise (:func:`modulation_sigmas`) are erased.

    Returns
    -------
    Equalised

    Raises
    ------
    ValueError
        Non-positive ``rows_per_chip`` or ``exposure_rows``, or an exposure
        longer than :data:`MAX_EXPOSURE_CHIPS` chips.
    """
    values = np.asarray(values, dtype=np.float64)
    if not rows_per_chip > 0:
        raise ValueError(f"rows_per_chip must be > 0, got {rows_per_chip}")
    if not exposure_rows > 0:
        raise ValueError(f"exposure_rows must be > 0, got {exposure_rows}")
    if exposure_rows / rows_per_chip > MAX_EXPOSURE_CHIPS:
        raise ValueError(f"exposure_rows = {exposure_rows}: longer than {MAX_EXPOSURE_CHIPS} chips of {rows_per_chip} rows")
    n = values.size
    window = window_rows or 2 * int(ENVELOPE_CHIPS * rows_per_chip // 2) + 1
    basis = spline_basis(n, LEVEL_KNOT_CHIPS * rows_per_chip)
    memory = memory_chips(exposure_rows, rows_per_chip)
    grids = [chip_grid(n, exposure_rows, rows_per_chip, rows_per_chip * k / PHASES) for k in range(PHASES)]
    layout = [row_weights(n, exposure_rows, grid, memory) for grid in grids]
    ceiling = profile_ceiling(values, 2 * window + 1, 0.0)
    levels = initial_levels(values, window, code_statistics(phy, exposure_rows, rows_per_chip), ceiling)
    inv_var = np.ones(n)
    # The phase is chosen once, on the first guess of the levels; the
    # passes after it refine the levels and the chips on that grid.
    best, chips = _best_grid(values, levels, inv_var, grids, layout)
    # A row time a little off makes the grid drift by a chip over a few
    # hundred: try pitches around the nominal one, anchored mid-profile.
    grids = pitch_candidates(grids[best], n, exposure_rows)
    layout = [row_weights(n, exposure_rows, grid, memory) for grid in grids]
    best, chips = _best_grid(values, levels, inv_var, grids, layout)
    grid, (last_chip, weights) = grids[best], layout[best]
    for _ in range(LEVEL_PASSES):
        levels = fit_levels(values, smeared(chips, last_chip, weights), basis, inv_var, ceiling)
        _, chips = _best_grid(values, levels, inv_var, [grid], [(last_chip, weights)])
    return _equalised(values, chips, grid, (last_chip, weights), levels, exposure_rows, min_modulation_sigma)


# The rows at a profile's ends searched for a level step (chips, and at
# least STEP_SEARCH_MIN_ROWS rows: a region keeps one block row past its
# footprint, 4 px by default, and a block straddling the edge), and the
# stripes' range it is measured against (chips just inside).
STEP_SEARCH_CHIPS = 2.0
STEP_SEARCH_MIN_ROWS = 8
STEP_REFERENCE_CHIPS = 24.0
# A row is past a step when it lies this many times the reference's 5–95 %
# spread outside that spread: stripes never leave their own range; noise
# alone puts the 5th and 95th percentiles 1.6 sigmas out and the spread at
# 3.3, so a noise row is cut only 8.2 sigmas from its mean (stripes widen
# the spread further); and a trend does not move a level that much within
# two chips.
STEP_SPREADS = 2.0


def stepped_ends(values: np.ndarray, rows_per_chip: float) -> tuple[int, int]:
    """The rows of a profile inside the level steps at its ends, as ``(first, stop)``.

    A region keeps a block row past its footprint's top and bottom, where a
    straddling block may hold chips. When the LED's face is darker (or
    brighter) than what surrounds it, those rows sit far off the LED's
    levels: an LED 17 mm across at 650 lx reads 25 DN inside its disk and
    60 DN outside, against a stripe gap of 1.6 DN at 10 dB. The detector's
    levels (smooth splines) cannot follow such a step, and its squared
    residuals (60 noise sigmas) outweigh all the stripes in choosing the
    grid's phase. Such rows are not the LED's: only rows within
    :data:`STEP_SEARCH_CHIPS` chips of each end are looked at, and those up
    to the innermost one lying :data:`STEP_SPREADS` spreads outside the
    stripes' range next to it (:data:`STEP_REFERENCE_CHIPS` chips, 5 to
    95 %) are cut. An LED whose OFF level is the background's has no step
    and loses no row.

    Parameters
    ----------
    values : ndarray, shape (n,)
        Row means (any units).
    rows_per_chip : float
        Chip pitch, rows.

    Returns
    -------
    (int, int)
        ``values[first:stop]`` is the LED's; ``(0, n)`` when no end steps.
    """
    values = np.asarray(values, dtype=np.float64)
    n = values.size
    search = int(max(STEP_SEARCH_MIN_ROWS, np.ceil(STEP_SEARCH_CHIPS * rows_per_chip)))
    reference = int(np.ceil(STEP_REFERENCE_CHIPS * rows_per_chip))
    if n < 2 * search + reference:
        return 0, n

    def cut(ends: np.ndarray, inside: np.ndarray) -> int:
        low, high = percentiles(inside, (5.0, 95.0))
        margin = STEP_SPREADS * (high - low)
        outside = np.flatnonzero((ends < low - margin) | (ends > high + margin))
        return int(outside[-1]) + 1 if outside.size else 0

    first = cut(values[:search], values[search : search + reference])
    stop = n - cut(values[::-1][:search], values[::-1][search : search + reference])
    return first, stop


def pitch_candidates(grid: ChipGrid, n_rows: int, exposure_rows: float) -> list[ChipGrid]:
    """Grids of pitches within ±:data:`PITCH_SPAN` of ``grid``'s, each at three phases about its edge nearest mid-profile."""
    middle = 0.5 * (n_rows - 1)
    pitch = grid.rows_per_chip
    edge = grid.phase_rows + pitch * np.round((middle - grid.phase_rows) / pitch)
    step = pitch / PHASES
    return [chip_grid(n_rows, exposure_rows, pitch * factor, (edge + shift) % (pitch * factor))
            for factor in 1.0 + PITCH_SPAN * np.linspace(-1.0, 1.0, PITCH_STEPS) for shift in (-step, 0.0, step)]


def _best_grid(values, levels, inv_var, grids, layout) -> tuple[int, np.ndarray]:
    """The phase whose best chip sequence fits best, and that sequence."""
    n_chips = max(grid.n_chips for grid in grids)
    metrics = np.stack([branch_metrics(values, levels, inv_var, last, weights, n_chips) for last, weights in layout])
    chips, cost = viterbi(metrics)
    best = int(np.argmin(cost))
    return best, chips[best, : grids[best].n_chips]


def _equalised(values, chips, grid: ChipGrid, layout, levels, exposure_rows: float, min_modulation_sigma: float) -> Equalised:
    """Erasures, confidences and chip positions of a detected sequence."""
    last_chip, weights = layout
    gap = levels.gap
    model = levels.model(smeared(chips, last_chip, weights))
    residual = values - model
    sigma = max(robust_sigma(residual), 1e-12)
    window = 2 * int(MODULATION_WINDOW_CHIPS * grid.rows_per_chip // 2) + 1
    modulation = modulation_sigmas(model, window, grid.rows_per_chip, sigma)
    valid = modulation > min_modulation_sigma
    memory = weights.shape[1]
    index = np.clip(last_chip[:, None] - memory + 1 + np.arange(memory), 0, grid.n_chips - 1)
    # A chip is read if some valid row sees a good share of it.
    seen = np.zeros(grid.n_chips)
    np.maximum.at(seen, index.ravel(), (weights * valid[:, None]).ravel())
    read = seen >= 0.5 * min(grid.rows_per_chip, exposure_rows) / exposure_rows
    # Confidence: the least-squares value of each chip with the others fixed,
    # as a distance from the midpoint (1 = exactly on its level).
    g_w = gap[:, None] * weights * valid[:, None]
    numerator = np.bincount(index.ravel(), (g_w * residual[:, None]).ravel(), grid.n_chips)
    energy = np.bincount(index.ravel(), (g_w * g_w).ravel(), grid.n_chips)
    estimate = chips + np.divide(numerator, energy, out=np.zeros(grid.n_chips), where=energy > 0)
    confidence = np.clip(np.abs(2.0 * estimate - 1.0), 0.0, 1.0)
    # Flipping chip c alone adds energy·(2c − 1)(2x̂ − 1) to the squared
    # residual (x̂ its least-squares value): negative where x̂ disagrees.
    reliability = np.maximum(energy * (2.0 * chips - 1.0) * (2.0 * estimate - 1.0), 0.0)
    values_out = np.where(read, chips, -1).astype(np.int8)
    confidence[~read] = 0.0
    reliability[~read] = 0.0
    edges = grid.edges()
    stream = ChipStream(values_out, edges[:-1], edges[1:], confidence, np.ones(grid.n_chips, dtype=bool), reliability)
    return Equalised(stream, valid, levels, sigma, modulation)
