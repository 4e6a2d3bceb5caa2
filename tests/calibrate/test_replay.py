"""Replayed goodput: the trace read cyclically, checked against a direct emission-by-emission replay."""

import numpy as np
import pytest

from rollsim.calibrate.replay import replay_goodput_bps
from rollsim.transmitter import Schedule


def _direct_replay(success, r, n_packets, payload_bits, sdu_s, strategy, max_emissions):
    """Every start of the trace, one emission at a time: the definition, no vectorisation."""
    x = list(map(bool, success))
    schedule = Schedule(strategy, n_packets, r)
    goodputs = []
    for start in range(len(x)):
        received = set()
        for e in range(max_emissions):
            if x[(start + e) % len(x)]:
                received.add(int(schedule.sequence_numbers(e)))
            if len(received) == n_packets:
                goodputs.append(payload_bits * n_packets / ((e + 1) * sdu_s))
                break
        else:
            goodputs.append(0.0)
    return float(np.mean(goodputs)), goodputs.count(0.0)


@pytest.mark.parametrize("strategy", ["rp", "rs"])
@pytest.mark.parametrize("r", [1, 2, 3])
@pytest.mark.parametrize("seed", [0, 1])
def test_replay_equals_the_direct_replay_of_every_start(strategy, r, seed):
    rng = np.random.default_rng(seed)
    horizon, n_packets = 37, 11  # a few rounds at most: replays run past the end and wrap
    success = rng.random(horizon) < 0.6
    got = replay_goodput_bps(success, r, n_packets, 19, 7e-3, max_starts=horizon, strategy=strategy,
                             max_emissions=400)
    expected, capped = _direct_replay(success, r, n_packets, 19, 7e-3, strategy, 400)
    assert got["goodput_bps"] == pytest.approx(expected, rel=1e-12)
    assert got["capped"] == capped and got["replays"] == horizon
    assert got["trace_rounds"] == pytest.approx(horizon / (r * n_packets))


def test_every_packet_received_at_once_gives_one_round():
    n_packets, r, sdu_s = 22, 3, 7e-3
    got = replay_goodput_bps(np.ones(100, dtype=bool), r, n_packets, 19, sdu_s)
    # The last packet's first copy is emission (n - 1) r.
    assert got["goodput_bps"] == pytest.approx(19 * n_packets / (((n_packets - 1) * r + 1) * sdu_s))
    assert got["capped"] == 0


def test_a_short_trace_gives_what_its_repetition_gives():
    # No replay is dropped for running past the trace's end: a trace shorter
    # than one round replays exactly as the same outcomes repeated ten times.
    rng = np.random.default_rng(3)
    success = rng.random(50) < 0.7
    short = replay_goodput_bps(success, 3, 422, 19, 8e-3, max_starts=50)
    long = replay_goodput_bps(np.tile(success, 10), 3, 422, 19, 8e-3, max_starts=500)
    assert short["trace_rounds"] < 0.05
    assert short["goodput_bps"] == pytest.approx(long["goodput_bps"], rel=1e-12)
    assert short["capped"] == 0


def test_a_packet_never_received_caps_every_replay_at_zero():
    # Even positions succeed, the trace has even length, r = 1 and 2 packets:
    # from any start one packet always meets the odd positions.
    success = np.arange(40) % 2 == 0
    got = replay_goodput_bps(success, 1, 2, 19, 7e-3, max_emissions=1000)
    assert got["goodput_bps"] == 0.0 and got["capped"] == got["replays"] == 40


def test_an_empty_trace_gives_no_goodput():
    got = replay_goodput_bps(np.zeros(0, dtype=bool), 1, 5, 19, 7e-3)
    assert got["goodput_bps"] is None and got["replays"] == 0


def test_batch_means_interval_is_students_t_on_the_batch_means():
    from scipy.stats import t

    from rollsim.calibrate.replay import batch_means_interval

    values = np.random.default_rng(3).normal(10.0, 2.0, 1000)
    means = np.array([c.mean() for c in np.array_split(values, 10)])
    half = t.ppf(0.975, 9) * means.std(ddof=1) / np.sqrt(10)
    low, high = batch_means_interval(values, 10)
    assert (low, high) == pytest.approx((values.mean() - half, values.mean() + half), rel=1e-12)
    assert batch_means_interval(values, 1) is None


def test_a_trace_shorter_than_two_replays_has_no_interval():
    """Two packets, two successes 101 emissions apart (one per packet): a replay needs ~100 emissions, the trace holds 150."""
    from rollsim.calibrate.replay import replay_goodput_bps

    success = np.zeros(150, dtype=bool)
    success[[10, 111]] = True
    replay = replay_goodput_bps(success, 1, 2, 19, 0.007, max_starts=150)
    assert replay["goodput_bps"] > 0 and replay["ci95"] is None


@pytest.mark.parametrize("strategy, r, n_packets, p", [("rp", 1, 50, 0.8), ("rp", 3, 7, 0.3), ("rs", 2, 13, 0.6),
                                                      ("rs", 1, 5, 0.05)])
def test_all_starts_at_once_equal_each_start_alone(strategy, r, n_packets, p, monkeypatch):
    """The table of every start (in blocks of starts: a small table forced here) ends each replay
    at the same emission as the per-start search, or refuses it (−1) alike within the window."""
    from rollsim.calibrate import replay

    monkeypatch.setattr(replay, "_TABLE_ELEMENTS", 500)
    rng = np.random.default_rng(n_packets)
    success = rng.random(301) < p
    schedule = Schedule(strategy, n_packets, r)
    hits = np.flatnonzero(success)
    starts = np.arange(success.size)
    for window in (n_packets * r, 3 * n_packets * r + 17, 900):
        table = replay._first_receptions_all(success, starts, schedule.sequence_numbers(np.arange(window)), n_packets)
        alone = [replay._first_receptions(hits, success.size, w, schedule.sequence_numbers, n_packets, window)
                 for w in starts.tolist()]
        assert table.tolist() == alone
