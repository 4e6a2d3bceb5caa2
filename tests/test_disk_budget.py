"""The disk budget: what a command will write is estimated and refused before the first byte."""

from __future__ import annotations

import os

import pytest

from clitools import SMALL, assert_one_error, run_rollsim
from rollsim.plumbing.budget import disk_budget_bytes, disk_margin_bytes, existing_ancestor
from rollsim.errors import RollsimError
from rollsim.render.writer import frame_disk_bytes
from rollsim.scene import load_scene


def test_a_billion_frames_are_refused_at_once_and_nothing_is_written(tmp_path):
    result = run_rollsim("render", "paper-default", "--out", "out", "--frames", "1000000000", cwd=tmp_path)
    assert_one_error(result, 2, "1000000000 frames of 1920 x 1080 gray8: would write about 2.", "PB",
                     "more than the disk budget of", "--disk-limit")
    assert result.seconds < 10  # a Python start-up; the estimate itself takes microseconds
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command, what", [
    (["render", "paper-default", "--out", "out", "--frames", "40"], "40 frames of 1920 x 1080 gray8"),
    (["run", "paper-default", "--out", "out", "--frames", "40"], "40 frames of 1920 x 1080 gray8"),
    (["sweep", "paper-default", "--stage", "run", "--keep-frames", "--frames", "20", "--grid",
      "link.distance_cm=5,10", "--out", "out"], "--keep-frames: 2 cells x 20 frames"),
])
def test_every_command_that_writes_frames_keeps_to_disk_limit(tmp_path, command, what):
    result = run_rollsim("--disk-limit", "50M", *command, cwd=tmp_path)
    assert_one_error(result, 2, what, "more than the disk budget of 50 MB", "set by --disk-limit or ROLLSIM_DISK_LIMIT")
    assert list(tmp_path.iterdir()) == []


def test_a_sweep_over_the_frame_size_counts_every_cells_frames(tmp_path):
    # Two cells of 64 x 48 fit 2 MB; the two of 1920 x 1080 do not.
    result = run_rollsim("--disk-limit", "2M", "sweep", "paper-default", "--stage", "run", "--keep-frames", "--frames",
                         "2", "--grid", "camera.height_px=48,1080", "--zip", "camera.width_px=64,1920", "--workers",
                         "1", "--out", "out", "--set", "camera.row_time_us=20", cwd=tmp_path)
    assert_one_error(result, 2, "--keep-frames: 4 cells x 2 frames: would write about 4.", "MB, more than the disk "
                     "budget of 2 MB")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("sizes, frames", [(SMALL, 12), ([], 2)], ids=["160x120", "1920x1080"])
def test_the_estimate_bounds_what_a_render_writes(tmp_path, sizes, frames):
    result = run_rollsim("render", "paper-default", "--out", "out", "--frames", str(frames), *sizes, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    written = sum(p.stat().st_size for p in (tmp_path / "out").rglob("*") if p.is_file()
                  and p.name not in ("scene.resolved.yaml", ".rollsim-output.json"))
    scene = load_scene("paper-default", [s for s in sizes if s != "--set"])
    estimate = frames * frame_disk_bytes(scene)
    assert written <= estimate
    if not sizes:  # a noisy 1080p frame's PNG holds most of its samples' bytes: the bound is close
        assert estimate < 1.3 * written


def test_the_budget_is_the_free_space_less_a_margin(tmp_path, monkeypatch):
    monkeypatch.delenv("ROLLSIM_DISK_LIMIT", raising=False)
    budget, source = disk_budget_bytes(tmp_path / "not" / "yet")
    info = os.statvfs(tmp_path)
    free = info.f_bavail * info.f_frsize
    # Other programs write meanwhile: the two readings of the free space may differ a little either way.
    assert abs(free - budget - disk_margin_bytes(info.f_blocks * info.f_frsize)) < 64 * 2**20
    assert source.startswith(f"the free space on {tmp_path} less")
    assert existing_ancestor(tmp_path / "a" / "b") == tmp_path
    assert disk_margin_bytes(10**6) == 50_000 and disk_margin_bytes(10**13) == 2**30


def test_a_bad_disk_limit_is_one_line(tmp_path, monkeypatch):
    result = run_rollsim("--disk-limit", "lots", "render", "paper-default", "--out", "out", cwd=tmp_path)
    assert_one_error(result, 2, "--disk-limit = 'lots': expected a size")
    monkeypatch.setenv("ROLLSIM_DISK_LIMIT", "0")
    with pytest.raises(RollsimError, match="ROLLSIM_DISK_LIMIT = '0'"):
        disk_budget_bytes(tmp_path)
