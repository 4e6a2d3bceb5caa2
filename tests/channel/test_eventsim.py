"""Tests of the event simulator and its channels (rollsim.channel.eventsim, .channels).

The statistical tests compare the simulator with the exact MMBP analysis of
rollsim.channel.analytic within 4 standard errors; with fixed seeds they are
deterministic, and a correct simulator fails one only with probability ~6e-5
per comparison at the seeds' draw.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rollsim.channel import analytic as an
from rollsim.channel.channels import (
    CAMCOMSIM_ROI_TABLE,
    DECODE_ERROR,
    GAP_LOSS,
    RECEIVED,
    CamcomsimChannel,
    MmbpChannel,
    TimedChannel,
    camcomsim_frame_slots,
    camcomsim_roi,
    camcomsim_sdu_slots,
    camcomsim_slot_sequence,
    camcomsim_visible_slots,
)
from rollsim.channel.eventsim import (
    CAMCOMSIM_RUN_FIELDS,
    METRICS,
    _add_loss_streaks,
    run_seed_sequence,
    simulate_broadcast,
    summary_statistics,
    to_camcomsim,
)
from rollsim.transmitter import Schedule

T_P = 0.0065  # s, CamComSim's PHY-SDU at 8 kHz, H = 5, P = 19


def simulate(channel, strategy="rp", n_packets=10, repeats=1, **kwargs):
    kwargs.setdefault("runs", 500)
    kwargs.setdefault("workers", 1)
    kwargs.setdefault("seed", 7)
    return simulate_broadcast(
        channel, Schedule(strategy, n_packets, repeats), header_bits=5, payload_bits=19, **kwargs
    )


def assert_within_4se(estimate, expected, se, what=""):
    # A tiny floor lets exact answers (p = 0 or 1, se = 0) compare exactly.
    assert abs(estimate - expected) <= 4.0 * se + 1e-12, f"{what}: {estimate} vs {expected} (se {se})"


# ----------------------------------------------------------------------------
# MMBP channel against the exact analysis
# ----------------------------------------------------------------------------
ONE_ROUND_CASES = [
    # (M, N, r, p_e, n_packets, strategy)
    (3, 2, 1, 0.0, 4, "rp"),
    (3, 2, 2, 0.1, 7, "rp"),
    (6, 2, 4, 0.3, 6, "rp"),
    (7, 3, 2, 0.2, 20, "rp"),
    (2, 6, 3, 0.05, 3, "rp"),
    (1, 0, 1, 0.5, 3, "rp"),  # N = 0: every slot ON
    (0, 3, 2, 0.0, 2, "rp"),  # M = 0: never
    (5, 3, 1, 0.2, 10, "rs"),
    (2, 5, 2, 0.1, 3, "rs"),
    (4, 3, 3, 0.1, 6, "rs"),
    (2, 3, 3, 0.3, 5, "rs"),  # n a multiple of C: exactly 0 (Fig. 12)
    (4, 4, 2, 0.05, 8, "rs"),  # idem
    (3, 1, 2, 0.0, 12, "rs"),  # idem, p_e = 0
    (4, 1, 1, 0.0, 1, "rs"),  # one packet
]


@pytest.mark.parametrize("M, N, r, p_e, n, strategy", ONE_ROUND_CASES)
def test_mmbp_message_within_one_round_matches_analytic(M, N, r, p_e, n, strategy):
    runs = 4000
    result = simulate(MmbpChannel(M, N, p_e, T_P), strategy, n, r, runs=runs, max_emissions=r * n, seed=11)
    expected = an.mmbp_p_message(M, N, r, p_e, n, strategy, exact=True)
    estimate = result.completed.mean()
    assert_within_4se(estimate, expected, math.sqrt(expected * (1 - expected) / runs), f"{(M, N, r, p_e, n, strategy)}")
    if expected == 0.0:
        assert not result.completed.any()


@pytest.mark.parametrize(
    "M, N, r, p_e, n, strategy",
    [(3, 2, 1, 0.1, 6, "rp"), (4, 3, 2, 0.2, 6, "rs"), (2, 5, 1, 0.0, 10, "rp"), (5, 2, 1, 0.3, 9, "rs")],
)
def test_mmbp_mean_emissions_matches_analytic(M, N, r, p_e, n, strategy):
    result = simulate(MmbpChannel(M, N, p_e, T_P), strategy, n, r, runs=5000, seed=3)
    assert result.completed.all()  # the cap is out of reach here
    expected = an.mmbp_expected_emissions(M, N, r, p_e, n, strategy)
    se = result.emissions.std(ddof=1) / math.sqrt(result.runs)
    assert_within_4se(result.emissions.mean(), expected, se, "E[emissions]")


def test_mmbp_completed_runs_are_consistent():
    result = simulate(MmbpChannel(3, 2, 0.2, T_P), "rp", 8, 2, runs=300)
    assert np.all(result.unique_receptions == 8)
    assert np.all(result.receptions + result.gap_losses + result.decode_errors == result.emissions)
    assert np.all(result.receptions >= result.unique_receptions)
    np.testing.assert_allclose(result.duration_s, result.emissions * T_P)
    np.testing.assert_allclose(result.goodput_bps, 19 * 8 / result.duration_s)
    np.testing.assert_allclose(result.throughput_bps, 24 * result.receptions / result.duration_s)


def test_mmbp_slot_pattern_follows_the_cycle():
    channel = MmbpChannel(3, 4, 0.0, T_P)
    codes = channel.open_run(run_seed_sequence(5, 0)).next_block(70)
    on = codes == RECEIVED
    np.testing.assert_array_equal(on[:63], on[7:70])  # period C = 7
    assert on[:7].sum() == 3
    # The three ON slots are consecutive (cyclically).
    assert np.roll(on[:7], -int(np.argmax(on[:7] & ~np.roll(on[:7], 1))))[:3].all()


# ----------------------------------------------------------------------------
# Timed channel
# ----------------------------------------------------------------------------
def timed_like_mmbp(M, N, p_e, jitter_s=0.0):
    """T_f = C T_p and W = (M + 1) T_p: exactly M whole PHY-SDUs per frame."""
    return TimedChannel((M + N) * T_P, (M + 1) * T_P, T_P, p_e, jitter_s)


def test_timed_without_jitter_has_the_mmbp_slot_pattern():
    for seed in range(5):
        codes = timed_like_mmbp(3, 4, 0.0).open_run(run_seed_sequence(seed, 0)).next_block(700)
        on = codes == RECEIVED
        assert set(np.unique(codes)) <= {RECEIVED, GAP_LOSS}
        np.testing.assert_array_equal(on[:-7], on[7:])
        assert on[:7].sum() == 3


@pytest.mark.parametrize("M, N, r, p_e, n, strategy", [(3, 2, 1, 0.1, 7, "rp"), (4, 3, 2, 0.2, 6, "rs")])
def test_timed_without_jitter_matches_mmbp(M, N, r, p_e, n, strategy):
    runs = 2000
    mmbp = simulate(MmbpChannel(M, N, p_e, T_P), strategy, n, r, runs=runs, seed=1)
    timed = simulate(timed_like_mmbp(M, N, p_e), strategy, n, r, runs=runs, seed=2)
    se = math.hypot(mmbp.emissions.std(ddof=1), timed.emissions.std(ddof=1)) / math.sqrt(runs)
    assert_within_4se(timed.emissions.mean(), mmbp.emissions.mean(), se, "mean emissions")
    # Both also agree with the exact expectation and one-round probability.
    assert_within_4se(timed.emissions.mean(), an.mmbp_expected_emissions(M, N, r, p_e, n, strategy), se, "E[T]")
    one_round = simulate(timed_like_mmbp(M, N, p_e), strategy, n, r, runs=runs, seed=4, max_emissions=r * n)
    p = an.mmbp_p_message(M, N, r, p_e, n, strategy)
    assert_within_4se(one_round.completed.mean(), p, math.sqrt(p * (1 - p) / runs), "P(one round)")


def test_timed_jitter_removes_the_fig12_artefact():
    # RS with n_packets a multiple of C = 5: without jitter some packets are
    # always in the gap, the message never completes; frame jitter moves the
    # windows and every packet eventually gets through.
    M, N, n = 4, 1, 10
    kwargs = dict(strategy="rs", n_packets=n, repeats=1, runs=200, max_emissions=40 * n)
    still = simulate(timed_like_mmbp(M, N, 0.01), **kwargs)
    jittered = simulate(timed_like_mmbp(M, N, 0.01, jitter_s=T_P), **kwargs)
    assert not still.completed.any()
    assert an.mmbp_p_message(M, N, 40, 0.01, n, "rs") == 0.0
    assert jittered.completed.mean() > 0.95


def test_timed_jitter_keeps_frames_ordered_and_bounded():
    from rollsim.channel.channels import _truncated_normal

    u = np.concatenate([[0.0, 0.5, 1.0 - 2**-53, 2**-53], np.random.default_rng(0).random(100_000)])
    for sigma, bound in [(1e-6, 0.0165), (0.01, 0.0165), (1.0, 0.0165)]:
        eps = _truncated_normal(u, sigma, bound)
        assert np.all(np.isfinite(eps)) and np.all(np.abs(eps) <= bound)
    eps = _truncated_normal(u[4:], 0.002, 0.0165)
    assert abs(eps.mean()) < 4 * 0.002 / math.sqrt(eps.size)
    assert eps.std() == pytest.approx(0.002, rel=0.02)


def test_timed_window_edge_cases():
    # W < T_p: nothing fits; W >= T_f + T_p: everything fits.
    never = simulate(TimedChannel(0.033, 0.5 * T_P, T_P, 0.0), runs=5, max_emissions=100)
    always = simulate(TimedChannel(0.033, 0.033 + T_P, T_P, 0.0), runs=5, n_packets=10)
    assert np.all(never.gap_losses == 100) and not never.completed.any()
    assert np.all(always.emissions == 10) and np.all(always.gap_losses == 0)


@pytest.mark.parametrize(
    "T_f, W, T_p, sigma",
    [(0.01, 0.012, 0.004, 0.003), (0.033, 0.025, 0.0065, 0.002), (0.01, 0.004, 0.001, 0.01), (0.01, 0.02, 0.0065, 0.0)],
)
def test_timed_matches_brute_force_over_all_frames(T_f, W, T_p, sigma):
    # Rebuild the run's phase and frame jitter from its streams and test every
    # emission against every frame: the candidate-frame search must agree.
    from rollsim.channel.channels import _truncated_normal

    channel = TimedChannel(T_f, W, T_p, 0.0, sigma)
    for seed in range(3):
        codes = np.concatenate([channel.open_run(run_seed_sequence(seed, 0)).next_block(n) for n in (1000,)])
        run = channel.open_run(run_seed_sequence(seed, 0))
        parts = [run.next_block(n) for n in (1, 256, 743)]  # other block cuts, same stream
        np.testing.assert_array_equal(np.concatenate(parts), codes)

        emission_ss, frame_ss = run_seed_sequence(seed, 0).spawn(2)
        phase = np.random.default_rng(emission_ss).random() * T_f
        J = channel.jitter_bound_s
        k_first = math.ceil((T_p - W - phase - J) / T_f) - 1  # the run's first candidate frame
        k = np.arange(k_first, k_first + int(1000 * T_p / T_f) + 10)
        eps = _truncated_normal(np.random.default_rng(frame_ss).random(k.size), sigma, J) if sigma else 0.0
        t_k = phase + k * T_f + eps
        start = np.arange(1000)[:, None] * T_p
        inside = ((t_k <= start) & (t_k + W >= start + T_p)).any(axis=1)
        np.testing.assert_array_equal(codes == RECEIVED, inside)


# ----------------------------------------------------------------------------
# CamComSim channel
# ----------------------------------------------------------------------------
def test_camcomsim_slots_visible_and_duration():
    assert camcomsim_frame_slots(33.3) == 333
    assert camcomsim_frame_slots(1000 / 30) == 333
    assert camcomsim_visible_slots(33.3, 0.1, 5) == 295
    assert camcomsim_sdu_slots(5, 19, 8000) == 65
    assert camcomsim_sdu_slots(5, 19, 8000, java_float32=True) == 65
    assert camcomsim_sdu_slots(5, 19, 8000, "4b6b") == 50  # (4 + 36) / 8 kHz = 5 ms
    channel = CamcomsimChannel.from_parameters()
    assert (channel.frame_slots, channel.visible_slots, channel.sdu_slots) == (333, 295, 65)


def test_camcomsim_float_traps():
    # 1000/30 * 0.9 = 30.000000000000004 in float64: a plain ceil gives 31 ms.
    assert math.ceil(1000 / 30 * (1 - 0.1)) == 31
    assert camcomsim_visible_slots(1000 / 30, 0.1, 5) == 295
    assert camcomsim_visible_slots(1000 / 30, 0.1, 5, java_float32=True) == 295  # float32: 29.999998
    # Truncating a float quotient loses a slot: (4 + 2*1) / 5000 Hz = 12 slots.
    assert int((4 + 2 * 1) / 5000 / 1e-4) == 11
    assert camcomsim_sdu_slots(0, 1, 5000) == 12
    # CamComSim's own float32 arithmetic loses one elsewhere: 16 slots -> 15.
    assert camcomsim_sdu_slots(0, 2, 5000) == 16
    assert camcomsim_sdu_slots(0, 2, 5000, java_float32=True) == 15


@pytest.mark.parametrize(
    "d, index",
    [(0, 0), (2.4, 0), (2.5, 1), (5, 1), (7.4, 1), (10, 2), (35, 7), (40, 8), (42.4, 8)]
    + [(42.5, None), (45, None), (1e4, None)],
)
def test_camcomsim_roi_table_indexing(d, index):
    assert camcomsim_roi(d) == (0.0 if index is None else CAMCOMSIM_ROI_TABLE[index])


def test_camcomsim_beyond_the_table_receives_nothing():
    channel = CamcomsimChannel.from_parameters(distance_cm=45)
    assert channel.visible_slots == 0
    result = simulate(channel, n_packets=5, runs=20, max_emissions=300)
    assert not result.completed.any()
    assert np.all(result.gap_losses == 300) and np.all(result.receptions == 0)
    assert np.all(result.goodput_bps == 0.0) and np.all(result.throughput_bps == 0.0)


def test_camcomsim_slot_sequence_is_the_java_recurrence():
    rng = np.random.default_rng(0)
    increments = rng.integers(65, 75, size=1000)
    slot, expected = 123, []
    for inc in increments:
        slot = (slot + inc) % 333
        expected.append(slot)
    np.testing.assert_array_equal(camcomsim_slot_sequence(123, increments, 333), expected)


def test_camcomsim_channel_is_a_literal_transcription():
    # Reproduce Channel.getNextErrorProbability emission by emission from
    # the same random draws and compare the outcomes.
    channel = CamcomsimChannel.from_parameters(distance_cm=10, p_e=0.2)
    S, V, d = channel.frame_slots, channel.visible_slots, channel.sdu_slots
    seed_sequence = run_seed_sequence(9, 3)
    rng = np.random.default_rng(seed_sequence)
    slot = int(rng.integers(S))
    gaps = rng.integers(d, d + 10, size=512) - d
    uniform = rng.random(512)
    expected = []
    for gap, u in zip(gaps, uniform):
        slot = (d + slot + gap) % S
        channel_error = 1.0 if slot + d >= V else channel.p_e
        if channel_error >= u:  # Simulation.java: lost
            expected.append(GAP_LOSS if channel_error == 1.0 else DECODE_ERROR)
        else:
            expected.append(RECEIVED)
    codes = channel.open_run(seed_sequence).next_block(512)
    np.testing.assert_array_equal(codes, expected)


def test_camcomsim_window_probability_and_clock():
    channel = CamcomsimChannel.from_parameters()
    # Every emission's slot is uniform: P(in window) = (295 - 65) / 333.
    result = simulate(channel, n_packets=1, runs=20000, max_emissions=1, workers=2)
    p = (295 - 65) / 333
    assert channel.window_probability == pytest.approx(p)
    assert_within_4se(1 - result.gap_losses.mean(), p, math.sqrt(p * (1 - p) / result.runs), "P(window)")
    long = simulate(channel, n_packets=50, runs=50)
    np.testing.assert_array_equal(long.duration_100us, long.emissions * 65)
    np.testing.assert_allclose(long.duration_s, long.emissions * 0.0065)


def test_camcomsim_format_fields():
    result = simulate(CamcomsimChannel.from_parameters(), n_packets=20, runs=30, record_loss_streaks=True)
    params = {"simuNbIteration": 30}
    rows = to_camcomsim(result, params)
    json.dumps(rows, allow_nan=False)
    assert isinstance(rows, list) and len(rows) == 30
    row = rows[0]
    assert tuple(row) == CAMCOMSIM_RUN_FIELDS  # every field, in CamComSim's order
    assert "througputBps" in row and "throughputBps" not in row
    assert row["nbTxPhysdu"] == result.emissions[0]
    assert row["duration100Us"] == result.emissions[0] * 65
    assert row["physduTxDurationMs"] == pytest.approx(6.5)
    assert row["nbInterFgError"] == result.gap_losses[0]
    assert row["isGenerationRx"] is bool(result.completed[0])
    assert row["simuParams"] == params
    for row in rows:
        # One round is 20 emissions (r = 1): the rounds begun cover the emissions.
        assert row["nbTxGeneration"] == math.ceil(row["nbTxPhysdu"] / 20)
        # A completed run ends in a reception, so every loss belongs to a streak.
        assert sum(row["nbConsecutiveDrop"]) == row["nbInterFgError"] + row["nbIntraFError"]
        assert all(streak > 0 for streak in row["nbConsecutiveDrop"])
        assert len(row["nbConsecutiveDrop"]) <= row["nbRxPhysdu"]


def test_camcomsim_format_needs_loss_streaks():
    result = simulate(CamcomsimChannel.from_parameters(), n_packets=5, runs=3)
    assert result.loss_streaks is None
    with pytest.raises(ValueError, match="record_loss_streaks"):
        to_camcomsim(result, {})


def reference_loss_streaks(codes):
    """Loss streaks ended by a reception, by a plain walk over the outcomes."""
    streaks, open_streak = [], 0
    for code in codes:
        if code == RECEIVED:
            if open_streak:
                streaks.append(open_streak)
            open_streak = 0
        else:
            open_streak += 1
    return streaks


@pytest.mark.parametrize("seed", range(20))
def test_loss_streaks_across_blocks_match_a_plain_walk(seed):
    rng = np.random.default_rng(seed)
    codes = rng.choice([RECEIVED, GAP_LOSS, DECODE_ERROR], size=int(rng.integers(1, 200)), p=[0.3, 0.5, 0.2])
    cuts = np.sort(rng.choice(np.arange(1, codes.size + 1), size=min(5, codes.size), replace=False))
    streaks, open_streak, start = [], 0, 0
    for stop in cuts:
        block = codes[start:stop]
        open_streak = _add_loss_streaks(np.flatnonzero(block == RECEIVED), open_streak, block.size, streaks)
        start = stop
    found = np.concatenate(streaks).tolist() if streaks else []
    assert found == reference_loss_streaks(codes[:start])


def test_loss_streaks_do_not_change_the_results():
    channel = CamcomsimChannel.from_parameters()
    plain = simulate(channel, n_packets=31, runs=40, seed=3)
    recorded = simulate(channel, n_packets=31, runs=40, seed=3, record_loss_streaks=True)
    assert_same(plain, recorded)
    assert len(recorded.loss_streaks) == 40


# ----------------------------------------------------------------------------
# Reproducibility, workers, progress
# ----------------------------------------------------------------------------
def all_arrays(result):
    return {**result.metrics(), "completed": result.completed}


def assert_same(a, b):
    for name, values in all_arrays(a).items():
        np.testing.assert_array_equal(values, all_arrays(b)[name], err_msg=name)


@pytest.mark.parametrize(
    "channel",
    [MmbpChannel(3, 2, 0.1, T_P), timed_like_mmbp(3, 2, 0.1, jitter_s=0.002), CamcomsimChannel.from_parameters()],
    ids=["mmbp", "timed", "camcomsim"],
)
def test_determinism_workers_and_chunks(channel):
    base = simulate(channel, n_packets=31, runs=60, seed=5, workers=1)
    assert_same(base, simulate(channel, n_packets=31, runs=60, seed=5, workers=1))
    assert_same(base, simulate(channel, n_packets=31, runs=60, seed=5, workers=2))
    assert_same(base, simulate(channel, n_packets=31, runs=60, seed=5, workers=2, chunk_runs=7))
    other = simulate(channel, n_packets=31, runs=60, seed=6, workers=1)
    assert not np.array_equal(base.emissions, other.emissions)


def test_run_k_uses_child_k():
    seed = 12
    children = np.random.SeedSequence(seed).spawn(10)
    for k in (0, 3, 9):
        np.testing.assert_array_equal(run_seed_sequence(seed, k).generate_state(4), children[k].generate_state(4))
    channel = MmbpChannel(3, 2, 0.1, T_P)
    few = simulate(channel, runs=5, seed=seed)
    many = simulate(channel, runs=40, seed=seed)
    np.testing.assert_array_equal(few.emissions, many.emissions[:5])


def test_capped_run_is_a_prefix_of_the_uncapped_run():
    channel = CamcomsimChannel.from_parameters(p_e=0.1)
    full = simulate(channel, n_packets=300, runs=40)
    cap = int(np.median(full.emissions))
    capped = simulate(channel, n_packets=300, runs=40, max_emissions=cap)
    done = full.emissions <= cap
    np.testing.assert_array_equal(capped.completed, done)
    np.testing.assert_array_equal(full.completed_within(cap), done)
    np.testing.assert_array_equal(capped.emissions[done], full.emissions[done])
    assert np.all(capped.emissions[~done] == cap)


def test_progress_is_called_per_chunk():
    calls = []
    simulate(MmbpChannel(3, 2, 0.1, T_P), runs=50, chunk_runs=8, progress=calls.append)
    assert calls == [8] * 6 + [2]
    calls = []
    simulate(MmbpChannel(3, 2, 0.1, T_P), runs=50, chunk_runs=8, workers=2, progress=calls.append)
    assert sorted(calls) == [2] + [8] * 6


# ----------------------------------------------------------------------------
# Hard cases, summaries and errors
# ----------------------------------------------------------------------------
def test_p_e_zero_every_slot_on():
    result = simulate(MmbpChannel(4, 0, 0.0, T_P), "rp", 25, 1, runs=10)
    assert np.all(result.emissions == 25) and result.completed.all()
    assert np.all(result.receptions == 25) and np.all(result.gap_losses == 0)


def test_p_e_one_never_completes():
    result = simulate(MmbpChannel(3, 2, 1.0, T_P), runs=10, max_emissions=1000)
    assert not result.completed.any()
    assert np.all(result.emissions == 1000) and np.all(result.receptions == 0)
    assert np.all(result.decode_errors + result.gap_losses == 1000)
    assert np.all(result.goodput_bps == 0.0)
    summary = result.summary()
    json.dumps(summary, allow_nan=False)
    assert summary["completed_fraction"] == 0.0
    assert summary["metrics"]["goodput_bps"] == {"mean": 0.0, "std": 0.0, "ci95": [0.0, 0.0]}


def test_m_zero_and_cap_one_and_single_packet():
    result = simulate(MmbpChannel(0, 3, 0.0, T_P), runs=5, max_emissions=50)
    assert not result.completed.any() and np.all(result.gap_losses == 50)
    result = simulate(MmbpChannel(1, 0, 0.0, T_P), n_packets=1, runs=5, max_emissions=1)
    assert result.completed.all() and np.all(result.emissions == 1)
    result = simulate(MmbpChannel(1, 0, 0.0, T_P), n_packets=2, runs=5, max_emissions=1)
    assert not result.completed.any() and np.all(result.unique_receptions == 1)
    assert np.all(result.throughput_bps == pytest.approx(24 / T_P))


def test_large_message_and_round():
    # A round longer than the largest block, and RP runs spanning blocks.
    result = simulate(MmbpChannel(5, 1, 0.01, T_P), "rp", 3000, 2, runs=4)
    assert result.completed.all() and np.all(result.unique_receptions == 3000)


def test_summary_statistics():
    s = summary_statistics([1.0, 2.0, 3.0, 4.0])
    assert s["mean"] == 2.5 and s["std"] == pytest.approx(np.std([1, 2, 3, 4], ddof=1))
    half = 3.182446305284263 * s["std"] / 2  # t_{0.975, 3}
    assert s["ci95"] == pytest.approx([2.5 - half, 2.5 + half])
    assert summary_statistics([5.0]) == {"mean": 5.0, "std": None, "ci95": None}
    one = simulate(MmbpChannel(3, 2, 0.1, T_P), runs=1).summary()
    json.dumps(one, allow_nan=False)
    assert set(one["metrics"]) == set(METRICS)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(runs=0), "runs"),
        (dict(max_emissions=0), "max_emissions"),
        (dict(workers=0), "workers"),
        (dict(seed=-1), "seed"),
        (dict(seed=1.5), "seed"),
        (dict(chunk_runs=0), "chunk_runs"),
        (dict(header_bits=-1), "header_bits"),
        (dict(payload_bits=0), "payload_bits"),
    ],
)
def test_invalid_simulation_parameters(kwargs, name):
    params = dict(header_bits=5, payload_bits=19, runs=1)
    params.update(kwargs)
    with pytest.raises(ValueError, match=name):
        simulate_broadcast(MmbpChannel(3, 2, 0.1, T_P), Schedule("rp", 3), **params)


@pytest.mark.parametrize(
    "build, name",
    [
        (lambda: MmbpChannel(0, 0, 0.1, T_P), "M = N = 0"),
        (lambda: MmbpChannel(-1, 2, 0.1, T_P), "M"),
        (lambda: MmbpChannel(3, 2, 1.5, T_P), "p_e"),
        (lambda: MmbpChannel(3, 2, 0.1, 0.0), "sdu_duration_s"),
        (lambda: TimedChannel(0.0, 0.01, T_P, 0.1), "frame_period_s"),
        (lambda: TimedChannel(0.03, -1.0, T_P, 0.1), "capture_window_s"),
        (lambda: TimedChannel(0.03, 0.01, T_P, 0.1, math.nan), "frame_jitter_s"),
        (lambda: CamcomsimChannel(333, 295, 0, 0.1), "sdu_slots"),
        (lambda: camcomsim_sdu_slots(5, 19, 1e7), "clock_hz"),
        (lambda: camcomsim_sdu_slots(5, 19, 8000, "nrz"), "line_code"),
        (lambda: camcomsim_visible_slots(33.3, 1.5, 5), "ifg_ratio"),
        (lambda: camcomsim_roi(-1), "distance_cm"),
    ],
)
def test_invalid_channel_parameters(build, name):
    with pytest.raises(ValueError, match=name):
        build()


def test_schedule_must_be_a_schedule():
    with pytest.raises(ValueError, match="schedule"):
        simulate_broadcast(MmbpChannel(3, 2, 0.1, T_P), "rp", header_bits=5, payload_bits=19)


# ----------------------------------------------------------------------------
# Benchmark (skipped by default: pytest -m benchmark)
# ----------------------------------------------------------------------------
@pytest.mark.benchmark
def test_bench_eventsim():
    from rollsim.bench.eventsim import bench_eventsim

    result = bench_eventsim()
    print(result)
    assert result["completed_fraction"] > 0.99
    assert result["emissions"] > 1e6


def test_every_channel_model_shares_one_base_and_anything_else_is_refused():
    from rollsim.channel.channels import ChannelModel

    models = [MmbpChannel(3, 2, 0.01, 7e-3), TimedChannel(1 / 30, 0.02, 7e-3, 0.01),
              CamcomsimChannel.from_parameters()]
    for model in models:
        assert isinstance(model, ChannelModel)
        assert model.emission_duration_100us == pytest.approx(model.emission_duration_s / 1e-4)
        assert model.parameters()["kind"] == model.kind
    # A look-alike with the right attribute names is not a channel model.
    fake = type("Fake", (), {"open_run": None, "kind": "x", "emission_duration_s": 1.0, "parameters": dict})()
    with pytest.raises(ValueError, match="channel must be one of the rollsim.channel.channels models"):
        simulate_broadcast(fake, Schedule("rp", 3, 1), header_bits=5, payload_bits=19, runs=1, seed=0)
    with pytest.raises(TypeError):
        ChannelModel()
