"""Calibration fits: recovery on synthetic traces, exact likelihoods, degenerate traces."""

import itertools
import json
import math
import warnings

import numpy as np
import pytest

from rollsim.calibrate import (
    Trace,
    calibrate,
    clopper_pearson,
    fit_mmbp_cycle,
    ge_method_of_moments,
    p_e_text,
    zero_failure_bound,
)
from rollsim.calibrate.compare import empirical_message_probability, run_lengths, simulate_ge_trace
from rollsim.calibrate.ge import ge_loglik
from rollsim.channel.analytic import mmbp_p_message
from rollsim.channel.channels import RECEIVED, MmbpChannel
from rollsim.errors import RollsimError


def _mmbp_channel_trace(M, N, p_e, n, seed):
    """A trace drawn from the mmbp event channel of rollsim.channel."""
    run = MmbpChannel(M, N, p_e, 7e-3).open_run(np.random.SeedSequence(seed))
    return run.next_block(n) == RECEIVED


def _recovery(seed: int, channels: int = 20) -> tuple[int, int]:
    """(exact M and N, p_e inside its 95% interval) over random MMBP channels."""
    rng = np.random.default_rng(seed)
    exact = covered = 0
    for trial in range(channels):
        # N >= 1: with no OFF slot every cycle fits equally (the channel is Bernoulli).
        M, N = int(rng.integers(1, 9)), int(rng.integers(1, 9))
        p_e = float(rng.choice([0.0, 1e-3, 0.01, 0.05, 0.2]))
        fit = fit_mmbp_cycle(_mmbp_channel_trace(M, N, p_e, 4000, seed=[seed, trial]))
        exact += (fit.M, fit.N) == (M, N)
        covered += fit.p_e_ci95[0] <= p_e <= fit.p_e_ci95[1]
    return exact, covered


def test_recovers_m_and_n_exactly_and_p_e_within_its_interval_on_20_random_channels():
    """The issue's acceptance, on the draw of seed 0. A 95% interval misses
    one channel in twenty on average, so 'at least 19 of 20' holds for most
    draws, not all (it held for 9 of seeds 0-11 when measured); the coverage
    test below checks the interval itself."""
    exact, covered = _recovery(seed=0)
    assert exact == 20
    assert covered >= 19


@pytest.mark.slow
def test_p_e_interval_covers_at_least_its_level_over_240_channels():
    results = [_recovery(seed) for seed in range(12)]
    assert all(exact == 20 for exact, _ in results)
    assert sum(covered for _, covered in results) / 240 >= 0.95


@pytest.mark.parametrize("p, q, p_e", [(0.05, 0.02, 0.1), (0.2, 0.05, 0.01), (0.02, 0.1, 0.2)])
def test_gilbert_elliott_source_is_selected_by_aic_and_recovered(p, q, p_e):
    # 100,000 emissions: the estimates' spread is about 3% (measured over
    # replicates), so 15% is five standard deviations.
    trace = simulate_ge_trace(p, q, p_e, 100_000, np.random.default_rng(int(1000 * p + 100 * q)))
    result = calibrate(Trace(trace))
    assert result["selected_by_aic"] == "ge"
    ge = result["ge"]
    assert ge["p"] == pytest.approx(p, rel=0.15) and ge["q"] == pytest.approx(q, rel=0.15)
    assert ge["p_e"] == pytest.approx(p_e, abs=0.02)


def test_mmbp_source_is_selected_by_aic():
    result = calibrate(Trace(_mmbp_channel_trace(5, 2, 0.01, 3000, seed=4)))
    assert result["selected_by_aic"] == "mmbp" and result["selected_by_bic"] == "mmbp"


def _brute_ge_loglik(x, p, q, p_e):
    T = np.array([[1 - q, q], [p, 1 - p]])
    pi = np.array([p, q]) / (p + q)
    total = 0.0
    for path in itertools.product([0, 1], repeat=len(x)):
        prob = pi[path[0]] * np.prod([T[a, b] for a, b in zip(path[:-1], path[1:])])
        for state, xv in zip(path, x):
            prob *= ((1 - p_e) if xv else p_e) if state == 0 else (0.0 if xv else 1.0)
        total += prob
    return math.log(total) if total > 0 else -math.inf


def test_ge_loglik_equals_the_sum_over_every_state_path():
    rng = np.random.default_rng(0)
    for _ in range(150):
        x = rng.random(int(rng.integers(1, 10))) < 0.6
        p, q, p_e = rng.uniform(0.02, 0.98, 3)
        assert ge_loglik(x, p, q, p_e) == pytest.approx(_brute_ge_loglik(x, p, q, p_e), abs=1e-12)


def test_ge_loglik_on_long_traces_stays_finite():
    x = simulate_ge_trace(0.01, 0.01, 0.3, 200_000, np.random.default_rng(1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        value = ge_loglik(x, 0.01, 0.01, 0.3)
    assert np.isfinite(value) and value < 0


def test_method_of_moments_is_close_on_a_long_bursty_trace():
    trace = simulate_ge_trace(0.05, 0.02, 0.1, 200_000, np.random.default_rng(3))
    mom = ge_method_of_moments(trace)
    assert mom.p == pytest.approx(0.05, rel=0.2) and mom.q == pytest.approx(0.02, rel=0.2)
    assert mom.p_e == pytest.approx(0.1, abs=0.02)


@pytest.mark.parametrize("trials", [1, 7, 50, 400])
def test_clopper_pearson_covers_by_exact_enumeration(trials):
    """P(interval covers p) >= 0.95 for every p, summed exactly over the binomial outcomes."""
    from scipy.stats import binom

    intervals = np.array([clopper_pearson(k, trials) for k in range(trials + 1)])
    for p in np.concatenate([np.linspace(1e-6, 1 - 1e-6, 401), 3 / trials * np.array([0.5, 0.9, 0.99])]):
        p = min(p, 1 - 1e-9)
        covers = (intervals[:, 0] <= p) & (p <= intervals[:, 1])
        assert binom.pmf(np.arange(trials + 1), trials, p)[covers].sum() >= 0.95 - 1e-9, p


def test_clopper_pearson_known_values():
    assert clopper_pearson(0, 10) == (0.0, pytest.approx(1 - 0.025 ** (1 / 10)))
    assert clopper_pearson(10, 10) == (pytest.approx(0.025 ** (1 / 10)), 1.0)
    # Zero failures: the one-sided bound, the rule of three for large n.
    assert zero_failure_bound(10) == pytest.approx(1 - 0.05 ** (1 / 10), rel=1e-12)
    assert zero_failure_bound(100_000) == pytest.approx(math.log(20) / 100_000, rel=1e-4)  # ≈ 3/n
    assert zero_failure_bound(10**15) > 0  # no cancellation to 0
    low, high = clopper_pearson(5, 10)
    assert low == pytest.approx(0.1871, abs=1e-4) and high == pytest.approx(0.8129, abs=1e-4)


def test_empirical_message_probability_matches_the_analytic_value():
    trace = _mmbp_channel_trace(5, 2, 0.01, 200_000, seed=9)
    for r, strategy in [(3, "rp"), (3, "rs"), (4, "rp")]:
        assert empirical_message_probability(trace, r, 50, strategy) == pytest.approx(
            mmbp_p_message(5, 2, r, 0.01, 50, strategy), abs=0.02
        )


def test_run_lengths():
    lengths = run_lengths(np.array([1, 1, 0, 0, 0, 1, 0, 1, 1, 1], dtype=bool))
    assert lengths["success"].tolist() == [2, 1, 3] and lengths["loss"].tolist() == [3, 1]


@pytest.mark.parametrize(
    "name, trace",
    [
        ("all successes", np.ones(500, dtype=bool)),
        ("shorter than one frame", np.array([True, False, True])),
        ("p_e exactly 0", np.tile([True, True, True, False, False], 200)),
    ],
)
def test_degenerate_traces_give_a_clear_result_never_nan(name, trace):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = calibrate(Trace(trace))
    json.dumps(result, allow_nan=False)
    assert 0.0 <= result["mmbp"]["p_e"] <= 1.0
    if name == "p_e exactly 0":
        assert (result["mmbp"]["M"], result["mmbp"]["N"], result["mmbp"]["p_e"]) == (3, 2, 0.0)
        assert result["mmbp"]["p_e_ci95"][0] == 0.0


def test_all_failures_is_a_clear_error():
    with pytest.raises(RollsimError, match="no success"):
        calibrate(Trace(np.zeros(300, dtype=bool), source="t.csv"))


def test_simulated_ge_sojourns_are_geometric_across_blocks():
    """Loss runs of a GE trace with p_e = 0 are the S2 sojourns: geometric
    with mean 1/p, also when the trace needs several blocks of draws."""
    trace = simulate_ge_trace(0.2, 0.001, 0.0, 400_000, np.random.default_rng(8))
    losses = run_lengths(trace)["loss"]
    successes = run_lengths(trace)["success"]
    assert losses.mean() == pytest.approx(1 / 0.2, rel=0.05)
    assert successes.mean() == pytest.approx(1 / 0.001, rel=0.1)


def test_p_e_text_never_states_a_bare_zero():
    fit = {"p_e": 0.0, "p_e_ci95": [0.0, 3.7e-3], "on_emissions": 1000, "on_failures": 0}
    text = p_e_text(fit)
    assert "< 0.002991" in text and "one-sided" in text and "1000 PHY-SDUs" in text
    fit = {"p_e": 0.01, "p_e_ci95": [0.005, 0.02], "on_emissions": 1000, "on_failures": 10}
    assert p_e_text(fit) == "p_e = 0.01 (95 % CI 0.005 .. 0.02)"


def test_beta_ppf_is_scipy_stats_beta_ppf_bit_for_bit():
    from scipy.stats import beta

    from rollsim.calibrate.mmbp import beta_ppf

    rng = np.random.default_rng(0)
    for trials in [1, 2, 3, 10, 57, *rng.integers(60, 100_000, 60).tolist()]:
        for failures in {0, 1, trials // 3, trials - 1, *rng.integers(0, trials + 1, 4).tolist()}:
            if failures > 0:
                assert beta_ppf(0.025, failures, trials - failures + 1) == beta.ppf(0.025, failures, trials - failures + 1)
            if failures < trials:
                assert beta_ppf(0.975, failures + 1, trials - failures) == beta.ppf(0.975, failures + 1, trials - failures)
