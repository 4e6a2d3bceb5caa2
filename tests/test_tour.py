"""The README's tour works as written, in order, in an empty folder.

Every shell command of the README's tour is run through the real command
line, one after the other in a new folder as a newcomer would, with fewer
frames and runs (:data:`SHRINK`) so that the whole tour takes seconds; each
must exit 0 and write what the next one reads. The Python example runs too,
and writes only into the folder it is given.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from rollsim.cli import main

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

# Fewer frames and runs, the same commands: (pattern, replacement) on each line.
SHRINK = [
    (r"--frames 60\b", "--frames 4"),
    (r"--frames 30\b", "--frames 3"),
    (r"--runs 1000\b", "--runs 40"),
    (r"--quick\b", "--quick --frames 2 --runs 5 --workers 2"),
    (r"(render paper-geometric .*)$", r"\1 --set camera.width_px=480 --set camera.height_px=360"),
]


def tour_commands(text: str) -> list[str]:
    """The shell commands of the README's tour sections, in order, without their comments."""
    tour = text[text.index("## A tour"):text.index("## ", text.index("## A tour") + 3)]
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", tour, flags=re.S):
        for line in block.splitlines():
            line = line.split("#", 1)[0].strip()
            if line:
                commands.append(line)
    return commands


def shrunk(command: str) -> str:
    for pattern, replacement in SHRINK:
        command = re.sub(pattern, replacement, command)
    return command


def test_the_tour_lists_the_commands_a_newcomer_needs():
    commands = tour_commands(README.read_text(encoding="utf-8"))
    verbs = [shlex.split(c)[1] for c in commands]
    assert all(shlex.split(c)[0] == "rollsim" for c in commands)
    for verb in ("render", "decode", "evaluate", "calibrate", "simulate", "sweep", "paper", "fit-camera", "bench"):
        assert verb in verbs, verb
    # The full paper run takes many minutes: the tour shows the reduced one.
    assert all("--quick" in c for c in commands if shlex.split(c)[1] == "paper")
    # fit-camera reads frames the tour itself wrote.
    fit = next(c for c in commands if shlex.split(c)[1] == "fit-camera")
    assert "*" not in fit


def test_the_tour_runs_in_order_in_an_empty_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(ROOT))  # examples.threshold_decoder, as from the repository's root
    for command in tour_commands(README.read_text(encoding="utf-8")):
        argv = shlex.split(shrunk(command))[1:]
        assert main(argv) == 0, command
        capsys.readouterr()
    assert (tmp_path / "run" / "decoded.jsonl").exists()
    assert (tmp_path / "paper" / "report.md").exists()
    assert (tmp_path / "my_camera" / "fit.json").exists()


@pytest.mark.parametrize("given", [True, False])
def test_the_python_tour_writes_only_into_its_folder(tmp_path, monkeypatch, given):
    import runpy

    monkeypatch.chdir(tmp_path)
    module = runpy.run_path(str(ROOT / "examples" / "tour.py"))
    if not given:  # where the plot goes does not depend on the table: one real run (above) is enough
        module["main"].__globals__["tour"] = lambda n_frames: [
            {"distance_cm": d, "ok_fraction": 0.5, "M": 1, "N": 1} for d in (5, 10)]
    out = tmp_path / "a" / "b"
    path = module["main"](["--out", str(out), "--frames", "8"] if given else ["--frames", "8"])
    assert path.exists() and path.name == "tour.png"
    if given:
        assert path.parent == out
    else:
        assert tmp_path not in path.parents
        path.unlink()
        path.parent.rmdir()
    assert [p for p in tmp_path.iterdir() if p.name != "a"] == []
