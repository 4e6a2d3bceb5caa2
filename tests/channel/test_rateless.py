"""Random linear coding over the MMBP: expected emissions against closed forms and simulation."""

import math

import numpy as np
import pytest

from rollsim.channel.rateless import (
    negative_binomial,
    on_emission_index_mean,
    rlnc_expected_emissions,
    rlnc_expected_goodput_bps,
)
from rollsim.protocol.gf2 import first_full_rank
from rollsim.protocol.rlnc import combinations, expected_receptions_to_full_rank


@pytest.mark.parametrize("k", [1, 5, 40])
def test_an_always_on_lossless_channel_needs_the_receptions_to_full_rank(k):
    assert rlnc_expected_emissions(3, 0, 0.0, k) == pytest.approx(expected_receptions_to_full_rank(k), rel=1e-12)


def test_one_packet_on_an_always_on_channel_is_geometric():
    assert rlnc_expected_emissions(4, 0, 0.2, 1) == pytest.approx(1 / 0.8, rel=1e-12)


@pytest.mark.parametrize("M, N", [(1, 1), (5, 2), (2, 3), (3, 17)])
def test_the_first_on_emission_over_the_phase(M, N):
    # Phases in the ON arc send on emission 0; phase s >= M waits C - s emissions.
    C = M + N
    expected = (M * 1 + sum(C - s + 1 for s in range(M, C))) / C
    assert rlnc_expected_emissions(M, N, 0.0, 1) == pytest.approx(expected, rel=1e-12)
    # The j-th ON emission: one cycle later than the (j - M)-th.
    means = on_emission_index_mean(M, N, 3 * M)
    np.testing.assert_allclose(means[M:] - means[:-M], C, rtol=1e-12)


@pytest.mark.parametrize("M, N, p_e, k", [(5, 2, 0.05, 10), (2, 3, 0.001, 22)])
def test_expected_emissions_equal_a_simulation_with_real_elimination(M, N, p_e, k):
    runs, horizon = 800, 40 * (k + 10)
    rng = np.random.default_rng(k)
    C = M + N
    totals = np.empty(runs)
    for run in range(runs):
        phase = rng.integers(C)
        slots = (phase + np.arange(horizon)) % C
        received = (slots < M) & (rng.random(horizon) >= p_e)
        emitted = np.flatnonzero(received)
        seeds = rng.integers(0, 2**63, size=emitted.size, dtype=np.uint64)
        n = first_full_rank(combinations(seeds, k))
        totals[run] = emitted[n - 1] + 1
    sigma = totals.std(ddof=1) / math.sqrt(runs)
    assert abs(totals.mean() - rlnc_expected_emissions(M, N, p_e, k)) < 3.3 * sigma


def test_goodput_and_bad_arguments():
    e = rlnc_expected_emissions(5, 2, 0.01, 22)
    assert rlnc_expected_goodput_bps(5, 2, 0.01, 22, 19, 1e-3) == pytest.approx(19 * 22 / (e * 1e-3))
    for args in [(0, 2, 0.0, 3), (5, -1, 0.0, 3), (5, 2, 1.0, 3), (5, 2, 0.0, 0), (10**6, 1, 0.0, 3)]:
        with pytest.raises(ValueError):
            rlnc_expected_emissions(*args)
    with pytest.raises(ValueError):
        rlnc_expected_goodput_bps(5, 2, 0.0, 3, 0, 1e-3)


@pytest.mark.parametrize("M, N, p_e, k", [(5, 2, 0.05, 10), (3, 1, 0.001, 60)])
def test_the_event_simulator_agrees_with_the_analysis(M, N, p_e, k):
    from rollsim.channel.channels import MmbpChannel
    from rollsim.channel.eventsim import simulate_broadcast
    from rollsim.transmitter.schedule import RlncSchedule

    result = simulate_broadcast(MmbpChannel(M, N, p_e, 1e-3), RlncSchedule(k, 2**32), header_bits=32, payload_bits=19,
                                runs=600, seed=3, workers=1)
    summary = result.summary()
    assert summary["completed_fraction"] == 1.0
    emissions = summary["metrics"]["emissions"]
    low, high = emissions["ci95"]
    # The 95 % interval, widened to 99.9 % (3.29 / 1.96), holds the exact mean.
    half = (high - low) / 2 * 3.29 / 1.96
    assert abs(emissions["mean"] - rlnc_expected_emissions(M, N, p_e, k)) < half
    assert summary["metrics"]["unique_receptions"]["mean"] == k


def test_a_seed_space_too_small_for_k_is_refused_and_seeds_wrap():
    from rollsim.transmitter.schedule import RlncSchedule

    with pytest.raises(ValueError, match="seed_space"):
        RlncSchedule(10, 8)
    np.testing.assert_array_equal(RlncSchedule(3, 4).sequence_numbers([0, 3, 4, 9]), [0, 3, 0, 1])


def test_a_capped_rateless_run_reports_its_rank():
    from rollsim.channel.channels import MmbpChannel
    from rollsim.channel.eventsim import simulate_broadcast
    from rollsim.transmitter.schedule import RlncSchedule

    result = simulate_broadcast(MmbpChannel(1, 9, 0.0, 1e-3), RlncSchedule(50, 2**20), header_bits=20,
                                payload_bits=19, runs=5, seed=1, workers=1, max_emissions=100)
    summary = result.summary()
    assert summary["completed_fraction"] == 0.0
    # 100 emissions over a 1-in-10 ON cycle: 10 receptions, each raising the rank but for 2^-40.
    assert summary["metrics"]["unique_receptions"]["mean"] == 10


@pytest.mark.parametrize("p", [0.999, 0.95, 0.5, 0.01, 1.0])
def test_the_negative_binomial_is_scipy_stats_to_the_bit(p):
    """pmf and isf without importing scipy.stats: nbinom's numbers, bit for bit."""
    from scipy.stats import nbinom

    pmf, isf = negative_binomial()
    k, n = np.arange(80)[None, :], np.array([1, 2, 5, 22, 40, 200])[:, None]
    assert pmf(k, n, p).tobytes() == nbinom.pmf(k, n, p).tobytes()
    for tail in (1e-15, 1e-6, 0.5):
        for count in (1, 22, 352):
            assert isf(tail, count, p) == nbinom.isf(tail, count, p)
