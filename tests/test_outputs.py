"""rollsim.plumbing.outputs: staging, commit, replacement, stale leftovers, modes."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from rollsim.plumbing import outputs
from rollsim.errors import CommitError, OutputError, SystemFailure


def _write_result(directory: Path, text: str = "result") -> None:
    (directory / "frames").mkdir()
    (directory / "frames" / "frame_000000.png").write_bytes(b"png" * 10)
    (directory / "report.md").write_text(text)


def _commit(target: Path, force: bool = False, text: str = "result") -> None:
    with outputs.staged_directory(target, force=force) as staging:
        _write_result(staging, text)


def _listing(root: Path) -> dict:
    return {p.relative_to(root).as_posix(): (p.read_bytes() if p.is_file() else None) for p in sorted(root.rglob("*"))}


def test_committed_directory_has_its_result_and_a_manifest_and_nothing_beside_it(tmp_path):
    _commit(tmp_path / "out")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    manifest = json.loads((tmp_path / "out" / outputs.MANIFEST_NAME).read_text())
    assert manifest["dirs"] == ["frames"]
    assert set(manifest["files"]) == {"frames/frame_000000.png", "report.md"}
    assert manifest["files"]["report.md"]["size"] == 6 and "sha256" in manifest["files"]["report.md"]
    assert outputs.foreign_entries(tmp_path / "out") == []


def test_failure_inside_the_block_leaves_the_target_as_it_was(tmp_path):
    _commit(tmp_path / "out", text="first")
    before = _listing(tmp_path)
    with pytest.raises(ZeroDivisionError):
        with outputs.staged_directory(tmp_path / "out", force=True) as staging:
            _write_result(staging, "second")
            raise ZeroDivisionError("a failure inside the block")
    assert _listing(tmp_path) == before


def test_force_replaces_a_rollsim_result_but_nothing_else(tmp_path):
    out = tmp_path / "out"
    _commit(out, text="first")
    with pytest.raises(OutputError, match="directory is not empty; use --force"):
        _commit(out, text="second")
    _commit(out, force=True, text="second")
    assert (out / "report.md").read_text() == "second"
    (out / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match=r"holds files rollsim did not write .*: notes.txt"):
        _commit(out, force=True, text="third")
    assert (out / "notes.txt").read_text() == "mine" and (out / "report.md").read_text() == "second"


def test_force_refuses_an_edited_result_and_a_directory_without_manifest(tmp_path):
    out = tmp_path / "out"
    _commit(out)
    (out / "report.md").write_text("edited")  # same size, other bytes
    with pytest.raises(OutputError, match="report.md"):
        _commit(out, force=True)
    plain = tmp_path / "plain"
    plain.mkdir()
    (plain / "data.csv").write_text("1,2\n")
    with pytest.raises(OutputError, match="not a rollsim output"):
        _commit(plain, force=True)
    assert (plain / "data.csv").read_text() == "1,2\n"


def test_something_written_into_the_target_meanwhile_keeps_both(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(CommitError) as info:
        with outputs.staged_directory(out) as staging:
            _write_result(staging)
            out.mkdir()
            (out / "notes.txt").write_text("mine")
    assert (out / "notes.txt").read_text() == "mine"
    kept = Path(str(info.value).rsplit("kept in ", 1)[1])
    assert kept.name.startswith("out.rollsim-uncommitted-") and (kept / "report.md").read_text() == "result"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["out", kept.name])


def test_a_file_slipped_into_the_old_result_during_a_forced_swap_is_not_deleted(tmp_path, monkeypatch):
    out = tmp_path / "out"
    _commit(out, text="first")
    real = outputs._rename_exchange

    def swap_after_a_user_write(a, b):
        if not (Path(b) / "late.txt").exists():
            (Path(b) / "late.txt").write_text("written during the swap")
        return real(a, b)

    monkeypatch.setattr(outputs, "_rename_exchange", swap_after_a_user_write)
    with pytest.raises(CommitError):
        _commit(out, force=True, text="second")
    assert (out / "late.txt").read_text() == "written during the swap"
    assert (out / "report.md").read_text() == "first"


def test_forced_replacement_without_an_atomic_exchange(tmp_path, monkeypatch):
    # File systems without renameat2(RENAME_EXCHANGE): two renames.
    monkeypatch.setattr(outputs, "_rename_exchange", lambda a, b: False)
    out = tmp_path / "out"
    _commit(out, text="first")
    _commit(out, force=True, text="second")
    assert (out / "report.md").read_text() == "second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_target_refusals_name_the_path(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scene.yaml").write_text("name: x\n")
    with pytest.raises(OutputError, match="is the working directory"):
        outputs.check_directory_target(Path("."), force=True)
    with pytest.raises(OutputError, match="is the working directory or holds it"):
        outputs.check_directory_target(tmp_path.parent, force=True)
    (tmp_path / "inputs").mkdir()
    (tmp_path / "work").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    with pytest.raises(OutputError, match="holds the input .*scene.yaml"):
        outputs.check_directory_target(tmp_path / "inputs", force=True, inputs=[tmp_path / "inputs" / "scene.yaml"])
    with pytest.raises(OutputError, match="holds the input"):
        outputs.check_directory_target(tmp_path / "inputs" / "scene.yaml", inputs=[tmp_path / "inputs" / "scene.yaml"])
    with pytest.raises(OutputError, match="exists and is not a directory"):
        outputs.check_directory_target(tmp_path / "scene.yaml")
    with pytest.raises(OutputError, match="scene.yaml is not a directory"):
        outputs.check_directory_target(tmp_path / "scene.yaml" / "run")
    # Missing parents are no refusal: they are made when the output is written.
    assert outputs.check_directory_target(tmp_path / "no" / "such") == (tmp_path / "no" / "such").resolve()
    assert not (tmp_path / "no").exists()


def _dead_process() -> tuple[int, int]:
    """The pid and start time of a process that has ended."""
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    start = outputs._process_start(child.pid)
    child.kill()
    child.wait()
    return child.pid, start


def test_stale_leftovers_of_dead_runs_are_removed_or_restored_and_named(tmp_path, capsys):
    pid, start = _dead_process()
    tag = f"{outputs._host_tag()}-{pid}-{start}-0123abcd"
    stale = tmp_path / f".out.rollsim-{tag}.staging"
    stale.mkdir()
    (stale / "frame.png").write_bytes(b"half")
    old = tmp_path / f".out.rollsim-{tag}.old"
    old.mkdir()
    (old / "report.md").write_text("previous result")
    live_tag = f"{outputs._host_tag()}-{os.getpid()}-{outputs._process_start(os.getpid())}-0123abcd"
    live = tmp_path / f".out.rollsim-{live_tag}.staging"
    live.mkdir()
    other_host = tmp_path / f".out.rollsim-ffffffff-{pid}-{start}-0123abcd.staging"
    other_host.mkdir()
    notices = outputs.clear_stale(tmp_path / "out")
    assert not stale.exists() and live.exists() and other_host.exists()
    # The old result of a run killed between its two renames is put back.
    assert (tmp_path / "out" / "report.md").read_text() == "previous result" and not old.exists()
    err = capsys.readouterr().err
    assert f"removed stale staging area {stale}" in err and f"process {pid}" in err and "restored" in err
    assert len(notices) == 2


def test_file_outputs_refuse_to_replace_and_commit_all_or_none(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    outputs.write_files({a: "1", b: "2"})
    with pytest.raises(OutputError, match="exists; use --force"):
        outputs.write_file(a, "3")
    outputs.write_files({a: "3", b: "4"}, force=True)
    assert (a.read_text(), b.read_text()) == ("3", "4")
    # A target that appears during the work: nothing is replaced, the new
    # results are kept and named.
    c, d = tmp_path / "c.json", tmp_path / "d.json"
    with pytest.raises(CommitError) as info:
        with outputs.staged_files([c, d]) as files:
            files.write(c, "new c")
            files.write(d, "new d")
            d.write_text("user's d")
    assert not c.exists() and d.read_text() == "user's d"
    kept = str(info.value).rsplit("kept in ", 1)[1].split(", ")
    assert sorted(Path(k).read_text() for k in kept) == ["new c", "new d"]


def test_file_output_errors(tmp_path):
    with pytest.raises(OutputError, match="is a directory"):
        outputs.check_file_targets([tmp_path])
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputError, match="file is not a directory"):
        outputs.check_file_targets([tmp_path / "file" / "x.json"])
    assert outputs.check_file_targets([tmp_path / "no" / "x.json"]) == [tmp_path / "no" / "x.json"]
    with pytest.raises(OutputError, match="given for two outputs"):
        outputs.check_file_targets([tmp_path / "x.json", tmp_path / "x.json"])


def test_a_failed_file_commit_removes_its_temporaries(tmp_path):
    with pytest.raises(RuntimeError):
        with outputs.staged_files([tmp_path / "x.json"]) as files:
            files.write(tmp_path / "x.json", "half")
            raise RuntimeError("stop")
    assert list(tmp_path.iterdir()) == []


def test_file_written_into_a_rollsim_directory_joins_its_manifest(tmp_path):
    out = tmp_path / "out"
    _commit(out)
    outputs.write_file(out / "decoded.jsonl", "{}\n")
    assert outputs.foreign_entries(out) == []
    assert "decoded.jsonl" in json.loads((out / outputs.MANIFEST_NAME).read_text())["files"]


@pytest.mark.parametrize("umask, dir_mode, file_mode", [(0o022, 0o755, 0o644), (0o077, 0o700, 0o600), (0o002, 0o775, 0o664)])
def test_new_directories_and_files_take_the_umask(tmp_path, umask, dir_mode, file_mode):
    old = os.umask(umask)
    try:
        _commit(tmp_path / "out")
        outputs.write_file(tmp_path / "x.json", "{}")
    finally:
        os.umask(old)
    assert (tmp_path / "out").stat().st_mode & 0o777 == dir_mode
    assert (tmp_path / "out" / "frames").stat().st_mode & 0o777 == dir_mode
    assert (tmp_path / "out" / outputs.MANIFEST_NAME).stat().st_mode & 0o777 == file_mode
    assert (tmp_path / "x.json").stat().st_mode & 0o777 == file_mode


def test_os_errors_become_one_line_failures_naming_the_target(tmp_path):
    with pytest.raises(SystemFailure) as info:
        with outputs.staged_directory(tmp_path / "out") as staging:
            raise OSError(28, "No space left on device", str(staging / "frames" / "frame_000003.png"))
    assert str(info.value) == f"{tmp_path / 'out'}/frames/frame_000003.png: No space left on device; " \
                              f"{tmp_path / 'out'} was left as it was"
    assert info.value.exit_code == 1 and list(tmp_path.iterdir()) == []
