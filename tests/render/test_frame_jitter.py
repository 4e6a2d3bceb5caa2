"""frame_jitter: actual frame starts, their truth, and frames that never overlap."""

import numpy as np
import pytest

from rollsim.errors import SceneError
from rollsim.render import RenderPipeline
from rollsim.numerics.seeds import rng as named_rng
from rollsim.sensor.frame_jitter import frame_margin_s, jitter_bound_s, max_std_s
from rollsim.sensor.frame_jitter import FrameJitter
from rollsim.numerics.gaussian import truncated_normal

from conftest import make_scene

CAMERA = {"height_px": 1080, "width_px": 32, "row_time_us": 25.0, "exposure_us": 60.0, "output": "gray8"}


def _scene(std_us, mode="independent", **sections):
    return make_scene(effects={"frame_jitter": {"std_us": std_us, "mode": mode}},
                      camera={**CAMERA, **sections.pop("camera", {})}, led={"size_mm": 25.0}, **sections)


def _margin(scene):
    cam = scene.camera
    return frame_margin_s(cam.frame_period_s, cam.readout_s, cam.exposure_s)


@pytest.mark.parametrize("mode", ["independent", "random_walk"])
def test_truth_records_the_jittered_start_drawn_from_the_scene_stream(mode):
    """ε_k recomputed by hand from the per-scene stream: block 0 of
    rng(seed, "frame_jitter", 0), a truncated normal per frame; the random
    walk's ε_k is the sum of the first k of them."""
    scene = _scene(40.0, mode)
    sigma, bound = 40e-6, jitter_bound_s(_margin(scene), mode)
    draws = truncated_normal(named_rng(scene.seed, "frame_jitter", 0).random((1024, 1)), 1.0, bound / sigma)[:, 0] * sigma
    expected = draws if mode == "independent" else np.concatenate([[0.0], np.cumsum(draws)])
    pipeline = RenderPipeline(scene)
    period = scene.camera.frame_period_s
    for k in (0, 1, 7, 300):
        assert pipeline.render(k).truth["start_s"] == pytest.approx(k * period + expected[k], abs=1e-15)
    assert "frame_jitter[" + mode + "]" in pipeline.stage_names


@pytest.mark.parametrize("mode", ["independent", "random_walk"])
def test_jitter_of_a_frame_does_not_depend_on_what_was_rendered_before(mode):
    frames = [3000, 5, 1024, 0, 2047, 2048]
    forward = FrameJitter(5, 30e-6, mode, 3e-3)
    values = {k: forward.offset_s(k) for k in sorted(frames)}
    for order in (frames, frames[::-1]):
        fresh = FrameJitter(5, 30e-6, mode, 3e-3)
        assert {k: fresh.offset_s(k) for k in order} == values  # bit for bit
    assert FrameJitter(6, 30e-6, mode, 3e-3).offset_s(5) != values[5]


@pytest.mark.parametrize("mode", ["independent", "random_walk"])
def test_frames_never_overlap_at_the_largest_allowed_jitter(mode):
    """t_{k+1} − t_k ≥ H·t_row + t_exp for every k, at σ = the largest the scene allows."""
    scene = _scene(1.0, mode, camera={"ifg_ratio": 0.02, "row_time_us": None, "exposure_us": 300.0})
    cam = scene.camera
    margin = _margin(scene)
    sigma = max_std_s(margin, mode)
    jitter = FrameJitter(1, sigma, mode, margin)
    n = 4000
    starts = np.arange(n) * cam.frame_period_s + np.array([jitter.offset_s(k) for k in range(n)])
    assert np.diff(starts).min() >= cam.readout_s + cam.exposure_s - 1e-12
    steps = np.diff(starts) - cam.frame_period_s if mode == "random_walk" else starts - np.arange(n) * cam.frame_period_s
    # The truncation at 4 σ barely changes the law.
    assert steps.std() == pytest.approx(sigma, rel=0.05)
    assert np.abs(steps).max() <= jitter_bound_s(margin, mode) * (1 + 1e-12)


def test_too_much_jitter_for_the_inter_frame_gap_is_a_one_line_error():
    with pytest.raises(SceneError) as info:
        _scene(600.0, camera={"ifg_ratio": 0.05, "row_time_us": None})
    (line,) = info.value.lines
    assert "effects.frame_jitter.std_us = 600: out of range for this camera, allowed [0, " in line


def test_zero_jitter_is_the_static_render():
    static = RenderPipeline(make_scene(effects=("ambient", "shot_noise"), camera=CAMERA, led={"size_mm": 25.0}))
    jittered = RenderPipeline(make_scene(effects={"ambient": {}, "shot_noise": {}, "frame_jitter": {"std_us": 0.0}},
                                         camera=CAMERA, led={"size_mm": 25.0}))
    for k in (0, 3):
        a, b = static.render(k), jittered.render(k)
        assert np.array_equal(a.image, b.image) and a.truth == b.truth


def test_jittered_frame_and_its_truth_follow_the_actual_start():
    """A frame started ε late sees what an on-time frame sees of a transmitter
    started ε early; the truth's PHY-SDUs keep their emission times and their
    rows move with the frame; the stripes sit where the truth says."""
    scene = _scene(200.0)
    pipeline = RenderPipeline(scene)
    tx = pipeline.setup.transmitter
    timing = pipeline.setup.timing
    for k in (1, 2):
        frame = pipeline.render(k)
        truth = frame.truth
        eps = truth["start_s"] - k * scene.camera.frame_period_s
        assert abs(eps) > 1e-6
        shifted = make_scene(camera=CAMERA, led={"size_mm": 25.0}, link={"start_offset_us": -eps * 1e6})
        np.testing.assert_allclose(pipeline.run_stages(k).led_exposure_s, RenderPipeline(shifted).run_stages(k).led_exposure_s,
                                   rtol=0, atol=1e-15)
        first, last = truth["led_rows"]
        profile = frame.image[:, 12:20].astype(float).mean(axis=1)
        mid = 0.5 * (profile[first:last].max() + profile[first:last].min())
        visible = [s for s in truth["sdus"] if s["fully_visible"]]
        assert visible
        for sdu in truth["sdus"]:
            assert sdu["start_s"] == pytest.approx(float(tx.emission_start_s(sdu["tx"])), abs=1e-15)
            centred = (sdu["start_s"] - truth["start_s"] - 0.5 * timing.exposure_s) / timing.row_time_s
            assert sdu["first_row_f"] == pytest.approx(centred, abs=1e-9)
        for sdu in visible:
            centres = sdu["start_s"] + (np.arange(tx.phy.sdu_chips) + 0.5) / tx.waveform.clock_hz
            rows = np.rint(timing.row_of_time(centres, truth["start_s"])).astype(int)
            np.testing.assert_array_equal((profile[rows] > mid).astype(np.uint8), tx.sdu_chips[sdu["sequence"]])
