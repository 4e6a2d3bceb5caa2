"""Chip timing: from row levels to chips.

Clock recovery re-aligns on every edge. The levels are cut into runs at
their edges (sub-row positions where the normalised profile crosses zero);
each run holds ``round(length / rows_per_chip)`` chips, spread evenly over
it. A row-time error of a few percent therefore changes a run's length by a
fraction of a row and never accumulates over a PHY-SDU: only a run of more
than about 1 / (2·error) chips would be miscounted.

A run cut by the region's border or by an erasure has only one real edge:
its chips are laid from that edge at the nominal pitch, and chips that reach
past the cut are flagged as not ``exact`` (a PHY-SDU holding one is
truncated).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Chips reaching farther than this past a cut (rows) are not exact. Edges at
# a footprint's ends are known to about half a row (partial rows, short
# exposures), so a PHY-SDU may miss up to this much of a chip and pass.
CUT_TOLERANCE_ROWS = 0.5
# Fewer rows per chip cannot be resolved by a row-sampled profile.
MIN_ROWS_PER_CHIP = 1.2


@dataclass(frozen=True)
class Runs:
    """Maximal runs of equal levels.

    Attributes
    ----------
    bounds : ndarray of float64, shape (m + 1,)
        Run boundaries in rows (profile coordinates); the first is -0.5 and
        the last n - 0.5 (the profile's outer row edges).
    values : ndarray of int8, shape (m,)
        Level of each run: 1, 0 or -1 (erasure).
    """

    bounds: np.ndarray
    values: np.ndarray

    @property
    def lengths(self) -> np.ndarray:
        return np.diff(self.bounds)


@dataclass(frozen=True)
class ChipStream:
    """Chips recovered from a profile, in order.

    Attributes
    ----------
    values : ndarray of int8, shape (k,)
        1 ON, 0 OFF, -1 erased.
    start, end : ndarray of float64, shape (k,)
        Row positions (profile coordinates) of each chip's start and end
        edge: the row whose exposure is centred on that instant.
    confidence : ndarray of float64, shape (k,)
        |q| at the chip centre, clipped to [0, 1]; 0 for erased chips.
    exact : ndarray of bool, shape (k,)
        False for chips laid past a cut (region border, erasure).
    reliability : ndarray of float64, shape (k,), optional
        What flipping each chip's decision alone would cost, in any unit
        shared by the stream (>= 0; for the line code's repair,
        :meth:`rollsim.protocol.PhyFormat.decode_coded`); None where
        ``confidence`` serves (a threshold's distance, whose sign is the
        decision's).
    """

    values: np.ndarray
    start: np.ndarray
    end: np.ndarray
    confidence: np.ndarray
    exact: np.ndarray
    reliability: np.ndarray | None = None

    @property
    def flip_costs(self) -> np.ndarray:
        """:attr:`reliability`, or :attr:`confidence` where there is none."""
        return self.confidence if self.reliability is None else self.reliability

    def __len__(self) -> int:
        return int(self.values.size)


def nominal_rows_per_chip(clock_hz: float, row_time_s: float) -> float:
    """Rows per chip, 1 / (f·t_row).

    Parameters
    ----------
    clock_hz : float
        Chip rate in Hz.
    row_time_s : float
        Row time in seconds.
    """
    if not (clock_hz > 0 and row_time_s > 0):
        raise ValueError(f"clock_hz and row_time_s must be > 0, got {clock_hz} and {row_time_s}")
    return 1.0 / (clock_hz * row_time_s)


def find_runs(level: np.ndarray, q: np.ndarray) -> Runs:
    """Runs of equal level, with sub-row edges.

    An ON/OFF edge lies where q crosses zero (linear interpolation between
    the last row on the old side and the next); an edge to or from an
    erasure lies between the two rows.

    Parameters
    ----------
    level : ndarray of int8, shape (n,)
    q : ndarray of float64, shape (n,)
        Normalised profile (see :mod:`decoder.binarize`).
    """
    n = level.size
    if n == 0:
        return Runs(np.array([-0.5, -0.5]), np.zeros(0, np.int8))
    change = np.flatnonzero(level[1:] != level[:-1])
    before, after = level[change], level[change + 1]
    edges = change + 0.5
    binary = (before >= 0) & (after >= 0)
    if binary.any():
        rows = np.arange(n)
        last_nonpositive = np.maximum.accumulate(np.where(q <= 0, rows, -1))
        last_nonnegative = np.maximum.accumulate(np.where(q >= 0, rows, -1))
        k = change[binary]
        # Hysteresis guarantees q crossed zero between the last opposite
        # decision and the switch.
        y = np.where(after[binary] == 1, last_nonpositive[k], last_nonnegative[k])
        y = np.clip(y, 0, n - 2)
        q0, q1 = q[y], q[y + 1]
        denom = q0 - q1
        frac = np.divide(q0, denom, out=np.full(q0.shape, 0.5), where=denom != 0)
        edges[binary] = y + np.clip(frac, 0.0, 1.0)
    bounds = np.concatenate([[-0.5], edges, [n - 0.5]])
    values = np.concatenate([level[:1], after]).astype(np.int8)
    return Runs(bounds, values)


# Runs in the sliding window of the local edge-bias estimate (about 20
# chips): saturation varies along a footprint (a disk's short chords at its
# ends hold more partly covered pixels, which saturate later).
BIAS_WINDOW_RUNS = 15


def edge_bias_chips(runs: Runs, rows_per_chip: float, min_runs: int = 8, window_runs: int = BIAS_WINDOW_RUNS) -> np.ndarray:
    """How much longer ON runs look than OFF runs, in chips (β), run by run.

    Saturation (and blooming) makes a row read as ON as soon as a small part
    of its exposure sees an ON chip, so every rising edge is found early and
    every falling edge late by the same amount: ON runs look k + β chips
    long and OFF runs k − β. β is the circular mean of the runs' fractional
    lengths (ON runs counted as +length, OFF runs as −length), among runs
    with a real edge on both sides, over a sliding window of
    ``window_runs`` runs, so that it follows the saturation along the
    profile. Of its two aliases (β and β − 1) a window takes the one under
    which fewer of its runs would hold no chip; a window too sparse, or
    whose runs' phases scatter too much to tell a bias
    (:data:`MIN_BIAS_RAYLEIGH`), takes the nearest window's that could, and
    the whole profile's β stands in where none could. A β under which more
    than :data:`MAX_BIAS_EMPTY_RUNS` of the runs would hold no chip is no
    square-wave bias at all, and is taken as 0.

    Returns
    -------
    ndarray of float64, shape (m,)
        β of each run, in (−1, 1); zeros when there are too few runs to
        tell.
    """
    values = runs.values
    beta = np.zeros(values.size)
    if values.size < 3:
        return beta
    inner = np.zeros(values.size, dtype=bool)
    inner[1:-1] = (values[1:-1] >= 0) & (values[:-2] >= 0) & (values[2:] >= 0)
    chips = runs.lengths / rows_per_chip
    on, off = inner & (values == 1), inner & (values == 0)
    if on.sum() + off.sum() < min_runs or not on.any() or not off.any():
        return beta
    phasor = np.where(on, np.exp(2j * np.pi * chips), np.where(off, np.exp(-2j * np.pi * chips), 0.0))
    # Under a bias b an ON run holds no chip when b > chips − ½, an OFF run
    # when b < ½ − chips.
    ceiling = np.where(on, chips - 0.5, np.inf)
    floor = np.where(off, 0.5 - chips, -np.inf)
    total = phasor.sum(keepdims=True)
    seen = np.count_nonzero(inner, keepdims=True)
    beta_all, coherent_all = _least_empty_alias(total, seen, ceiling[None, :], floor[None, :], np.zeros(1))
    overall = float(beta_all[0]) if coherent_all[0] else 0.0
    width = min(window_runs, values.size)
    kernel = np.ones(width)
    local = np.convolve(phasor.real, kernel, "same") + 1j * np.convolve(phasor.imag, kernel, "same")
    counts = np.convolve(inner.astype(float), kernel, "same")
    # The runs of each window, aligned as np.convolve's "same" centres them.
    pad = np.arange(values.size)[:, None] + np.arange(width)[None, :] - width // 2
    outside = (pad < 0) | (pad >= values.size)
    pad = np.clip(pad, 0, values.size - 1)
    beta, coherent = _least_empty_alias(local, counts, np.where(outside, np.inf, ceiling[pad]),
                                        np.where(outside, -np.inf, floor[pad]), np.full(values.size, overall))
    known = coherent & (counts >= 0.5 * width)
    if not known.any():
        return np.full(values.size, overall)
    # A window too sparse or too scattered to tell its own β takes the
    # nearest one that could: across a saturated core's edge, the core's or
    # the halo's, rather than a mean of both.
    return beta[_nearest_true(known)]


def _nearest_true(mask: np.ndarray) -> np.ndarray:
    """For every index, the nearest index where ``mask`` is True (ties to the left); ``mask`` has one."""
    index = np.arange(mask.size)
    left = np.maximum.accumulate(np.where(mask, index, -1))
    right = np.minimum.accumulate(np.where(mask, index, mask.size)[::-1])[::-1]
    use_left = (right >= mask.size) | ((left >= 0) & (index - left <= right - index))
    return np.where(use_left, left, right)


# A bias estimate under which more than this fraction of the runs it corrects
# would hold no whole chip does not describe them (noise, not saturation).
MAX_BIAS_EMPTY_RUNS = 0.15
# Nor can one be told from runs whose fractional lengths scatter. Rayleigh's
# test: for n runs of random phase, n·R² (R the length of their mean phasor)
# exceeds K with probability e^−K, so below K = 6 (0.25 %) the runs are not
# known to share a bias. Runs biased alike whose lengths jitter by σ chips
# have R ≈ exp(−2π²σ²): 0.61 at σ = 0.16 (0.7 row at 4.5 rows per chip), so
# a window of 15 runs (n·R² = 5.6) falls back on the whole profile's β,
# while the whole profile's hundreds of runs pass easily.
MIN_BIAS_RAYLEIGH = 6.0


def _least_empty_alias(phasor_sum: np.ndarray, runs_seen: np.ndarray, ceiling: np.ndarray, floor: np.ndarray,
                       prior: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per window of runs, β from the sum of its runs' phasors: the alias that leaves the fewest runs without a chip.

    Of the two aliases (the phase in [0, 1) chips, and it less 1), a
    corrected run (ON k + β − β, OFF k − β + β) must round to at least one
    chip: an ON run fails when β exceeds its ``ceiling``, an OFF run when β
    is below its ``floor`` (windows × runs, ±inf where there is no run).
    Ties go to the alias nearest ``prior``. A best alias that still empties
    more than :data:`MAX_BIAS_EMPTY_RUNS` of the window's ``runs_seen`` runs
    gives 0.

    Returns
    -------
    (ndarray, ndarray of bool)
        β per window, and whether the window's phasors are coherent enough
        to tell it (:data:`MIN_BIAS_RAYLEIGH`).
    """
    high = np.mod(np.angle(phasor_sum) / (2 * np.pi), 1.0)
    aliases = np.stack([high, high - 1.0], axis=-1)
    b = aliases[:, :, None]
    misses = np.count_nonzero((b > ceiling[:, None, :]) | (b < floor[:, None, :]), axis=2)
    closer = np.abs(aliases - prior[:, None])
    pick = np.where(misses[:, 0] == misses[:, 1], closer[:, 1] < closer[:, 0], misses[:, 1] < misses[:, 0])
    rows = np.arange(pick.size)
    chosen, missed = aliases[rows, pick.astype(np.int64)], misses[rows, pick.astype(np.int64)]
    coherent = np.abs(phasor_sum) ** 2 >= MIN_BIAS_RAYLEIGH * np.maximum(runs_seen, 1)
    fit = missed <= MAX_BIAS_EMPTY_RUNS * runs_seen
    return np.where(fit, chosen, 0.0), coherent


def correct_edge_bias(runs: Runs, beta_chips: np.ndarray, rows_per_chip: float) -> Runs:
    """Move each rising edge later and each falling edge earlier by β/2 chip.

    ``beta_chips`` is per run (:func:`edge_bias_chips`); an edge takes the
    mean of its two runs'. Edges to or from an erasure are cuts, not level
    changes, and stay.
    """
    if runs.values.size < 2 or not np.any(beta_chips):
        return runs
    shift = 0.25 * (beta_chips[:-1] + beta_chips[1:]) * rows_per_chip
    return shifted_level_edges(runs, shift, shift)


def shifted_level_edges(runs: Runs, later_rows: np.ndarray, earlier_rows: np.ndarray) -> Runs:
    """Runs with each rising edge moved later and each falling edge earlier.

    Parameters
    ----------
    runs : Runs
        At least two runs.
    later_rows, earlier_rows : ndarray, shape (m − 1,)
        Per edge (edge k lies between runs k and k + 1), how far a rising
        edge moves later and a falling edge earlier, in rows. Edges to or
        from an erasure are cuts, not level changes, and stay.
    """
    before, after = runs.values[:-1], runs.values[1:]
    step = np.where((before == 0) & (after == 1), later_rows, np.where((before == 1) & (after == 0), -earlier_rows, 0.0))
    bounds = runs.bounds.copy()
    bounds[1:-1] += step
    # A correction never reorders edges: clip into the profile and keep order.
    bounds[1:-1] = np.clip(bounds[1:-1], bounds[0], bounds[-1])
    return Runs(np.maximum.accumulate(bounds), runs.values)


def merge_glitches(runs: Runs, rows_per_chip: float, passes: int = 3) -> Runs:
    """Absorb runs shorter than half a chip into their neighbours.

    A short ON/OFF run between two runs of the other level is noise: the
    three become one run. Next to an erasure it joins the erasure.
    """
    bounds, values = runs.bounds, runs.values
    for _ in range(passes):
        m = values.size
        if m < 3:
            break
        chips = np.rint(np.diff(bounds) / rows_per_chip)
        glitch = np.zeros(m, dtype=bool)
        glitch[1:-1] = (chips[1:-1] == 0) & (values[1:-1] >= 0)
        if not glitch.any():
            break
        i = np.flatnonzero(glitch)
        new = values.copy()
        new[i] = np.where(values[i - 1] == values[i + 1], values[i - 1], -1)
        keep = np.concatenate([[True], new[1:] != new[:-1]])
        values = new[keep]
        bounds = np.concatenate([bounds[:-1][keep], bounds[-1:]])
    return Runs(bounds, values)


def estimate_rows_per_chip(runs: Runs, min_runs: int = 8) -> float | None:
    """Rows per chip from the lengths of whole ON/OFF runs.

    Every run spans a whole number of chips. Start from the 20th percentile
    of the run lengths (one chip: the commonest run in Manchester and 4B6B)
    and refine by least squares, rows_per_chip = Σ length / Σ round(length /
    rows_per_chip).

    Returns
    -------
    float or None
        None when there are too few runs or they fit no chip pitch.
    """
    values = runs.values
    lengths = runs.lengths
    if values.size < 3:
        return None
    # Only runs with a real edge on both sides.
    inner = np.zeros(values.size, dtype=bool)
    inner[1:-1] = (values[1:-1] >= 0) & (values[:-2] >= 0) & (values[2:] >= 0)
    lengths = lengths[inner & (lengths >= MIN_ROWS_PER_CHIP * 0.5)]
    if lengths.size < min_runs:
        return None
    pitch = float(np.percentile(lengths, 20.0))
    for _ in range(10):
        chips = np.maximum(np.rint(lengths / pitch), 1.0)
        new = float(lengths.sum() / chips.sum())
        if abs(new - pitch) < 1e-9 * pitch:
            break
        pitch = new
    chips = np.maximum(np.rint(lengths / pitch), 1.0)
    misfit = float(np.median(np.abs(lengths / pitch - chips)))
    if misfit > 0.25 or pitch < MIN_ROWS_PER_CHIP:
        return None
    return pitch


def runs_to_chips(
    runs: Runs,
    rows_per_chip: float,
    q: np.ndarray | None = None,
    cut_left: np.ndarray | None = None,
    cut_right: np.ndarray | None = None,
) -> ChipStream:
    """Lay chips over runs: clock recovery re-aligned at every edge.

    Parameters
    ----------
    runs : Runs
    rows_per_chip : float
        Nominal chip pitch in rows.
    q : ndarray, optional
        Normalised profile, for the chip confidences.
    cut_left, cut_right : ndarray of bool, optional
        Runs whose left (right) boundary is to be treated as a cut rather
        than an edge, in addition to the region's ends and erasures.
    """
    values = runs.values
    lengths = runs.lengths
    erased = values < 0
    chips = np.rint(lengths / rows_per_chip).astype(np.int64)
    chips[erased] = np.maximum(chips[erased], 1)  # an erasure always costs a chip
    left = np.concatenate([[True], erased[:-1]])
    right = np.concatenate([erased[1:], [True]])
    cut_left = left if cut_left is None else left | cut_left
    cut_right = right if cut_right is None else right | cut_right
    one_cut = cut_left ^ cut_right
    # Runs between two real edges are divided evenly; runs with one real edge
    # are laid from it at the nominal pitch.
    width = np.where(one_cut, rows_per_chip, lengths / np.maximum(chips, 1))
    origin = np.where(cut_left & ~cut_right, runs.bounds[1:] - chips * rows_per_chip, runs.bounds[:-1])
    run_of = np.repeat(np.arange(values.size), chips)
    first_chip = np.cumsum(chips) - chips
    index = np.arange(run_of.size) - first_chip[run_of]
    start = origin[run_of] + index * width[run_of]
    end = start + width[run_of]
    exact = (start >= runs.bounds[:-1][run_of] - CUT_TOLERANCE_ROWS) & (end <= runs.bounds[1:][run_of] + CUT_TOLERANCE_ROWS)
    chip_values = values[run_of].astype(np.int8)
    if q is not None and q.size:
        centre = 0.5 * (start + end)
        confidence = np.clip(np.abs(np.interp(centre, np.arange(q.size), q)), 0.0, 1.0)
    else:
        confidence = np.ones(run_of.size)
    confidence[chip_values < 0] = 0.0
    return ChipStream(chip_values, start, end, confidence, exact | (chip_values < 0))
