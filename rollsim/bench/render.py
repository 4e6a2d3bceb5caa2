"""``rollsim bench render``: render speed at 1920x1080 against its targets, and memory flatness.

Every figure is a median time per frame (ms) or a rate (frames/s), printed
beside its target (:data:`TARGETS`) where one exists:

1. **stage profile** of the default-effects render: each stage of
   ``RenderPipeline(scene).stages`` called in turn on one
   :class:`~rollsim.render_contract.state.FrameState`, as ``run_stages`` does, each
   timed; the median per stage and of the frame's total. Nothing here
   depends on the stages' names, so fused or renamed stages profile alike.
   Also ``render`` itself (the stages plus the truth record) of the core
   alone and of the default effects with either shot-noise method.
2. **PNG floor**: ms to encode one frame as the writer does
   (:func:`~rollsim.render.png.encode_png` with the frame's text
   chunks), and the rate that PNG encoding alone would allow on N workers,
   N x 1000 / ms. The end-to-end rate (render, encode and write with
   ``render_to_dir``) is given as a fraction of that floor.
3. **each effect's marginal cost**: ms per frame with the effect minus
   without it, the two rendered in turn
   (:func:`rollsim.bench.effect_cost.effect_cost`), for every effect of
   :data:`rollsim.effects.REGISTRY`, with the parameters of the bundled
   ``effect-*`` scene that shows it (else its defaults). The heavy effects
   (:data:`HEAVY_EFFECTS`) have no target.
4. **in-memory render + decode**, the pixel stage of a sweep
   (:class:`rollsim.sweeps.stream.DecodedRun`, no PNG): frames/s on one core, and
   on N worker processes at once.
5. **start-up**: wall seconds of ``rollsim render SCENE --frames 1`` and
   ``rollsim describe paper-default`` as fresh processes, median of a few.
6. **peak memory** of a render of few and of many frames: flat.

One-core figures are measured in this process with OpenCV on one thread.
The end-to-end runs are what ``rollsim render`` does (its worker processes
keep OpenCV's default threads); the in-memory workers each run on one
OpenCV thread, one core each.
"""

from __future__ import annotations

import contextlib
import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Optional, Sequence

import numpy as np

from rollsim.bench.common import machine, one_opencv_thread, seconds_per_call, strict_floats, write_bytecode
from rollsim.bench.effect_cost import effect_cost
from rollsim.plumbing.outputs import write_file
from rollsim.plumbing.text_tables import format_table

if TYPE_CHECKING:
    from multiprocessing.synchronize import Barrier

    from rollsim.scene.model import Scene

SCENE = "paper-geometric"  # the core pipeline's speed; the glare's cost is in bench accuracy
DESCRIBE_SCENE = "paper-default"
VARIANTS = {
    "core only (no effects)": ["effects=[]"],
    "default effects, Poisson shot noise": [],
    "default effects, Gaussian shot noise": ["effects.shot_noise.method=gaussian"],
}
DEFAULT_VARIANT = "default effects, Poisson shot noise"

# The effects the speed targets leave out as heavy (motion blur, defocus, and
# the recording's video encoder and decoder): their cost is printed without a target.
HEAVY_EFFECTS = ("motion", "defocus", "video_codec")
# defocus's focus distance is relative to the LED's distance: it stays at
# effect_pair's rule (1.5x the distance, effect-defocus's own ratio).
SCENE_RELATIVE_PARAMETERS = ("defocus",)

# Target per figure: (comparison, value, unit). On "both cores" = 2 workers.
TARGETS: dict[str, tuple[str, float, str]] = {
    "default_effects_ms_per_frame": ("<=", 15.0, "ms/frame"),  # one core
    "end_to_end_frames_per_s": (">=", 45.0, "frames/s"),  # both cores
    "effect_ms_added": ("<=", 10.0, "ms/frame"),  # every effect but the heavy ones
    "in_memory_decode_frames_per_s": (">=", 60.0, "frames/s"),  # both cores
    "render_one_frame_s": ("<=", 0.8, "s"),
    "describe_s": ("<=", 0.4, "s"),
}
# Memory is flat when the long run's peak is within this of the short run's.
MEMORY_GROWTH_FACTOR = 1.2
MEMORY_SLACK_MB = 20.0

# Frame counts and repeats: the full run and --quick. The 2,000-frame memory
# run (4 GB of PNGs) takes most of the full run's time.
DEFAULT_COUNTS: dict[str, Any] = {
    "frames": 20, "effect_frames": 6, "decode_frames": 30, "decode_repeats": 3, "e2e_frames": 120, "e2e_repeats": 3,
    "rss_frames": (200, 2000), "startup_runs": 3,
}
QUICK_COUNTS: dict[str, Any] = {
    "frames": 5, "effect_frames": 3, "decode_frames": 10, "decode_repeats": 1, "e2e_frames": 40, "e2e_repeats": 1,
    "rss_frames": (50, 250), "startup_runs": 1,
}


def _load(scene: str, overrides: Sequence[str], extra: Sequence[str] = ()) -> Scene:
    from rollsim.scene import load_scene

    return load_scene(scene, [*overrides, *extra])


def meets(value: float | None, comparison: str, target: float) -> bool | None:
    """Whether ``value`` meets a target (None when there is no value)."""
    if value is None:
        return None
    return value <= target if comparison == "<=" else value >= target


# ----------------------------------------------------------- 1. one core


def render_ms_per_frame(scene: Scene, frames: int) -> float:
    """Median ms of ``RenderPipeline.render`` per frame (stages and truth), after a warm-up frame."""
    from rollsim.render import RenderPipeline

    return 1e3 * seconds_per_call(RenderPipeline(scene).render, frames)


def stage_profile(scene: Scene, frames: int, warmup: int = 1) -> dict:
    """Median ms per frame of each stage of ``scene``'s render pipeline, and of their total.

    The stages are called one by one on a fresh
    :class:`~rollsim.render_contract.state.FrameState` per frame, as
    ``RenderPipeline.run_stages`` calls them.

    Returns
    -------
    dict
        ``effects`` (the scene's), ``frames``, ``stages`` (one entry per
        stage, in pipeline order: ``stage`` name, ``slot``, ``ms_per_frame``
        and ``share_pct`` of the total) and ``total_ms_per_frame`` (median
        of each frame's sum over the stages).
    """
    from rollsim.render import RenderPipeline
    from rollsim.render_contract.state import FrameState

    pipeline = RenderPipeline(scene)
    stages = pipeline.stages
    seconds: list[list[float]] = [[] for _ in stages]
    totals = []
    for index in range(warmup + frames):
        state = FrameState(pipeline.setup, index)
        times = []
        for stage in stages:
            start = time.perf_counter()
            stage(state)
            times.append(time.perf_counter() - start)
        if index >= warmup:
            for per_stage, elapsed in zip(seconds, times):
                per_stage.append(elapsed)
            totals.append(sum(times))
    total_ms = 1e3 * float(np.median(totals))
    rows = []
    for stage, per_stage in zip(stages, seconds):
        ms = 1e3 * float(np.median(per_stage))
        rows.append({"stage": str(getattr(stage, "name", stage)), "slot": getattr(stage, "slot", None),
                     "ms_per_frame": ms, "share_pct": 100.0 * ms / total_ms if total_ms > 0 else None})
    return {"effects": list(scene.effects.enabled()), "frames": frames, "stages": rows,
            "total_ms_per_frame": total_ms}


# --------------------------------------------------------- 2. PNG floor


def png_ms_per_frame(scene: Scene, frames: int) -> float:
    """Median ms to PNG-encode one rendered frame, as the writer does (with its text chunks)."""
    from rollsim.render import RenderPipeline
    from rollsim.render.png import encode_png
    from rollsim.render.writer import frame_text

    frame = RenderPipeline(scene).render(0)
    text = frame_text(scene, frame.truth)
    return 1e3 * seconds_per_call(lambda _: encode_png(frame.image, text), frames)


def png_floor_frames_per_s(png_ms: float, workers: int) -> float:
    """Frames/s that PNG encoding alone allows on ``workers`` processes: N x 1000 / ms."""
    return workers * 1e3 / png_ms


def end_to_end_frames_per_s(scene: Scene, frames: int, workers: int, repeats: int = 3) -> list[float]:
    """Frames per second of ``render_to_dir`` (render, encode, write), per repeat.

    Writing ~2 MB per frame makes the figure depend on the disk's write-back
    at the time, so the run is repeated and every figure reported.
    """
    from rollsim.render.writer import render_to_dir

    rates = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            render_to_dir(scene, Path(tmp) / "out", frames, workers=workers)
            rates.append(frames / (time.perf_counter() - start))
    return rates


# ------------------------------------------------------- 3. effect costs


def bundled_effect_parameters() -> dict[str, tuple[str, dict]]:
    """Effect name -> (bundled scene, parameters) of every effect an ``effect-*`` scene lists.

    An effect's own scene (``effect-<name>``) wins; otherwise the first
    scene by name that lists it. Effects whose parameters are relative to
    the scene (:data:`SCENE_RELATIVE_PARAMETERS`) are left out.
    """
    from rollsim.scene import bundled_scene_paths, load_scene

    found: dict[str, tuple[str, dict]] = {}
    for path in bundled_scene_paths():
        if not path.stem.startswith("effect-"):
            continue
        for effect, params in load_scene(path.stem).effects.listed():
            if effect.name in SCENE_RELATIVE_PARAMETERS:
                continue
            entry = (path.stem, params.model_dump(mode="json"))
            if path.stem == f"effect-{effect.name}":
                found[effect.name] = entry
            else:
                found.setdefault(effect.name, entry)
    return found


def effect_costs(scene: Scene, frames: int, effects: Optional[Iterable[str]] = None, progress=None) -> list[dict]:
    """Each effect's marginal cost on ``scene`` (:func:`~rollsim.bench.effect_cost.effect_cost`), with its target.

    Parameters
    ----------
    scene : Scene
    frames : int
        Frames rendered with and without each effect.
    effects : iterable of str, optional
        Default: every effect of :data:`rollsim.effects.REGISTRY`, in its order.
    progress : callable, optional
        Called with one line of text per effect.

    Returns
    -------
    list of dict
        The rows of :func:`effect_cost` plus ``parameters_from`` (the scene,
        a bundled ``effect-*`` scene, or the defaults), ``heavy``,
        ``target_ms`` (None for a heavy effect) and ``met``.
    """
    from rollsim.effects import REGISTRY

    names = [effect.name for effect in REGISTRY] if effects is None else list(effects)
    bundled = bundled_effect_parameters()
    comparison, target, _ = TARGETS["effect_ms_added"]
    rows = []
    for number, name in enumerate(names, start=1):
        if progress is not None:
            progress(f"      effect {number}/{len(names)}: {name}")
        listed = name in scene.effects.enabled()
        relative = name in SCENE_RELATIVE_PARAMETERS
        source, params = bundled.get(name, (f"effect-{name}, scaled" if relative else "defaults", None))
        row = effect_cost(scene, name, frames, None if listed else params)
        heavy = name in HEAVY_EFFECTS
        row.update(parameters_from=scene.name if listed else source, heavy=heavy,
                   target_ms=None if heavy else target,
                   met=None if heavy else meets(row["ms_added"], comparison, target))
        rows.append(row)
    return rows


# --------------------------------------------- 4. render + decode in memory


def in_memory_one_core(scene: Scene, frames: int) -> dict:
    """Render and decode ``frames`` frames in memory in this process, as a sweep cell does.

    Returns
    -------
    dict
        ``frames_per_s`` (wall time of the frames after a warm-up frame),
        and the median ``render_ms_per_frame`` and ``decode_ms_per_frame``.
    """
    from rollsim.render import RenderPipeline
    from rollsim.sweeps.stream import DecodedRun

    run = DecodedRun(RenderPipeline(scene), measure_stripes=True)
    run.step(0)
    start = time.perf_counter()
    for index in range(1, frames + 1):
        run.step(index)
    elapsed = time.perf_counter() - start
    return {"frames": frames, "frames_per_s": frames / elapsed,
            "render_ms_per_frame": 1e3 * float(np.median(run.render_s[1:])),
            "decode_ms_per_frame": 1e3 * float(np.median(run.decode_s[1:]))}


_WORKER: dict[str, Any] = {}


def _init_in_memory_worker(scene: Scene, barrier: Barrier) -> None:
    import cv2

    from rollsim.render import RenderPipeline

    cv2.setNumThreads(1)  # one core per worker process
    _WORKER.update(pipeline=RenderPipeline(scene), barrier=barrier)


def _in_memory_chunk(indices: list[int]) -> tuple[float, float]:
    """Step a chunk's frames once all workers are ready; (start, end) in monotonic seconds."""
    from rollsim.sweeps.stream import DecodedRun

    run = DecodedRun(_WORKER["pipeline"], measure_stripes=True)
    run.step(indices[0])  # warm-up
    _WORKER["barrier"].wait()
    start = time.monotonic()  # system-wide on Linux: comparable between processes
    for index in indices:
        run.step(index)
    return start, time.monotonic()


def in_memory_workers_frames_per_s(scene: Scene, frames_per_worker: int, workers: int) -> float:
    """Frames/s of ``workers`` processes rendering and decoding in memory at once.

    Each worker steps its own block of frames; all start together (a
    barrier, after building the pipeline and a warm-up frame), and the rate
    is all their frames over the span from the first start to the last end.
    """
    from rollsim.plumbing.parallel import pool_context, process_pool

    context = pool_context()  # the barrier must come from the pool's own context
    barrier = context.Barrier(workers, timeout=600)
    chunks = [list(range(w * frames_per_worker, (w + 1) * frames_per_worker)) for w in range(workers)]
    # A pool even for one worker: the figure is always that of worker processes.
    with process_pool(workers, _init_in_memory_worker, (scene, barrier), context=context) as pool:
        spans = [future.result() for future in [pool.submit(_in_memory_chunk, chunk) for chunk in chunks]]
    start = min(s for s, _ in spans)
    end = max(e for _, e in spans)
    return workers * frames_per_worker / (end - start)


# ----------------------------------------------------------- 5. start-up


def rollsim_command() -> list[str]:
    """The ``rollsim`` command of this Python: its console script, else ``python -m rollsim``."""
    script = Path(sys.executable).with_name("rollsim")
    return [str(script)] if script.exists() else [sys.executable, "-m", "rollsim"]


def startup_seconds(args: Sequence[str], runs: int, out_arg: bool = False) -> list[float]:
    """Wall seconds of ``rollsim ARGS`` as a fresh process, per run.

    With ``out_arg``, ``--out DIR`` is added, a directory that does not
    exist yet (in a temporary directory removed afterwards). The modules'
    bytecode is written first (:func:`rollsim.bench.common.write_bytecode`),
    and one untimed run reads the files the command needs into the page
    cache, as any first run of an install does.
    """
    seconds = []
    tmp = tempfile.mkdtemp()
    write_bytecode()
    try:
        for run in range(-1, runs):
            argv = [*rollsim_command(), *args] + (["--out", str(Path(tmp) / f"out{run + 1}")] if out_arg else [])
            start = time.perf_counter()
            subprocess.run(argv, check=True, capture_output=True)
            if run >= 0:
                seconds.append(time.perf_counter() - start)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return seconds


def startup_figures(scene: str, overrides: Sequence[str], runs: int) -> dict:
    """Median wall seconds (and every run) of ``rollsim render --frames 1`` and ``rollsim describe``."""
    render_args = ["render", scene, "--frames", "1", *[f"--set={item}" for item in overrides]]
    describe_args = ["describe", DESCRIBE_SCENE]
    figures = {}
    for key, args, out in (("render", render_args, True), ("describe", describe_args, False)):
        seconds = startup_seconds(args, runs, out_arg=out)
        figures[key] = {"command": shlex.join(["rollsim", *args] + (["--out", "TMPDIR"] if out else [])),
                        "median_s": float(np.median(seconds)), "runs_s": seconds}
    return figures


# ------------------------------------------------------------ 6. memory


def peak_rss_mb(scene: str, overrides: Sequence[str], frames: int, workers: int) -> float:
    """Peak resident memory (MB) of any process of a ``rollsim render`` run.

    Measured as the children's ``ru_maxrss`` of a fresh interpreter that runs
    the render, so that this process's own memory does not count.
    """
    tmp = tempfile.mkdtemp()
    code = (
        "import resource, sys; from pathlib import Path;"
        "from rollsim.render.writer import render_to_dir; from rollsim.scene import load_scene;"
        f"render_to_dir(load_scene({scene!r}, {list(overrides)!r}), Path({tmp!r}) / 'out', {frames}, workers={workers});"
        "own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss;"
        "kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss;"
        "print(max(own, kids))"
    )
    try:
        out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return int(out.strip().splitlines()[-1]) / 1024.0


def memory_is_flat(few_mb: float, many_mb: float) -> bool:
    """Whether the peak of the long run is within :data:`MEMORY_GROWTH_FACTOR` (+ slack) of the short run's."""
    return many_mb <= few_mb * MEMORY_GROWTH_FACTOR + MEMORY_SLACK_MB


# ------------------------------------------------------------ the bench


def bench_render(
    frames: int = DEFAULT_COUNTS["frames"],
    e2e_frames: int = DEFAULT_COUNTS["e2e_frames"],
    rss_frames: tuple[int, int] = DEFAULT_COUNTS["rss_frames"],
    workers: int = 2,
    *,
    effect_frames: int = DEFAULT_COUNTS["effect_frames"],
    decode_frames: int = DEFAULT_COUNTS["decode_frames"],
    decode_repeats: int = DEFAULT_COUNTS["decode_repeats"],
    e2e_repeats: int = DEFAULT_COUNTS["e2e_repeats"],
    startup_runs: int = DEFAULT_COUNTS["startup_runs"],
    effects: Optional[Iterable[str]] = None,
    scene: str = SCENE,
    overrides: Sequence[str] = (),
    progress: Optional[Callable[[str], None]] = None,
) -> dict:
    """Run the render benchmark; returns a JSON-ready dict (no NaN or inf).

    Parameters
    ----------
    frames : int
        Frames timed for the stage profile, each ``render`` variant and the PNG encoding.
    e2e_frames : int
        Frames of each end-to-end run (``render_to_dir``).
    rss_frames : (int, int)
        Frame counts of the two peak-memory runs.
    workers : int
        Worker processes of the end-to-end, in-memory and memory runs (2: both cores here).
    effect_frames : int
        Frames rendered with and without each effect.
    decode_frames : int
        Frames rendered and decoded in memory on one core, and by each worker.
    decode_repeats : int
        Runs of the workers rendering and decoding in memory (the median counts).
    e2e_repeats : int
        End-to-end runs.
    startup_runs : int
        Runs of each start-up command.
    effects : iterable of str, optional
        Effects whose cost to measure (default: every registered effect).
    scene : str
        Scene file or bundled scene name.
    overrides : sequence of str
        ``--set`` overrides of the scene (e.g. a smaller frame for a quick check).
    progress : callable, optional
        Called with one line of text per step.
    """
    if not 0 < rss_frames[0] < rss_frames[1]:
        raise ValueError(f"rss_frames must be two increasing frame counts, got {rss_frames}")
    say = progress or (lambda text: None)
    began = time.perf_counter()
    base = _load(scene, overrides)
    result: dict[str, Any] = {
        "scene": base.name, "overrides": list(overrides),
        "resolution": f"{base.camera.width_px}x{base.camera.height_px}", "output": base.camera.output,
        "machine": machine(), "workers": workers, "opencv_threads_one_core": 1,
        "counts": {"frames": frames, "effect_frames": effect_frames, "decode_frames": decode_frames,
                   "decode_repeats": decode_repeats,
                   "e2e_frames": e2e_frames, "e2e_repeats": e2e_repeats, "rss_frames": list(rss_frames),
                   "startup_runs": startup_runs},
        "targets": {key: {"comparison": c, "value": v, "unit": u} for key, (c, v, u) in TARGETS.items()},
        "heavy_effects": list(HEAVY_EFFECTS),
        # Other work on the machine slows every figure: say how busy it was
        # (at the start, the end, and after each part).
        "load_average_1min": {"start": os.getloadavg()[0]},
    }
    seconds: dict[str, float] = {}
    loads: dict[str, float] = {}

    @contextlib.contextmanager
    def part(name: str, text: str):
        say(f"[{len(seconds) + 1}/6] {text}")
        start = time.perf_counter()
        yield
        seconds[name] = time.perf_counter() - start
        loads[name] = os.getloadavg()[0]
        say(f"      {seconds[name]:.0f} s, load average {loads[name]:.1f}")

    with part("stages", f"stage profile and render variants, {frames} frames each"), one_opencv_thread():
        result["stage_profile"] = stage_profile(base, frames)
        result["in_memory_ms_per_frame"] = {name: render_ms_per_frame(_load(scene, overrides, extra), frames)
                                            for name, extra in VARIANTS.items()}
    with part("png", f"PNG encoding, {frames} frames; end to end, {e2e_repeats} x {e2e_frames} frames on {workers} "
              "workers"):
        with one_opencv_thread():
            result["png_encode_ms_per_frame"] = png_ms_per_frame(base, frames)
        result["png_floor_frames_per_s"] = png_floor_frames_per_s(result["png_encode_ms_per_frame"], workers)
        runs = sorted(end_to_end_frames_per_s(base, e2e_frames, workers, e2e_repeats))
        result["end_to_end_frames_per_s"] = runs[len(runs) // 2]
        result["end_to_end_frames_per_s_runs"] = runs
        result["end_to_end_vs_png_floor"] = result["end_to_end_frames_per_s"] / result["png_floor_frames_per_s"]
    with part("effects", f"effect costs, {effect_frames} frames with and without each"), one_opencv_thread():
        result["effects_cost"] = effect_costs(base, effect_frames, effects, progress=say)
    with part("in_memory", f"render + decode in memory, {decode_frames} frames on one core, then per worker "
              f"({decode_repeats} runs)"):
        with one_opencv_thread():
            decode = in_memory_one_core(base, decode_frames)
        # Repeated, as the end-to-end runs: work elsewhere on the machine hits the multi-core figures most.
        runs = sorted(in_memory_workers_frames_per_s(base, decode_frames, workers) for _ in range(decode_repeats))
        decode.update(frames_per_s_workers=runs[len(runs) // 2], frames_per_s_workers_runs=runs)
        result["in_memory_decode"] = {"workers": workers, **decode}
    with part("startup", f"start-up, {startup_runs} runs of each command"):
        result["startup"] = startup_figures(scene, overrides, startup_runs)
    with part("memory", f"peak memory, {rss_frames[0]} and {rss_frames[1]} frames on {workers} workers"):
        rss = {str(n): peak_rss_mb(scene, overrides, n, workers) for n in rss_frames}
        result["peak_rss_mb"] = rss
        result["memory_flat"] = memory_is_flat(*rss.values())
    result["part_seconds"] = seconds
    result["load_average_1min"].update(end=os.getloadavg()[0], after_part=loads)
    result["summary"] = summary_rows(result)
    result["seconds"] = time.perf_counter() - began
    return strict_floats(result)


def summary_rows(result: dict) -> list[dict]:
    """One row per target: ``what``, ``key``, ``measured`` (number), ``unit``, ``target``, ``met``."""

    def row(what: str, key: str, measured, detail: str = "") -> dict:
        comparison, value, unit = TARGETS[key]
        return {"what": what, "key": key, "measured": measured, "unit": unit, "detail": detail,
                "target": f"{comparison} {value:g} {unit}", "met": meets(measured, comparison, value)}

    workers = result["workers"]
    rows = [row("default effects: render, one core", "default_effects_ms_per_frame",
                result["in_memory_ms_per_frame"][DEFAULT_VARIANT]),
            row(f"end to end to PNG, {workers} workers", "end_to_end_frames_per_s", result["end_to_end_frames_per_s"],
                f"{result['end_to_end_vs_png_floor']:.2f}x the PNG floor")]
    measured = [c for c in result["effects_cost"] if not c["heavy"] and c["ms_added"] is not None]
    worst = max(measured, key=lambda c: c["ms_added"], default=None)
    over = sum(1 for c in measured if not c["met"])
    rows.append(row("every effect's marginal cost but the heavy ones", "effect_ms_added",
                    None if worst is None else worst["ms_added"],
                    "" if worst is None else f"worst: {worst['effect']}; {over} of {len(measured)} over"))
    rows.append(row(f"in memory: render + decode, {workers} workers", "in_memory_decode_frames_per_s",
                    result["in_memory_decode"]["frames_per_s_workers"]))
    rows.append(row(result["startup"]["render"]["command"], "render_one_frame_s", result["startup"]["render"]["median_s"]))
    rows.append(row(result["startup"]["describe"]["command"], "describe_s", result["startup"]["describe"]["median_s"]))
    few, many = result["peak_rss_mb"]
    rows.append({"what": f"peak memory, {few} vs {many} frames", "key": "memory_flat",
                 "measured": result["peak_rss_mb"][many], "unit": "MB",
                 "detail": f"{result['peak_rss_mb'][few]:.0f} MB at {few} frames", "target": "flat",
                 "met": result["memory_flat"]})
    return rows


# ---------------------------------------------------------------- output


def _figure(value, unit: str) -> str:
    if value is None:
        return "n/a"
    digits = 2 if unit == "s" else (0 if unit == "MB" else 1)
    return f"{value:.{digits}f} {unit}"


def _summary_row(result: dict, key: str) -> dict:
    return next(row for row in result["summary"] if row["key"] == key)


def _met(met) -> str:
    return "" if met is None else ("yes" if met else "NO")


def format_render(result: dict) -> str:
    """The benchmark's figures as text: the targets first, then each part."""
    workers = result["workers"]
    load = result["load_average_1min"]
    out = [f"rollsim bench render: {result['scene']} at {result['resolution']} ({result['output']}), "
           f"{result['machine']['cpus']} CPUs (load average {load['start']:.1f} at the start, {load['end']:.1f} at "
           f"the end); one-core figures with OpenCV on one thread",
           "", "targets",
           format_table([(r["what"], _figure(r["measured"], r["unit"]) + (f" ({r['detail']})" if r["detail"] else ""),
                          r["target"], _met(r["met"])) for r in result["summary"]],
                        ("what", "measured", "target", "met"))]

    profile = result["stage_profile"]
    target = result["targets"]["default_effects_ms_per_frame"]
    limit = f"{target['comparison']} {target['value']:g} {target['unit']}"
    rows = [(s["stage"], s["slot"] or "", f"{s['ms_per_frame']:.2f}",
             "" if s["share_pct"] is None else f"{s['share_pct']:.0f} %", "") for s in profile["stages"]]
    rows.append(("total (the stages of one frame)", "", f"{profile['total_ms_per_frame']:.2f}", "", limit))
    out += ["", f"1. stages of the default-effects render ({', '.join(profile['effects']) or 'none'}), one core, "
            f"median of {profile['frames']} frames",
            format_table(rows, ("stage", "slot", "ms/frame", "share of total", "target"))]
    variants = [(name, f"{ms:.1f}", limit if name == DEFAULT_VARIANT else "")
                for name, ms in result["in_memory_ms_per_frame"].items()]
    out += ["", "render (the stages and the truth record), one core",
            format_table(variants, ("what", "ms/frame", "target"))]

    e2e = _summary_row(result, "end_to_end_frames_per_s")
    runs = ", ".join(f"{r:.1f}" for r in result["end_to_end_frames_per_s_runs"])
    out += ["", "2. PNG floor and end to end",
            f"PNG encoding (encode_png with the frame's text), one core: {result['png_encode_ms_per_frame']:.1f} ms/frame"
            f" -> floor {result['png_floor_frames_per_s']:.1f} frames/s on {workers} workers",
            f"end to end (render + PNG + write, {workers} workers): median {result['end_to_end_frames_per_s']:.1f} "
            f"frames/s (runs: {runs}) = {result['end_to_end_vs_png_floor']:.2f}x the PNG floor; "
            f"target {e2e['target']}: {_met(e2e['met'])}"]

    costs: list[tuple] = []
    for c in result["effects_cost"]:
        name = c["effect"] + (" (heavy)" if c["heavy"] else "")
        target_text = "none (heavy)" if c["heavy"] else f"<= {c['target_ms']:g}"
        if c["ms_added"] is None:
            costs.append((name, "yes" if c["listed"] else "no", c["parameters_from"], "", "", "", target_text, "",
                         c["note"]))
            continue
        costs.append((name, "yes" if c["listed"] else "no", c["parameters_from"], f"{c['ms_with']:.1f}",
                     f"{c['ms_without']:.1f}", f"{c['ms_added']:+.1f}", target_text, _met(c["met"]), c["note"]))
    if costs:
        out += ["", f"3. each effect's marginal cost, ms/frame with it minus without it (rendered in turn, "
                f"{result['counts']['effect_frames']} frames), one core",
                format_table(costs, ("effect", "in scene", "parameters", "with", "without", "added", "target", "met",
                                    "note"))]

    decode = result["in_memory_decode"]
    memory_row = _summary_row(result, "in_memory_decode_frames_per_s")
    out += ["", f"4. in memory: render + decode, no PNG ({decode['frames']} frames per run)",
            f"one core: {decode['frames_per_s']:.1f} frames/s (render {decode['render_ms_per_frame']:.1f} + "
            f"decode {decode['decode_ms_per_frame']:.1f} ms/frame)",
            f"{workers} workers: median {decode['frames_per_s_workers']:.1f} frames/s (runs: "
            f"{', '.join(f'{r:.1f}' for r in decode['frames_per_s_workers_runs'])}); "
            f"target {memory_row['target']}: {_met(memory_row['met'])}"]

    startup = []
    for key, target_key in (("render", "render_one_frame_s"), ("describe", "describe_s")):
        figure, row = result["startup"][key], _summary_row(result, target_key)
        startup.append((figure["command"], f"{figure['median_s']:.2f} s", " ".join(f"{s:.2f}" for s in figure["runs_s"]),
                     row["target"], _met(row["met"])))
    out += ["", "5. start-up (fresh processes)", format_table(startup, ("command", "median", "runs", "target", "met"))]

    rss = ", ".join(f"{n} frames: {mb:.1f} MB" for n, mb in result["peak_rss_mb"].items())
    out += ["", f"6. peak RSS of one process ({workers} workers): {rss}; flat: {_met(result['memory_flat'])}"]
    after = result["load_average_1min"]["after_part"]
    parts = ", ".join(f"{name} {s:.0f} s (load {after[name]:.1f})" for name, s in result["part_seconds"].items())
    out += ["", f"took {result['seconds']:.0f} s: {parts}. The load average counts this benchmark too (about 1 "
            f"after one-core work, {workers} after {workers} workers): more means other work shared the CPUs"]
    return "\n".join(out)


def counts_from_args(args) -> dict:
    """Frame counts and repeats: the options given, else --quick's, else the defaults."""
    base = QUICK_COUNTS if getattr(args, "quick", False) else DEFAULT_COUNTS
    counts = {}
    for key, default in base.items():
        value = getattr(args, key, None)
        counts[key] = default if value is None else (tuple(value) if key == "rss_frames" else value)
    return counts


def main(args) -> int:
    from rollsim.errors import RollsimError
    from rollsim.effects import REGISTRY

    names = [effect.name for effect in REGISTRY]
    unknown = sorted(set(args.effects or ()) - set(names))
    if unknown:
        raise RollsimError(f"unknown effect {', '.join(unknown)}; effects: {', '.join(names)}")
    counts = counts_from_args(args)
    if not counts["rss_frames"][0] < counts["rss_frames"][1]:
        raise RollsimError(f"--rss-frames {' '.join(map(str, counts['rss_frames']))}: give a smaller, then a larger count")
    _load(args.scene, args.overrides)  # a bad scene or override: one error line before any work
    progress = None if args.quiet else (lambda text: print(text, file=sys.stderr, flush=True))
    result = bench_render(workers=args.workers, effects=args.effects, scene=args.scene, overrides=args.overrides,
                          progress=progress, **counts)
    print(format_render(result))
    if args.json:
        write_file(args.json, json.dumps(result, indent=2, allow_nan=False) + "\n", force=args.force)
    return 0
