"""The bundled effect scenes: the decoder still reads them, frames stay
byte-deterministic, and an unlisted effect is not in the pipeline."""

import hashlib
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import decoder
from rollsim.cli import main
from rollsim.evaluate import evaluate
from rollsim.render import RenderPipeline, render_frames
from rollsim.scene import load_scene
from rollsim.transmitter import transmitter_from_scene

from conftest import make_scene
from test_render_io import HARD_CASES

# Effect name -> the stage name its bundled scene adds.
EFFECT_STAGES = {
    "led_rise_time": "led_rise_time[exact]",
    "frame_jitter": "frame_jitter[independent]",
    "motion": "motion[random_walk]",
    "flicker": "flicker",
    "blooming": "blooming",
}
SMALL = ["camera.width_px=96", "camera.height_px=540", "camera.row_time_us=40"]


@pytest.mark.parametrize("effect", sorted(EFFECT_STAGES))
def test_decoder_reads_the_bundled_effect_scene(effect):
    scene = load_scene(f"effect-{effect}")
    assert EFFECT_STAGES[effect] in RenderPipeline(scene).stage_names
    images, truth = render_frames(scene, 12)
    tx = transmitter_from_scene(scene)
    frames = decoder.decode_frames(images, tx.phy, scene.link.clock_hz, scene.camera.row_time_s)
    summary = evaluate(truth, [r for fd in frames for r in fd.to_records()], tx).summary
    assert summary["fully_visible"] >= 30
    assert summary["counts"]["ok"] >= 0.95 * summary["fully_visible"]
    assert summary["false_decodes"] == 0


@pytest.mark.parametrize("effect", sorted(EFFECT_STAGES))
def test_effect_scene_renders_the_same_bytes_twice(effect):
    scene = load_scene(f"effect-{effect}", SMALL)
    first = [RenderPipeline(scene).render(k) for k in (0, 5)]
    again = [RenderPipeline(scene).render(k) for k in (5, 0)][::-1]
    for a, b in zip(first, again):
        assert a.image.tobytes() == b.image.tobytes() and a.truth == b.truth


@pytest.mark.parametrize("effect", ["frame_jitter", "motion"])
def test_one_or_two_workers_write_the_same_bytes(effect, tmp_path):
    args = ["render", f"effect-{effect}", "--frames", "6", "--quiet"]
    for item in SMALL:
        args += ["--set", item]
    digests = []
    for workers in ("1", "2"):
        out = tmp_path / workers
        assert main([*args, "--out", str(out), "--workers", workers]) == 0
        digests.append({p.relative_to(out).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
                        for p in sorted(Path(out).rglob("*")) if p.is_file()})
    assert digests[0] == digests[1]


def test_unlisted_effects_are_absent_from_the_assembled_pipeline():
    names = RenderPipeline(load_scene("paper-default", SMALL)).stage_names
    assert not any(n.startswith(tuple(EFFECT_STAGES)) for n in names)
    assert len(names) == len(set(names))


@pytest.mark.parametrize("case", ["led_under_one_pixel", "led_larger_than_frame", "led_outside_frame", "exposure_1us",
                                  "exposure_equals_frame_period", "chip_shorter_than_a_row", "ambient_0_lux",
                                  "saturating_led"])
def test_hard_cases_stay_finite_with_every_temporal_effect(case):
    sections = HARD_CASES[case]
    jitter = 0.0 if case == "exposure_equals_frame_period" else 30.0  # no room to jitter a frame-long exposure
    effects = {"ambient": {}, "shot_noise": {}, "read_noise": {}, "led_rise_time": {"tau_us": 20.0},
               "frame_jitter": {"std_us": jitter, "mode": "random_walk"}, "flicker": {"depth": 1.0},
               "motion": {"mode": "sinusoid", "amplitude_x_px": 50.0, "amplitude_y_px": 300.0, "frequency_hz": 40.0},
               "blooming": {}}
    scene = make_scene(effects=effects, **sections)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pipeline = RenderPipeline(scene)
        frames = [pipeline.render(k) for k in (0, 1, 2)]
    for frame in frames:
        assert frame.image.shape == (200, 160) and frame.image.max() <= 1023
        json.dumps(frame.truth, allow_nan=False)
