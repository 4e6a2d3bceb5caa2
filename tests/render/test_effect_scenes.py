"""The optical effects' bundled scenes decode; effects are opt-in and deterministic."""

import hashlib

import numpy as np
import pytest

import decoder
from rollsim.cli import main
from rollsim.evaluate import evaluate
from rollsim.render import RenderPipeline, render_frames
from rollsim.scene import load_scene
from rollsim.transmitter import transmitter_from_scene

from conftest import make_scene

OPTICAL = ("blur", "defocus", "vignetting", "bayer")


@pytest.mark.parametrize("effect", OPTICAL)
def test_bundled_effect_scene_decodes(effect):
    scene = load_scene(f"effect-{effect}")
    assert getattr(scene.effects, effect) is not None
    images, truth = render_frames(scene, 12)
    tx = transmitter_from_scene(scene)
    decodes = decoder.decode_frames(images, tx.phy, scene.link.clock_hz, scene.camera.row_time_s)
    records = [r for fd in decodes for r in fd.to_records()]
    summary = evaluate(truth, records, tx).summary
    assert summary["fully_visible"] >= 20
    assert summary["counts"]["ok"] >= 0.95 * summary["fully_visible"]
    assert summary["false_decodes"] == 0


ALL_OPTICAL = {"blur": {"sigma_px": 1.5}, "defocus": {"focus_distance_cm": 8.0}, "vignetting": {},
               "bayer": {"demosaic": "vng"}, "ambient": {}, "shot_noise": {}, "read_noise": {}}


def test_unlisted_optical_effects_are_absent_and_cost_nothing():
    plain = RenderPipeline(make_scene(effects=("ambient", "shot_noise"), led={"size_mm": 2.0}))
    setup = plain.setup
    assert setup.prepared == ()
    assert all(np.ndim(r) == 0 for r in (setup.led_e_per_s, setup.background_e_per_s, setup.face_e_per_s))
    assert plain.stage_names == ("frame_start", "led_exposure", "led_signal", "ambient", "shot_noise[poisson]",
                                 "full_well", "adc", "raw16")
    full = RenderPipeline(make_scene(effects=ALL_OPTICAL, camera={"output": "rgb8"}, led={"size_mm": 2.0}))
    assert full.setup.prepared == ("bayer", "blur", "defocus", "vignetting")
    assert full.stage_names[-1] == "rgb8[vng]"


def test_frames_with_every_optical_effect_are_byte_identical(tmp_path):
    scene = make_scene(effects=ALL_OPTICAL, camera={"output": "rgb8"}, led={"size_mm": 2.0})
    a, _ = render_frames(scene, 2)
    b, _ = render_frames(scene, 2)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    args = ["render", "effect-bayer", "--frames", "4", "--quiet", "--set", "camera.width_px=96",
            "--set", "camera.height_px=540", "--set", "camera.row_time_us=40",
            "--set", "effects.blur.sigma_px=1.5", "--set", "effects.defocus.focus_distance_cm=8",
            "--set", "effects.vignetting=null"]
    assert main([*args, "--out", str(tmp_path / "one"), "--workers", "1"]) == 0
    assert main([*args, "--out", str(tmp_path / "two"), "--workers", "2"]) == 0
    digest = lambda d: {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(d.rglob("*")) if p.is_file()}  # noqa: E731
    assert digest(tmp_path / "one") == digest(tmp_path / "two")
