"""Tests of rollsim.channel.periodic: the periodic slot channel and its exact figures.

The references are naive: the MMBP's own exact analysis, enumeration of every
outcome sequence of the first emissions, a per-emission loop over packets,
and the event simulator (fixed seed, 99.9 % intervals: deterministic).
"""

from __future__ import annotations

import itertools
import json
import math
import pickle
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rollsim.channel import analytic as an
from rollsim.channel.channels import DECODE_ERROR, GAP_LOSS, RECEIVED
from rollsim.channel.eventsim import simulate_broadcast
from rollsim.channel.periodic import PeriodicChannel, PeriodicFigures, exact_figures, goodput_bps
from rollsim.transmitter import Schedule

pytestmark = pytest.mark.filterwarnings("error")

Z999 = 3.2905  # two-sided 99.9 % normal quantile


# ----------------------------------------------------------------------------
# Naive references
# ----------------------------------------------------------------------------
def packet_of(t, r, n, strategy):
    return (t // r) % n if strategy == "rp" else t % n


def enumerate_completion(q, weights, r, n, strategy, J):
    """``P(T = j)`` for ``j = 0 .. J`` and ``P(T > J)``, listing every success/failure sequence of ``J`` emissions."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    P, C = q.shape
    prob = np.zeros(J + 1)
    later = 0.0
    for p in range(P):
        for s in range(C):
            for outcome in itertools.product((True, False), repeat=J):
                weight = weights[p] / C
                for t, ok in enumerate(outcome):
                    qt = q[p, (s + t) % C]
                    weight *= qt if ok else 1.0 - qt
                if weight == 0.0:
                    continue
                have = set()
                for t, ok in enumerate(outcome):
                    if ok:
                        have.add(packet_of(t, r, n, strategy))
                        if len(have) == n:
                            prob[t + 1] += weight
                            break
                else:
                    later += weight
    return prob, later


def naive_survival(q, weights, r, n, strategy, stop):
    """``1 - G(j)`` for ``j = 0 .. stop`` by a loop over emissions, per profile and phase."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    P, C = q.shape
    out = np.zeros(stop + 1)
    for p in range(P):
        for s in range(C):
            miss = np.ones(n)
            out[0] += weights[p] / C
            for t in range(stop):
                miss[packet_of(t, r, n, strategy)] *= 1.0 - q[p, (s + t) % C]
                out[t + 1] += weights[p] / C * (1.0 - np.prod(1.0 - miss))
    return out


# ----------------------------------------------------------------------------
# The MMBP is the case P = 1, q = [1 - p_e] * M + [0] * N
# ----------------------------------------------------------------------------
MMBP_GRID = [
    (M, N, p_e, r, n, strategy)
    for M, N in [(1, 0), (3, 0), (1, 2), (2, 3), (4, 1), (3, 3), (0, 2)]
    for p_e in (0.0, 1e-9, 0.3, 0.9, 1.0)
    for r in (1, 2, 3)
    for n in (1, 3, 6)
    for strategy in ("rp", "rs")
]


@pytest.mark.parametrize("M, N, p_e, r, n, strategy", MMBP_GRID)
def test_mmbp_special_case(M, N, p_e, r, n, strategy):
    figures = exact_figures([1.0 - p_e] * M + [0.0] * N, [1.0], r, n, strategy)
    p_message = an.mmbp_p_message(M, N, r, p_e, n, strategy)
    assert figures.p_round == pytest.approx(p_message, rel=1e-12, abs=1e-300)
    expected = an.mmbp_expected_emissions(M, N, r, p_e, n, strategy)
    if math.isinf(expected):
        assert math.isinf(figures.expected_emissions)
    else:
        assert figures.expected_emissions == pytest.approx(expected, rel=1e-10)


def test_mmbp_grid_covers_the_rs_artefact_and_p_e_zero():
    infinite = [(M, N, p_e, r, n, strategy) for M, N, p_e, r, n, strategy in MMBP_GRID
                if 0 < M and p_e < 1.0 and math.isinf(an.mmbp_expected_emissions(M, N, r, p_e, n, strategy))]
    assert any(case[5] == "rs" for case in infinite) and any(case[2] == 0.0 for case in MMBP_GRID)
    # RS with n a multiple of C: some packet never meets an ON slot in any phase.
    figures = exact_figures([0.7, 0.7, 0.0], None, 2, 6, "rs")
    assert math.isinf(figures.expected_emissions) and figures.p_capped == 1.0 and figures.p_round == 0.0
    # One ON slot of two, no errors: T = 1 or 2 (a round is 1 emission), E[T] = 1.5, E[1/T] = 0.75.
    assert exact_figures([1.0, 0.0], None, 1, 1, "rp") == PeriodicFigures(0.5, 1.5, 0.75, 0.0)


# ----------------------------------------------------------------------------
# Enumeration of outcome sequences
# ----------------------------------------------------------------------------
# Floats from 0.05: the naive loop below must converge within 2000 emissions.
probabilities = st.sampled_from([0.0, 1.0, 0.25, 0.5, 0.9]) | st.floats(0.05, 1.0)


@settings(max_examples=30, deadline=None, derandomize=True)
@given(
    C=st.integers(1, 4),
    rows=st.data(),
    r=st.integers(1, 3),
    n=st.integers(1, 3),
    strategy=st.sampled_from(["rp", "rs"]),
    w0=st.sampled_from([0.0, 0.3, 0.5, 1.0]),
)
def test_enumeration(C, rows, r, n, strategy, w0):
    if r * n > 6:
        r = 6 // n
    q = np.array([[rows.draw(probabilities) for _ in range(C)] for _ in range(2)])
    weights = [w0, 1.0 - w0]
    J = 8
    prob, later = enumerate_completion(q, weights, r, n, strategy, J)
    completed = np.cumsum(prob)  # G(j), j = 0 .. J

    figures = exact_figures(q, weights, r, n, strategy, max_emissions=J)
    assert figures.p_round == pytest.approx(completed[r * n], rel=1e-12, abs=1e-15)
    assert figures.p_capped == pytest.approx(later, rel=1e-12, abs=1e-15)
    inverse = float(sum(prob[j] / j for j in range(1, J + 1)))
    assert figures.mean_inverse_emissions == pytest.approx(inverse, rel=1e-12, abs=1e-15)
    # E[T] = sum_j (1 - G(j)): the enumerated terms are a lower bound, and the
    # per-emission loop gives the whole sum.
    head = float(np.sum(1.0 - completed[:J]))
    assert figures.expected_emissions >= head - 1e-12
    if math.isfinite(figures.expected_emissions):
        survival = naive_survival(q, weights, r, n, strategy, 2000)
        assert survival[:J + 1] == pytest.approx(1.0 - completed, abs=1e-14)
        assert survival[-1] < 1e-12
        assert figures.expected_emissions == pytest.approx(survival.sum(), rel=1e-9)


def test_deterministic_slots_give_exact_completion_times():
    # q in {0, 1}: given the profile and phase, T is fixed; the loop lists it.
    q = [[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]
    survival = naive_survival(q, [0.4, 0.6], 1, 2, "rp", 40)
    figures = exact_figures(q, [0.4, 0.6], 1, 2, "rp", max_emissions=5)
    assert figures.expected_emissions == pytest.approx(survival.sum(), rel=1e-14)
    assert figures.p_capped == pytest.approx(survival[5], abs=1e-15)
    assert figures.p_round == pytest.approx(1.0 - survival[2], abs=1e-15)


def test_a_profile_that_never_completes_makes_e_t_infinite_but_not_the_mean_goodput():
    # Profile 1 has no success at all; profile 0 always completes.
    q = [[0.8, 0.5, 0.0], [0.0, 0.0, 0.0]]
    figures = exact_figures(q, [0.75, 0.25], 2, 3, "rp", max_emissions=40)
    alone = exact_figures(q[0], None, 2, 3, "rp", max_emissions=40)
    assert math.isinf(figures.expected_emissions)
    assert figures.mean_inverse_emissions == pytest.approx(0.75 * alone.mean_inverse_emissions, rel=1e-13)
    assert figures.p_capped == pytest.approx(0.25 + 0.75 * alone.p_capped, rel=1e-13)
    assert figures.p_round == pytest.approx(0.75 * alone.p_round, rel=1e-13)
    # A profile of weight 0 does not count, not even its infinite E[T].
    assert exact_figures(q, [1.0, 0.0], 2, 3, "rp", max_emissions=40) == alone


# ----------------------------------------------------------------------------
# Goodput and the event simulator
# ----------------------------------------------------------------------------
def test_goodput_definitions():
    q, w = [[0.9, 0.6, 0.0, 1.0], [0.3, 0.0, 0.0, 0.8]], [0.6, 0.4]
    figures = exact_figures(q, w, 2, 5, "rs", max_emissions=60)
    out = goodput_bps(q, w, 2, 5, "rs", 19, 6.5e-3, max_emissions=60)
    assert out["mean_goodput_bps"] == pytest.approx(19 * 5 / 6.5e-3 * figures.mean_inverse_emissions, rel=1e-15)
    assert out["expected_goodput_bps"] == pytest.approx(19 * 5 / (6.5e-3 * figures.expected_emissions), rel=1e-15)
    assert out["p_capped"] == figures.p_capped
    mmbp = an.mmbp_expected_goodput_bps(3, 2, 2, 0.2, 4, "rp", 19, 6.5e-3)
    assert goodput_bps([0.8] * 3 + [0.0] * 2, None, 2, 4, "rp", 19, 6.5e-3)["expected_goodput_bps"] == \
        pytest.approx(mmbp, rel=1e-10)
    assert goodput_bps([0.0, 0.5], None, 1, 2, "rs", 19, 1e-3)["expected_goodput_bps"] == 0.0


@pytest.mark.parametrize("strategy, r, n, cap", [("rp", 2, 6, 18), ("rs", 2, 5, 12), ("rs", 1, 5, 400),
                                                  ("rp", 3, 40, 50_000)])
def test_event_simulator_agrees(strategy, r, n, cap):
    # Small caps cap ~40 % of the runs; RP(3) of 40 packets runs up to thousands of emissions.
    q, w = [[0.9, 0.0, 1.0, 0.4], [0.2, 0.7, 0.0, 0.0]], [0.7, 0.3]
    T_p = 6.5e-3
    channel = PeriodicChannel(q, w, T_p)
    runs = 3000
    result = simulate_broadcast(channel, Schedule(strategy, n, r), header_bits=5, payload_bits=19, runs=runs,
                                seed=11, max_emissions=cap, workers=1)
    exact = goodput_bps(q, w, r, n, strategy, 19, T_p, max_emissions=cap)
    goodput = result.goodput_bps
    half = Z999 * goodput.std(ddof=1) / math.sqrt(runs)
    assert abs(goodput.mean() - exact["mean_goodput_bps"]) <= half
    p = exact["p_capped"]
    capped = 1.0 - result.completed.mean()
    assert abs(capped - p) <= Z999 * math.sqrt(p * (1.0 - p) / runs) + 1e-12
    if cap < 20:
        assert 0.05 < p < 0.95  # the cap matters in this case
    assert goodput.std() > 0.0
    assert result.channel["kind"] == "periodic"


def test_channel_outcomes_and_draws():
    channel = PeriodicChannel([[0.0, 1.0, 0.5], [1.0, 1.0, 1.0], [0.0, 0.0, 0.0]], [0.5, 0.0, 0.5], 1e-3)
    seen = set()
    for k in range(200):
        codes = channel.open_run(np.random.SeedSequence(3, spawn_key=(k,))).next_block(30)
        assert codes.dtype == np.uint8
        if np.all(codes == GAP_LOSS):
            seen.add("dark")
            continue
        assert not np.all(codes == RECEIVED)  # the weight-0 profile is never drawn
        period = codes.reshape(10, 3)
        column = int(np.flatnonzero(np.all(period == GAP_LOSS, axis=0))[0])  # the q = 0 slot
        assert np.all(period[:, (column + 1) % 3] == RECEIVED)  # the q = 1 slot
        assert set(period[:, (column + 2) % 3].tolist()) <= {RECEIVED, DECODE_ERROR}
        seen.add("bright")
    assert seen == {"dark", "bright"}
    # Block sizes do not change the codes.
    run_a = channel.open_run(np.random.SeedSequence(5))
    run_b = channel.open_run(np.random.SeedSequence(5))
    np.testing.assert_array_equal(np.concatenate([run_a.next_block(7), run_a.next_block(5)]),
                                  np.concatenate([run_b.next_block(3), run_b.next_block(9)]))


def test_channel_is_a_plain_frozen_value():
    channel = PeriodicChannel(np.array([0.25, 0.0, 1.0]), None, 2e-3)
    assert channel.success == ((0.25, 0.0, 1.0),) and channel.weights == (1.0,)
    assert channel.kind == "periodic" and channel.emission_duration_s == 2e-3 and channel.cycle_slots == 3
    assert json.loads(json.dumps(channel.parameters())) == {
        "kind": "periodic", "success": [[0.25, 0.0, 1.0]], "weights": [1.0], "sdu_duration_s": 2e-3}
    assert pickle.loads(pickle.dumps(channel)) == channel
    assert hash(channel) == hash(PeriodicChannel([[0.25, 0.0, 1.0]], [1.0], 2e-3))


# ----------------------------------------------------------------------------
# Numerical stability
# ----------------------------------------------------------------------------
def test_extreme_probabilities_and_long_messages_stay_finite():
    eps = 1e-12
    cases = [
        ([eps, 1.0 - eps, 0.5, 0.3, 0.0], None, 3, 1000, "rp"),
        ([[eps, 1.0 - eps, 0.5, 0.3, 0.0], [1.0 - eps] * 4 + [eps]], [0.3, 0.7], 3, 1000, "rp"),
        ([1.0 - eps] * 5, None, 1, 1000, "rs"),
        ([1.0 - eps, 5e-324, 1.0], None, 2, 1000, "rs"),
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with np.errstate(all="raise", under="ignore"):
            for q, w, r, n, strategy in cases:
                figures = exact_figures(q, w, r, n, strategy)
                for value in (figures.p_round, figures.expected_emissions, figures.mean_inverse_emissions,
                              figures.p_capped):
                    assert math.isfinite(value) and value >= 0.0
                assert figures.expected_emissions >= n
                assert figures.p_round <= 1.0 and figures.p_capped <= 1.0
    # Every slot 1 - 1e-12: the message completes in its first n emissions but
    # for ~n * 1e-12 of the runs.
    figures = exact_figures([1.0 - eps] * 5, None, 1, 1000, "rs")
    assert figures.p_round == pytest.approx(1.0 - 1000 * eps, rel=1e-12)
    assert figures.expected_emissions == pytest.approx(1000.0, rel=1e-9)


def test_too_costly_sum_is_refused_fast():
    with pytest.raises(an.ExactSumTooCostly, match="row-emissions") as caught:
        exact_figures([1e-12] * 5, None, 1, 10, "rs")
    assert isinstance(caught.value, ValueError) and "\n" not in str(caught.value)


# ----------------------------------------------------------------------------
# Bad inputs
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, name", [
    ({"q": [[[0.5]]]}, "q"),
    ({"q": np.zeros((2, 0))}, "q"),
    ({"q": [0.5, 1.5]}, "q"),
    ({"q": [0.5, float("nan")]}, "q"),
    ({"q": "abc"}, "q"),
    ({"weights": [0.5, 0.6]}, "weights"),
    ({"weights": [1.2, -0.2]}, "weights"),
    ({"weights": [1.0]}, "weights"),
    ({"r": 0}, "r"),
    ({"r": 1.5}, "r"),
    ({"n_packets": 0}, "n_packets"),
    ({"strategy": "rx"}, "strategy"),
    ({"strategy": None}, "strategy"),
    ({"max_emissions": 0}, "max_emissions"),
])
def test_bad_inputs(kwargs, name):
    args = {"q": [[0.5, 0.0], [1.0, 0.2]], "weights": [0.5, 0.5], "r": 2, "n_packets": 3, "strategy": "rp"}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name) as caught:
        exact_figures(**args)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("kwargs, name", [
    ({"payload_bits": 0}, "payload_bits"),
    ({"sdu_duration_s": -1.0}, "sdu_duration_s"),
])
def test_bad_goodput_inputs(kwargs, name):
    args = {"q": [0.5, 0.0], "weights": None, "r": 1, "n_packets": 2, "strategy": "rs", "payload_bits": 19,
            "sdu_duration_s": 1e-3}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        goodput_bps(**args)


@pytest.mark.parametrize("kwargs, name", [
    ({"success": [[0.5, 2.0]]}, "success"),
    ({"weights": [0.2]}, "weights"),
    ({"sdu_duration_s": 0.0}, "sdu_duration_s"),
])
def test_bad_channel_inputs(kwargs, name):
    args = {"success": [[0.5, 0.0], [1.0, 0.2]], "weights": [0.5, 0.5], "sdu_duration_s": 1e-3}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        PeriodicChannel(**args)
