"""decoder.framing: SYNC search, line decoding, checks; false accepts."""

import numpy as np
import pytest
from synth import profile_from_chips

from rollsim.protocol import PhyFormat, sync_pattern
from decoder.framing import (CHECK_FAILED, CODE_ERROR, ERASURE, OK, TRUNCATED, decode_chip_stream, find_sync_starts,
                             neighbour_starts)
from decoder.pipeline import decode_profile
from decoder.profile import RowProfile
from decoder.timing import ChipStream

PHY = PhyFormat(5, 19)
FORMATS = [PhyFormat(5, 19), PhyFormat(5, 19, "crc8"), PhyFormat(5, 19, "parity2", "4b6b"), PhyFormat(5, 19, "crc8", "4b6b")]


def stream_of(chips):
    chips = np.asarray(chips, dtype=np.int8)
    start = np.arange(chips.size, dtype=np.float64)
    return ChipStream(chips, start, start + 1.0, np.ones(chips.size), np.ones(chips.size, bool))


def sdus(phy, sequences, seed=0):
    rng = np.random.default_rng(seed)
    payload = rng.integers(0, 2, (len(sequences), phy.payload_bits))
    return phy.encode(np.asarray(sequences), payload), payload


def test_sync_is_found_by_the_end_of_the_on_run():
    # Payload ending in bit 1 (chips 01) runs into the next SYNC: ON run of 4.
    chips, _ = sdus(PHY, [1, 2, 3])
    chips[:, -2:] = [0, 1]
    stream = chips.ravel()
    assert find_sync_starts(stream, PHY).tolist() == [0, PHY.sdu_chips, 2 * PHY.sdu_chips]


@pytest.mark.parametrize("phy", FORMATS, ids=lambda p: f"{p.check}-{p.line_code}")
def test_clean_stream_decodes(phy):
    chips, payload = sdus(phy, [3, 4, 5, 6])
    found = decode_chip_stream(stream_of(np.concatenate([[0, 1, 0], chips.ravel()])), phy)
    assert found.status.tolist() == [OK] * 4
    assert found.sequence.tolist() == [3, 4, 5, 6]
    assert np.array_equal(found.payload, payload)
    assert found.first_row.tolist() == [3 + k * phy.sdu_chips for k in range(4)]
    assert found.last_row.tolist() == [3 + (k + 1) * phy.sdu_chips for k in range(4)]


def test_errors_are_reported_not_guessed():
    chips, _ = sdus(PHY, [1, 2, 3, 4, 5, 6])
    chips[0, 10] ^= 1  # breaks a Manchester pair
    chips[1, [10, 11]] ^= 1  # flips one bit: parity catches it
    chips = chips.ravel().astype(np.int8)
    chips[3 * PHY.sdu_chips + 20] = -1  # erased chip
    stream = stream_of(chips)
    found = decode_chip_stream(stream, PHY, row_span=(0.0, 5 * PHY.sdu_chips))
    assert found.status.tolist() == [CODE_ERROR, CHECK_FAILED, OK, ERASURE, OK, TRUNCATED]
    assert found.confidence[3] == 0.0


@pytest.mark.parametrize("phy", FORMATS, ids=lambda p: f"{p.check}-{p.line_code}")
def test_a_pdu_whose_sync_lost_a_chip_is_read_between_its_neighbours(phy):
    # Every SYNC chip of the middle PHY-SDU, over payloads that make the SYNC
    # found move by a chip (a predecessor ending ON, data starting 01).
    missed = []
    for seed in range(8):
        for sync_chip in range(phy.sync_chips):
            chips, payload = sdus(phy, [7, 8, 9], seed=seed)
            chips[1, sync_chip] ^= 1
            stream = stream_of(np.concatenate([[0, 1, 0], chips.ravel()]))
            found = decode_chip_stream(stream, phy)
            passed = found.check_ok
            if found.sequence[passed].tolist() != [7, 8, 9] or not np.array_equal(found.payload[passed], payload):
                missed.append((seed, sync_chip))
                continue
            assert found.first_row[passed].tolist() == [3 + k * phy.sdu_chips for k in range(3)]
            # No failed reading of the same PHY-SDU a chip off is left beside it.
            assert np.all(np.min(np.abs(found.first_row[~passed, None] - found.first_row[None, passed]), axis=1,
                                 initial=np.inf) > 1.0)
    assert missed == []


def test_an_erased_sync_chip_and_a_run_of_lost_syncs_are_read():
    chips, _ = sdus(PHY, [1, 2, 3, 4, 5])
    chips[1, 1] ^= 1
    chips[2, 0] ^= 1  # two SYNCs in a row: found from each end in turn
    stream = chips.ravel().astype(np.int8)
    stream[3 * PHY.sdu_chips + 2] = -1  # an erased SYNC chip
    found = decode_chip_stream(stream_of(stream), PHY)
    assert found.sequence[found.check_ok].tolist() == [1, 2, 3, 4, 5]


def test_a_guess_whose_sync_is_two_chips_off_is_not_made():
    chips, _ = sdus(PHY, [7, 8, 9])
    chips[1, [0, 2]] ^= 1
    found = decode_chip_stream(stream_of(chips.ravel()), PHY)
    assert found.sequence[found.check_ok].tolist() == [7, 9]


def test_one_broken_pair_is_repaired_from_the_chips_reliabilities():
    chips, payload = sdus(PHY, [4, 5])
    stream = chips.ravel().astype(np.int8)
    reliability = np.ones(stream.size)
    broken = PHY.sdu_chips + PHY.sync_chips + 9
    stream[broken] ^= 1
    reliability[broken] = 0.3  # the noisy chip of its pair
    start = np.arange(stream.size, dtype=np.float64)
    confident = ChipStream(stream, start, start + 1.0, np.ones(stream.size), np.ones(stream.size, bool))
    assert decode_chip_stream(confident, PHY).status.tolist() == [OK, CODE_ERROR]  # a tie: never a guess
    graded = ChipStream(stream, start, start + 1.0, np.ones(stream.size), np.ones(stream.size, bool), reliability)
    found = decode_chip_stream(graded, PHY)
    assert found.status.tolist() == [OK, OK]
    np.testing.assert_array_equal(found.payload, payload)


def test_a_guessed_start_is_kept_only_if_it_passes():
    chips, _ = sdus(PHY, [7, 8, 9])
    chips[1, 0] ^= 1  # the middle PHY-SDU's SYNC ...
    chips[1, 10] ^= 1  # ... and a Manchester pair: nothing to read there
    found = decode_chip_stream(stream_of(chips.ravel()), PHY)
    assert found.sequence.tolist() == [7, 9]
    assert found.status.tolist() == [OK, OK]


def test_a_lone_sync_in_noise_guesses_nothing_that_passes():
    # Random chips either side of one PHY-SDU: its guessed neighbours are noise.
    rng = np.random.default_rng(3)
    chips, _ = sdus(PHY, [5])
    noise = rng.integers(0, 2, PHY.sdu_chips).astype(np.uint8)
    noise[-PHY.sync_chips:] = [0, 1, 0, 1]  # no SYNC-like run reaching into the PHY-SDU
    stream = np.concatenate([noise, chips[0], 1 - noise])
    found = decode_chip_stream(stream_of(stream), PHY)
    assert found.sequence[found.check_ok].tolist() == [5]


def test_neighbour_starts():
    starts = np.array([10, 66, 200])
    # 10 - 56 < 0 and 200 + 56 > 250 - 56 are not made; 10 + 56 and 66 - 56 are SYNCs found.
    assert neighbour_starts(np.array([10, 66, 200]), starts, 250, 56).tolist() == [122, 144]
    assert neighbour_starts(np.array([66]), np.array([9, 66]), 250, 56).tolist() == [122]
    assert neighbour_starts(np.array([66]), np.array([8, 66]), 250, 56).tolist() == [10, 122]
    assert neighbour_starts(np.zeros(0, np.int64), starts, 250, 56).size == 0


def test_truncated_at_stream_end_and_inexact_chips():
    chips, _ = sdus(PHY, [1, 2])
    stream = stream_of(chips.ravel()[:-3])
    assert decode_chip_stream(stream, PHY).status.tolist() == [OK, TRUNCATED]
    exact = np.ones(len(stream), bool)
    exact[0] = False  # the first chip reaches past a cut
    cut = ChipStream(stream.values, stream.start, stream.end, stream.confidence, exact)
    assert decode_chip_stream(cut, PHY).status.tolist() == [TRUNCATED, TRUNCATED]


def test_parity2_misses_two_errors_in_one_class():
    # A documented blind spot of the paper's two parity bits.
    chips, _ = sdus(PHY, [7])
    chips[0, [4 + 2 * 3, 4 + 2 * 3 + 1, 4 + 2 * 5, 4 + 2 * 5 + 1]] ^= 1  # bits 3 and 5
    assert decode_chip_stream(stream_of(chips.ravel()), PHY).status.tolist() == [OK]


def test_false_accepts_of_random_chips():
    """Random chips after a SYNC: the line code rejects nearly all; parity2
    alone accepts a quarter of random codewords."""
    rng = np.random.default_rng(11)
    n = 10_000
    random_coded = rng.integers(0, 2, (n, PHY.coded_chips)).astype(np.uint8)
    decoded = PHY.decode_coded(random_coded)
    assert decoded.check_ok.sum() == 0  # P = 2^-26 / 4 per word
    # Random valid Manchester words isolate the parity check: ~1/4 pass.
    bits = rng.integers(0, 2, (n, PHY.codeword_bits))
    valid_words = np.stack([1 - bits, bits], axis=2).reshape(n, -1).astype(np.uint8)
    rate = PHY.decode_coded(valid_words).check_ok.mean()
    assert 0.23 < rate < 0.27


def test_no_false_accepts_on_random_binary_profiles():
    """10 000 random chip profiles through binarisation, timing and framing."""
    rng = np.random.default_rng(12)
    candidates = accepted = 0
    for _ in range(10_000):
        chips = rng.integers(0, 2, 130)
        values = profile_from_chips(chips, 4.5, 3.6, rng.uniform(0, 1), on=150.0, off=20.0, noise=2.0, rng=rng)
        profile = RowProfile(0, values, np.full(values.size, 2.0))
        found = decode_profile(profile, PHY, 4.5, include_truncated=True)
        candidates += len(found)
        accepted += sum(s.check_ok for s in found)
    assert candidates > 10_000  # random chips hold many SYNC-like runs
    assert accepted == 0


@pytest.mark.parametrize("check, expected", [("parity2", 0.25), ("crc8", 1 / 256)])
def test_check_code_false_accept_rate_through_the_decoder(check, expected):
    """The check code's false-accept rate, measured through the whole decoder.

    10,000 random codewords (random header, payload and check bits), each
    line-coded after a SYNC as the transmitter would, 50 back to back per
    profile: every one is a valid-looking PHY-SDU whose check bits are
    random. The fraction the decoder reports ``ok`` is the check code's
    false-accept rate: 1/4 for parity2 (two parity bits), 1/256 for CRC-8.
    Junk that is not even valid line code (the test above) is rejected by
    the line code first: 2^-26 of random chips pass Manchester decoding.
    """
    phy = PhyFormat(5, 19, check)
    rng = np.random.default_rng(21)
    n, per_profile = 10_000, 50
    accepted = candidates = 0
    for _ in range(n // per_profile):
        bits = rng.integers(0, 2, (per_profile, phy.codeword_bits)).astype(np.uint8)
        coded = np.stack([1 - bits, bits], axis=2).reshape(per_profile, -1)  # Manchester
        sync = np.tile(sync_pattern(phy.line_code), (per_profile, 1))
        chips = np.concatenate([sync, coded], axis=1).ravel()
        values = profile_from_chips(chips, 4.5, 3.6, rng.uniform(0, 1), on=150.0, off=20.0, noise=1.0, rng=rng)
        found = decode_profile(RowProfile(0, values, np.full(values.size, 1.0)), phy, 4.5)
        candidates += len(found)
        accepted += sum(s.check_ok for s in found)
    # The first and last PHY-SDU of a profile may be cut by its ends.
    assert candidates >= n - 2 * (n // per_profile)
    rate = accepted / candidates
    sigma = np.sqrt(expected * (1 - expected) / candidates)
    print(f"{check}: {accepted} of {candidates} random codewords accepted, rate {rate:.4f} (expected {expected:.4f})")
    assert abs(rate - expected) < 4 * sigma


def test_merged_readings_keep_both_receivers_passes_once():
    from decoder.framing import SduCandidates, merge_readings

    def candidates(rows, statuses):
        n = len(rows)
        rows = np.asarray(rows, dtype=np.float64)
        return SduCandidates(rows, rows + 250.0, np.arange(n), np.zeros((n, PHY.payload_bits), np.uint8),
                             np.asarray(statuses), np.ones(n))

    # Thresholding passed the PHY-SDU at row 0 and failed the one at 250;
    # the second look passed those at 2 (the same one), 251 and 500.
    primary = candidates([0.0, 250.0], [OK, CODE_ERROR])
    secondary = candidates([2.0, 251.0, 500.0], [OK, OK, OK])
    merged = merge_readings(primary, secondary, 250.0)
    assert merged.first_row.tolist() == [0.0, 251.0, 500.0]
    assert merged.status.tolist() == [OK, OK, OK]
    assert merge_readings(primary, candidates([], []), 250.0) is primary
