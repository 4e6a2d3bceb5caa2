"""Tests of rollsim.channel.periodic_rlnc: random linear coding over a periodic slot channel.

The references are naive: the MMBP's own rlnc analysis, enumeration of every
outcome sequence of the first emissions, a per-emission recursion over a
long horizon, the event simulator (fixed seed, 99.9 % intervals:
deterministic) and a per-start loop over a trace.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rollsim.channel.analytic import ExactSumTooCostly
from rollsim.channel.eventsim import simulate_broadcast
from rollsim.channel.periodic import PeriodicChannel
from rollsim.channel.periodic_rlnc import rlnc_periodic_figures, rlnc_replay_goodput_bps
from rollsim.channel.rateless import rlnc_expected_emissions
from rollsim.protocol.rlnc import receptions_to_full_rank_pmf
from rollsim.transmitter.schedule import RlncSchedule

pytestmark = pytest.mark.filterwarnings("error")

Z999 = 3.2905  # two-sided 99.9 % normal quantile
T_P = 1e-3
PAYLOAD = 19


def rank_pmf(k, n_max=None):
    return receptions_to_full_rank_pmf(k, k + 60 if n_max is None else n_max)


# ----------------------------------------------------------------------------
# Naive references
# ----------------------------------------------------------------------------
def rows_of(q, weights):
    """``(q of each row's emissions as a function, weight)`` per (profile, phase)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    P, C = q.shape
    w = np.full(P, 1.0 / P) if weights is None else np.asarray(weights, dtype=float)
    return [(np.roll(q[p], -s), w[p] / C) for p in range(P) for s in range(C)]


def enumerated(q, weights, k, J):
    """By enumerating every outcome of the first ``J`` emissions: ``E[1/T; T <= J]``, ``P(T > J)``,
    and ``sum_{t < J} P(T > t)``."""
    pmf = rank_pmf(k, J)  # n > J: T >= n > J
    outcomes = ((np.arange(2**J)[:, None] >> np.arange(J)[None, :]) & 1).astype(bool)  # (2^J, J)
    counts = np.cumsum(outcomes, axis=1)
    inverse = capped = truncated = 0.0
    for q_row, weight in rows_of(q, weights):
        slots = np.resize(q_row, J)
        prob = np.prod(np.where(outcomes, slots, 1.0 - slots), axis=1)
        for n in range(1, J + 1):
            if pmf[n] == 0.0:
                continue
            reached = counts[:, -1] >= n
            tau = np.argmax(counts >= n, axis=1) + 1  # first emission with n receptions
            inverse += weight * pmf[n] * np.sum(prob[reached] / tau[reached])
            capped += weight * pmf[n] * np.sum(prob[~reached])
            # P(T > t) for t < J: tau_n > t.
            truncated += weight * pmf[n] * np.sum(prob * np.where(reached, np.minimum(tau, J), J))
        capped += weight * (1.0 - pmf[: J + 1].sum())
        truncated += weight * (1.0 - pmf[: J + 1].sum()) * J
    return inverse, capped, truncated


def recursion(q, weights, k, horizon, cap):
    """Per-emission recursion over ``horizon`` emissions, all rows at once: ``E[T]`` (truncated) and
    ``E[1/T; T <= cap]``."""
    pmf = rank_pmf(k)
    v = pmf[1:]
    S = 1.0 - np.cumsum(pmf)[:-1]
    rows = rows_of(q, weights)
    q_rows = np.array([q_row for q_row, _ in rows])
    weight = np.array([w for _, w in rows])
    C = q_rows.shape[1]
    D = np.zeros((len(rows), v.size))
    D[:, 0] = 1.0
    expected = inverse = 0.0
    for t in range(horizon):
        expected += weight @ (D @ S)
        qt = q_rows[:, t % C, None]
        if t + 1 <= cap:
            inverse += weight @ (qt[:, 0] * (D @ v)) / (t + 1)
        D = np.concatenate((D[:, :1] * (1 - qt), D[:, 1:] * (1 - qt) + D[:, :-1] * qt), axis=1)
    return expected, inverse


def deterministic_taus(pattern, phase, n_max):
    """tau_n for n = 1 .. n_max of a 0/1 pattern read cyclically from ``phase``."""
    C = len(pattern)
    taus, count, t = [], 0, 0
    while len(taus) < n_max:
        if pattern[(phase + t) % C]:
            count += 1
            taus.append(t + 1)
        t += 1
    return np.array(taus, dtype=float)


# ----------------------------------------------------------------------------
# Against the MMBP analysis
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("M, N", [(1, 0), (1, 3), (3, 2), (5, 0), (2, 7)])
@pytest.mark.parametrize("p_e", [0.0, 0.2, 0.7])
@pytest.mark.parametrize("k", [1, 4, 25])
def test_the_mmbp_profile_gives_the_rateless_expected_emissions(M, N, p_e, k):
    q = [1.0 - p_e] * M + [0.0] * N
    figures = rlnc_periodic_figures(q, None, k, PAYLOAD, T_P)
    reference = rlnc_expected_emissions(M, N, p_e, k)
    assert figures["expected_emissions"] == pytest.approx(reference, rel=1e-9)
    assert figures["expected_goodput_bps"] == pytest.approx(PAYLOAD * k / (reference * T_P), rel=1e-9)
    # Jensen: E[1/T] >= 1/E[T].
    assert figures["mean_goodput_bps"] >= figures["expected_goodput_bps"] * (1 - 1e-12)
    assert figures["p_capped"] == 0.0


# ----------------------------------------------------------------------------
# Brute force on tiny cases
# ----------------------------------------------------------------------------
TINY = [
    # (q of two profiles, weights)
    ([[0.6, 0.0, 1.0], [0.3, 0.9, 0.5]], [0.25, 0.75]),
    ([[1.0, 0.0, 0.0, 0.5], [0.0, 0.8, 0.2, 1.0]], [0.5, 0.5]),
    ([[0.7, 0.7], [0.2, 1.0]], [0.9, 0.1]),
]


@pytest.mark.parametrize("q, weights", TINY)
@pytest.mark.parametrize("k", [1, 2])
def test_enumerating_every_outcome_gives_the_capped_figures(q, weights, k):
    J = 12
    inverse, capped, truncated = enumerated(q, weights, k, J)
    figures = rlnc_periodic_figures(q, weights, k, PAYLOAD, T_P, max_emissions=J)
    assert figures["mean_goodput_bps"] == pytest.approx(PAYLOAD * k / T_P * inverse, rel=1e-12)
    assert figures["p_capped"] == pytest.approx(capped, rel=1e-10, abs=1e-15)
    # E[T] is the truncated sum plus the rest after J, at most sum_{t >= J} P(T > t).
    assert truncated <= figures["expected_emissions"] <= truncated + 40 * capped


@pytest.mark.parametrize("q, weights", TINY)
@pytest.mark.parametrize("k", [1, 2, 6])
def test_a_long_recursion_gives_the_uncapped_figures(q, weights, k):
    horizon = 400
    expected, inverse = recursion(q, weights, k, horizon, cap=10**6)
    figures = rlnc_periodic_figures(q, weights, k, PAYLOAD, T_P)
    assert figures["expected_emissions"] == pytest.approx(expected, rel=1e-12)
    assert figures["mean_goodput_bps"] == pytest.approx(PAYLOAD * k / T_P * inverse, rel=1e-12)
    # The cap in the middle of a cycle and of the second one.
    for cap in (2, 5, 7):
        _, inverse = recursion(q, weights, k, horizon, cap=cap)
        capped = rlnc_periodic_figures(q, weights, k, PAYLOAD, T_P, max_emissions=cap)
        assert capped["mean_goodput_bps"] == pytest.approx(PAYLOAD * k / T_P * inverse, rel=1e-12)


@pytest.mark.parametrize("pattern", [[1, 0, 0, 1], [0, 1, 1], [1], [0, 0, 0, 1]])
@pytest.mark.parametrize("k", [1, 2, 5])
def test_a_deterministic_pattern_is_the_rank_distribution_over_its_reception_times(pattern, k):
    pmf = rank_pmf(k)
    C = len(pattern)
    expected = inverse = 0.0
    for phase in range(C):
        taus = deterministic_taus(pattern, phase, pmf.size - 1)
        expected += (pmf[1:] @ taus) / C
        inverse += (pmf[1:] @ (1.0 / taus)) / C
    figures = rlnc_periodic_figures(pattern, None, k, PAYLOAD, T_P)
    assert figures["expected_emissions"] == pytest.approx(expected, rel=1e-12)
    assert figures["mean_goodput_bps"] == pytest.approx(PAYLOAD * k / T_P * inverse, rel=1e-12)


def test_many_cycles_and_many_slots_agree_with_the_recursion():
    """Rare receptions (hundreds of cycles, the inverse weights as a table) and a cycle longer than T."""
    rng = np.random.default_rng(5)
    q = np.zeros((2, 3))
    q[:, 0] = [0.05, 0.02]
    expected, inverse = recursion(q, [0.5, 0.5], 3, 6000, cap=10**6)
    figures = rlnc_periodic_figures(q, [0.5, 0.5], 3, PAYLOAD, T_P)
    assert figures["expected_emissions"] == pytest.approx(expected, rel=1e-9)
    assert figures["mean_goodput_bps"] == pytest.approx(PAYLOAD * 3 / T_P * inverse, rel=1e-9)
    q = rng.uniform(0.2, 1.0, (2, 150))
    expected, inverse = recursion(q, [0.3, 0.7], 4, 200, cap=10**6)
    figures = rlnc_periodic_figures(q, [0.3, 0.7], 4, PAYLOAD, T_P)
    assert figures["expected_emissions"] == pytest.approx(expected, rel=1e-12)
    assert figures["mean_goodput_bps"] == pytest.approx(PAYLOAD * 4 / T_P * inverse, rel=1e-12)


def test_many_profiles_of_a_short_cycle_agree_with_the_recursion():
    """A short span (the increment applied by shifted adds) and batches of several profiles."""
    q = np.random.default_rng(1).uniform(0.0, 1.0, (40, 3))
    w = np.random.default_rng(2).dirichlet(np.ones(40))
    expected, inverse = recursion(q, w, 2, 300, cap=10**6)
    figures = rlnc_periodic_figures(q, w, 2, PAYLOAD, T_P)
    assert figures["expected_emissions"] == pytest.approx(expected, rel=1e-12)
    assert figures["mean_goodput_bps"] == pytest.approx(PAYLOAD * 2 / T_P * inverse, rel=1e-12)


# ----------------------------------------------------------------------------
# Against the event simulator
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("cap", [50_000, 9])
def test_the_event_simulator_agrees_with_the_mean_goodput(cap):
    q = [[0.9, 0.0, 0.6, 0.3, 1.0], [0.2, 0.5, 0.0, 0.0, 0.8]]
    w = [0.6, 0.4]
    k, runs = 4, 3000
    result = simulate_broadcast(PeriodicChannel(q, w, T_P), RlncSchedule(k, 2**32), header_bits=32,
                                payload_bits=PAYLOAD, runs=runs, seed=7, max_emissions=cap, workers=1)
    exact = rlnc_periodic_figures(q, w, k, PAYLOAD, T_P, max_emissions=cap)
    goodput = result.goodput_bps
    assert abs(goodput.mean() - exact["mean_goodput_bps"]) <= Z999 * goodput.std(ddof=1) / math.sqrt(runs)
    p = exact["p_capped"]
    assert abs((1.0 - result.completed.mean()) - p) <= Z999 * math.sqrt(p * (1.0 - p) / runs) + 1e-12
    if cap < 50_000:
        assert 0.05 < p < 0.95  # the cap matters
    else:
        emissions = result.emissions
        assert abs(emissions.mean() - exact["expected_emissions"]) <= Z999 * emissions.std(ddof=1) / math.sqrt(runs)


# ----------------------------------------------------------------------------
# Replay
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("pattern", [[1, 0, 1, 1, 0, 0, 1], [0, 0, 1], [1, 1]])
@pytest.mark.parametrize("k", [1, 3, 8])
@pytest.mark.parametrize("cap", [50_000, 10])
def test_replaying_a_deterministic_pattern_is_the_exact_figure(pattern, k, cap):
    trace = np.tile(np.array(pattern, dtype=bool), 30)
    replay = rlnc_replay_goodput_bps(trace, k, PAYLOAD, T_P, max_starts=trace.size, max_emissions=cap)
    exact = rlnc_periodic_figures(pattern, None, k, PAYLOAD, T_P, max_emissions=cap)
    assert replay["replays"] == trace.size  # every phase as often
    assert replay["goodput_bps"] == pytest.approx(exact["mean_goodput_bps"], rel=1e-12)
    assert replay["goodput_bps"] == pytest.approx(replay["per_start"].mean(), rel=1e-15)
    assert replay["p_capped"] == pytest.approx(exact["p_capped"], rel=1e-9, abs=1e-15)
    if cap == 50_000:
        assert replay["mean_length"] == pytest.approx(exact["expected_emissions"], rel=1e-12)


def replay_by_loop(trace, k, max_starts, cap):
    """Per start, walk the trace cyclically up to the n_max-th success."""
    pmf = rank_pmf(k, k + 56)
    L = len(trace)
    starts = np.unique(np.linspace(0, L - 1, max_starts).astype(np.int64))
    goodputs, lengths = [], []
    for w in starts:
        taus, t = [], 0
        while len(taus) < pmf.size - 1:
            if trace[(w + t) % L]:
                taus.append(t + 1)
            t += 1
        g = length = 0.0
        for n, tau in enumerate(taus, start=1):
            g += pmf[n] * (PAYLOAD * k / (tau * T_P) if tau <= cap else 0.0)
            length += pmf[n] * min(tau, cap)
        goodputs.append(g)
        lengths.append(length)
    return np.array(goodputs), float(np.mean(lengths))


@pytest.mark.parametrize("k, max_starts, cap", [(1, 10, 50_000), (3, 37, 12), (6, 500, 30)])
def test_the_replay_agrees_with_a_loop_over_starts(k, max_starts, cap):
    trace = np.random.default_rng(k).random(37) < 0.3
    trace[5] = True
    replay = rlnc_replay_goodput_bps(trace.astype(int), k, PAYLOAD, T_P, max_starts=max_starts, max_emissions=cap)
    goodputs, length = replay_by_loop(trace, k, max_starts, cap)
    np.testing.assert_allclose(replay["per_start"], goodputs, rtol=1e-12)
    assert replay["mean_length"] == pytest.approx(length, rel=1e-12)
    assert replay["replays"] == goodputs.size


def test_a_replay_of_an_empty_or_silent_trace():
    empty = rlnc_replay_goodput_bps([], 3, PAYLOAD, T_P)
    assert empty["goodput_bps"] is None and empty["replays"] == 0 and empty["per_start"].size == 0
    silent = rlnc_replay_goodput_bps(np.zeros(20, dtype=bool), 3, PAYLOAD, T_P, max_emissions=100)
    assert silent["goodput_bps"] == 0.0 and silent["p_capped"] == 1.0 and silent["mean_length"] == 100.0
    with pytest.raises(ValueError, match="success"):
        rlnc_replay_goodput_bps([0, 2, 1], 3, PAYLOAD, T_P)
    with pytest.raises(ValueError, match="success"):
        rlnc_replay_goodput_bps(np.ones((2, 3)), 3, PAYLOAD, T_P)
    with pytest.raises(ValueError, match="max_starts"):
        rlnc_replay_goodput_bps([1, 0], 3, PAYLOAD, T_P, max_starts=0)


# ----------------------------------------------------------------------------
# Edge cases
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("q", [
    [1e-3, 0.0, 0.0],
    [1.0 - 1e-12, 1.0, 1e-9],
    [1.0, 1.0],
    [[2e-3, 0.0], [1.0 - 1e-15, 0.5]],
    [[1e-300, 0.5], [0.999, 0.0]],
])
def test_probabilities_near_0_and_1_give_finite_figures_without_warnings(q):
    for k in (1, 7):
        figures = rlnc_periodic_figures(q, None, k, PAYLOAD, T_P)
        assert all(math.isfinite(value) for value in figures.values())
        assert figures["expected_emissions"] >= k
        assert 0.0 < figures["mean_goodput_bps"] <= PAYLOAD / T_P


def test_all_ones_decode_at_the_rank_distribution():
    for k in (1, 2, 9):
        pmf = rank_pmf(k)
        figures = rlnc_periodic_figures([1.0, 1.0, 1.0], None, k, PAYLOAD, T_P)
        assert figures["expected_emissions"] == pytest.approx(np.arange(pmf.size) @ pmf, rel=1e-13)


def test_a_profile_that_never_receives():
    q = [[0.0, 0.0], [0.5, 1.0]]
    figures = rlnc_periodic_figures(q, [0.3, 0.7], 3, PAYLOAD, T_P)
    alone = rlnc_periodic_figures(q[1], None, 3, PAYLOAD, T_P)
    assert figures["expected_emissions"] == math.inf and figures["expected_goodput_bps"] == 0.0
    assert figures["mean_goodput_bps"] == pytest.approx(0.7 * alone["mean_goodput_bps"], rel=1e-14)
    assert figures["p_capped"] == pytest.approx(0.3, rel=1e-14)
    # Of weight 0 it does not count.
    assert rlnc_periodic_figures(q, [0.0, 1.0], 3, PAYLOAD, T_P) == alone
    never = rlnc_periodic_figures([0.0, 0.0], None, 3, PAYLOAD, T_P)
    assert never == {"expected_emissions": math.inf, "expected_goodput_bps": 0.0, "mean_goodput_bps": 0.0,
                     "p_capped": 1.0}


def test_a_sum_too_long_is_refused_in_one_line():
    with pytest.raises(ExactSumTooCostly) as raised:
        rlnc_periodic_figures([1e-7, 0.0], None, 5, PAYLOAD, T_P)
    assert "\n" not in str(raised.value) and "budget" in str(raised.value)
    with pytest.raises(ExactSumTooCostly, match="too close to 0"):
        rlnc_periodic_figures([1e-20, 0.0], None, 5, PAYLOAD, T_P)
    with pytest.raises(ExactSumTooCostly, match="too close to 0 for the exact"):
        rlnc_periodic_figures([1e-310, 0.0], None, 5, PAYLOAD, T_P)
    with pytest.raises(ExactSumTooCostly):
        rlnc_periodic_figures([[1e-300, 0.0], [0.999, 0.999]], None, 5, PAYLOAD, T_P)
    assert issubclass(ExactSumTooCostly, ValueError)
    # A k whose rank distribution alone is too long, refused before it is computed.
    with pytest.raises(ExactSumTooCostly, match="k = 40000"):
        rlnc_periodic_figures([0.5], None, 40_000, PAYLOAD, T_P)
    with pytest.raises(ExactSumTooCostly, match="k = 40000"):
        rlnc_replay_goodput_bps([0, 1], 40_000, PAYLOAD, T_P)


@pytest.mark.parametrize("budget", [40_800, 47_000])
def test_the_work_done_is_held_to_the_budget(monkeypatch, budget):
    """Past an estimate below the budget, the work done is checked (over the spans, then the rows)."""
    import rollsim.channel.periodic_rlnc as module

    assert rlnc_periodic_figures([0.3, 0.0, 0.0], None, 3, PAYLOAD, T_P)["expected_emissions"] > 0
    monkeypatch.setattr(module, "_WORK_BUDGET", budget)
    with pytest.raises(ExactSumTooCostly, match="still above 1e-16 after") as raised:
        rlnc_periodic_figures([0.3, 0.0, 0.0], None, 3, PAYLOAD, T_P)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize("args, name", [
    (([1.2, 0.5], None, 3, PAYLOAD, T_P), "q"),
    (([[0.5, 0.5]], [0.5, 0.5], 3, PAYLOAD, T_P), "weights"),
    (([0.5], None, 0, PAYLOAD, T_P), "k"),
    (([0.5], None, 2, 0, T_P), "payload_bits"),
    (([0.5], None, 2, PAYLOAD, -1.0), "sdu_duration_s"),
])
def test_invalid_inputs_are_refused_by_name(args, name):
    with pytest.raises(ValueError, match=name):
        rlnc_periodic_figures(*args)
    with pytest.raises(ValueError, match="max_emissions"):
        rlnc_periodic_figures([0.5], None, 2, PAYLOAD, T_P, max_emissions=0)
