"""Every pair of effects works together, or is refused for a physical reason.

For every registered effect alone and for every unordered pair of them, a
small scene (the bundled ``paper-geometric`` shrunk to 96 x 64 px, its LED
scaled with the frame and still striped; 2 frames) either

* is refused by the scene loader, with one line naming both effects, and
  only for a pair the registry declares in an effect's ``excludes``; or
* renders, and then: every float the render computes (the per-scene setup
  and each stage's output) is finite, the image is of the output format and
  within the ADC's range, the truth agrees with the frame (the LED's rows
  inside it, each fully visible PHY-SDU's rows inside the LED's rows, every
  PHY-SDU overlapping the frame's capture span), the frames written to disk
  are those rendered in memory, and 1 and 2 worker processes write the same
  bytes.

Each effect takes its default parameters, or the smallest set that makes it
valid (:data:`PARAMS`), with the effects it requires; the output format is
the one the listing needs (:func:`output_for`). The default run checks
every effect alone and every pair in memory, and writes to disk (with 1 and
2 workers) every effect alone and a fixed-seed sample of :data:`SAMPLE_SIZE`
pairs; the run marked ``slow`` writes every pair.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import itertools
import json
import math
import random
from pathlib import Path

import numpy as np
import pytest

from decoder.io import read_frame
from rollsim.effects import REGISTRY
from rollsim.errors import SceneError
from rollsim.numerics.jit import numpy_only
from rollsim.protocol.frames import FRAME_NAME
from rollsim.render import RenderPipeline
from rollsim.render.pipeline import gop_frames
from rollsim.video.roundtrip import gop_round_trip
from rollsim.render import writer
from rollsim.render.truth import frame_truth
from rollsim.render.writer import render_to_dir
from rollsim.render_contract.state import FrameState
from rollsim.scene import load_scene
from rollsim.sensor.frame_jitter import frame_margin_s

BASE_SCENE = "paper-geometric"
WIDTH_PX, HEIGHT_PX = 96, 64
N_FRAMES = 2
# The LED's image spans this share of the frame's rows (paper-geometric's
# spans 0.985 of its 1080): smaller, so that rows above and below it show the
# LED's rows as the truth gives them, with 2 fully visible PHY-SDUs a frame.
LED_ROW_SHARE = 0.6
SAMPLE_SIZE = 40
SAMPLE_SEED = 20240611

NAMES = tuple(effect.name for effect in REGISTRY)
BY_NAME = {effect.name: effect for effect in REGISTRY}
# Effects that are invalid with their defaults alone: the smallest valid parameters.
# defocus: a lens focused at 5.5 cm, the LED at 5 cm: a blur disk of about 9 px.
# video_codec: a GOP of the test's two frames (its default, one second's, would render 30).
PARAMS = {"defocus": {"focus_distance_cm": 5.5}, "video_codec": {"gop_frames": N_FRAMES}}
# Effects of the ISP and the recording, which act on 8-bit output only.
EIGHT_BIT = {"tone_curve", "isp_smoothing", "sharpening", "jpeg", "video_codec"}


def listing(names) -> dict:
    """The effects ``names`` with their parameters, plus every effect they require."""
    listed = {name: PARAMS.get(name, {}) for name in names}
    for name in names:
        for other, _ in BY_NAME[name].requires:
            listed.setdefault(other, PARAMS.get(other, {}))
    return listed


def output_for(names) -> str:
    """The output the listing needs: rgb8 with a colour filter (demosaiced),
    gray8 with an ISP effect, raw16 (all of the ADC's range) otherwise."""
    if "bayer" in names:
        return "rgb8"
    return "gray8" if EIGHT_BIT & set(names) else "raw16"


def declared_exclusions(names) -> set[frozenset]:
    """The pairs of the listing that an effect's ``excludes`` declares."""
    listed = listing(names)
    return {frozenset((effect, other)) for effect in listed for other, _ in BY_NAME[effect].excludes
            if other in listed}


@functools.lru_cache(maxsize=1)
def base_scene():
    return load_scene(BASE_SCENE)


def overrides(names) -> list[str]:
    base = base_scene()
    scale = LED_ROW_SHARE * HEIGHT_PX / base.camera.height_px
    listed = listing(names)
    items = [f"camera.width_px={WIDTH_PX}", f"camera.height_px={HEIGHT_PX}", f"camera.output={output_for(listed)}",
             f"frames={N_FRAMES}",
             # The LED scaled with the frame, at the same luminance: the same pixel values.
             f"led.size_mm={base.led.size_mm * scale!r}",
             f"led.luminous_intensity_cd={base.led.luminous_intensity_cd * scale**2!r}"]
    items += [f"effects.{name}=false" for name in base.effects.enabled() if name not in listed]
    items += [f"effects.{name}={json.dumps(params)}" for name, params in listed.items()]
    return items


def scene_of(names):
    return load_scene(BASE_SCENE, overrides(names))


ALL_PAIRS = list(itertools.combinations(NAMES, 2))
REFUSED = [pair for pair in ALL_PAIRS if declared_exclusions(pair)]
PAIRS = [pair for pair in ALL_PAIRS if not declared_exclusions(pair)]
SAMPLE = sorted(random.Random(SAMPLE_SEED).sample(PAIRS, SAMPLE_SIZE), key=ALL_PAIRS.index)


def pair_ids(pairs) -> list[str]:
    return [f"{a}+{b}" for a, b in pairs]


# ------------------------------------------------------------------ checks


def non_finite(value, name: str, skip=()) -> list[str]:
    """Names of the non-finite floats in ``value``: an array, a number, or a
    dataclass, tuple or list of them (fields in ``skip`` left out)."""
    if isinstance(value, np.ndarray):
        return [name] if value.dtype.kind in "fc" and not np.isfinite(value).all() else []
    if isinstance(value, (float, np.floating)):
        return [] if math.isfinite(value) else [name]
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return [bad for field in dataclasses.fields(value) if field.name not in skip
                for bad in non_finite(getattr(value, field.name), f"{name}.{field.name}")]
    if isinstance(value, (tuple, list)):
        return [bad for i, item in enumerate(value) for bad in non_finite(item, f"{name}[{i}]")]
    return []


def render_checked(scene) -> tuple[list[np.ndarray], list[dict]]:
    """Frames and truth of ``scene``, rendered stage by stage (unfused), every
    float of the setup and of each stage's output checked finite."""
    with numpy_only():
        pipeline = RenderPipeline(scene, fuse=False)
        setup = pipeline.setup
        assert not non_finite(setup, "setup", skip=("scene", "transmitter"))
        images, truths = [], []
        for index in range(N_FRAMES):
            state = FrameState(setup, index)
            for stage in pipeline.stages:
                stage(state)
                bad = non_finite(state, "state", skip=("setup",))
                assert not bad, f"frame {index}, after stage {stage.name}: not finite: {', '.join(bad)}"
            images.append(state.image)
            truths.append(frame_truth(setup, state.index, state.start_s, state.led_rows, state.led_centre_px))
    if setup.video_codec is not None:  # the recording codes the finished frames a GOP at a time
        gop = gop_frames(setup)
        images = [image for first in range(0, N_FRAMES, gop) for image in gop_round_trip(
            images[first:first + gop], setup.video_codec, scene.camera.frame_rate_hz)]
    return images, truths


def check_image(image: np.ndarray, scene) -> None:
    cam = scene.camera
    shape = (HEIGHT_PX, WIDTH_PX, 3) if cam.output == "rgb8" else (HEIGHT_PX, WIDTH_PX)
    dtype = np.uint16 if cam.output == "raw16" else np.uint8
    assert image.shape == shape and image.dtype == dtype, (image.shape, image.dtype)
    top = 2**cam.adc_bits - 1 if cam.output == "raw16" else 255
    assert int(image.max()) <= top, f"{cam.output} value {int(image.max())} above {top}"


def check_truth(truth: dict, index: int, scene, listed) -> None:
    cam = scene.camera
    json.dumps(truth, allow_nan=False)
    assert truth["frame"] == index
    assert truth["row_time_s"] == cam.row_time_s and truth["exposure_s"] == cam.exposure_s
    t_k, t_row, t_exp = truth["start_s"], cam.row_time_s, cam.exposure_s
    # Frames never overlap: a start moves by less than the gap the frame leaves.
    margin = frame_margin_s(cam.frame_period_s, cam.readout_s, cam.exposure_s)
    if "frame_jitter" in listed:
        assert abs(t_k - index * cam.frame_period_s) < margin
    else:
        assert t_k == pytest.approx(index * cam.frame_period_s, abs=1e-12)
    led_rows = truth["led_rows"]
    if led_rows is not None:
        assert len(led_rows) == 2 and 0 <= led_rows[0] <= led_rows[1] <= HEIGHT_PX - 1, led_rows
    span_end = t_k + (HEIGHT_PX - 1) * t_row + t_exp
    sdus = truth["sdus"]
    txs = [sdu["tx"] for sdu in sdus]
    assert txs == list(range(txs[0], txs[0] + len(txs)) if txs else []), f"PHY-SDUs not consecutive: {txs}"
    for sdu in sdus:
        what = f"frame {index}, PHY-SDU {sdu['tx']}"
        assert sdu["start_s"] < sdu["end_s"], what
        assert sdu["end_s"] > t_k and sdu["start_s"] < span_end, f"{what}: outside the frame's capture span"
        assert sdu["first_row_f"] <= sdu["last_row_f"], what
        if sdu["fully_visible"]:
            assert led_rows is not None, f"{what}: fully visible, but the frame has no LED rows"
            rows = (sdu["first_row"], sdu["last_row"])
            assert led_rows[0] <= rows[0] <= rows[1] <= led_rows[1], f"{what}: rows {rows} outside the LED's {led_rows}"
            assert sdu["start_s"] >= t_k + led_rows[0] * t_row - 1e-12, what
            assert sdu["end_s"] <= t_k + led_rows[1] * t_row + t_exp + 1e-12, what


def digest(directory: Path) -> dict:
    return {p.relative_to(directory).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(directory.rglob("*")) if p.is_file()}


def rendered(names):
    """The scene of ``names``, its frames and truth, every invariant of the render checked."""
    listed = listing(names)
    try:
        scene = scene_of(names)
    except SceneError as exc:
        pytest.fail(f"refused, though no effect excludes another: {exc}")
    assert set(scene.effects.enabled()) == set(listed)
    images, truths = render_checked(scene)
    for index, (image, truth) in enumerate(zip(images, truths)):
        check_image(image, scene)
        check_truth(truth, index, scene, listed)
    return scene, images, truths


def check_on_disk(names, tmp_path: Path, monkeypatch) -> None:
    """The written frames (the fused chain, as a render runs) are those
    rendered stage by stage, and 1 and 2 workers write the same bytes (one
    frame a chunk, so that each worker renders a frame)."""
    scene, images, truths = rendered(names)
    one, two = tmp_path / "one", tmp_path / "two"
    render_to_dir(scene, one, N_FRAMES, workers=1)
    written = [json.loads(line) for line in (one / "truth.jsonl").read_text().splitlines()]
    assert written == truths
    for index, image in enumerate(images):
        assert np.array_equal(read_frame(one / "frames" / FRAME_NAME.format(index)), image), f"frame {index}"
    monkeypatch.setattr(writer, "CHUNK_FRAMES", 1)
    render_to_dir(scene, two, N_FRAMES, workers=2)
    assert digest(one) == digest(two)


# ------------------------------------------------------------------- tests


def test_the_small_scene_shows_the_led_with_stripes():
    """Without effects: the LED's rows inside the frame, and fully visible PHY-SDUs in every frame."""
    images, truths = render_checked(scene_of(()))
    for image, truth in zip(images, truths):
        top, bottom = truth["led_rows"]
        assert 0 < top < bottom < HEIGHT_PX - 1
        assert sum(s["fully_visible"] for s in truth["sdus"]) >= 2
        assert len(np.unique(image[top : bottom + 1].max(axis=1))) >= 3  # stripes


def test_the_sample_is_fixed():
    assert len(SAMPLE) == SAMPLE_SIZE == len(set(SAMPLE))
    assert SAMPLE == sorted(random.Random(SAMPLE_SEED).sample(PAIRS, SAMPLE_SIZE), key=ALL_PAIRS.index)


def test_only_the_declared_exclusions_are_refused():
    """Every effect alone and every pair is loaded: the refusals are exactly
    the pairs some effect ``excludes``."""
    refused = []
    for names in [(name,) for name in NAMES] + ALL_PAIRS:
        try:
            scene_of(names)
        except SceneError:
            refused.append(names)
    assert sorted(refused) == sorted(REFUSED)


def test_no_pair_is_declared_exclusive():
    """docs/scenes.md says no pair of effects is refused: every effect combines with every other."""
    assert REFUSED == []


@pytest.mark.parametrize("name", NAMES)
def test_each_effect_alone(name, tmp_path, monkeypatch):
    check_on_disk((name,), tmp_path, monkeypatch)


@pytest.mark.parametrize("a, b", PAIRS, ids=pair_ids(PAIRS))
def test_every_pair_renders_within_its_invariants(a, b):
    rendered((a, b))


@pytest.mark.parametrize("a, b", SAMPLE, ids=pair_ids(SAMPLE))
def test_a_sample_of_pairs_on_disk(a, b, tmp_path, monkeypatch):
    check_on_disk((a, b), tmp_path, monkeypatch)


@pytest.mark.slow
@pytest.mark.parametrize("a, b", PAIRS, ids=pair_ids(PAIRS))
def test_every_pair_on_disk(a, b, tmp_path, monkeypatch):
    check_on_disk((a, b), tmp_path, monkeypatch)
