"""``rollsim bench waits``: the waits a user meets, each against its target.

One command for the table of user-facing waits in ``docs/speed.md``: each
row measured ``--repeats`` times on this machine, its median with the
smallest and largest beside it (the machine's spread), its target and
whether the median meets it.

* **commands as a user runs them** (a fresh process, start-up included,
  output into a new temporary directory, the modules' bytecode written as
  after an install's first run, :func:`rollsim.bench.common.write_bytecode`): ``rollsim paper`` (the full
  reproduction; only with ``--all`` or ``--only paper``: minutes a run),
  ``rollsim paper --quick``, ``rollsim run paper-default``, the README
  tour's sweep and ``rollsim describe paper-default``;
* **the render's command against its own engine**: ``rollsim render
  paper-default --frames 300`` as a fresh process, its frames per second
  over the end-to-end rate measured just before it in this process
  (:func:`rollsim.bench.render.end_to_end_frames_per_s`, 300 frames on the
  same workers, without the start-up): the share of the engine's rate a
  user gets. Each repeat pairs the two, so that the machine's state moves
  both;
* **one core, one frame**: the render of a 1080p frame with its scene's
  default effects (:func:`rollsim.bench.render.render_ms_per_frame`, OpenCV
  on one thread), for paper-geometric and for the densest bundled scene's
  chain, effect-blooming.
"""

from __future__ import annotations

import json
import shlex
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional, Sequence

from rollsim.bench.common import machine, spread, strict_floats, timed_process, write_bytecode
from rollsim.plumbing.text_tables import format_table

REPEATS = 3
RENDER_FRAMES = 300
RENDER_WORKERS = 2
ONE_CORE_FRAMES = 20


@dataclass(frozen=True)
class Wait:
    """One row: what the user runs, its target and how it is measured.

    Attributes
    ----------
    key : str
        The row's name for ``--only``.
    what : str
        The command or figure, as the table shows it.
    comparison : str
        ``"<="`` or ``">="``: how the median meets ``target``.
    target : float
    unit : str
        ``"s"``, ``"ms/frame"`` or ``"x"`` (a ratio).
    slow : bool
        Measured only when asked for (``--all``, ``--only``).
    """

    key: str
    what: str
    comparison: str
    target: float
    unit: str
    slow: bool = False


TOUR_SWEEP = ["sweep", "paper-default", "--grid", "link.distance_cm=5,10,20", "--stage", "run", "--frames", "30"]
WAITS = (
    Wait("paper", "rollsim paper --out DIR (the full reproduction)", "<=", 180.0, "s", slow=True),
    Wait("paper-quick", "rollsim paper --quick --out DIR", "<=", 20.0, "s"),
    Wait("run", "rollsim run paper-default --out DIR (README's main job)", "<=", 7.0, "s"),
    Wait("render", f"rollsim render paper-default --frames {RENDER_FRAMES} --out DIR, over the engine's "
         "end-to-end rate", ">=", 0.9, "x"),
    Wait("sweep", f"rollsim {shlex.join(TOUR_SWEEP)} --out DIR (the tour's sweep)", "<=", 8.0, "s"),
    Wait("describe", "rollsim describe paper-default", "<=", 0.3, "s"),
    Wait("default-effects", "one 1080p frame, default effects, one core (paper-geometric)", "<=", 10.0, "ms/frame"),
    Wait("blooming", "one 1080p frame, effect-blooming's chain, one core", "<=", 15.0, "ms/frame"),
)
KEYS = tuple(w.key for w in WAITS)


def fresh_process_seconds(args: Sequence[str], out: Optional[Path]) -> float:
    """Wall seconds of ``rollsim ARGS [--out OUT]`` as a fresh process; raises with its stderr if it fails."""
    from rollsim.bench.render import rollsim_command

    return timed_process([*rollsim_command(), *args] + (["--out", str(out)] if out is not None else []))[0]


def render_share(workdir: Path, k: int) -> float:
    """``rollsim render paper-default --frames 300``'s frames/s over the engine's end-to-end rate just before."""
    from rollsim.bench.render import end_to_end_frames_per_s
    from rollsim.scene import load_scene

    engine = end_to_end_frames_per_s(load_scene("paper-default"), RENDER_FRAMES, RENDER_WORKERS, repeats=1)[0]
    seconds = fresh_process_seconds(["render", "paper-default", "--frames", str(RENDER_FRAMES), "--quiet",
                                     "--workers", str(RENDER_WORKERS)], workdir / f"render{k}")
    return RENDER_FRAMES / seconds / engine


def one_core_ms(scene_name: str) -> float:
    """Median ms of one 1080p frame's render (its stages and truth) on one core."""
    from rollsim.bench.common import one_opencv_thread
    from rollsim.bench.render import render_ms_per_frame
    from rollsim.scene import load_scene

    with one_opencv_thread():
        return render_ms_per_frame(load_scene(scene_name), ONE_CORE_FRAMES)


def measure_once(key: str, workdir: Path, k: int) -> float:
    """One measurement of row ``key`` (seconds, ms per frame or a ratio); outputs under ``workdir``."""
    out = workdir / f"{key}{k}"
    if key == "paper":
        return fresh_process_seconds(["paper", "--quiet"], out)
    if key == "paper-quick":
        return fresh_process_seconds(["paper", "--quick", "--quiet"], out)
    if key == "run":
        return fresh_process_seconds(["run", "paper-default", "--quiet"], out)
    if key == "render":
        return render_share(workdir, k)
    if key == "sweep":
        return fresh_process_seconds(TOUR_SWEEP, out)
    if key == "describe":
        return fresh_process_seconds(["describe", "paper-default"], None)
    if key == "default-effects":
        return one_core_ms("paper-geometric")
    if key == "blooming":
        return one_core_ms("effect-blooming")
    raise ValueError(f"no wait named {key!r}; the waits: {', '.join(KEYS)}")


def summary(wait: Wait, values: Sequence[float]) -> dict:
    """A row's figures: every value, the median, the smallest and largest, and whether the median meets the target."""
    figures = spread(values)
    median = figures["median"]
    met = median <= wait.target if wait.comparison == "<=" else median >= wait.target
    return {"key": wait.key, "what": wait.what, "unit": wait.unit, "target": wait.target,
            "comparison": wait.comparison, "values": [float(v) for v in values], **figures, "met": bool(met)}


def chosen(only: Sequence[str] = (), everything: bool = False) -> list[Wait]:
    """The rows to measure: those named in ``only`` (in the table's order), else every one not slow (all with ``everything``)."""
    unknown = sorted(set(only) - set(KEYS))
    if unknown:
        raise ValueError(f"--only {unknown[0]}: no such wait; the waits: {', '.join(KEYS)}")
    if only:
        return [w for w in WAITS if w.key in only]
    return [w for w in WAITS if everything or not w.slow]


def bench_waits(waits: Sequence[Wait], repeats: int = REPEATS,
                progress: Optional[Callable[[str], None]] = None) -> dict:
    """Every chosen row measured ``repeats`` times, JSON-ready."""
    say = progress or (lambda text: None)
    rows = []
    with tempfile.TemporaryDirectory(prefix="rollsim-waits-") as tmp:
        workdir = Path(tmp)
        write_bytecode()
        for wait in waits:
            values = []
            for k in range(repeats):
                say(f"{wait.key}: run {k + 1} of {repeats}")
                values.append(measure_once(wait.key, workdir, k))
            rows.append(summary(wait, values))
    return {"repeats": repeats, "machine": machine(), "rows": rows}


def table_rows(result: dict) -> list[tuple[str, str, str, str]]:
    """``(what, median (min … max) unit, target, met)`` per row."""
    return [(r["what"], f"{r['median']:.2f} ({r['min']:.2f} … {r['max']:.2f}) {r['unit']}",
             f"{r['comparison']} {r['target']:g} {r['unit']}", "yes" if r["met"] else "NO") for r in result["rows"]]


HEADER = ("what the user waits for", "median (min … max)", "target", "met")


def main(args) -> int:
    from rollsim.plumbing.outputs import check_file_targets, write_file

    try:
        waits = chosen(args.only or (), args.all)
    except ValueError as exc:
        print(f"rollsim: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        check_file_targets([args.json], args.force)  # refused before any work
    progress = None if args.quiet else (lambda text: print(f"rollsim: bench waits: {text}", file=sys.stderr,
                                                           flush=True))
    result = strict_floats(bench_waits(waits, args.repeats, progress))
    print(f"rollsim bench waits: {result['repeats']} runs each on {result['machine'].get('cpus', '?')} CPUs")
    print(format_table(table_rows(result), HEADER))
    if args.json:
        write_file(args.json, json.dumps(result, indent=2, allow_nan=False) + "\n", force=args.force)
    return 0
