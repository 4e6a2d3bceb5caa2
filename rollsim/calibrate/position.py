"""The position model: a PHY-SDU's chance of being read depends on where in the frame it starts.

The MMBP gives every PHY-SDU inside the capture window one error
probability p_e. Rendered and real frames do not: a PHY-SDU read near the
window's edge (the LED's first or last rows, where a chord of the disk is
short) or in a saturated band fails more often than one in the middle, and
the window's edge is soft. The position model keeps the frame clock of the
aligned MMBP fit (each emission's start offset within its frame period,
[0, T_f)) and lets the success probability be a step function of that
offset with K steps:

    P(success | offset o) = q_j   for o in segment j,  j = 0 … K − 1,

the K segments tiling the circle [0, T_f). K = 1 is a constant rate; the
MMBP with a leak is close to K = 3 (outside, inside, outside). The
segments' edges are placed by maximum likelihood (an exact dynamic
programme over the distinct offsets, :func:`best_segmentations`) and each
q_j is its segment's success fraction. K is chosen by held-out likelihood:
the frames are split into contiguous folds, each fold is predicted by the
fit to the others (:func:`cross_validated_loglik`), and the K with the
greatest held-out log-likelihood wins (ties to the smaller K). AIC and BIC
(2K − 1 parameters: K rates, K − 1 free edges) are reported beside it.

Offsets are grouped at a thousandth of a PHY-SDU, as in the aligned MMBP
fit. An edge lies midway between the last offset of one segment and the
first of the next: the starts of a trace with a rational T_f / T_p visit
only a lattice of offsets, and the midpoint is where a continuous phase
puts the edge on average.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rollsim.calibrate.heldout import bernoulli_score, frame_folds, kt_rate
from rollsim.calibrate.mmbp import _bernoulli_logliks, clopper_pearson, leak_trimmed_arc, offset_bins
from rollsim.channel.position import step_success

# Offsets are grouped at this fraction of a PHY-SDU (as fit_mmbp_aligned).
OFFSET_RESOLUTION_SDU = 1e-3
# Distinct offsets at most: the dynamic programme holds G² numbers, so
# finer groups are merged (a real camera's starts visit every offset).
MAX_GROUPS = 1200
# Steps tried; more than a handful never earned their parameters on
# rendered traces of 300 frames (docs/calibration.md).
MAX_SEGMENTS = 8


@dataclass(frozen=True)
class PositionFit:
    """A fitted position model.

    Attributes
    ----------
    frame_period_s, sdu_duration_s : float
        T_f and T_p, seconds.
    edges_s : tuple of float
        Segment j spans offsets [edges_s[j], edges_s[j + 1]) modulo T_f;
        ``K + 1`` values, increasing, ``edges_s[K] = edges_s[0] + T_f``.
    success : tuple of float
        q_j, the success probability of a start in segment j.
    trials, successes : tuple of int
        Emissions and successes of the trace in each segment.
    loglik : float
        Maximised log-likelihood of the trace.
    cv_loglik : dict
        K -> held-out log-likelihood summed over the folds, for every K tried.
    """

    frame_period_s: float
    sdu_duration_s: float
    edges_s: tuple
    success: tuple
    trials: tuple
    successes: tuple
    loglik: float
    cv_loglik: dict

    @property
    def segments(self) -> int:
        """K."""
        return len(self.success)

    @property
    def parameters(self) -> int:
        """Free parameters: K rates and K − 1 edges (the circle's cut is not free)."""
        return 2 * self.segments - 1

    def success_at(self, offset_s) -> np.ndarray:
        """q at start offsets (seconds, any real values: taken modulo T_f)."""
        return step_success(offset_s, self.edges_s, self.success, self.frame_period_s)

    def as_dict(self) -> dict:
        return {
            "segments": self.segments,
            "edges_s": list(self.edges_s),
            "edges_sdu": [(e - self.edges_s[0]) / self.sdu_duration_s for e in self.edges_s],
            "success": list(self.success),
            "success_ci95": [list(_success_interval(s, n)) for s, n in zip(self.successes, self.trials)],
            "trials": list(self.trials),
            "successes": list(self.successes),
            "loglik": self.loglik,
            "cv_loglik": {str(k): v for k, v in self.cv_loglik.items()},
            "frame_period_s": self.frame_period_s,
            "sdu_duration_s": self.sdu_duration_s,
        }


def _success_interval(successes: int, trials: int) -> tuple[float, float]:
    if trials == 0:
        return 0.0, 1.0
    low, high = clopper_pearson(trials - successes, trials)
    return 1.0 - high, 1.0 - low


def frame_offsets(start_s, frame_starts_s, frame_period_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Each emission's frame (index into ``frame_starts_s``) and start offset within it, seconds."""
    start_s = np.asarray(start_s, dtype=np.float64)
    frames = np.asarray(frame_starts_s, dtype=np.float64)
    k = np.clip(np.searchsorted(frames, start_s, side="right") - 1, 0, frames.size - 1)
    return k, np.mod(start_s - frames[k], frame_period_s)


def _cut_s(index: np.ndarray, success: np.ndarray, bins: int, frame_period_s: float) -> float:
    """Where the circle is cut into a line: opposite the middle of the MMBP's ON arc,
    deep in the inter-frame gap, so that the window's segments are not split."""
    first, length, _ = leak_trimmed_arc(index, success, bins)
    return float(np.mod((first + length / 2.0) / bins * frame_period_s + frame_period_s / 2.0, frame_period_s))


def _grouped(u: np.ndarray, success: np.ndarray, resolution_s: float):
    """Distinct offsets along the line (grouped at ``resolution_s``), their trials and successes."""
    while True:
        key = np.floor(u / resolution_s).astype(np.int64)
        values, inverse = np.unique(key, return_inverse=True)
        if values.size <= MAX_GROUPS:
            break
        resolution_s *= 2.0
    trials = np.bincount(inverse).astype(np.float64)
    wins = np.bincount(inverse, weights=success.astype(np.float64))
    # Each group's offset: the mean of its members (the grouping is finer than any edge).
    where = np.bincount(inverse, weights=u) / trials
    return where, trials, wins


def best_segmentations(trials: np.ndarray, wins: np.ndarray, max_segments: int) -> list[tuple[float, np.ndarray]]:
    """Maximum-likelihood splits of a line of groups into 1 … ``max_segments`` contiguous segments.

    Exact dynamic programme: ``best[k][j]`` is the greatest log-likelihood
    of the first j groups in k segments, each segment's rate its success
    fraction. O(max_segments · G²) for G groups, vectorised over the last
    segment's start.

    Returns
    -------
    list of (float, ndarray of int)
        For k = 1 … ``max_segments`` (fewer when there are fewer groups):
        the log-likelihood and the k − 1 split positions (a segment
        starts at each, in group indices).
    """
    g = trials.size
    ct = np.concatenate(([0.0], np.cumsum(trials)))
    cw = np.concatenate(([0.0], np.cumsum(wins)))
    # ll[i, j]: log-likelihood of groups i … j − 1 as one segment (i < j).
    n = ct[None, :] - ct[:, None]
    s = cw[None, :] - cw[:, None]
    valid = np.triu(np.ones((g + 1, g + 1), dtype=bool), 1)
    ll = np.where(valid, _bernoulli_logliks(n - s, np.where(valid, n, 0.0)), -np.inf)
    best = ll[0].copy()  # one segment ending at j
    back = []
    out = [(float(best[g]), np.zeros(0, dtype=np.int64))]
    for _ in range(2, min(max_segments, g) + 1):
        total = best[:, None] + ll  # last segment i … j − 1
        arg = np.argmax(total, axis=0)
        best = total[arg, np.arange(g + 1)]
        back.append(arg)
        splits, j = [], g
        for step in reversed(back):
            j = int(step[j])
            splits.append(j)
        out.append((float(best[g]), np.array(sorted(splits), dtype=np.int64)))
    return out


def _fit_line(u, success, resolution_s, segments_max):
    where, trials, wins = _grouped(u, success, resolution_s)
    return where, trials, wins, best_segmentations(trials, wins, segments_max)


def _edges_on_line(where: np.ndarray, splits: np.ndarray, length_s: float) -> np.ndarray:
    """Segment edges along the line [0, length_s): midway between neighbouring groups at each split."""
    inner = (where[splits - 1] + where[splits]) / 2.0 if splits.size else np.zeros(0)
    return np.concatenate(([0.0], inner, [length_s]))


def _rates(u, success, edges):
    seg = np.clip(np.searchsorted(edges[1:-1], u, side="right"), 0, edges.size - 2)
    k = edges.size - 1
    return np.bincount(seg, minlength=k), np.bincount(seg[success], minlength=k)


def cross_validated_loglik(u, success, frame, resolution_s, length_s, max_segments) -> dict:
    """Held-out log-likelihood per K (:mod:`rollsim.calibrate.heldout`): each fold of frames
    predicted by the segments and rates fitted to the others."""
    totals: dict[int, float] = {}
    scored: dict[int, int] = {}
    for test in frame_folds(frame):
        train = ~test
        if not train.any():
            continue
        where, _, _, fits = _fit_line(u[train], success[train], resolution_s, max_segments)
        for k, (_, splits) in enumerate(fits, start=1):
            edges = _edges_on_line(where, splits, length_s)
            n, s = _rates(u[train], success[train], edges)
            seg = np.clip(np.searchsorted(edges[1:-1], u[test], side="right"), 0, k - 1)
            totals[k] = totals.get(k, 0.0) + bernoulli_score(success[test], kt_rate(s, n)[seg])
            scored[k] = scored.get(k, 0) + 1
    # A K that some fold's training frames could not hold (fewer distinct offsets) is not compared.
    return {k: v for k, v in totals.items() if scored[k] == max(scored.values())}


def fit_position(success, start_s, frame_starts_s, frame_period_s: float, sdu_duration_s: float,
                 max_segments: int = MAX_SEGMENTS, segments: int | None = None) -> PositionFit:
    """Fit the position model to a trace with its frames' start times (see the module docstring).

    Parameters
    ----------
    success : array_like of bool
    start_s, frame_starts_s : array_like of float
        Emission and frame start times, seconds.
    frame_period_s, sdu_duration_s : float
        T_f and T_p, seconds.
    max_segments : int
        Largest K tried.
    segments : int, optional
        Fit this K instead of choosing by held-out likelihood (by BIC for a
        trace of one frame, which has nothing to hold out).

    Raises
    ------
    ValueError
        For an empty trace, one without a success, or without frame times.
    """
    success = np.asarray(success, dtype=bool)
    if success.size == 0:
        raise ValueError("the trace is empty")
    if not success.any():
        raise ValueError("the trace has no success: the position model has nothing to place")
    if np.asarray(frame_starts_s).size == 0:
        raise ValueError("no frame start times")
    frame, offset = frame_offsets(start_s, frame_starts_s, frame_period_s)
    resolution_s = sdu_duration_s * OFFSET_RESOLUTION_SDU
    index, bins = offset_bins(offset, frame_period_s, sdu_duration_s)
    cut = _cut_s(index, success, bins, frame_period_s)
    u = np.mod(offset - cut, frame_period_s)
    cv = cross_validated_loglik(u, success, frame, resolution_s, frame_period_s, max_segments)
    if segments is None and cv:
        # The greatest held-out likelihood; a tie (within 1e-9) goes to the fewer segments.
        top = max(cv.values())
        segments = min(k for k, v in cv.items() if v >= top - 1e-9)
    where, trials, wins, fits = _fit_line(u, success, resolution_s, segments or max_segments)
    if segments is None:
        # One frame: nothing to hold out, so BIC (2K − 1 parameters) chooses.
        bic = [(2 * k - 1) * np.log(success.size) - 2 * loglik for k, (loglik, _) in enumerate(fits, start=1)]
        segments = int(np.argmin(bic)) + 1
    segments = min(segments, len(fits))
    loglik, splits = fits[segments - 1]
    edges = _edges_on_line(where, splits, frame_period_s) + cut
    n, s = _rates(u, success, edges - cut)
    q = s / np.maximum(n, 1)
    return PositionFit(float(frame_period_s), float(sdu_duration_s), tuple(float(e) for e in edges),
                       tuple(float(x) for x in q), tuple(int(x) for x in n), tuple(int(x) for x in s),
                       float(loglik), cv)
