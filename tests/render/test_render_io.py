"""rollsim render on disk: determinism, atomic output, bad input, hard cases."""

import hashlib
import json
import os
import warnings
from pathlib import Path

import numpy as np
import pytest

from rollsim.cli import main
from rollsim.errors import SceneError
from rollsim.render import RenderPipeline, render_frames

from conftest import make_scene

SMALL = ["--set", "camera.width_px=96", "--set", "camera.height_px=540", "--set", "camera.row_time_us=40"]


def _digest(directory: Path) -> dict:
    return {
        p.relative_to(directory).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(directory.rglob("*"))
        if p.is_file()
    }


def test_render_writes_frames_truth_and_resolved_scene(tmp_path):
    out = tmp_path / "run"
    assert main(["render", "paper-default", "--frames", "3", "--out", str(out), "--quiet", *SMALL]) == 0
    assert sorted(p.name for p in (out / "frames").iterdir()) == [f"frame_{k:06d}.png" for k in range(3)]
    truth = [json.loads(line) for line in (out / "truth.jsonl").read_text().splitlines()]
    assert [t["frame"] for t in truth] == [0, 1, 2]
    resolved = (out / "scene.resolved.yaml").read_text()
    assert "width_px: 96" in resolved and "luminous_intensity_cd" in resolved
    assert not list(tmp_path.glob("*partial*"))


def test_same_seed_is_byte_identical_for_any_worker_count_and_another_seed_differs(tmp_path):
    args = ["render", "paper-default", "--frames", "4", "--quiet", *SMALL]
    assert main([*args, "--out", str(tmp_path / "a"), "--workers", "1"]) == 0
    assert main([*args, "--out", str(tmp_path / "b"), "--workers", "2"]) == 0
    assert main([*args, "--out", str(tmp_path / "c"), "--seed", "2"]) == 0
    a, b, c = (_digest(tmp_path / name) for name in "abc")
    assert a == b
    frames = [k for k in a if k.startswith("frames/")]
    assert all(a[k] != c[k] for k in frames)


def test_non_empty_output_needs_force_and_force_replaces_only_rollsim_output(tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    assert main(["render", "paper-default", "--frames", "1", "--out", str(out), "--quiet", *SMALL]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [f"rollsim: error: {out}: directory is not empty; use --force to replace a previous rollsim output"]
    assert (out / "keep.txt").read_text() == "mine" and not (out / "frames").exists()
    # --force never deletes what rollsim did not write.
    assert main(["render", "paper-default", "--frames", "1", "--out", str(out), "--quiet", "--force", *SMALL]) == 2
    assert "not a rollsim output" in capsys.readouterr().err
    assert [p.name for p in out.iterdir()] == ["keep.txt"] and (out / "keep.txt").read_text() == "mine"
    # A previous rollsim result is replaced.
    (out / "keep.txt").unlink()
    assert main(["render", "paper-default", "--frames", "1", "--out", str(out), "--quiet", *SMALL]) == 0
    assert main(["render", "paper-default", "--frames", "2", "--out", str(out), "--quiet", "--force", *SMALL]) == 0
    assert sorted(p.name for p in (out / "frames").iterdir()) == ["frame_000000.png", "frame_000001.png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


@pytest.mark.skipif(os.geteuid() == 0, reason="root can write anywhere")
def test_unwritable_output_is_one_line(tmp_path, capsys):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    assert main(["render", "paper-default", "--frames", "1", "--out", str(locked / "run"), "--quiet", *SMALL]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1


def test_output_path_that_is_a_file_is_one_line(tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("x")
    assert main(["render", "paper-default", "--frames", "1", "--out", str(target), "--quiet", *SMALL]) == 2
    assert capsys.readouterr().err.splitlines() == [f"rollsim: error: {target}: exists and is not a directory"]


def test_output_under_a_file_is_one_line(tmp_path, capsys):
    # Missing parents are made (tests/test_cli_paths.py); a file on the way cannot be.
    (tmp_path / "no").write_text("x")
    out = tmp_path / "no" / "such" / "dir"
    assert main(["render", "paper-default", "--frames", "1", "--out", str(out), "--quiet", *SMALL]) == 2
    assert capsys.readouterr().err.splitlines() == [f"rollsim: error: {out}: {tmp_path / 'no'} is not a directory"]


def test_bad_scene_writes_nothing(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["render", "paper-default", "--frames", "1", "--out", str(out), "--set", "camera.iso=-1"]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1
    assert not out.exists() and not list(tmp_path.iterdir())


def test_an_effect_refusing_its_scene_is_a_clear_error(tmp_path, capsys):
    # A defocus whose blur circle is wider than rollsim convolves: the
    # effect's per-scene hook refuses it, before anything is written.
    out = tmp_path / "run"
    args = ["render", "paper-default", "--frames", "1", "--out", str(out), "--set", "effects.defocus.focus_distance_cm=0.5"]
    assert main(args) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("rollsim: error: effects.defocus.focus_distance_cm = 0.5: the circle of confusion")
    assert not out.exists()


def test_render_frames_api_returns_arrays_and_truth():
    images, truth = render_frames(make_scene(effects=("shot_noise",)), 2)
    assert len(images) == 2 and images[0].shape == (200, 160) and truth[1]["frame"] == 1


HARD_CASES = {
    "led_under_one_pixel": dict(led={"size_mm": 0.002}),
    "led_larger_than_frame": dict(led={"size_mm": 500.0}),
    "led_outside_frame": dict(led={"size_mm": 2.0, "position_px": [-400.0, 90.0]}),
    "exposure_1us": dict(camera={"exposure_us": 1.0}),
    "exposure_equals_frame_period": dict(camera={"exposure_us": 1e6 / 30}),
    "chip_shorter_than_a_row": dict(camera={"row_time_us": 150.0}, link={"clock_hz": 10000.0}),
    "ambient_0_lux": dict(environment={"ambient_lux": 0.0}),
    "ambient_1e6_lux": dict(environment={"ambient_lux": 1e6}),
    "iso_base": dict(camera={"iso": 100.0}),
    "iso_extreme": dict(camera={"iso": 1e6}),
    "saturating_led": dict(led={"luminous_intensity_cd": 1e6}),
}


@pytest.mark.parametrize("case", sorted(HARD_CASES))
@pytest.mark.parametrize("output", ["gray8", "raw16"])
def test_hard_cases_render_finite_clipped_frames(case, output):
    sections = HARD_CASES[case]
    camera = {**sections.get("camera", {}), "output": output}
    scene = make_scene(effects=("ambient", "shot_noise", "read_noise", "dark_current", "prnu", "dsnu"),
                       **{**sections, "camera": camera})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pipeline = RenderPipeline(scene)
        frames = [pipeline.render(k) for k in range(2)]
    for frame in frames:
        image = frame.image
        assert image.dtype == (np.uint8 if output == "gray8" else np.uint16)
        assert image.shape == (200, 160)
        assert output == "gray8" or image.max() <= 1023
        truth = frame.truth
        json.dumps(truth, allow_nan=False)  # finite numbers only
        led_rows = truth["led_rows"]
        for sdu in truth["sdus"]:
            if sdu["fully_visible"]:
                assert led_rows
                # No row lies wholly inside a PHY-SDU shorter than the exposure.
                if sdu["first_row"] <= sdu["last_row"]:
                    assert led_rows[0] <= sdu["first_row"] <= sdu["last_row"] <= led_rows[1]
    if case == "led_outside_frame":
        assert all(f.truth["led_rows"] is None for f in frames)
        assert not any(s["fully_visible"] for f in frames for s in f.truth["sdus"])
    if case == "exposure_equals_frame_period":
        # Every row integrates a whole frame period: no stripes are left.
        rows = frames[0].image[slice(*frames[0].truth["led_rows"]), 70:90].astype(float).mean(axis=1)
        assert rows.std() < 0.02 * max(rows.mean(), 1)
    if case == "ambient_1e6_lux":
        background = frames[0].image[:, :5]
        assert background.min() == (255 if output == "gray8" else 1023)


def test_distance_at_the_focal_length_is_a_clear_error():
    with pytest.raises(SceneError, match="the thin lens diverges"):
        make_scene(link={"distance_cm": 0.397})


def test_one_frame(tmp_path):
    assert main(["render", "paper-default", "--frames", "1", "--out", str(tmp_path / "one"), "--quiet", *SMALL]) == 0
    assert len(list((tmp_path / "one" / "frames").iterdir())) == 1
