"""``rollsim bench video``: what video costs at 1080p: rendering to H.264, reading it back.

Each preset renders the same frames of a scene to a video with ``rollsim
render --container mp4``'s own code (:func:`rollsim.render.writer.render_to_dir`,
two workers rendering while this process encodes) and to PNG frames for
comparison; then the video is read back as ``rollsim decode`` reads it
(:func:`rollsim.video.read.read_video_frames`). Rates are whole runs
(frames over wall time, the pipeline's set-up included), reads are the
median of repeated passes over the file.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path
from typing import Any, Optional, Sequence

from rollsim.bench.common import machine
from rollsim.plumbing.text_tables import format_table

SCENE = "paper-default"
FRAMES = 150
PRESETS = ("superfast", "ultrafast")
# The targets: rendering to H.264 at the default settings, and reading a frame back.
TARGET_FRAMES_PER_S = 60.0
TARGET_READ_MS = 3.0
READ_PASSES = 2


def render_rate(scene, frames: int, workers: int, video=None, read_back: bool = False) -> tuple[float, float | None]:
    """Frames per second of writing ``frames`` frames of ``scene`` (a video, or PNGs when
    ``video`` is None); with ``read_back``, also the median over :data:`READ_PASSES` of the
    ms per frame to read the video back (None otherwise)."""
    from rollsim.render.writer import render_to_dir
    from rollsim.video.read import read_video_frames
    from rollsim.video.write import video_name

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        start = time.perf_counter()
        render_to_dir(scene, out, frames, workers=workers, video=video)
        rate = frames / (time.perf_counter() - start)
        if not read_back or video is None:
            return rate, None
        passes = []
        for _ in range(READ_PASSES):
            start = time.perf_counter()
            count = sum(1 for _ in read_video_frames(out / video_name(video)))
            passes.append((time.perf_counter() - start) / max(1, count))
    return rate, 1e3 * sorted(passes)[len(passes) // 2]


def bench_video(frames: int = FRAMES, presets: Sequence[str] = PRESETS, workers: int = 2,
                scene_name: str = SCENE, overrides: Optional[list] = None) -> dict:
    """Run the video benchmark; a JSON-ready dict."""
    from rollsim.scene import load_scene
    from rollsim.video.settings import DEFAULT_PRESET, VideoSettings

    scene = load_scene(scene_name, overrides or [])
    png, _ = render_rate(scene, frames, workers)
    rows: list[dict[str, Any]] = []
    for preset in presets:
        rate, read_ms = render_rate(scene, frames, workers, VideoSettings(preset=preset), read_back=True)
        assert read_ms is not None  # a video was written and read back
        rows.append({"preset": preset, "default": preset == DEFAULT_PRESET, "render_frames_per_s": round(rate, 1),
                     "read_ms_per_frame": round(read_ms, 2)})
    cam = scene.camera
    return {"scene": scene_name, "resolution": f"{cam.width_px}x{cam.height_px}", "output": cam.output,
            "frames": frames, "workers": workers, "machine": machine(), "png_frames_per_s": round(png, 1),
            "encoding": "h264, 17 Mb/s, one-second GOP, 4:2:0", "presets": rows,
            "targets": {"render_frames_per_s": TARGET_FRAMES_PER_S, "read_ms_per_frame": TARGET_READ_MS}}


def format_video(result: dict) -> str:
    rows = [(r["preset"] + (" (default)" if r["default"] else ""), r["render_frames_per_s"],
             "met" if r["render_frames_per_s"] >= TARGET_FRAMES_PER_S else "not met", r["read_ms_per_frame"],
             "met" if r["read_ms_per_frame"] <= TARGET_READ_MS else "not met") for r in result["presets"]]
    header = ("preset", "render to video, frames/s", f"≥ {TARGET_FRAMES_PER_S:g}", "read back, ms/frame",
              f"≤ {TARGET_READ_MS:g}")
    return "\n".join([
        f"rollsim bench video: {result['scene']} {result['resolution']} {result['output']}, {result['frames']} frames, "
        f"{result['workers']} workers, {result['encoding']}; PNG frames: {result['png_frames_per_s']} frames/s",
        format_table(rows, header)])


def main(args) -> int:
    from rollsim.plumbing.outputs import check_file_targets, write_file

    if args.json:
        check_file_targets([args.json], args.force)
    result = bench_video(args.frames, workers=args.workers or 2)
    print(format_video(result))
    if args.json:
        write_file(args.json, json.dumps(result, indent=2, allow_nan=False) + "\n", force=args.force)
    return 0
