"""``rollsim bench render``: render speed at 1920x1080 and memory flatness."""

from __future__ import annotations

from typing import Any

import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rollsim.text_tables import format_table
from rollsim.bench.common import machine, seconds_per_call
from rollsim.outputs import write_file
from rollsim.render import RenderPipeline
from rollsim.render.writer import encode_png, render_to_dir
from rollsim.scene import load_scene

SCENE = "paper-geometric"  # the core pipeline's speed; the glare's cost is in bench accuracy
VARIANTS = {
    "core only (no effects)": ["effects=[]"],
    "default effects, Poisson shot noise": [],
    "default effects, Gaussian shot noise": ["effects.shot_noise.method=gaussian"],
}


def in_memory_ms_per_frame(overrides: list[str], frames: int) -> float:
    """Median ms to render one 1080p frame in memory, on one core."""
    pipeline = RenderPipeline(load_scene(SCENE, overrides))
    return 1e3 * seconds_per_call(pipeline.render, frames)


def png_ms_per_frame(frames: int) -> float:
    """Median ms to PNG-encode one rendered 1080p frame."""
    image = RenderPipeline(load_scene(SCENE)).render(0).image
    return 1e3 * seconds_per_call(lambda _: encode_png(image), frames)


def end_to_end_frames_per_s(frames: int, workers: int, repeats: int = 3) -> list[float]:
    """Frames per second of ``render_to_dir`` (render, encode, write), per repeat.

    Writing ~2 MB per frame makes the figure depend on the disk's write-back
    at the time, so the run is repeated and every figure reported.
    """
    scene = load_scene(SCENE)
    rates = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            render_to_dir(scene, Path(tmp) / "out", frames, workers=workers)
            rates.append(frames / (time.perf_counter() - start))
    return rates


def peak_rss_mb(frames: int, workers: int) -> float:
    """Peak resident memory (MB) of any process of a ``rollsim render`` run.

    Measured as the children's ``ru_maxrss`` of a fresh interpreter that runs
    the render, so that this process's own memory does not count.
    """
    tmp = tempfile.mkdtemp()
    code = (
        "import resource, sys; from pathlib import Path;"
        "from rollsim.render.writer import render_to_dir; from rollsim.scene import load_scene;"
        f"render_to_dir(load_scene({SCENE!r}), Path({tmp!r}) / 'out', {frames}, workers={workers});"
        "own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss;"
        "kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss;"
        "print(max(own, kids))"
    )
    try:
        out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return int(out.strip().splitlines()[-1]) / 1024.0


def bench_render(frames: int = 20, e2e_frames: int = 120, rss_frames: tuple[int, int] = (200, 2000), workers: int = 2) -> dict:
    """Run the render benchmark; returns a JSON-ready dict."""
    result: dict[str, Any] = {"scene": SCENE, "resolution": "1920x1080", "machine": machine(),
                              "in_memory_ms_per_frame": {}}
    for name, overrides in VARIANTS.items():
        result["in_memory_ms_per_frame"][name] = round(in_memory_ms_per_frame(overrides, frames), 1)
    result["png_encode_ms_per_frame"] = round(png_ms_per_frame(frames), 1)
    rates = sorted(end_to_end_frames_per_s(e2e_frames, workers))
    result["end_to_end_frames_per_s"] = round(rates[len(rates) // 2], 1)
    result["end_to_end_frames_per_s_runs"] = [round(r, 1) for r in rates]
    result["workers"] = workers
    result["peak_rss_mb"] = {str(n): round(peak_rss_mb(n, workers), 1) for n in rss_frames}
    return result


def format_render(result: dict) -> str:
    rows = [(name, ms) for name, ms in result["in_memory_ms_per_frame"].items()]
    rows.append(("PNG encoding of one frame", result["png_encode_ms_per_frame"]))
    text = [f"rollsim bench render: {result['scene']} at {result['resolution']}, one core", format_table(rows, ("what", "ms/frame"))]
    runs = ", ".join(map(str, result["end_to_end_frames_per_s_runs"]))
    text.append(
        f"end to end (render + PNG + write, {result['workers']} workers): median {result['end_to_end_frames_per_s']} "
        f"frames/s (runs: {runs})"
    )
    rss = ", ".join(f"{n} frames: {mb} MB" for n, mb in result["peak_rss_mb"].items())
    text.append(f"peak RSS of one process: {rss}")
    return "\n".join(text)


def main(args) -> int:
    result = bench_render(frames=args.frames, e2e_frames=args.e2e_frames, rss_frames=tuple(args.rss_frames), workers=args.workers)
    print(format_render(result))
    if args.json:
        write_file(args.json, json.dumps(result, indent=2) + "\n", force=args.force)
    return 0
