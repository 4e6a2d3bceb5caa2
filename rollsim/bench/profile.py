"""``rollsim bench profile``: where a user's wait goes in ``rollsim run`` and ``rollsim describe``.

Each figure is the median of ``--repeats`` runs on this machine, with the
smallest and largest beside it (its spread). The fresh processes start with
the modules' bytecode written, as after an install's first run
(:func:`rollsim.bench.common.write_bytecode`):

* **start-up**: the wall time of fresh processes that do no work of a
  scene's: Python alone, ``import rollsim.cli``, the heavy imports some
  commands need (matplotlib for plots, numba for the compiled kernels),
  ``rollsim --version``, and ``rollsim describe SCENE`` (a user's quickest
  question);
* **the run as a user meets it**: ``rollsim run SCENE`` as a fresh process,
  its wall time and its own clock of the stages (render and decode, evaluate,
  calibrate, report); what is left is start-up, the checks before the
  render and the output's move into place;
* **inside the run**: :func:`rollsim.report.run.run_scene` in this process
  under :mod:`cProfile`, and the cumulative seconds of the named phases
  (:data:`PHASES`): the render pipeline's set-up (the glare's transform,
  the footprint), loading the compiled kernels, the waits on the render
  and decode workers (their own work is not profiled: it is the wait),
  each part of the calibration, and the report: the plot this process
  draws and the wait on those a second process draws.

The phases are the main process's; a phase that calls another includes it
(the calibration's parts sum to less than the stage: the rest is its
bookkeeping).
"""

from __future__ import annotations

import cProfile
import json
import pstats
import re
import shlex
import sys
import tempfile
import time
from pathlib import Path
from typing import Optional

from rollsim.bench.common import machine, spread, strict_floats, timed_process, write_bytecode
from rollsim.plumbing.text_tables import format_table, markdown_table

REPEATS = 3
# (label, file suffix, function): cumulative seconds in the main process's profile.
PHASES = (
    ("render set-up: pipelines (glare transform, footprint)", "rollsim/render/pipeline.py", "__init__"),
    ("render: compiled kernels loaded (numba), frame 0 run once", "rollsim/render/writer.py", "warm_up_render"),
    ("render and decode: waiting on the workers", "rollsim/plumbing/parallel.py", "ordered_chunk_map"),
    ("evaluate", "rollsim/stages/evaluate.py", "evaluate_directory"),
    ("calibrate: MMBP fit", "rollsim/calibrate/__init__.py", "fit_mmbp"),
    ("calibrate: Gilbert-Elliott fits", "rollsim/calibrate/ge.py", "fit_ge"),
    ("calibrate: position model", "rollsim/calibrate/__init__.py", "fit_position_model"),
    ("calibrate: held-out likelihoods", "rollsim/calibrate/__init__.py", "heldout_logliks"),
    ("calibrate: goodput table", "rollsim/calibrate/goodput.py", "goodput_table"),
    ("calibrate: replays (within the goodput table)", "rollsim/calibrate/replay.py", "replay_goodput_bps"),
    # With workers, a second process draws the other plots (the frames' during
    # the calibration, the later calibration plots during this one's).
    ("report: run lengths plot (this process)", "rollsim/report/plots.py", "plot_run_lengths"),
    ("report: waiting on the second process's plots", "rollsim/report/run.py", "drawn_beside"),
)
_STAGE_LINE = re.compile(r"^time: (.*)$", re.M)




def stage_seconds(stdout: str) -> dict[str, float]:
    """The stages of a ``rollsim run``'s ``time:`` line: ``{"render": 4.4, ...}`` (seconds)."""
    match = _STAGE_LINE.search(stdout)
    if match is None:
        return {}
    stages = {}
    for part in match.group(1).split(", "):
        name, value, _unit = part.rsplit(" ", 2)
        stages[name] = float(value)
    return stages


def startup(scene: str, repeats: int, cwd: Path) -> dict:
    """Wall seconds of the fresh processes that do no scene's work, and of ``rollsim describe``."""
    python = sys.executable
    commands = {
        "python alone": [python, "-c", "pass"],
        "import rollsim.cli": [python, "-c", "import rollsim.cli"],
        "import matplotlib.figure (the report's plots)": [python, "-c", "import matplotlib.figure"],
        "import numba (the compiled kernels)": [python, "-c", "import numba"],
        "rollsim --version": [python, "-m", "rollsim", "--version"],
        f"rollsim describe {scene}": [python, "-m", "rollsim", "describe", scene],
    }
    return {name: spread([timed_process(argv, cwd)[0] for _ in range(repeats)]) for name, argv in commands.items()}


def run_as_user(scene: str, frames: Optional[int], repeats: int, workdir: Path) -> dict:
    """``rollsim run SCENE`` as fresh processes: wall seconds and the run's own stage clock."""
    walls, stages = [], []
    for k in range(repeats):
        argv = [sys.executable, "-m", "rollsim", "run", scene, "--out", str(workdir / f"run{k}")]
        if frames is not None:
            argv += ["--frames", str(frames)]
        seconds, stdout = timed_process(argv, workdir)
        walls.append(seconds)
        stages.append(stage_seconds(stdout))
    names = list(stages[0])
    result = {"wall": spread(walls), "stages": {n: spread([s[n] for s in stages]) for n in names}}
    result["outside_stages"] = spread([w - sum(s.values()) for w, s in zip(walls, stages)])
    return result


def phase_seconds(stats: pstats.Stats) -> dict[str, float]:
    """Cumulative seconds of each :data:`PHASES` function in a profile (0 where not called)."""
    table = stats.stats  # type: ignore[attr-defined]
    seconds = {}
    for label, suffix, function in PHASES:
        seconds[label] = float(sum(entry[3] for (path, _line, name), entry in table.items()
                                   if name == function and path.replace("\\", "/").endswith(suffix)))
    return seconds


def run_profiled(scene_name: str, frames: Optional[int], workers: int, repeats: int, workdir: Path) -> dict:
    """:func:`rollsim.report.run.run_scene` in this process under cProfile: stages and phases."""
    from rollsim.report.run import run_scene
    from rollsim.scene import load_scene

    scene = load_scene(scene_name)
    runs: list[dict] = []
    for k in range(repeats):
        profiler = cProfile.Profile()
        start = time.perf_counter()
        profiler.enable()
        summary = run_scene(scene, workdir / f"profiled{k}", frames or scene.frames, workers=workers)
        profiler.disable()
        wall = time.perf_counter() - start
        runs.append({"wall": wall, "stages": dict(summary.timings),
                     "phases": phase_seconds(pstats.Stats(profiler))})
    return {"wall": spread([r["wall"] for r in runs]),
            "stages": {n: spread([r["stages"][n] for r in runs]) for n in runs[0]["stages"]},
            "phases": {n: spread([r["phases"][n] for r in runs]) for n in runs[0]["phases"]}}


def bench_profile(scene: str, frames: Optional[int] = None, repeats: int = REPEATS, workers: int = 2,
                  progress=None) -> dict:
    """Every figure of the module docstring, JSON-ready."""
    say = progress or (lambda text: None)
    # The fresh processes run in a scratch folder: a scene file is named by its absolute path.
    scene = str(Path(scene).resolve()) if Path(scene).is_file() else scene
    with tempfile.TemporaryDirectory(prefix="rollsim-profile-") as tmp:
        workdir = Path(tmp)
        write_bytecode()  # the fresh processes start as after an install's first run
        say("start-up")
        first = startup(scene, repeats, workdir)
        say(f"rollsim run {scene}, {repeats} fresh processes")
        user = run_as_user(scene, frames, repeats, workdir)
        say(f"rollsim run {scene} in this process, profiled")
        inside = run_profiled(scene, frames, workers, repeats, workdir)
    return {"scene": scene, "frames": frames, "repeats": repeats, "workers": workers, "machine": machine(),
            "startup": first, "run": user, "profiled": inside}


def _cell(figure: dict) -> str:
    return f"{figure['median']:.2f} ({figure['min']:.2f} … {figure['max']:.2f})"


def table_rows(result: dict) -> list[tuple[str, str]]:
    """``(what, seconds as median (min … max))`` rows, in the order a user meets them."""
    rows = [(f"start-up: {name}", _cell(figure)) for name, figure in result["startup"].items()]
    run = result["run"]
    rows.append((f"rollsim run {result['scene']}: wall (fresh process)", _cell(run["wall"])))
    rows += [(f"  stage: {name}", _cell(figure)) for name, figure in run["stages"].items()]
    rows.append(("  outside the stages (start-up, checks, the output's move)", _cell(run["outside_stages"])))
    rows.append(("inside the run (this process, profiled): wall", _cell(result["profiled"]["wall"])))
    rows += [(f"  {name}", _cell(figure)) for name, figure in result["profiled"]["phases"].items()]
    return rows


HEADER = ("what", "seconds: median (min … max)")


def format_markdown(result: dict, command: str) -> str:
    lines = [f"`{command}` ({result['repeats']} runs each, {result['workers']} workers; "
             f"{result['machine'].get('cpus', '?')} CPUs)", ""]
    return "\n".join(lines + markdown_table(table_rows(result), HEADER)) + "\n"


def command_line(args) -> str:
    words = ["rollsim", "bench", "profile", args.scene]
    if args.frames is not None:
        words += ["--frames", str(args.frames)]
    if args.repeats != REPEATS:
        words += ["--repeats", str(args.repeats)]
    if args.out:
        words += ["--out", args.out]
    return shlex.join(words)


def main(args) -> int:
    from rollsim.plumbing.outputs import check_directory_files, write_files

    paths = None
    if args.out:
        # Refused before any work; the folder is made only when the files are written.
        md, js = check_directory_files(args.out, ("profile.md", "profile.json"), args.force)
        paths = {"md": md, "json": js}
    progress = None if args.quiet else (lambda text: print(text, file=sys.stderr, flush=True))
    result = strict_floats(bench_profile(args.scene, args.frames, args.repeats, args.workers, progress))
    command = command_line(args)
    print(f"{command}")
    print(format_table(table_rows(result), HEADER))
    if paths is not None:
        write_files({paths["md"]: format_markdown(result, command),
                     paths["json"]: json.dumps({"command": command, **result}, indent=2, allow_nan=False) + "\n"},
                    force=args.force)
        print(f"wrote {paths['md']} and {paths['json']}")
    return 0
