"""What happens to a user's files when runs collide, die or meet a full disk.

Real processes, real signals, real file systems: two ``rollsim run`` into one
directory, a user's file written mid-render, SIGKILL and SIGTERM mid-run, a
full tmpfs, a file-size limit and a read-only mount.
"""

import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest

from clitools import SMALL, alive, assert_one_error, descendants, run_rollsim, staging_areas, start_rollsim, \
    tree_state, wait_for


def _kept(stderr: str) -> Path:
    match = re.search(r"result is kept in (\S+)$", stderr.strip())
    assert match, stderr
    return Path(match.group(1))


def _frames(directory: Path) -> int:
    return len((directory / "truth.jsonl").read_text().splitlines())


def test_two_runs_into_one_directory_commit_exactly_one(tmp_path):
    # The first is long, the second short: both stage, and whichever commits
    # second (the first, unless the machine is loaded enough that the
    # second's start-up outlasts the first's frames) finds the directory
    # taken when it commits.
    first = start_rollsim("run", "paper-default", "--out", "out", "--frames", "900", "--seed", "1", "--workers", "1",
                          "--quiet", *SMALL, cwd=tmp_path)
    wait_for(lambda: staging_areas(tmp_path))
    second = start_rollsim("run", "paper-default", "--out", "out", "--frames", "8", "--seed", "2", "--quiet", *SMALL,
                           cwd=tmp_path)
    _, second_err = second.communicate(timeout=180)
    _, first_err = first.communicate(timeout=180)
    codes = (second.returncode, first.returncode)
    assert sorted(codes) == [0, 1], (second_err, first_err)
    later_err = first_err if first.returncode else second_err
    assert_one_error(later_err, 1, "out: something was written into it while this run was working",
                     "nothing was replaced")
    kept = tmp_path / _kept(later_err)
    assert (kept / "report.md").exists() and (tmp_path / "out" / "report.md").exists()
    committed, kept_frames = (8, 900) if second.returncode == 0 else (900, 8)
    assert _frames(tmp_path / "out") == committed and _frames(kept) == kept_frames
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["out", kept.name])


def test_a_file_the_user_writes_mid_render_is_kept_and_the_run_says_why(tmp_path):
    process = start_rollsim("render", "paper-default", "--out", "out", "--frames", "200", *SMALL, cwd=tmp_path)
    wait_for(lambda: staging_areas(tmp_path))
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "notes.txt").write_bytes(b"every byte the user wrote\n" * 100)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 1
    assert_one_error(err, 1, "out: something was written into it", "this run's result is kept in")
    assert (tmp_path / "out" / "notes.txt").read_bytes() == b"every byte the user wrote\n" * 100
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["notes.txt"]
    assert _frames(tmp_path / _kept(err)) == 200


def _workers_started(process) -> list[int]:
    wait_for(lambda: len(descendants(process.pid)) >= 2)
    return descendants(process.pid)


def test_sigkill_mid_render_then_the_next_run_clears_the_stale_staging(tmp_path):
    process = start_rollsim("render", "paper-default", "--out", "out", "--frames", "400", "--workers", "2", *SMALL,
                            cwd=tmp_path)
    wait_for(lambda: staging_areas(tmp_path) and any(staging_areas(tmp_path)[0].glob("frames/*.png")))
    workers = _workers_started(process)
    process.kill()
    process.wait(timeout=10)
    # The workers die with their parent (no orphan keeps a core busy).
    wait_for(lambda: not any(alive(pid) for pid in workers), timeout=2.0)
    [stale] = staging_areas(tmp_path)
    assert not (tmp_path / "out").exists()
    result = run_rollsim("render", "paper-default", "--out", "out", "--frames", "3", *SMALL, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.err_lines == [f"rollsim: removed stale staging area {stale} of a run (process {process.pid}) "
                                "that is no longer running"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"] and _frames(tmp_path / "out") == 3


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_signal_stops_every_worker_within_2_s_and_removes_the_staging(tmp_path, sig):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("mine")
    process = start_rollsim("run", "paper-default", "--out", "new", "--frames", "400", "--workers", "2", "--quiet",
                            *SMALL, cwd=tmp_path)
    wait_for(lambda: staging_areas(tmp_path) and any(staging_areas(tmp_path)[0].glob("frames/*.png")))
    workers = _workers_started(process)
    before = tree_state(tmp_path / "out")
    process.send_signal(sig)
    start = time.monotonic()
    _, err = process.communicate(timeout=10)
    assert process.returncode == 128 + sig
    wait_for(lambda: not any(alive(pid) for pid in workers), timeout=max(0.1, 2.0 - (time.monotonic() - start)))
    assert err.strip().splitlines() == [f"rollsim: stopped by {signal.Signals(sig).name}; nothing was written"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"] and tree_state(tmp_path / "out") == before


# ------------------------------------------------------------- file systems


@pytest.fixture
def tmpfs(tmp_path):
    """A 1 MiB tmpfs of our own (mounting needs root: skipped otherwise)."""
    mount = tmp_path / "tmpfs"
    mount.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mount)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], capture_output=True)


def _remount(mount: Path, options: str) -> None:
    subprocess.run(["mount", "-o", f"remount,{options}", str(mount)], check=True, capture_output=True)


def test_frames_over_the_disk_budget_are_refused_before_any_work(tmpfs):
    result = run_rollsim("render", "paper-default", "--out", "out", "--frames", "300", *SMALL, cwd=tmpfs)
    assert_one_error(result, 2, "300 frames of 160 x 120 gray8: would write about", "MB, more than the disk budget of",
                     f"the free space on {tmpfs} less")
    assert result.seconds < 5
    assert list(tmpfs.iterdir()) == []


def test_a_full_disk_is_one_line_leaves_the_target_as_it_was_and_a_rerun_succeeds(tmpfs):
    # A budget larger than the disk: the disk fills as if another program had filled it meanwhile.
    result = run_rollsim("--disk-limit", "1G", "render", "paper-default", "--out", "out", "--frames", "300", *SMALL,
                         cwd=tmpfs)
    assert_one_error(result, 1, "No space left on device", "out was left as it was")
    assert list(tmpfs.iterdir()) == []
    result = run_rollsim("render", "paper-default", "--out", "out", "--frames", "3", *SMALL, cwd=tmpfs)
    assert result.returncode == 0 and _frames(tmpfs / "out") == 3


def test_a_read_only_file_system_is_one_line_and_the_target_is_kept(tmpfs):
    assert run_rollsim("render", "paper-default", "--out", "out", "--frames", "2", *SMALL, cwd=tmpfs).returncode == 0
    before = tree_state(tmpfs)
    _remount(tmpfs, "ro")
    try:
        forced = run_rollsim("render", "paper-default", "--out", "out", "--frames", "3", "--force", *SMALL, cwd=tmpfs)
        fresh = run_rollsim("render", "paper-default", "--out", "other", "--frames", "1", *SMALL, cwd=tmpfs)
    finally:
        _remount(tmpfs, "rw")
    assert_one_error(forced, 1, "read-only file system")
    assert_one_error(fresh, 1, "read-only file system")
    assert tree_state(tmpfs) == before


def test_a_file_size_limit_mid_render_is_one_line_and_a_rerun_succeeds(tmp_path):
    result = run_rollsim("render", "paper-default", "--out", "out", "--frames", "20", "--set", "camera.width_px=640",
                         "--set", "camera.height_px=480", "--set", "camera.row_time_us=60", cwd=tmp_path,
                         file_size=40_000)
    assert_one_error(result, 1, "File too large", "out was left as it was")
    assert list(tmp_path.iterdir()) == []
    result = run_rollsim("render", "paper-default", "--out", "out", "--frames", "2", *SMALL, cwd=tmp_path)
    assert result.returncode == 0


def test_outputs_take_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        assert run_rollsim("render", "paper-default", "--out", "out", "--frames", "1", *SMALL, cwd=tmp_path).returncode == 0
    finally:
        os.umask(old)
    modes = {p.relative_to(tmp_path).as_posix(): p.stat().st_mode & 0o777 for p in tmp_path.rglob("*")}
    assert modes["out"] == modes["out/frames"] == 0o755
    assert modes["out/truth.jsonl"] == modes["out/frames/frame_000000.png"] == 0o644
