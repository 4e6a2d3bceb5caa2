"""The position model: its fit against known step functions, its exact segmentation, its slot profiles."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rollsim.calibrate.mmbp import _bernoulli_logliks
from rollsim.calibrate.position import best_segmentations, fit_position
from rollsim.channel.position import cycle_of, slot_profiles, step_success

FRAME_S = 1 / 30
SDU_S = 0.007


def synthetic_trace(edges_s, success, frames=300, sdu_s=SDU_S, frame_s=FRAME_S, phase_s=0.0011, seed=0):
    """Emissions every sdu_s from phase_s, frames every frame_s, each read with the step function's probability."""
    rng = np.random.default_rng(seed)
    n = int(frames * frame_s / sdu_s)
    start = phase_s + sdu_s * np.arange(n)
    frame_starts = frame_s * np.arange(frames + 1)
    q = step_success(np.mod(start, frame_s), edges_s, success, frame_s)
    return rng.random(n) < q, start, frame_starts


def test_fit_finds_a_window_with_soft_edges():
    """A window of 3.3 PHY-SDUs, read at 0.98 inside, 0.5 in a 0.1-PHY-SDU band at each edge and
    never outside: the fit's steps land on the true edges (within one lattice step of the starts)
    and its rates within their 95 % intervals."""
    a = 0.004
    truth = [0.5, 0.98, 0.5, 0.0]
    # 29.97 frames/s against a 7 ms PHY-SDU: the starts visit offsets 1/143 of a frame apart.
    frame_s = 1 / 29.97
    edges = [a, a + 0.1 * SDU_S, a + 3.2 * SDU_S, a + 3.3 * SDU_S, a + frame_s]
    success, start, frames = synthetic_trace(edges, truth, frames=3000, frame_s=frame_s, seed=3)
    fit = fit_position(success, start, frames, frame_s, SDU_S)
    step = frame_s / 143
    assert fit.segments >= 4
    # Every true edge has a fitted edge within a lattice step (modulo the frame).
    fitted = np.mod(np.array(fit.edges_s[:-1]), frame_s)
    for edge in np.mod(edges[:-1], frame_s):
        gap = np.abs((fitted - edge + frame_s / 2) % frame_s - frame_s / 2)
        assert gap.min() <= step, (edge, fitted)
    # Rates: the model's success at the middle of each true segment lies in the fitted interval.
    intervals = fit.as_dict()["success_ci95"]
    for lo_edge, hi_edge, q in zip(edges[:-1], edges[1:], truth):
        middle = (lo_edge + hi_edge) / 2
        j = int(np.searchsorted(np.array(fit.edges_s[1:-1]), middle + (fit.edges_s[0] > middle) * frame_s, side="right"))
        low, high = intervals[j]
        assert low - 1e-12 <= q <= high + 1e-12, (q, intervals[j])


def test_a_plain_window_is_three_steps():
    """Inside a window every start is read with one probability, outside none: the held-out
    likelihood picks the MMBP's shape (outside, inside, outside), not more steps."""
    a = 0.002
    edges = [a, a + 3.4 * SDU_S, a + FRAME_S]
    success, start, frames = synthetic_trace(edges, [0.95, 0.0], frames=600, seed=1)
    fit = fit_position(success, start, frames, FRAME_S, SDU_S)
    assert fit.segments == 3
    assert sorted(fit.success)[0] == 0.0 and sorted(fit.success)[1] == 0.0
    assert abs(max(fit.success) - 0.95) < 0.03
    assert set(fit.cv_loglik) == set(range(1, 9))


def _brute_force(trials, wins, k):
    g = trials.size
    best = -math.inf
    for splits in itertools.combinations(range(1, g), k - 1):
        bounds = (0, *splits, g)
        n = np.array([trials[i:j].sum() for i, j in zip(bounds[:-1], bounds[1:])])
        s = np.array([wins[i:j].sum() for i, j in zip(bounds[:-1], bounds[1:])])
        best = max(best, float(np.sum(_bernoulli_logliks(n - s, n))))
    return best


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 6), st.integers(0, 6)), min_size=1, max_size=7))
def test_segmentation_is_the_maximum_over_every_split(groups):
    """The dynamic programme's likelihood equals the best over every split, enumerated."""
    trials = np.array([n for n, _ in groups], dtype=float)
    wins = np.array([min(s, n) for n, s in groups], dtype=float)
    fits = best_segmentations(trials, wins, 4)
    assert len(fits) == min(4, trials.size)
    for k, (loglik, splits) in enumerate(fits, start=1):
        assert splits.size == k - 1
        assert loglik == pytest.approx(_brute_force(trials, wins, k), abs=1e-9)


def test_cycle_of_is_the_frame_against_the_sdu_in_lowest_terms():
    assert cycle_of(1 / 30, 0.007) == (100, 21)
    C, F = cycle_of(1 / 29.97, 0.007)
    assert abs(C * 0.007 / F * 29.97 - 1) < 1e-6 and C <= 5000
    C, F = cycle_of(math.pi * 1e-2, 1e-3 * math.e, max_cycle=500)
    assert C <= 500 and abs(C / F / (math.pi * 10 / math.e) - 1) < 1e-4


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=2, max_size=6, unique=True),
       st.lists(st.floats(0.0, 1.0), min_size=6, max_size=6), st.sampled_from([(1 / 30, 0.007), (1 / 29.97, 0.007),
                                                                                (0.04, 0.0031)]))
def test_slot_profiles_conserve_the_step_function(cuts, rates, clock):
    """Averaged over the profiles' weights and the slots, the success probability is the step
    function's mean over the frame (a uniform phase visits every offset equally); each profile is the
    step function at its phase's starts."""
    frame_s, sdu_s = clock
    edges = np.sort(np.array(cuts)) * frame_s
    edges = np.concatenate((edges, [edges[0] + frame_s]))
    q = np.array(rates[: edges.size - 1])
    slots = slot_profiles(frame_s, sdu_s, edges, q)
    widths = np.diff(edges)
    mean_step = float(np.sum(widths * q) / frame_s)
    mean_slots = float(slots.weights @ slots.success.mean(axis=1))
    assert mean_slots == pytest.approx(mean_step, abs=1e-9 + abs(slots.frame_period_error))
    assert slots.weights.sum() == pytest.approx(1.0)
    assert np.all(slots.weights > 0) and slots.success.shape[0] <= edges.size
