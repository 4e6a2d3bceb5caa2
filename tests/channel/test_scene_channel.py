"""Tests of rollsim.channel.scene_channel: scene -> channel, schedule and format."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rollsim.channel import analytic as an
from rollsim.channel.channels import CamcomsimChannel, MmbpChannel, TimedChannel
from rollsim.channel.eventsim import simulate_broadcast
from rollsim.channel.scene_channel import (
    CHANNEL_KINDS,
    broadcast_from_scene,
    capture_window_from_scene,
    channel_from_scene,
    camcomsim_parameters,
    led_row_count,
    mmbp_slots_from_scene,
    scene_relaxations,
    sdu_duration_from_scene,
    simulate_scene,
)
from rollsim.optics import led_rows
from rollsim.protocol import PhyFormat
from rollsim.errors import SceneError
from rollsim.scene import load_scene
from rollsim.scene.loader import DISTANCE_WITHOUT_LENS, SEQUENCE_WRAP, relaxations_used


@pytest.fixture(scope="module")
def paper():
    return load_scene("paper-geometric")  # the geometric LED's rows


def test_sdu_duration_and_capture_window(paper):
    assert sdu_duration_from_scene(paper) == PhyFormat(5, 19, "parity2", "manchester").sdu_duration_s(8000)
    first, last = led_rows(paper)
    rows = last - first + 1
    assert led_row_count(paper) == rows > 0
    expected = rows * paper.camera.row_time_s + paper.camera.exposure_s
    assert capture_window_from_scene(paper) == pytest.approx(expected, rel=1e-15)


def test_mmbp_slots_derived_from_physics(paper):
    slots = mmbp_slots_from_scene(paper)
    expected = an.mmbp_slots_from_physics(
        paper.camera.frame_period_s, capture_window_from_scene(paper), sdu_duration_from_scene(paper)
    )
    assert slots == expected
    channel = channel_from_scene(paper, "mmbp")
    assert isinstance(channel, MmbpChannel)
    assert (channel.M, channel.N, channel.p_e) == (slots.M, slots.N, paper.channel.p_e)


def test_mmbp_slots_given_in_the_scene():
    scene = load_scene("paper-default", ["channel.M=4", "channel.N=1"])
    channel = channel_from_scene(scene, "mmbp")
    assert (channel.M, channel.N) == (4, 1)


def test_timed_channel_from_scene():
    scene = load_scene("paper-default", ["channel.frame_jitter_us=500"])
    channel = channel_from_scene(scene, "timed")
    assert isinstance(channel, TimedChannel)
    assert channel.frame_period_s == scene.camera.frame_period_s
    assert channel.capture_window_s == capture_window_from_scene(scene)
    assert channel.sdu_duration_s == sdu_duration_from_scene(scene)
    assert channel.frame_jitter_s == pytest.approx(500e-6)


def test_led_outside_the_frame_is_never_captured():
    scene = load_scene("paper-default", ["led.position_px=[960, -5000]"])
    assert led_row_count(scene) == 0 and capture_window_from_scene(scene) == 0.0
    result = simulate_scene(scene, "timed", runs=3, max_emissions=50, workers=1)
    assert not result.completed.any() and np.all(result.gap_losses == 50)


def test_camcomsim_channel_from_scene(paper):
    channel = channel_from_scene(paper, "camcomsim")
    assert isinstance(channel, CamcomsimChannel)
    # 1000/30 ms is read as CamComSim's 33.3 would be: 333 slots, 30 ms visible.
    assert (channel.frame_slots, channel.visible_slots, channel.sdu_slots) == (333, 295, 65)
    assert channel == channel_from_scene(paper, "camcomsim", java_float32=True)


def test_camcomsim_uses_the_effective_ifg_ratio():
    scene = load_scene("paper-default", ["camera.row_time_us=20"])
    ifg = scene.camera.ifg_ratio_effective
    channel = channel_from_scene(scene, "camcomsim")
    assert channel.visible_slots == int(math.ceil(1000 / 30 * (1 - ifg)) * 10 * 0.98452928286029235)


def test_broadcast_packets_per_kind(paper):
    G, P = paper.link.message_bytes, paper.link.payload_bits
    assert broadcast_from_scene(paper, "mmbp").schedule.n_packets == math.ceil(8 * G / P)
    assert broadcast_from_scene(paper, "timed").schedule.n_packets == math.ceil(8 * G / P)
    setup = broadcast_from_scene(paper, "camcomsim")
    assert setup.schedule.n_packets == math.ceil(8 * G / P)  # bytes on every channel
    assert (setup.schedule.strategy, setup.schedule.repeats) == (paper.link.strategy, paper.link.repeats)
    assert (setup.header_bits, setup.payload_bits) == (5, 19)


@pytest.mark.parametrize("kind", CHANNEL_KINDS)
def test_simulate_scene_is_reproducible(paper, kind):
    a = simulate_scene(paper, kind, runs=20, workers=1)
    b = simulate_scene(paper, kind, runs=20, workers=1, seed=paper.seed)
    np.testing.assert_array_equal(a.emissions, b.emissions)
    assert a.completed.all()
    assert a.seed == paper.seed
    if kind == "camcomsim":
        assert any("bytes" in note for note in a.summary()["notes"])


def test_unknown_kind(paper):
    with pytest.raises(ValueError, match="kind"):
        channel_from_scene(paper, "gilbert")


# ----------------------------------------------------------------------------
# CamComSim compatibility: what its channel accepts that the others refuse
# ----------------------------------------------------------------------------
CAMCOMSIM_LOG = ["link.message_bytes=1000", "link.header_bits=5"]  # its published 1 kB workload


def camcomsim_scene(overrides):
    return load_scene("paper-default", overrides, relax=scene_relaxations("camcomsim"))


def test_relaxations_per_kind():
    assert scene_relaxations("camcomsim") == (SEQUENCE_WRAP, DISTANCE_WITHOUT_LENS)
    assert scene_relaxations("mmbp") == scene_relaxations("timed") == ()
    with pytest.raises(ValueError, match="relax"):
        load_scene("paper-default", relax=["everything"])


def test_wrapping_sequence_numbers_only_on_camcomsim():
    with pytest.raises(SceneError, match="header_bits = 5: too few for 422 packets"):
        load_scene("paper-default", CAMCOMSIM_LOG)
    scene = camcomsim_scene(CAMCOMSIM_LOG)
    assert relaxations_used(scene) == (SEQUENCE_WRAP,)
    setup = broadcast_from_scene(scene, "camcomsim")
    assert setup.schedule.n_packets == 422  # ceil(8 * 1000 / 19)
    assert len(setup.warnings) == 1 and "wrap" in setup.warnings[0] and "422 packets" in setup.warnings[0]
    for kind in ("mmbp", "timed"):
        with pytest.raises(ValueError, match="only the camcomsim channel"):
            broadcast_from_scene(scene, kind)


def test_header_bits_zero_and_distance_zero_on_camcomsim():
    scene = camcomsim_scene(["link.header_bits=0", "link.distance_cm=0"])
    assert scene.link.distance_cm == 0.0 and scene.link.header_bits == 0
    setup = broadcast_from_scene(scene, "camcomsim")
    channel = setup.channel
    # ROI 1 at 0 cm: the capture time (ceil(33.3 ms * (1 - 0.115)) = 30 ms) is visible whole.
    full = channel_from_scene(camcomsim_scene(["link.distance_cm=0"]), "camcomsim")
    assert full.visible_slots == 300
    assert channel.visible_slots == 300
    result = simulate_broadcast(channel, setup.schedule, header_bits=0, payload_bits=19, runs=20, seed=1, workers=1)
    assert result.completed.all()
    with pytest.raises(SceneError, match="distance_cm"):
        load_scene("paper-default", ["link.distance_cm=0"])
    with pytest.raises(ValueError, match="focal length"):
        broadcast_from_scene(camcomsim_scene(["link.distance_cm=0"]), "mmbp")


def test_camcomsim_refuses_rs():
    scene = load_scene("paper-default", ["link.strategy=rs", "link.repeats=4"])
    with pytest.raises(ValueError, match="only the RP strategy"):
        broadcast_from_scene(scene, "camcomsim")
    assert broadcast_from_scene(scene, "mmbp").schedule.strategy == "rs"


def test_camcomsim_far_link_warns_and_never_completes():
    scene = load_scene("paper-default", ["link.distance_cm=35"])
    setup = broadcast_from_scene(scene, "camcomsim")
    assert setup.channel.window_probability == 0.0
    assert any("never receives" in w for w in setup.warnings)
    result = simulate_broadcast(setup.channel, setup.schedule, header_bits=5, payload_bits=19, runs=5, seed=1,
                                max_emissions=300, workers=1)
    assert not result.completed.any()
    np.testing.assert_array_equal(result.emissions, 300)
    np.testing.assert_array_equal(result.goodput_bps, 0.0)


def test_camcomsim_parameters_have_every_field(paper):
    setup = broadcast_from_scene(paper, "camcomsim")
    result = simulate_broadcast(setup.channel, setup.schedule, header_bits=5, payload_bits=19, runs=4, seed=1,
                                workers=1)
    params = camcomsim_parameters(paper, result, save_path="out/")
    assert list(params) == [
        "simuGenerationSizeByte", "simuScenario", "simuStrategy", "simuNbRepeatPhysdu", "simuNbIteration",
        "camFrameIntervalMs", "camIFGRatio", "camPDecodeError", "chanDistanceCm", "physduMaxLen",
        "physduPayloadLen", "physduHeaderLen", "ledTxFreqHz", "ledRll", "saveResult", "savePath", "verbose",
        "stopCondition",
    ]
    assert params["simuGenerationSizeByte"] == paper.link.message_bytes
    assert params["simuStrategy"] == "REPEAT_PACKET_STRATEGY" and params["simuNbIteration"] == 4
    assert params["chanDistanceCm"] == 5 and isinstance(params["chanDistanceCm"], int)
    assert params["ledRll"] == "RLL_MANCHESTER" and params["stopCondition"] == "50000X"
