"""The command line names input paths that do not exist, and makes the missing folders above its outputs.

Every case runs the real entry point (``rollsim.cli.main``) in an empty
working directory: a missing input is one line naming it, exit 2, and
nothing written; an output under missing folders is written there, still
never over an existing one, and a command that fails removes the folders
it made.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from clitools import SMALL
from rollsim.cli import main
from rollsim.errors import Interrupted, RollsimError

SCENE_HINT = "does not exist, as a file or a bundled scene (rollsim scenes lists them)"


def _tree(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


@pytest.fixture
def work(tmp_path, monkeypatch):
    """An empty working directory."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


# ------------------------------------------------------------ missing inputs

MISSING = [
    # An unexpanded glob: named as a pattern, with the folder it looks in.
    (["fit-camera", "my_frames/*.png", "--clock-hz", "5000", "--out", "cam"],
     ["no file matches my_frames/*.png (my_frames does not exist)"]),
    (["estimate-row-time", "my_frames/*.png", "--clock-hz", "5000"],
     ["no file matches my_frames/*.png (my_frames does not exist)"]),
    (["estimate-row-time", "frames_*/[0-9].png", "--clock-hz", "5000"], ["no file matches frames_*/[0-9].png"]),
    (["decode", "run"], ["run: does not exist"]),
    (["decode", "runs/run1", "--scene", "mine.yaml"], ["runs/run1: does not exist", f"mine.yaml: {SCENE_HINT}"]),
    (["evaluate", "run"], ["run: does not exist"]),
    (["evaluate", "run", "--decoded", "mine.jsonl", "--against", "theirs.jsonl"],
     ["run: does not exist", "mine.jsonl: does not exist", "theirs.jsonl: does not exist"]),
    (["calibrate", "run"], ["run: does not exist"]),
    (["calibrate", "trace.csv"], ["trace.csv: does not exist"]),
    (["describe", "mine.yaml"], [f"mine.yaml: {SCENE_HINT}"]),
    (["describe", "paper-defualt"],
     ["paper-defualt: does not exist, as a file or a bundled scene (did you mean paper-default? rollsim scenes "
      "lists them)"]),
    (["describe", "scenes/mine.yaml"], ["scenes/mine.yaml: does not exist"]),
    (["render", "scenes/*.yaml", "--out", "run"], ["no file matches scenes/*.yaml (scenes does not exist)"]),
    (["run", "mine.yaml", "--out", "run"], [f"mine.yaml: {SCENE_HINT}"]),
    (["simulate", "mine.yaml"], [f"mine.yaml: {SCENE_HINT}"]),
    (["sweep", "mine.yaml", "--grid", "link.distance_cm=5,10", "--out", "sweep"], [f"mine.yaml: {SCENE_HINT}"]),
    (["validate", "mine.yaml"], [f"mine.yaml: {SCENE_HINT}"]),
    (["bench", "render", "--scene", "mine.yaml"], [f"mine.yaml: {SCENE_HINT}"]),
    (["bench", "stress", "paper-default", "mine.yaml"], [f"mine.yaml: {SCENE_HINT}"]),
    (["bench", "accuracy", "mine.yaml", "--out", "acc"], [f"mine.yaml: {SCENE_HINT}"]),
]


@pytest.mark.parametrize("argv, lines", MISSING, ids=[" ".join(argv[:2]) for argv, _ in MISSING])
def test_a_missing_input_is_named_in_one_line(work, capsys, argv, lines):
    assert main(argv) == 2
    assert capsys.readouterr().err.splitlines() == [f"rollsim: error: {line}" for line in lines]
    assert _tree(work) == []


def test_a_glob_that_matched_nothing_is_named_not_counted_as_a_frame(work, capsys):
    # One frame that exists and a pattern: the pattern is named, not "needs at least two frames, got 1".
    (work / "one.png").write_bytes(b"")
    (work / "my_frames").mkdir()
    assert main(["fit-camera", "one.png", "my_frames/*.png", "--clock-hz", "5000", "--out", "cam"]) == 2
    assert capsys.readouterr().err.splitlines() == ["rollsim: error: no file matches my_frames/*.png"]
    assert _tree(work) == ["my_frames", "one.png"]


def test_a_dangling_link_is_named_with_its_target(work, capsys):
    os.symlink("gone", work / "run")
    assert main(["decode", "run"]) == 2
    assert capsys.readouterr().err.splitlines() == ["rollsim: error: run: a symbolic link to gone, which does not exist"]


def test_an_existing_input_of_the_wrong_kind_is_not_called_missing(work, capsys):
    (work / "run").write_text("a file")
    assert main(["decode", "run"]) == 2
    assert capsys.readouterr().err.splitlines() == ["rollsim: error: run: not a directory"]


# ------------------------------------------------------ outputs under new folders


def test_render_makes_the_missing_folders_of_its_out_and_never_writes_over_it(work, capsys):
    argv = ["render", "paper-default", "--frames", "1", "--quiet", "--workers", "1", *SMALL, "--out", "a/b/run"]
    assert main(argv) == 0
    assert (work / "a/b/run/frames/frame_000000.png").is_file() and (work / "a/b/run/.rollsim-output.json").is_file()
    before = (work / "a/b/run/truth.jsonl").read_bytes()
    capsys.readouterr()
    assert main(argv) == 2
    assert capsys.readouterr().err.splitlines() == [
        "rollsim: error: a/b/run: directory is not empty; use --force to replace a previous rollsim output"]
    assert (work / "a/b/run/truth.jsonl").read_bytes() == before
    assert not [p for p in (work / "a/b").iterdir() if p.name != "run"]  # no staging left beside it


@pytest.mark.parametrize("failure, code", [(RollsimError("the render failed"), 2), (OSError(28, "No space left on device"), 1),
                                           (Interrupted(signal.SIGINT), 130)], ids=["error", "disk-full", "sigint"])
def test_a_failed_render_removes_the_folders_it_made_and_only_those(work, capsys, monkeypatch, failure, code):
    def fail(*args, **kwargs):
        assert (work / "old/a/b").is_dir()  # made before the work, beside its staging area
        raise failure

    monkeypatch.setattr("rollsim.render.writer.render_into", fail)
    (work / "old").mkdir()
    assert main(["render", "paper-default", "--frames", "1", "--quiet", *SMALL, "--out", "old/a/b/run"]) == code
    assert _tree(work) == ["old"]


def test_a_file_on_the_way_is_refused_in_one_line_and_nothing_is_made(work, capsys):
    (work / "notes.txt").write_text("mine")
    assert main(["render", "paper-default", "--frames", "1", "--quiet", *SMALL, "--out", "notes.txt/a/run"]) == 2
    assert capsys.readouterr().err.splitlines() == ["rollsim: error: notes.txt/a/run: notes.txt is not a directory"]
    assert main(["analytic", "--json", "notes.txt/x.json"]) == 2
    assert capsys.readouterr().err.splitlines() == ["rollsim: error: notes.txt/x.json: notes.txt is not a directory"]
    assert _tree(work) == ["notes.txt"] and (work / "notes.txt").read_text() == "mine"


def test_file_outputs_make_their_folders_and_never_replace_a_file(work, capsys):
    assert main(["analytic", "--json", "tables/p0/analytic.json", "--plot", "plots/analytic.png"]) == 0
    assert (work / "tables/p0/analytic.json").is_file() and (work / "plots/analytic.png").is_file()
    (work / "tables/p0/analytic.json").write_text("mine")
    assert main(["analytic", "--json", "tables/p0/analytic.json", "--plot", "more/analytic.png"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "rollsim: error: tables/p0/analytic.json: exists; use --force to replace it")
    assert (work / "tables/p0/analytic.json").read_text() == "mine" and not (work / "more").exists()


def test_a_sweep_makes_the_missing_folders_of_its_out(work, capsys):
    assert main(["sweep", "paper-default", "--grid", "link.distance_cm=5,10", "--workers", "1", "--quiet",
                 "--out", "sweeps/distance/run1"]) == 0
    assert (work / "sweeps/distance/run1/results.csv").is_file()
    assert (work / "sweeps/distance/run1/.rollsim-output.json").is_file()


@pytest.mark.parametrize("fails", [False, True], ids=["done", "failed"])
def test_a_benchmark_out_gets_its_folders_and_loses_them_when_it_fails(work, capsys, monkeypatch, fails):
    # The benchmark's own check of --out (rollsim.bench.accuracy.output_paths) meets the folders made.
    from rollsim.bench import accuracy
    from rollsim.plumbing.outputs import write_files

    def bench(args) -> int:
        paths = accuracy.output_paths(Path(args.out), args.force)
        if fails:
            raise RollsimError("the benchmark failed")
        write_files({paths["accuracy.md"]: "# accuracy\n"})
        return 0

    monkeypatch.setattr(accuracy, "main", bench)
    code = main(["bench", "accuracy", "paper-default", "--out", "bench/today/accuracy"])
    if fails:
        assert code == 2 and _tree(work) == []
    else:
        assert code == 0 and (work / "bench/today/accuracy/accuracy.md").read_text() == "# accuracy\n"
