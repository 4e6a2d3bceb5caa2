"""The rlnc strategy end to end: scene, transmitter, render, decode, the receiver and the predictions."""

import numpy as np
import pytest

import rollsim as rs
from rollsim.errors import SceneError
from rollsim.protocol.rlnc import combinations
from rollsim.stages.receiver import decodable_at, receive_message
from rollsim.transmitter import transmitter_from_scene

RLNC = {"link.strategy": "rlnc"}


def test_a_coded_phy_sdu_carries_its_seed_and_the_xor_of_its_sources():
    tx = transmitter_from_scene(rs.load_scene("paper-default", overrides=RLNC))
    assert tx.schedule.seed_space == 31 and tx.sdu_chips.shape[0] == tx.schedule.seed_space
    seeds = tx.schedule.sequence_numbers(np.arange(70))
    np.testing.assert_array_equal(seeds, np.arange(70) % 31)
    codewords = tx.codeword_bits(np.arange(70))
    subsets = combinations(seeds, tx.n_packets).astype(np.int64)
    expected = (subsets @ tx.payloads.astype(np.int64)) % 2
    np.testing.assert_array_equal(codewords[:, tx.phy.header_bits : tx.phy.data_bits], expected)
    header = codewords[:, : tx.phy.header_bits] @ (1 << np.arange(tx.phy.header_bits - 1, -1, -1))
    np.testing.assert_array_equal(header, seeds)


def test_rlnc_refuses_repeats():
    with pytest.raises(SceneError, match="link.repeats = 2: strategy rlnc"):
        rs.load_scene("paper-default", overrides={**RLNC, "link.repeats": 2})


@pytest.mark.parametrize("scene_name", ["paper-default", "paper-10cm"])
def test_the_pixel_pipeline_recovers_the_message_bit_exactly(scene_name):
    frames = rs.render(rs.load_scene(scene_name, overrides=RLNC), n_frames=20, seed=1)
    result = rs.evaluate(frames.truth, rs.decode(frames))
    message = result.summary["message"]
    assert message["decodable"] and message["message_ok"]
    assert message["receptions"] >= frames.scene.link.message_bytes * 8 // frames.scene.link.payload_bits
    assert message["goodput_bps"] > 0


class _Tx:
    """The parts of a transmitter the receiver reads."""

    def __init__(self, strategy, payloads, message):
        from rollsim.transmitter.schedule import RlncSchedule, Schedule

        self.n_packets = payloads.shape[0]
        self.payloads = payloads
        self.message = message
        self.schedule = RlncSchedule(self.n_packets, 2**16) if strategy == "rlnc" else Schedule(strategy, self.n_packets)


def _record(frame, seq, bits, ok=True, last_row=100):
    return {"frame": frame, "first_row": 0, "last_row": last_row, "sequence": int(seq),
            "bits": "".join("1" if b else "0" for b in bits), "check_ok": ok}


TRUTH = [{"frame": f, "start_s": 0.05 * f, "row_time_s": 1e-5, "exposure_s": 1e-4} for f in range(10)]


def test_repetition_is_decodable_when_every_sequence_number_has_been_read():
    from rollsim.protocol import packetize

    message = bytes(range(12))
    packets = packetize(message, 19).astype(bool)
    tx = _Tx("rp", packets, message)
    assert packets.shape[0] == 6  # 96 bits in 19-bit payloads, the last padded
    order = [0, 2, 2, 4, 1, 3, 5, 0]
    records = [_record(i // 3, s, packets[s]) for i, s in enumerate(order)]
    assert decodable_at(np.array(order), 6, "rp") == 7
    got = receive_message(records, TRUTH, tx)
    assert got.decodable and got.message_ok and got.receptions == 7 and got.frame == 2
    assert got.duration_s == pytest.approx(0.10 + 100 * 1e-5 + 1e-4)
    assert got.goodput_bps == pytest.approx(96 / got.duration_s)
    # A failed check is not used; a missing packet leaves it undecodable.
    records[4]["check_ok"] = False
    assert not receive_message(records, TRUTH, tx).decodable


def test_rlnc_is_decodable_at_rank_k_and_an_undetected_error_shows():
    from rollsim.protocol import packetize
    from rollsim.protocol.rlnc import encode

    message = bytes(range(40, 52))
    packets = packetize(message, 19).astype(bool)
    tx = _Tx("rlnc", packets, message)
    seeds = np.arange(100, 120)
    coded = encode(packets, seeds)
    records = [_record(i // 4, s, c) for i, (s, c) in enumerate(zip(seeds, coded))]
    got = receive_message(records, TRUTH, tx)
    assert got.decodable and got.message_ok
    assert got.receptions == decodable_at(seeds, 6, "rlnc") >= 6
    records[0]["bits"] = ("0" if records[0]["bits"][0] == "1" else "1") + records[0]["bits"][1:]
    assert receive_message(records, TRUTH, tx).message_ok is False
    none = receive_message([], TRUTH, tx)
    assert not none.decodable and none.goodput_bps == 0.0 and none.message_ok is None


def test_describe_and_simulate_know_rlnc(capsys):
    from rollsim.cli import main

    assert main(["describe", "paper-default", "--set", "link.strategy=rlnc"]) == 0
    assert "predicted  RLNC, 22 source packets" in capsys.readouterr().out
    summary = rs.simulate(rs.load_scene("paper-default", overrides=RLNC), runs=30, seed=2).summary()
    assert summary["completed_fraction"] == 1.0 and summary["metrics"]["unique_receptions"]["mean"] == 22


def test_the_seed_space_is_prime_so_no_camera_cycle_hides_seeds():
    from rollsim.channel.channels import MmbpChannel
    from rollsim.channel.eventsim import simulate_broadcast
    from rollsim.protocol.rlnc import seed_space
    from rollsim.transmitter.schedule import RlncSchedule

    assert [seed_space(h) for h in (1, 2, 5, 9, 10, 16)] == [2, 3, 31, 509, 1021, 65521]
    # A cycle of 4 slots (3 ON) over 2^5 = 32 seeds would show only 24 of them
    # for ever, too few for 28 packets; over 31 seeds every one comes round.
    channel = MmbpChannel(3, 1, 0.0, 1e-3)
    blind = simulate_broadcast(channel, RlncSchedule(28, 32), header_bits=5, payload_bits=19, runs=10, seed=1,
                               workers=1, max_emissions=2000)
    assert blind.summary()["completed_fraction"] == 0.0
    prime = simulate_broadcast(channel, RlncSchedule(28, seed_space(5)), header_bits=5, payload_bits=19, runs=10,
                               seed=1, workers=1, max_emissions=2000)
    assert prime.summary()["completed_fraction"] == 1.0
    with pytest.raises(SceneError, match="link.header_bits = 4: strategy rlnc"):
        rs.load_scene("paper-default", overrides={**RLNC, "link.header_bits": 4})
