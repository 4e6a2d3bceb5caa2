"""``rollsim bench video``: what video costs at 1080p: rendering to H.264, reading it back.

Each encoding renders the same frames of a scene to a video with ``rollsim
render --container mp4``'s own code (:func:`rollsim.render.writer.render_to_dir`,
two workers rendering while this process encodes) and to PNG frames for
comparison; then the video is read back as ``rollsim decode`` reads it
(:func:`rollsim.video.read.read_video_frames`). Rates are whole runs
(frames over wall time, the pipeline's set-up included) and, for long
renders, the rate after the first second's frames; reads are the median
of repeated passes over the file.
"""

from __future__ import annotations

import json
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Sequence

from rollsim.bench.common import machine
from rollsim.plumbing.text_tables import format_table

SCENE = "paper-default"
FRAMES = 150
# The encodings timed: rollsim's default, the same tuned for fast decoding
# (CAVLC, no deblocking), x264's superfast as x264 ships it (3 B-frames),
# and the fastest preset.
ENCODINGS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("default: superfast, no B-frames", {}),
    ("superfast, fastdecode", {"tune": "fastdecode"}),
    ("superfast, 3 B-frames (x264's own)", {"b_frames": 3}),
    ("ultrafast, no B-frames", {"preset": "ultrafast"}),
)
# The targets: rendering to H.264 at the default settings, and reading a frame back.
TARGET_FRAMES_PER_S = 60.0
TARGET_READ_MS = 3.0
READ_PASSES = 2


@dataclass(frozen=True)
class RenderTiming:
    """One render's rates (frames/s): over the whole run, and after its first GOP (start-up
    and the pipeline's filling left out); the read back in ms per frame, where timed."""

    whole_frames_per_s: float
    steady_frames_per_s: float
    read_ms_per_frame: Optional[float] = None


def render_rate(scene, frames: int, workers: int, video=None, read_back: bool = False) -> RenderTiming:
    """Time writing ``frames`` frames of ``scene`` (a video, or PNGs when ``video`` is None);
    with ``read_back``, also the median over :data:`READ_PASSES` of the ms per frame to read
    the video back."""
    from rollsim.render.writer import render_to_dir
    from rollsim.video.read import read_video_frames
    from rollsim.video.write import video_name

    skip = min(frames - 1, int(round(scene.camera.frame_rate_hz)))  # a one-second GOP
    written: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        start = time.perf_counter()
        render_to_dir(scene, out, frames, workers=workers, video=video,
                      progress=lambda n: written.append(time.perf_counter()))
        end = time.perf_counter()
        whole = frames / (end - start)
        steady = (frames - 1 - skip) / (written[-1] - written[skip]) if frames - 1 > skip else whole
        if not read_back or video is None:
            return RenderTiming(whole, steady)
        passes = []
        for _ in range(READ_PASSES):
            start = time.perf_counter()
            count = sum(1 for _ in read_video_frames(out / video_name(video)))
            passes.append((time.perf_counter() - start) / max(1, count))
    return RenderTiming(whole, steady, 1e3 * sorted(passes)[len(passes) // 2])


def bench_video(frames: int = FRAMES, encodings: Sequence[tuple[str, dict]] = ENCODINGS, workers: int = 2,
                scene_name: str = SCENE, overrides: Optional[list] = None) -> dict:
    """Run the video benchmark; a JSON-ready dict."""
    from rollsim.scene import load_scene
    from rollsim.video.settings import VideoSettings

    scene = load_scene(scene_name, overrides or [])
    png = render_rate(scene, frames, workers)
    rows: list[dict[str, Any]] = []
    for name, given in encodings:
        settings = VideoSettings(**given)
        timing = render_rate(scene, frames, workers, settings, read_back=True)
        assert timing.read_ms_per_frame is not None  # a video was written and read back
        rows.append({"encoding": name, "settings": settings.describe(), "default": settings == VideoSettings(),
                     "render_frames_per_s": round(timing.whole_frames_per_s, 1),
                     "steady_frames_per_s": round(timing.steady_frames_per_s, 1),
                     "read_ms_per_frame": round(timing.read_ms_per_frame, 2)})
    cam = scene.camera
    return {"scene": scene_name, "resolution": f"{cam.width_px}x{cam.height_px}", "output": cam.output,
            "frames": frames, "workers": workers, "machine": machine(), "png_frames_per_s": round(png.whole_frames_per_s, 1),
            "png_steady_frames_per_s": round(png.steady_frames_per_s, 1),
            "encoding": "h264, 17 Mb/s, one-second GOP, 4:2:0", "encodings": rows,
            "targets": {"render_frames_per_s": TARGET_FRAMES_PER_S, "read_ms_per_frame": TARGET_READ_MS}}


def _met(value: float, target: float, above: bool) -> str:
    return "met" if (value >= target if above else value <= target) else "not met"


def format_video(result: dict) -> str:
    rows = [(r["encoding"], r["render_frames_per_s"], r["steady_frames_per_s"],
             _met(r["render_frames_per_s"], TARGET_FRAMES_PER_S, True), r["read_ms_per_frame"],
             _met(r["read_ms_per_frame"], TARGET_READ_MS, False)) for r in result["encodings"]]
    header = ("encoding", "frames/s, whole run", "after the first GOP", f"≥ {TARGET_FRAMES_PER_S:g} (whole run)",
              "read back, ms/frame", f"≤ {TARGET_READ_MS:g}")
    return "\n".join([
        f"rollsim bench video: {result['scene']} {result['resolution']} {result['output']}, {result['frames']} frames, "
        f"{result['workers']} workers, {result['encoding']}; PNG frames: {result['png_frames_per_s']} frames/s "
        f"({result['png_steady_frames_per_s']} after the first GOP)",
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
