"""``rollsim bench stress``: the decoder's outcome rates on the stress scenes.

Each scene is rendered in memory, decoded and evaluated against its truth
(:func:`rollsim.sweeps.stream.scene_outcomes`), frame by frame in constant memory; scenes run in
parallel. The table it prints (``--markdown``) is the stress table of docs/evaluation.md.
"""

from __future__ import annotations

import json

from rollsim.plumbing.text_tables import format_table, markdown_table
from rollsim.bench.common import machine
from rollsim.sweeps.stream import scene_outcomes
from rollsim.plumbing.parallel import process_pool
from rollsim.scene import bundled_scene_paths, load_scene, read_yaml

# The scenes of the table by default: the paper's, the stress set and one
# per optional effect.
DEFAULT_PREFIXES = ("paper-", "stress-", "effect-")


def default_scenes() -> list[str]:
    """Names of the bundled paper, stress and effect scenes."""
    return [p.stem for p in bundled_scene_paths() if p.stem.startswith(DEFAULT_PREFIXES)]


def _run_one(name: str, n_frames: int, other_decoder: str | None) -> tuple[str, str, dict]:
    scene = load_scene(name)
    path = next((p for p in bundled_scene_paths() if p.stem == name), None)
    description = read_yaml(path).get("description", "") if path is not None else scene.name
    return name, description, scene_outcomes(scene, n_frames, other_decoder)


def bench_stress(scenes: list[str], n_frames: int, workers: int = 2, progress=None,
                 other_decoder: str | None = None) -> dict:
    """Outcome rates of every scene; a JSON-ready dict.

    With ``other_decoder`` (``package.module:function``), each scene's
    frames are also decoded by it, and its summary is the row's ``other``.
    """
    from rollsim.stages.decode import load_decoder

    for name in scenes:
        load_scene(name)  # fail on a bad scene before any work
    if other_decoder is not None:
        load_decoder(other_decoder)  # and on a decoder that cannot be loaded
    rows = []
    with process_pool(max(1, workers)) as pool:
        n = len(scenes)
        for name, description, summary in pool.map(_run_one, scenes, [n_frames] * n, [other_decoder] * n):
            rows.append({"scene": name, "description": description, **summary})
            if progress is not None:
                progress(name)
    return {"frames": n_frames, "machine": machine(), "other_decoder": other_decoder, "scenes": rows}


def _percent(value) -> str:
    return "n/a" if value is None else f"{100 * value:.2f}"


def table_rows(result: dict) -> list[tuple]:
    """One row per scene: counts, rates and times."""
    rows = []
    for r in result["scenes"]:
        rows.append(
            (
                r["scene"],
                r["fully_visible"],
                _percent(None if not r["fully_visible"] else 1.0 - r["error_rate"]),
                _percent(r["corrupted_rate"]),
                _percent(r["missed_rate"]),
                r["counts"]["undetected_error"],
                f"{r['false_decodes_per_1000_frames']:.1f}",
                f"{r['render_ms_per_frame']:.0f}",
                f"{r['decode_ms_per_frame']:.1f}",
            )
        )
    return rows


HEADER = (
    "scene", "fully visible", "ok %", "corrupted %", "missed %", "undetected errors",
    "false decodes / 1000 frames", "render ms/frame", "decode ms/frame",
)


COMPARISON_HEADER = ("scene", "fully visible", "ok % rollsim", "ok % other", "false decodes rollsim",
                     "false decodes other", "decode ms/frame rollsim", "decode ms/frame other")


def comparison_rows(result: dict) -> list[tuple]:
    """One row per scene: rollsim's decoder against the other on the same frames."""
    rows = []
    for r in result["scenes"]:
        o = r["other"]
        ok = [None if not s["fully_visible"] else 1.0 - s["error_rate"] for s in (r, o)]
        rows.append((r["scene"], r["fully_visible"], _percent(ok[0]), _percent(ok[1]), r["false_decodes"],
                     o["false_decodes"], f"{r['decode_ms_per_frame']:.1f}", f"{o['decode_ms_per_frame']:.1f}"))
    return rows


def format_markdown(result: dict) -> str:
    """The stress table as Markdown, with each scene's description below it."""
    if result.get("other_decoder"):
        lines = [f"Other decoder: `{result['other_decoder']}`", ""]
        lines += markdown_table(comparison_rows(result), COMPARISON_HEADER) + [""]
    else:
        lines = markdown_table(table_rows(result), HEADER) + [""]
    lines += [f"- `{r['scene']}`: {r['description']}" for r in result["scenes"]]
    return "\n".join(lines)


def main(args) -> int:
    from rollsim.plumbing.outputs import write_files

    scenes = args.scenes or default_scenes()
    result = bench_stress(scenes, args.frames, args.workers, other_decoder=args.decoder)
    print(f"rollsim bench stress: {args.frames} frames per scene, rendered, decoded and evaluated in memory")
    if args.decoder:
        print(f"rollsim's decoder against {args.decoder} on the same frames")
        print(format_table(comparison_rows(result), COMPARISON_HEADER))
    else:
        print(format_table(table_rows(result), HEADER))
    contents = {args.markdown: format_markdown(result) + "\n", args.json: json.dumps(result, indent=2, allow_nan=False) + "\n"}
    write_files({path: text for path, text in contents.items() if path}, force=args.force)
    return 0
