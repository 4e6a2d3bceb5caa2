"""Tests of rollsim.channel.scene_channel: scene -> channel, schedule and format."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rollsim.channel import analytic as an
from rollsim.channel.channels import CamcomsimChannel, MmbpChannel, TimedChannel
from rollsim.channel.scene_channel import (
    CHANNEL_KINDS,
    broadcast_from_scene,
    capture_window_from_scene,
    channel_from_scene,
    led_row_count,
    mmbp_slots_from_scene,
    sdu_duration_from_scene,
    simulate_scene,
)
from rollsim.optics import led_rows
from rollsim.protocol import PhyFormat
from rollsim.scene import load_scene


@pytest.fixture(scope="module")
def paper():
    return load_scene("paper-default")


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
    assert setup.schedule.n_packets == G  # CamComSim's G counts packets
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
        assert any("packets" in note for note in a.summary()["notes"])


def test_unknown_kind(paper):
    with pytest.raises(ValueError, match="kind"):
        channel_from_scene(paper, "gilbert")
