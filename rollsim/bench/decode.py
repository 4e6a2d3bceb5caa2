"""``rollsim bench decode``: decoder speed on 1080p frames, and PNG reading apart."""

from __future__ import annotations

from typing import Any

import json
import tempfile
from pathlib import Path

import cv2

from rollsim.plumbing.text_tables import format_table
from rollsim.bench.common import machine, seconds_per_call
from rollsim.render import render_frames
from rollsim.render.png import encode_png
from rollsim.scene import load_scene
from rollsim.stages.decode import settings_from_scene

SCENES = ("paper-default", "paper-10cm", "stress-saturation")


def decode_ms_per_frame(scene_name: str, frames: int) -> tuple[float, float]:
    """Median ms to decode one rendered frame in memory, and to read it from PNG.

    OpenCV is held to one thread, so the figures are for one core.
    """
    from decoder import decode_frame, read_frame

    scene = load_scene(scene_name)
    images, _ = render_frames(scene, frames)
    settings = settings_from_scene(scene)
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        decode = 1e3 * seconds_per_call(
            lambda i: decode_frame(images[i % frames], settings.phy, settings.clock_hz, settings.row_time_s, i,
                                   exposure_s=settings.exposure_s), frames
        )
        with tempfile.TemporaryDirectory() as tmp:
            paths = []
            for index, image in enumerate(images):
                path = Path(tmp) / f"frame_{index:06d}.png"
                path.write_bytes(encode_png(image))
                paths.append(path)
            read = 1e3 * seconds_per_call(lambda i: read_frame(paths[i % frames]), frames)
    finally:
        cv2.setNumThreads(threads)
    return decode, read


def bench_decode(frames: int = 30, scenes=SCENES) -> dict:
    """Run the decode benchmark; a JSON-ready dict."""
    result: dict[str, Any] = {"resolution": "1920x1080", "frames": frames, "machine": machine(), "scenes": {}}
    for name in scenes:
        decode, read = decode_ms_per_frame(name, frames)
        result["scenes"][name] = {"decode_ms_per_frame": round(decode, 2), "png_read_ms_per_frame": round(read, 2)}
    return result


def format_decode(result: dict) -> str:
    rows = [(name, r["decode_ms_per_frame"], r["png_read_ms_per_frame"]) for name, r in result["scenes"].items()]
    header = ("scene", "decode ms/frame (in memory)", "PNG read ms/frame")
    return "\n".join(
        [
            f"rollsim bench decode: {result['resolution']}, one core, median of {result['frames']} frames",
            format_table(rows, header),
        ]
    )


def main(args) -> int:
    from rollsim.plumbing.outputs import write_file

    result = bench_decode(args.frames)
    print(format_decode(result))
    if args.json:
        write_file(args.json, json.dumps(result, indent=2, allow_nan=False) + "\n", force=args.force)
    return 0
