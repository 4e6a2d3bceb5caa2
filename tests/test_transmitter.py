"""Transmitter: strategy schedules, chip sources, s(t), S(t) and time lookup."""

import math
from fractions import Fraction

import numpy as np
import pytest

from rollsim.protocol import PhyFormat
from rollsim.transmitter import Schedule, build_transmitter, message_from_seed

# Hand-enumerated schedules for N_p = 3 packets (first 2 rounds).
HAND_RP = {
    1: [0, 1, 2, 0, 1, 2],
    2: [0, 0, 1, 1, 2, 2, 0, 0, 1, 1, 2, 2],
    3: [0, 0, 0, 1, 1, 1, 2, 2, 2, 0, 0, 0, 1, 1, 1, 2, 2, 2],
    4: [0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2] * 2,
}
HAND_RS = {r: [0, 1, 2] * (2 * r) for r in (1, 2, 3, 4)}


@pytest.mark.parametrize("r", [1, 2, 3, 4])
def test_rp_schedule_matches_hand_enumeration(r):
    schedule = Schedule("rp", 3, r)
    expected = HAND_RP[r]
    assert schedule.sequence_numbers(np.arange(len(expected))).tolist() == expected
    assert schedule.copy_index(np.arange(2 * r)).tolist() == list(range(r)) * 2


@pytest.mark.parametrize("r", [1, 2, 3, 4])
def test_rs_schedule_matches_hand_enumeration(r):
    schedule = Schedule("rs", 3, r)
    expected = HAND_RS[r]
    assert schedule.sequence_numbers(np.arange(len(expected))).tolist() == expected
    # Round k covers emissions [3r·k, 3r·(k+1)); within it copy j of every packet.
    assert schedule.round_index(np.arange(len(expected))).tolist() == sorted([0, 1] * (3 * r))
    assert schedule.copy_index(np.arange(3 * r)).tolist() == np.repeat(np.arange(r), 3).tolist()


@pytest.mark.parametrize("strategy", ["rp", "rs"])
@pytest.mark.parametrize("r", [1, 2, 5])
def test_schedule_is_periodic_into_the_past(strategy, r):
    schedule = Schedule(strategy, 7, r)
    tx = np.arange(-200, 200)
    period = schedule.emissions_per_round if strategy == "rp" else 7
    np.testing.assert_array_equal(schedule.sequence_numbers(tx), schedule.sequence_numbers(tx + period))


@pytest.mark.parametrize("strategy", ["rp", "rs"])
@pytest.mark.parametrize("r", [1, 3])
def test_cumulative_equals_brute_force_sum(strategy, r):
    schedule = Schedule(strategy, 5, r)
    weights = np.array([3, 0, 7, 1, 4])
    for a in range(-40, 40, 3):
        for b in range(a, a + 35, 4):
            brute = sum(weights[schedule.sequence_numbers(k)] for k in range(a, b))
            assert schedule.cumulative(b, weights) - schedule.cumulative(a, weights) == brute
    assert schedule.cumulative(0, weights) == 0


def test_schedule_rejects_bad_parameters():
    with pytest.raises(ValueError, match="strategy"):
        Schedule("xx", 3)
    with pytest.raises(ValueError, match="repeats"):
        Schedule("rp", 3, 0)


def _transmitter(pattern="data", strategy="rp", r=2, off_level=0.0, start_s=0.0, clock_hz=8000.0, code="manchester"):
    phy = PhyFormat(5, 19, "parity2", code)
    return build_transmitter(phy, message_from_seed(7, 50), strategy, r, pattern, clock_hz, start_s, off_level)


def _reference_integral(waveform, t1, t2):
    """Exact integral of s over [t1, t2] in rational arithmetic.

    The float inputs are exact rationals; the interval is split at every chip
    boundary t0 + k/f inside it, s is constant on each piece (its level read
    from the chip source's values, not from S), and width × level is summed
    exactly. So this is the numerical integral with no discretisation or
    rounding error at all."""
    f, t0 = Fraction(waveform.clock_hz), Fraction(waveform.start_s)
    a, b = Fraction(t1), Fraction(t2)
    first, last = math.floor((a - t0) * f), math.floor((b - t0) * f)
    chips = np.arange(first, last + 1)
    on = waveform.chips.values(chips)
    levels = {1: Fraction(waveform.on_level), 0: Fraction(waveform.off_level)}
    total = Fraction(0)
    for k, v in zip(chips.tolist(), on.tolist()):
        lo, hi = max(a, t0 + k / f), min(b, t0 + (k + 1) / f)
        if hi > lo:
            total += (hi - lo) * levels[v]
    return float(total)


INTERVALS = [
    (0.0, 0.033),  # one frame period
    (1.23e-3, 1.26e-3),  # shorter than a chip (125 us)
    (-0.0517, 0.0003),  # starts before t = 0
    (-0.2, -0.1),  # wholly before t = 0
    (0.5, 2.1),  # many PHY-SDUs and rounds
    (123.4567, 123.4568),  # late in a run, 100 us
    (3333.3001, 3333.3001 + 1e-6),  # 100,000 frames in, 1 us
]


@pytest.mark.parametrize("pattern", ["data", "square", "on", "off"])
@pytest.mark.parametrize("strategy", ["rp", "rs"])
def test_exposure_integral_equals_fine_numerical_integral(pattern, strategy):
    tx = _transmitter(pattern, strategy, r=3, off_level=0.15, start_s=-0.0123)
    w = tx.waveform
    rng = np.random.default_rng(11)
    random = [(a, a + d) for a, d in zip(rng.uniform(-1, 5, 30), rng.uniform(1e-6, 0.05, 30))]
    late = [(a, a + d) for a, d in zip(rng.uniform(1e3, 4e3, 20), rng.uniform(1e-6, 2e-4, 20))]
    for t1, t2 in INTERVALS + random + late:
        reference = _reference_integral(w, t1, t2)
        exact = w.exposure(t1, t2)
        assert exact == pytest.approx(reference, rel=1e-12, abs=0)
        # S itself, differenced: exact to rounding relative to |S|.
        scale = max(abs(float(w.integral(t1))), abs(float(w.integral(t2))), 1e-300)
        assert abs(w.integral(t2) - w.integral(t1) - reference) <= 1e-14 * scale


def test_exposure_agrees_with_riemann_sum():
    w = _transmitter(off_level=0.1).waveform
    t = np.linspace(0.0101, 0.0301, 2_000_001)
    riemann = np.sum(w.level(0.5 * (t[:-1] + t[1:]))) * (t[1] - t[0])
    assert w.exposure(t[0], t[-1]) == pytest.approx(riemann, rel=1e-5)


def test_constant_on_exposure_is_level_times_duration():
    w = _transmitter("on").waveform
    starts = np.linspace(-1, 1, 1001)
    np.testing.assert_allclose(w.exposure(starts, starts + 100e-6), 100e-6, rtol=1e-12)


def test_back_to_back_windows_sum_to_the_union():
    w = _transmitter(off_level=0.2).waveform
    edges = np.cumsum(np.r_[0.0123, np.random.default_rng(3).uniform(1e-6, 3e-3, 500)])
    parts = w.exposure(edges[:-1], edges[1:])
    assert math.fsum(parts) == pytest.approx(float(w.exposure(edges[0], edges[-1])), rel=1e-12)


def test_level_follows_the_chips_of_each_emission():
    tx = _transmitter(strategy="rp", r=2, start_s=1e-3)
    phy = tx.phy
    T = 1.0 / tx.waveform.clock_hz
    for i in (-3, 0, 1, 5, 44):
        centres = tx.waveform.start_s + (i * phy.sdu_chips + np.arange(phy.sdu_chips) + 0.5) * T
        seq = tx.schedule.sequence_numbers(i)
        np.testing.assert_array_equal(tx.waveform.level(centres), tx.sdu_chips[seq])


def test_locate_maps_time_to_emission_and_bit():
    tx = _transmitter(strategy="rs", r=1)
    phy = tx.phy
    T = 1.0 / tx.waveform.clock_hz
    i, bit = 9, 6
    chip_in_sdu = phy.sync_chips + 2 * bit + 1
    t = (i * phy.sdu_chips + chip_in_sdu + 0.3) * T
    where = tx.locate(np.array([t]))
    assert where["tx"][0] == i and where["sequence"][0] == 9 % tx.n_packets
    assert where["chip_in_sdu"][0] == chip_in_sdu and where["bit"][0] == bit
    codeword = tx.codeword_bits(np.array([i]))[0]
    assert where["level"][0] == codeword[bit]  # second Manchester chip carries the bit
    assert tx.emission_start_s(i) == pytest.approx(i * phy.sdu_chips * T)
    assert tx.locate(np.array([(i * phy.sdu_chips + 1) * T]))["bit"][0] == -1


def test_emissions_between_covers_every_overlapping_sdu():
    tx = _transmitter()
    d = tx.sdu_duration_s
    got = tx.emissions_between(2.5 * d, 5.0 * d)
    assert got.tolist() == [2, 3, 4]
    assert _transmitter("square").emissions_between(0, 1).size == 0


def test_square_pattern_is_a_chip_rate_square_wave():
    w = _transmitter("square").waveform
    centres = (np.arange(-4, 8) + 0.5) / w.clock_hz
    np.testing.assert_array_equal(w.level(centres), [1, 0] * 6)


def test_message_from_seed_is_deterministic():
    assert message_from_seed(3, 20) == message_from_seed(3, 20)
    assert message_from_seed(3, 20) != message_from_seed(4, 20)


def test_every_chip_source_is_a_chip_source():
    from rollsim.transmitter.chips import ChipSource, ConstantChips, DataChips, SquareChips

    schedule = Schedule("rp", 2, 1)
    sources = [ConstantChips(1), ConstantChips(0), SquareChips(), DataChips(schedule, np.array([[1, 0, 1], [0, 0, 1]]))]
    assert all(isinstance(source, ChipSource) for source in sources)
    assert not isinstance(object(), ChipSource)
    # ones_before counts the ON chips that values gives, over any range.
    chips = np.arange(-12, 13)
    for source in sources:
        counted = np.concatenate([[0], np.cumsum(source.values(chips).astype(np.int64))])
        assert np.array_equal(source.ones_before(np.append(chips, 13)) - source.ones_before(-12), counted)
