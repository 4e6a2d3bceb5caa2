"""PHY-SDU protocol: packets, check bits, line codes, SYNC uniqueness."""

import itertools
from itertools import combinations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rollsim.protocol import (
    CRC8_MAX_DATA_BITS,
    FOUR_B_SIX_B_TABLE,
    PhyFormat,
    camcomsim_sdu_duration_s,
    check_bits,
    crc8,
    depacketize,
    last_payload_bits,
    min_header_bits,
    n_packets,
    packetize,
    parity2,
    sync_pattern,
    verify,
)
from rollsim.protocol import linecode

FORMATS = [
    PhyFormat(h, p, check, code)
    for (h, p) in [(5, 19), (8, 64), (1, 1), (0, 7)]
    for check in ("parity2", "crc8")
    for code in ("manchester", "4b6b")
]


def _random_message(rng, n_bytes):
    return rng.integers(0, 256, size=n_bytes, dtype=np.uint8).tobytes()


@pytest.mark.parametrize("code", ["manchester", "4b6b"])
@pytest.mark.parametrize("check", ["parity2", "crc8"])
def test_round_trip_1000_random_messages(code, check):
    rng = np.random.default_rng(2024)
    for _ in range(1000):
        message = _random_message(rng, int(rng.integers(1, 40)))
        payload_bits = int(rng.integers(1, 48))
        count = n_packets(len(message), payload_bits)
        phy = PhyFormat(max(1, min_header_bits(count)), payload_bits, check, code)
        payloads = packetize(message, payload_bits)
        chips = phy.encode(np.arange(count), payloads)
        assert chips.shape == (count, phy.sdu_chips)
        decoded = phy.decode(chips)
        assert decoded.check_ok.all() and decoded.code_ok.all()
        np.testing.assert_array_equal(decoded.sequence, np.arange(count))
        assert depacketize(decoded.payload, len(message)) == message


def test_packetize_pads_last_payload_and_reports_its_length():
    message = bytes([0xFF] * 50)
    payloads = packetize(message, 19)
    assert payloads.shape == (22, 19)  # ceil(400 / 19)
    assert last_payload_bits(50, 19) == 400 - 21 * 19 == 1
    assert payloads[-1, 0] == 1 and not payloads[-1, 1:].any()


def test_min_header_bits():
    assert [min_header_bits(n) for n in (1, 2, 3, 4, 5, 22, 32, 33)] == [0, 1, 2, 2, 3, 5, 5, 6]


def test_manchester_polarity_is_ieee_802_3():
    np.testing.assert_array_equal(linecode.encode([1, 0], "manchester"), [[0, 1, 1, 0]])


def test_invalid_manchester_pair_is_an_error_not_a_guess():
    bits, valid = linecode.decode([[0, 1, 1, 1]], "manchester", 2)
    assert not valid[0]


def test_repair_keeps_the_more_reliable_chip_of_an_equal_pair():
    chips, repaired = linecode.repair([[1, 1, 0, 1], [0, 0, 1, 0]], [[0.9, 0.2, 1, 1], [0.1, 0.8, 1, 1]], "manchester")
    np.testing.assert_array_equal(chips, [[1, 0, 0, 1], [1, 0, 1, 0]])
    assert repaired.tolist() == [1, 1]


@pytest.mark.parametrize("chips, reliability, margin", [
    ([1, 1, 0, 0], [0.9, 0.2, 0.9, 0.2], 0.0),  # two invalid pairs: more than one chip went wrong
    ([1, 1, 0, 1], [0.5, 0.5, 1, 1], 0.0),  # a tie: nothing says which chip is wrong
    ([1, 1, 0, 1], [0.9, 0.5, 1, 1], 0.67),  # 2·0.4/1.4 = 0.57 of the pair's reliability: not clear enough
])
def test_repair_leaves_what_it_cannot_tell(chips, reliability, margin):
    out, repaired = linecode.repair([chips], [reliability], "manchester", 1, margin)
    np.testing.assert_array_equal(out, [chips])
    assert repaired.tolist() == [0]


def test_repair_of_4b6b_takes_the_codeword_of_least_flipped_reliability():
    word = np.array([int(c) for c in FOUR_B_SIX_B_TABLE[5]], dtype=np.uint8)  # 100011
    broken = word.copy()
    broken[2] ^= 1  # 101011: four ON chips, no codeword
    reliability = np.array([1.0, 1.0, 0.1, 1.0, 1.0, 1.0])
    out, repaired = linecode.repair(broken, reliability, "4b6b", 1, 2.0 / 3.0)
    np.testing.assert_array_equal(out[0], word)
    assert repaired.tolist() == [1]


@pytest.mark.parametrize("line_code", ["manchester", "4b6b"])
def test_decode_coded_repairs_a_weak_chip_in_either_code(line_code):
    # The margin is measured on the chips where the two best replacements
    # differ, so it asks the same of a 6-chip word as of a pair.
    phy = PhyFormat(5, 19, "crc8", line_code)
    rng = np.random.default_rng(5)
    repaired = 0
    for _ in range(40):
        payload = rng.integers(0, 2, (1, phy.payload_bits))
        coded = phy.encode(np.array([9]), payload)[:, phy.sync_chips:].copy()
        reliability = rng.uniform(0.6, 1.0, coded.shape)
        chip = rng.integers(coded.shape[1])
        coded[0, chip] ^= 1
        reliability[0, chip] = 0.1
        decoded = phy.decode_coded(coded, reliability)
        assert not phy.decode_coded(coded).code_ok[0]
        if decoded.code_ok[0]:
            repaired += 1
            assert decoded.check_ok[0] and np.array_equal(decoded.payload, payload)
    # Every flip breaks its symbol (a pair of equal chips; a word of two or
    # four ON chips), and the weak chip is the clear one to flip back.
    assert repaired == 40


def test_repair_of_no_rows():
    out, repaired = linecode.repair(np.zeros((0, 8), np.uint8), np.zeros((0, 8)), "manchester")
    assert out.shape == (0, 8) and repaired.shape == (0,)


@pytest.mark.parametrize("n_pairs", [1, 4, 6])
def test_repair_lets_random_chips_pass_with_probability_n_plus_1_over_2_to_the_n(n_pairs):
    # Exact enumeration of every chip pattern, with distinct reliabilities
    # (one chip of each pair clearly the less reliable): the valid ones pass,
    # and so does every pattern with exactly one equal pair.
    patterns = np.array(list(itertools.product([0, 1], repeat=2 * n_pairs)), dtype=np.uint8)
    reliability = np.tile([1.0, 0.1], (patterns.shape[0], n_pairs))
    out, _ = linecode.repair(patterns, reliability, "manchester", 1, 0.67)
    _, valid = linecode.decode(out, "manchester", n_pairs)
    assert int(valid.sum()) == (n_pairs + 1) * 2**n_pairs
    _, plain = linecode.decode(patterns, "manchester", n_pairs)
    assert int(plain.sum()) == 2**n_pairs


@pytest.mark.parametrize("call, message", [
    (lambda: linecode.repair([[1, 1, 0]], [[1, 1, 1]], "manchester"), "whole 2-chip symbols"),
    (lambda: linecode.repair([[1, 1]], [[1, 1, 1]], "manchester"), "must match"),
    (lambda: linecode.repair([[1, 1]], [[1, -1]], "manchester"), "reliability"),
    (lambda: linecode.repair([[1, 1]], [[1, np.nan]], "manchester"), "reliability"),
    (lambda: linecode.repair([[1, 1]], [[1, 0]], "manchester", -1), "max_symbols"),
])
def test_repair_refuses_bad_input(call, message):
    with pytest.raises(ValueError, match=message):
        call()


@pytest.mark.parametrize("check", ["parity2", "crc8"])
def test_decode_coded_repairs_one_chip_error_given_reliabilities(check):
    phy = PhyFormat(5, 19, check)
    rng = np.random.default_rng(8)
    payload = rng.integers(0, 2, (3, phy.payload_bits))
    coded = phy.encode(np.array([1, 2, 3]), payload)[:, phy.sync_chips:].copy()
    reliability = np.ones(coded.shape)
    coded[0, 7] ^= 1
    reliability[0, 7] = 0.2  # the noisy chip: the repair flips it back
    coded[1, [7, 12]] ^= 1
    reliability[1, [7, 12]] = 0.2  # two broken pairs: left as a code error
    decoded = phy.decode_coded(coded, reliability)
    assert decoded.check_ok.tolist() == [True, False, True]
    assert decoded.code_ok.tolist() == [True, False, True]
    np.testing.assert_array_equal(decoded.payload[0], payload[0])
    assert not phy.decode_coded(coded).code_ok[0]  # without reliabilities: never a guess


def test_4b6b_table_is_dc_balanced_and_invertible():
    assert len(set(FOUR_B_SIX_B_TABLE)) == 16
    assert all(word.count("1") == 3 and len(word) == 6 for word in FOUR_B_SIX_B_TABLE)
    nibbles = (np.arange(16)[:, None] >> np.arange(3, -1, -1)) & 1
    chips = linecode.encode(nibbles, "4b6b")
    assert ["".join(map(str, row)) for row in chips] == list(FOUR_B_SIX_B_TABLE)
    bits, valid = linecode.decode(chips, "4b6b", 4)
    assert valid.all()
    np.testing.assert_array_equal(bits, nibbles)


def test_4b6b_rejects_every_non_codeword():
    patterns = (np.arange(64)[:, None] >> np.arange(5, -1, -1)) & 1
    _, valid = linecode.decode(patterns, "4b6b", 4)
    assert valid.sum() == 16


@pytest.mark.parametrize("code, expected", [("manchester", 2), ("4b6b", 4)])
def test_max_run_length_matches_exhaustive_streams(code, expected):
    rng = np.random.default_rng(5)
    bits = rng.integers(0, 2, size=(200, 64), dtype=np.uint8)
    stream = linecode.encode(bits, code).ravel()
    runs = np.diff(np.flatnonzero(np.diff(np.r_[-1, stream.astype(int), -1]) != 0))
    assert runs.max() == linecode.max_run_length(code) == expected


def _occurrences(stream: np.ndarray, pattern: np.ndarray) -> np.ndarray:
    windows = np.lib.stride_tricks.sliding_window_view(stream, pattern.size)
    return np.flatnonzero(np.all(windows == pattern, axis=1))


@settings(max_examples=200, deadline=None)
@given(
    data=st.data(),
    code=st.sampled_from(["manchester", "4b6b"]),
    check=st.sampled_from(["parity2", "crc8"]),
    payload_bits=st.integers(1, 40),
    count=st.integers(1, 6),
)
def test_sync_occurs_only_where_a_phy_sdu_starts(data, code, check, payload_bits, count):
    """SYNC uniqueness: in any stream of back-to-back PHY-SDUs with random
    payloads, the SYNC pattern occurs exactly at the PHY-SDU starts, never
    inside coded data or across the boundary of two PHY-SDUs."""
    phy = PhyFormat(3, payload_bits, check, code)
    payloads = np.array(
        [data.draw(st.lists(st.integers(0, 1), min_size=payload_bits, max_size=payload_bits)) for _ in range(count)],
        dtype=np.uint8,
    )
    seq = np.array(data.draw(st.lists(st.integers(0, 7), min_size=count, max_size=count)))
    stream = phy.encode(seq, payloads).ravel()
    np.testing.assert_array_equal(_occurrences(stream, phy.sync), np.arange(count) * phy.sdu_chips)


def test_sync_patterns():
    np.testing.assert_array_equal(sync_pattern("manchester"), [1, 1, 1, 0])
    np.testing.assert_array_equal(sync_pattern("4b6b"), [1, 1, 1, 1, 1, 0])


def _all_error_patterns(n, weight):
    for positions in combinations(range(n), weight):
        e = np.zeros(n, dtype=np.uint8)
        e[list(positions)] = 1
        yield e


@pytest.mark.parametrize("data_bits", [1, 8, 24, 64, CRC8_MAX_DATA_BITS])
def test_crc8_detects_every_single_and_double_error(data_bits):
    rng = np.random.default_rng(data_bits)
    data = rng.integers(0, 2, size=(1, data_bits), dtype=np.uint8)
    word = np.concatenate([data, crc8(data)], axis=1)[0]
    n = word.size
    errors = np.array(list(_all_error_patterns(n, 1)) + list(_all_error_patterns(n, 2)))
    assert not verify(word ^ errors, "crc8").any()


def test_crc8_known_value():
    # CRC-8 (poly 0x07, init 0) of the ASCII bytes "123456789" is 0xF4.
    bits = np.unpackbits(np.frombuffer(b"123456789", dtype=np.uint8))
    assert int("".join(map(str, crc8(bits)[0])), 2) == 0xF4


def _parity2_should_detect(error: np.ndarray) -> bool:
    # The stated rule: detected iff an odd number of flips at even codeword
    # positions, or an odd number at odd positions.
    return bool(error[0::2].sum() % 2 or error[1::2].sum() % 2)


@pytest.mark.parametrize("data_bits", [24, 25, 7])
def test_parity2_detects_exactly_what_it_states(data_bits):
    """parity2 detects every single error, every adjacent double error and
    every odd-weight pattern; of the double errors it misses exactly those
    whose two flips share a position parity. Exhaustive over weights 1-3."""
    rng = np.random.default_rng(data_bits)
    data = rng.integers(0, 2, size=(1, data_bits), dtype=np.uint8)
    word = np.concatenate([data, parity2(data)], axis=1)[0]
    n = word.size
    for weight in (1, 2, 3):
        errors = np.array(list(_all_error_patterns(n, weight)))
        detected = ~verify(word ^ errors, "parity2")
        expected = np.array([_parity2_should_detect(e) for e in errors])
        np.testing.assert_array_equal(detected, expected)
        if weight in (1, 3):
            assert detected.all()
    adjacent = np.array([np.roll(np.r_[1, 1, np.zeros(n - 2, np.uint8)], k) for k in range(n - 1)], dtype=np.uint8)
    assert (~verify(word ^ adjacent, "parity2")).all()
    two_apart = np.zeros(n, np.uint8)
    two_apart[[0, 2]] = 1
    assert verify(word ^ two_apart[None, :], "parity2")[0]


def test_check_bits_rejects_unknown_kind():
    with pytest.raises(ValueError, match="unknown check"):
        check_bits(np.zeros((1, 4)), "crc16")


def test_sdu_length_in_chips_and_seconds():
    phy = PhyFormat(5, 19, "parity2", "manchester")
    assert phy.sdu_chips == 4 + 2 * (5 + 19 + 2) == 56
    assert phy.sdu_duration_s(8000) == pytest.approx(7e-3, rel=1e-15)
    phy6 = PhyFormat(5, 19, "crc8", "4b6b")
    assert phy6.sdu_chips == 6 + 6 * 8  # 32 bits -> 8 nibbles


def test_camcomsim_length_formula():
    assert camcomsim_sdu_duration_s(5, 19, 8000) == pytest.approx((4 + 2 * 24) / 8000)
    assert camcomsim_sdu_duration_s(5, 19, 8000, "4b6b") == pytest.approx((4 + 1.5 * 24) / 8000)


def test_bit_index_of_chip():
    phy = PhyFormat(5, 19)
    idx = phy.bit_index_of_chip(np.arange(phy.sdu_chips))
    assert (idx[:4] == -1).all()
    np.testing.assert_array_equal(idx[4:], np.repeat(np.arange(26), 2))


def test_wrong_sync_fails_the_check():
    phy = PhyFormat(5, 19)
    chips = phy.encode([3], np.zeros((1, 19), np.uint8))
    chips[0, 1] = 0
    assert not phy.decode(chips).check_ok[0]


@pytest.mark.parametrize("phy", FORMATS, ids=lambda f: f"{f.header_bits}-{f.payload_bits}-{f.check}-{f.line_code}")
def test_every_format_round_trips(phy):
    rng = np.random.default_rng(0)
    count = min(2 ** phy.header_bits, 5)
    payloads = rng.integers(0, 2, size=(count, phy.payload_bits), dtype=np.uint8)
    decoded = phy.decode(phy.encode(np.arange(count), payloads))
    assert decoded.check_ok.all()
    np.testing.assert_array_equal(decoded.payload, payloads)
