"""Blooming's edge shifts: ON runs stretched in proportion to their length.

A pixel filled past its full well spills the excess along its column into
the rows above and below (:mod:`rollsim.sensor.blooming`, with no
anti-blooming drain). An ON run of L chips at f full wells holds (f − 1)·L
chips' worth of excess, half of which fills the OFF rows above it and half
those below: the run reads f·L chips long and an OFF run between ON runs of
L₁ and L₂ chips reads (f − 1)·(L₁ + L₂)/2 shorter. Measured on
effect-blooming's link at 1.35 full wells (noiseless): ON runs of one chip
read 1.31 to 1.36 chips and of two 2.69; OFF runs of one chip between ON
runs of one read 0.64 to 0.69, of two 1.66.

That shift is not the constant one of saturation
(:func:`decoder.timing.edge_bias_chips`, every ON run β longer): it grows
with the run, so from about 1.25 full wells an ON run of two chips rounds to
three. Each ON run is shrunk back by the spilled fraction h = 1 − 1/f of its
read length, split between its two edges, before the constant bias is
measured; h is the one under which the runs so mended agree best on whole
chips (:func:`spill_fraction`). An OFF chip the spill flooded in part shows
as a dip inside an ON run that never crosses the threshold; it is split out
first (:func:`split_at_dips`). The decoder reads the runs so only where
thresholding left PHY-SDUs unread (:func:`decoder.pipeline.bloomed_runs`).
"""

from __future__ import annotations

import numpy as np

from decoder.timing import MIN_BIAS_RAYLEIGH, Runs, shifted_level_edges

# A dip inside an ON run is an OFF chip the spill flooded in part when it
# falls this far below the ON envelope (in q, where the envelopes are ±1)
# and this many noise sigmas: on effect-blooming at 1.35 full wells the
# SYNC's closing OFF chip after four ON chips dips to q = 0.36.
DIP_DEPTH_Q = 0.3
DIP_SIGMAS = 6.0

# Spilled fractions looked at: up to 0.4 (1.67 full wells; at 1.5 a lone
# OFF chip after the SYNC is flooded whole), in steps of 0.02, then in
# steps of 0.0025 within a coarse step of the best (a run of 4 chips turns
# its phase by half a radian a coarse step: the peak is not stepped over).
MAX_SPILL_FRACTION = 0.4
COARSE_SPILL_STEP = 0.02
FINE_SPILL_STEP = 0.0025
# Below this no spill is told from the runs' jitter.
MIN_SPILL_FRACTION = 0.03
# The shrunk lengths must agree this much better (mean phasor length, of 1)
# than the lengths as read: a spill is taken only where it explains the
# runs, never to tidy noise.
MIN_SPILL_GAIN = 0.1
# And the runs, taken out of it, must agree on whole chips to this much: on
# effect-blooming's frames at 1.2 to 1.35 full wells they agree to 0.95 to
# 0.99, where a bright core's saturation, whose constant bias varies along
# the profile, reaches 0.35 under any spill.
MIN_SPILL_AGREEMENT = 0.8
# Least inner ON runs, and of each of two lengths, to tell a spill: with one
# length any scale fits.
MIN_SPILL_RUNS = 8
# Runs of each level the fit looks at, evenly spread (a 1080-row profile at
# 4.5 rows a chip holds about 90 of each): it bounds the fit's cost, and 32
# of each still tell h to the fine step (tests/decoder/test_decoder_bloom.py).
MAX_SPILL_RUNS = 32
MIN_RUNS_PER_LENGTH = 3


def split_at_dips(runs: Runs, level: np.ndarray, q: np.ndarray, noise_q: np.ndarray, rows_per_chip: float) -> Runs:
    """Runs with an empty OFF run laid at each flooded OFF chip's dip inside an ON run.

    A dip is a stretch of ON rows at most a chip long, below the ON envelope
    by :data:`DIP_DEPTH_Q` and :data:`DIP_SIGMAS` sigmas, with shallower
    ON rows on both sides (so inside one ON run: a run's ramps at its ends
    are bounded by OFF rows). The empty run lies at the dip's centroid
    (weighted by depth); removing the spill (:func:`without_spill`) then
    opens it to the OFF chip's length.

    Parameters
    ----------
    runs : Runs
        The runs of ``level``.
    level, q : ndarray, shape (n,)
        The rows' levels and normalised profile (:class:`decoder.binarize.Binarized`).
    noise_q : ndarray, shape (n,)
        Noise sigma of each row in q.
    rows_per_chip : float
    """
    n = q.size
    on = level == 1
    depth = 1.0 - q
    dipped = on & (depth > DIP_DEPTH_Q) & (depth > DIP_SIGMAS * noise_q)
    if n < 3 or not dipped.any():
        return runs
    change = np.flatnonzero(np.diff(dipped.astype(np.int8)))
    starts = change[~dipped[change]] + 1
    stops = change[dipped[change]] + 1
    if starts.size == 0 or stops.size == 0:
        return runs
    stops = stops[stops > starts[0]]
    starts = starts[: stops.size]
    # A stretch's rows are starts … stops − 1; rows starts − 1 and stops
    # exist (a stretch at either end of the profile has no edge there).
    keep = on[starts - 1] & on[stops] & (stops - starts <= rows_per_chip)
    starts, stops = starts[keep], stops[keep]
    if starts.size == 0:
        return runs
    weight = np.where(dipped, depth, 0.0)
    cumulative = np.concatenate([[0.0], np.cumsum(weight)])
    moment = np.concatenate([[0.0], np.cumsum(weight * np.arange(n))])
    centre = (moment[stops] - moment[starts]) / (cumulative[stops] - cumulative[starts])
    run = np.searchsorted(runs.bounds, centre, side="right") - 1
    # Run k splits into ON [b_k, c), OFF [c, c), ON [c, b_k+1).
    bounds = np.insert(runs.bounds, np.repeat(run + 1, 2), np.repeat(centre, 2))
    values = np.insert(runs.values, np.repeat(run + 1, 2), np.tile(np.array([0, 1], dtype=runs.values.dtype), run.size))
    return Runs(bounds, values)


def between_runs(runs: Runs, value: int) -> np.ndarray:
    """Runs of ``value`` (1 ON, 0 OFF) with a run of the other level on both sides, as a mask over runs."""
    values = runs.values
    inner = np.zeros(values.size, dtype=bool)
    if values.size >= 3:
        inner[1:-1] = (values[1:-1] == value) & (values[:-2] == 1 - value) & (values[2:] == 1 - value)
    return inner


def spill_fraction(runs: Runs, rows_per_chip: float) -> float:
    """The fraction h of each ON run's read length that blooming spilled into it; 0 where none shows.

    For each h on a grid over [0, :data:`MAX_SPILL_FRACTION`] (coarse, then
    fine about the best), each ON run
    between two OFF runs is shrunk to L·(1 − h) chips and each OFF run
    between two ON runs widened by h times its neighbours' mean length
    (:func:`without_spill`); h is where their phasors (ON runs
    exp(2πi·L), OFF runs exp(−2πi·L), as saturation's constant bias
    lengthens one and shortens the other alike) agree best. Both kinds are
    needed: ON runs alone cannot tell a spill from a chip pitch a few
    percent off. It is taken only if it beats h = 0 by
    :data:`MIN_SPILL_GAIN`, the runs then agree to
    :data:`MIN_SPILL_AGREEMENT`, it passes Rayleigh's test
    (:data:`~decoder.timing.MIN_BIAS_RAYLEIGH`), is at least
    :data:`MIN_SPILL_FRACTION`, and the ON runs hold two lengths of
    :data:`MIN_RUNS_PER_LENGTH` runs each.

    Parameters
    ----------
    runs : Runs
    rows_per_chip : float
        Chip pitch, rows.

    Returns
    -------
    float
        h, in [0, :data:`MAX_SPILL_FRACTION`]; the full wells of the ON
        level are 1 / (1 − h).
    """
    on, off = between_runs(runs, 1), between_runs(runs, 0)
    if np.count_nonzero(on) < MIN_SPILL_RUNS or not off.any():
        return 0.0
    chips = runs.lengths / rows_per_chip
    on_chips = chips[_evenly(np.flatnonzero(on))]
    off_index = _evenly(np.flatnonzero(off))
    off_chips = chips[off_index]
    neighbours = 0.5 * (chips[off_index - 1] + chips[off_index + 1])

    def agreement(h: np.ndarray) -> np.ndarray:
        h = h[:, None]
        phasors = np.concatenate([np.exp(2j * np.pi * on_chips[None, :] * (1.0 - h)),
                                  np.exp(-2j * np.pi * (off_chips[None, :] + h * neighbours[None, :]))], axis=1)
        return np.abs(phasors.mean(axis=1))

    unshrunk = float(agreement(np.zeros(1))[0])
    if unshrunk > 1.0 - MIN_SPILL_GAIN:
        # No spill could beat the runs as read by the gain asked for.
        return 0.0
    coarse = np.arange(COARSE_SPILL_STEP, MAX_SPILL_FRACTION + 0.5 * COARSE_SPILL_STEP, COARSE_SPILL_STEP)
    coarse_agreement = agreement(coarse)
    reach = int(round(COARSE_SPILL_STEP / FINE_SPILL_STEP))
    fine = np.clip(coarse[int(np.argmax(coarse_agreement))] + FINE_SPILL_STEP * np.arange(1 - reach, reach), 0.0,
                   MAX_SPILL_FRACTION)
    fine_agreement = agreement(fine)
    best = int(np.argmax(fine_agreement))
    spilled, agreed = float(fine[best]), float(fine_agreement[best])
    if spilled < MIN_SPILL_FRACTION or agreed < max(unshrunk + MIN_SPILL_GAIN, MIN_SPILL_AGREEMENT):
        return 0.0
    if (on_chips.size + off_chips.size) * agreed ** 2 < MIN_BIAS_RAYLEIGH:
        return 0.0
    _, counts = np.unique(np.rint(on_chips * (1.0 - spilled)), return_counts=True)
    return spilled if np.count_nonzero(counts >= MIN_RUNS_PER_LENGTH) >= 2 else 0.0


def _evenly(index: np.ndarray, most: int = MAX_SPILL_RUNS) -> np.ndarray:
    """At most ``most`` of ``index``, evenly spaced along it."""
    return index if index.size <= most else index[np.linspace(0, index.size - 1, most).astype(np.int64)]


def without_spill(runs: Runs, spilled: float) -> Runs:
    """Runs with each ON run shrunk by ``spilled`` of its length, half at each edge.

    Only edges between an ON and an OFF run move (an edge to or from an
    erasure is a cut, not a level change); edges keep their order.
    """
    if spilled <= 0.0 or runs.values.size < 2:
        return runs
    half = 0.5 * spilled * runs.lengths * (runs.values == 1)
    # Edge k lies between runs k and k + 1: a rising edge moves later by
    # the ON run after it, a falling edge earlier by the ON run before it.
    return shifted_level_edges(runs, half[1:], half[:-1])
