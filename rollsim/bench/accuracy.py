"""``rollsim bench accuracy SCENE``: what accuracy costs in time.

For every fidelity knob (:data:`rollsim.bench.variants.KNOBS`), each setting
is measured against the knob's most accurate setting, the *reference*, on the
same frames and seed:

* **time**: median ms of ``RenderPipeline.render`` per frame, in one process
  with OpenCV on one thread, after a warm-up frame; the settings of a knob
  are rendered in turn frame by frame, so that a busy machine slows them
  alike. Also the setup time (per-scene constants, once per scene): where
  a knob's work is per scene (a lens PSF), its cost is there.
* **image error** of the noiseless image (the scene without its noise
  effects): RMS and largest difference in output DN, PSNR and SSIM
  (:mod:`rollsim.bench.image_error`), and the RMS of the mean electrons
  before the ADC, which shows differences below one output level.
  Demosaicing has no exact setting: every method is compared with the
  full-colour image, each pixel's three channels read from the four CFA
  phases of the mosaic (:func:`full_colour_image`), and the reference is
  the method closest to it.
* **noise distribution** (noise methods, whose noiseless image is the same):
  two-sample Kolmogorov-Smirnov distance between the ADC values of flat
  fields (:func:`rollsim.bench.variants.flat_field_overrides`) at a few
  electrons and higher signals, with the distance two independent
  reference flat fields have (another seed) as the floor.
* **decode outcomes**: the percentage of emitted PHY-SDUs whose outcome
  equals the reference's (matched on tx index), and the MMBP fit (p_e, M)
  of each setting's outcomes with its change against the reference.

And each effect's own cost: ms per frame with the effect (the scene's
parameters, or the defaults) minus without it, the two rendered in turn
(:func:`rollsim.bench.effect_cost.effect_cost`, which ``rollsim bench
render`` shares).
"""

from __future__ import annotations

import csv
import io
import json
import math
import shlex
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rollsim.plumbing.text_tables import format_table, markdown_table
from rollsim.bench.common import machine, strict_floats
from rollsim.bench.effect_cost import effect_cost, timed_pipeline
from rollsim.bench.image_error import IMAGE_FIELDS, ImageError, data_range_of
from rollsim.sweeps.stream import DecodedRun, fitted_mmbp
from rollsim.bench.variants import (
    KNOBS,
    Knob,
    KnobScenes,
    flat_field_levels_e,
    flat_field_overrides,
    knob_scenes,
)
from rollsim.errors import OutputError, RollsimError
from rollsim.sensor.cfa import CFA_PATTERNS, cfa_channels

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

SSIM_FRAMES = 4  # frames whose SSIM is computed, spread over the run
FLAT_FIELD_FRAMES = 1  # frames per flat field (a 1080p frame holds 2 M samples)
MAX_AMBIENT_LUX = 1e7  # the scene key's limit
OUTPUT_FILES = ("accuracy.csv", "effects_cost.csv", "accuracy.json", "accuracy.md", "accuracy_pareto.png")


def ssim_frame_indices(n_frames: int, count: int = SSIM_FRAMES) -> list[int]:
    """Up to ``count`` frame indices spread evenly over ``n_frames``."""
    return sorted({int(round(i)) for i in np.linspace(0, n_frames - 1, min(count, n_frames))})


# ------------------------------------------------------------- full colour


def full_colour_image(mosaics: dict[str, np.ndarray]) -> np.ndarray:
    """The RGB image a sensor with all three channels at every pixel would give.

    Each of the four Bayer patterns puts R, B and (twice) G on every pixel
    once, so each pixel's channel values are read from the mosaics of the
    pattern that gives the pixel that channel.

    Parameters
    ----------
    mosaics : dict of str to ndarray, shape (H, W)
        The same frame rendered with each pattern of :data:`CFA_PATTERNS`.

    Returns
    -------
    ndarray, shape (H, W, 3), the mosaics' dtype, RGB order
    """
    shape = next(iter(mosaics.values())).shape
    out = np.zeros(shape + (3,), dtype=next(iter(mosaics.values())).dtype)
    filled = np.zeros(shape + (3,), dtype=bool)
    for pattern, mosaic in mosaics.items():
        channels = cfa_channels(pattern, shape)
        for c in range(3):
            take = (channels == c) & ~filled[..., c]
            out[..., c][take] = mosaic[take]
            filled[..., c] |= take
    if not filled.all():
        raise ValueError(f"the patterns {sorted(mosaics)} do not give every pixel all three channels")
    return out


class _FullColourReference:
    """Noiseless full-colour frames of a knob's scene (its CFA pattern varied)."""

    def __init__(self, scenes: KnobScenes, knob: Knob):
        from rollsim.render import RenderPipeline

        # gray8 output of a mosaic is the 8-bit mosaic the demosaicing reads.
        self._pipelines = {
            pattern: RenderPipeline(
                scenes.scene(knob.settings[0], noiseless=True, extra=[f"effects.bayer.pattern={pattern}", "camera.output=gray8"])
            )
            for pattern in CFA_PATTERNS
        }

    def frame(self, index: int) -> np.ndarray:
        return full_colour_image({p: pipeline.render(index).image for p, pipeline in self._pipelines.items()})


# ---------------------------------------------------------- measurements


def image_errors(knob: Knob, scenes: KnobScenes, n_frames: int) -> dict[str, dict]:
    """Error of each setting's noiseless frames against the reference's (or the full-colour image)."""
    from rollsim.render import RenderPipeline

    pipelines = {s.label: RenderPipeline(scenes.scene(s, noiseless=True)) for s in knob.settings}
    full_colour = _FullColourReference(scenes, knob) if knob.full_colour else None
    reference = knob.settings[0].label
    ssim_frames = set(ssim_frame_indices(n_frames))
    errors: dict[str, ImageError] = {}
    for index in range(n_frames):
        states = {label: pipeline.run_stages(index) for label, pipeline in pipelines.items()}
        target = full_colour.frame(index) if full_colour is not None else states[reference].image
        for label, state in states.items():
            image = _stage_array(state.image, "image")
            if label not in errors:
                adc_bits = pipelines[label].setup.scene.camera.adc_bits
                errors[label] = ImageError(data_range_of(image, adc_bits))
            errors[label].add(_stage_array(target, "image"), image, ssim=index in ssim_frames)
            if full_colour is None:
                errors[label].add_electrons(_stage_array(states[reference].electrons, "electrons"),
                                            _stage_array(state.electrons, "electrons"))
    return {label: error.result() for label, error in errors.items()}


def decoded_runs(knob: Knob, scenes: KnobScenes, n_frames: int, warmup: int = 1) -> dict[str, tuple]:
    """Each setting's frames rendered (timed) and decoded, the settings in turn frame by frame.

    Returns
    -------
    dict
        label -> (DecodedRun, setup ms).
    """
    runs = {}
    for setting in knob.settings:
        pipeline, setup_ms = timed_pipeline(scenes.scene(setting))
        runs[setting.label] = (DecodedRun(pipeline), setup_ms)
    for index in range(warmup):
        for run, _ in runs.values():
            run.pipeline.render(index)
    for index in range(n_frames):
        for run, _ in runs.values():
            run.step(index)
    return runs


def _stage_array(array: np.ndarray | None, name: str) -> np.ndarray:
    """A frame state's array that the render's stages always fill."""
    if array is None or array.size == 0:
        raise RuntimeError(f"the render left the frame's {name} empty")
    return array


def _flat_field_dn(scene: Scene, n_frames: int) -> np.ndarray:
    from rollsim.render import RenderPipeline

    pipeline = RenderPipeline(scene, fuse=False)  # each stage fills its own field: the DN too
    return np.concatenate([_stage_array(pipeline.run_stages(index).dn, "dn").ravel() for index in range(n_frames)])


def _background_e_per_lux(scene: Scene) -> float:
    """Mean photo-electrons per pixel per lux of ambient light in a flat field of ``scene``."""
    from rollsim.render import RenderPipeline

    setup = RenderPipeline(scene).setup
    lux = scene.environment.ambient_lux
    return float(np.mean(setup.background_e_per_s)) * scene.camera.exposure_s / lux


def noise_distances(knob: Knob, scenes: KnobScenes, n_frames: int = FLAT_FIELD_FRAMES) -> dict:
    """Kolmogorov-Smirnov distance of each setting's flat fields from the reference's.

    Returns
    -------
    dict
        ``levels_e`` (mean photo-electrons per pixel), ``floor`` (distance
        of the reference from itself with another seed, per level) and
        ``distances`` (label -> one distance per level; None for a level
        the scene cannot reach).
    """
    from scipy.stats import ks_2samp

    reference = knob.settings[0]
    ref_scene = scenes.scene(reference)
    reflectance = ref_scene.environment.background_reflectance or 0.5
    probe_lux = 1000.0
    e_per_lux = _background_e_per_lux(scenes.scene(reference, extra=flat_field_overrides(probe_lux, reflectance)))
    levels = flat_field_levels_e(ref_scene)
    floor: list[float | None] = []
    distances: dict[str, list[float | None]] = {s.label: [] for s in knob.settings}
    for level in levels:
        lux = level / e_per_lux if e_per_lux > 0 else math.inf
        if not lux <= MAX_AMBIENT_LUX:
            floor.append(None)
            for values in distances.values():
                values.append(None)
            continue
        flat = flat_field_overrides(lux, reflectance)
        samples = {s.label: _flat_field_dn(scenes.scene(s, extra=flat), n_frames) for s in knob.settings}
        another_seed = (ref_scene.seed + 1) % 2**63
        other_seed = _flat_field_dn(scenes.scene(reference, extra=[*flat, f"seed={another_seed}"]), n_frames)
        floor.append(float(ks_2samp(samples[reference.label], other_seed).statistic))
        for label, sample in samples.items():
            distances[label].append(float(ks_2samp(samples[reference.label], sample).statistic))
    return {"levels_e": levels, "frames": n_frames, "floor": floor, "distances": distances}


def outcome_agreement_pct(reference: list[dict], outcomes: list[dict]) -> float | None:
    """Percentage of emissions (by tx index, either side) whose outcome is the same."""
    ref = {o["tx"]: o["outcome"] for o in reference}
    other = {o["tx"]: o["outcome"] for o in outcomes}
    keys = ref.keys() | other.keys()
    if not keys:
        return None
    return 100.0 * sum(ref.get(tx) == other.get(tx) for tx in keys) / len(keys)


def _change(value, reference):
    return None if value is None or reference is None else value - reference


def _decode_figures(run: DecodedRun) -> dict:
    evaluation = run.evaluation()
    mmbp = fitted_mmbp(evaluation, run.truth, run.pipeline.setup.scene)
    summary = evaluation.summary
    return {
        "outcomes": evaluation.outcomes,
        "emissions": summary["emissions"],
        "ok_pct": None if summary["error_rate"] is None else 100.0 * (1.0 - summary["error_rate"]),
        "false_decodes": summary["false_decodes"],
        "p_e": None if mmbp is None else mmbp["p_e"],
        "M": None if mmbp is None else mmbp["M"],
    }


def measure_knob(scene: Scene, knob: Knob, n_frames: int) -> dict:
    """Every setting of ``knob`` on ``scene`` against the reference (see the module docstring)."""
    scenes = knob_scenes(scene, knob)
    labels = [s.label for s in knob.settings]
    errors = None if knob.noise else image_errors(knob, scenes, n_frames)
    reference = labels[0]
    if knob.full_colour and errors is not None:
        found = errors
        reference = min(labels, key=lambda label: (found[label]["rms_dn"], labels.index(label)))
    noise = noise_distances(knob, scenes) if knob.noise else None
    runs = decoded_runs(knob, scenes, n_frames)
    decode = {label: _decode_figures(run) for label, (run, _) in runs.items()}
    ref_ms = 1e3 * float(np.median(runs[reference][0].render_s))
    rows = []
    for label in labels:
        run, setup_ms = runs[label]
        ms = 1e3 * float(np.median(run.render_s))
        figures = decode[label]
        row = {
            "setting": label,
            "reference": label == reference,
            "ms_per_frame": ms,
            "time_vs_reference": ms / ref_ms,
            "setup_ms": setup_ms,
            **(errors[label] if errors is not None else dict.fromkeys(IMAGE_FIELDS)),
            "ks_distance": noise["distances"][label] if noise is not None else None,
            "emissions": figures["emissions"],
            "agreement_pct": outcome_agreement_pct(decode[reference]["outcomes"], figures["outcomes"]),
            "ok_pct": figures["ok_pct"],
            "false_decodes": figures["false_decodes"],
            "p_e": figures["p_e"],
            "p_e_change": _change(figures["p_e"], decode[reference]["p_e"]),
            "M": figures["M"],
            "M_change": _change(figures["M"], decode[reference]["M"]),
        }
        rows.append(row)
    return {
        "knob": knob.name,
        "key": knob.key,
        "effect_added": scenes.added,
        "noise": knob.noise,
        "reference": reference,
        "compared_with": "full colour" if knob.full_colour else ("flat fields" if knob.noise else reference),
        "flat_field": None if noise is None else {k: noise[k] for k in ("levels_e", "frames", "floor")},
        "settings": rows,
    }


def bench_accuracy(scene: Scene, n_frames: int = 30, knobs=KNOBS, effects=None, progress=None) -> dict:
    """Run the accuracy benchmark on a scene; a JSON-ready dict (no NaN or inf).

    Parameters
    ----------
    scene : Scene
    n_frames : int
        Frames per setting (the same indices 0 … n_frames − 1 for all).
    knobs : sequence of Knob
    effects : sequence of str, optional
        Effects whose own cost to measure; default every registered effect.
    progress : callable, optional
        Called with one line of text per step.
    """
    import cv2

    from rollsim.scene.effects import EFFECT_NAMES

    say = progress or (lambda text: None)
    effects = EFFECT_NAMES if effects is None else tuple(effects)
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    start = time.perf_counter()
    try:
        measured = []
        for number, knob in enumerate(knobs, start=1):
            began = time.perf_counter()
            say(f"[{number}/{len(knobs)}] {knob.name} ({knob.key}): {', '.join(s.label for s in knob.settings)}")
            measured.append(measure_knob(scene, knob, n_frames))
            say(f"      done in {time.perf_counter() - began:.0f} s")
        say(f"effect costs: {len(effects)} effects")
        costs = [effect_cost(scene, name, n_frames) for name in effects]
    finally:
        cv2.setNumThreads(threads)
    return {
        "scene": scene.name,
        "resolution": f"{scene.camera.width_px}x{scene.camera.height_px}",
        "output": scene.camera.output,
        "frames": n_frames,
        "ssim_frames": ssim_frame_indices(n_frames),
        "machine": machine(),
        "opencv_threads": 1,
        "seconds": time.perf_counter() - start,
        "knobs": [strict_floats(k) for k in measured],
        "effects_cost": [strict_floats(c) for c in costs],
    }


# ------------------------------------------------------------------ output

ACCURACY_COLUMNS = (
    "knob", "key", "setting", "reference", "effect_added", "compared_with", "ms_per_frame", "time_vs_reference",
    "setup_ms", "rms_dn", "max_abs_dn", "psnr_db", "identical", "ssim", "rms_e", "ks_d_low", "ks_d_mid", "ks_d_high",
    "emissions", "agreement_pct", "ok_pct", "false_decodes", "p_e", "p_e_change", "M", "M_change",
)
COST_COLUMNS = ("effect", "listed", "ms_with", "ms_without", "ms_added", "setup_ms_added", "parameters", "note")


def accuracy_rows(result: dict) -> list[dict]:
    """One flat row per knob setting (the CSV's columns)."""
    rows = []
    for knob in result["knobs"]:
        for row in knob["settings"]:
            ks = list(row["ks_distance"] or [])
            ks += [None] * (3 - len(ks))
            flat = {k: row[k] for k in ACCURACY_COLUMNS if k in row}
            flat.update(knob=knob["knob"], key=knob["key"], effect_added=knob["effect_added"],
                        compared_with=knob["compared_with"], ks_d_low=ks[0], ks_d_mid=ks[1], ks_d_high=ks[-1])
            rows.append(flat)
    return rows


def _csv_cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, dict):
        return " ".join(f"{k}={v}" for k, v in value.items())
    return str(value)


def to_csv(rows: list[dict], columns) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([_csv_cell(row.get(c)) for c in columns])
    return buffer.getvalue()


def _num(value, spec: str = ".3g", none: str = "n/a") -> str:
    return none if value is None else format(value, spec)


def _with_change(value, change, spec: str) -> str:
    if value is None:
        return "n/a"
    return f"{value:{spec}} ({change:+{spec}})" if change else f"{value:{spec}}"


def table_rows(result: dict) -> list[tuple]:
    """The accuracy table for the terminal and docs/accuracy.md, one row per setting."""
    out = []
    for knob in result["knobs"]:
        for row in knob["settings"]:
            psnr = "inf" if row["identical"] else _num(row["psnr_db"], ".1f", "")
            ks = "" if row["ks_distance"] is None else " / ".join(_num(d, ".3f") for d in row["ks_distance"])
            out.append((
                knob["knob"],
                row["setting"] + (" (ref)" if row["reference"] else ""),
                f"{row['ms_per_frame']:.1f}",
                f"{row['time_vs_reference']:.2f}",
                f"{row['setup_ms']:.0f}",
                _num(row["rms_dn"], ".3g", ""),
                _num(row["max_abs_dn"], ".0f", ""),
                psnr,
                _num(row["ssim"], ".5f", ""),
                _num(row["rms_e"], ".2g", ""),
                ks,
                _num(row["agreement_pct"], ".1f"),
                _with_change(row["p_e"], row["p_e_change"], ".3g"),
                _with_change(row["M"], row["M_change"], "d"),
            ))
    return out


TABLE_HEADER = ("knob", "setting", "ms/frame", "x ref", "setup ms", "RMS DN", "max DN", "PSNR dB", "SSIM", "RMS e-",
                "KS D (low/mid/high)", "same outcome %", "p_e (change)", "M (change)")


def cost_table_rows(result: dict) -> list[tuple]:
    rows = []
    for c in result["effects_cost"]:
        if c["ms_added"] is None:
            rows.append((c["effect"], "yes" if c["listed"] else "no", "", "", "", "", c["note"]))
            continue
        rows.append((c["effect"], "yes" if c["listed"] else "no", f"{c['ms_with']:.1f}", f"{c['ms_without']:.1f}",
                     f"{c['ms_added']:+.1f}", f"{c['setup_ms_added']:+.0f}", c["note"]))
    return rows


COST_HEADER = ("effect", "in scene", "ms/frame with", "without", "added", "setup ms added", "note")


def flat_field_lines(result: dict) -> list[str]:
    lines = []
    for knob in result["knobs"]:
        flat = knob["flat_field"]
        if flat is None:
            continue
        levels = ", ".join(_num(level, ".3g") for level in flat["levels_e"])
        floor = " / ".join(_num(d, ".4f") for d in flat["floor"])
        lines.append(f"{knob['knob']}: flat fields at {levels} photo-electrons per pixel; "
                     f"KS floor (the reference against another seed) {floor}")
    return lines


def format_accuracy(result: dict) -> str:
    lines = [
        f"rollsim bench accuracy: {result['scene']} at {result['resolution']} ({result['output']}), "
        f"{result['frames']} frames per setting, one core; SSIM on frames {result['ssim_frames']}",
        format_table(table_rows(result), TABLE_HEADER),
        *flat_field_lines(result),
    ]
    if result["effects_cost"]:
        lines += ["", "ms/frame added by each effect (with it minus without it, rendered in turn):",
                  format_table(cost_table_rows(result), COST_HEADER)]
    return "\n".join(lines)


def format_markdown(result: dict) -> str:
    """Both tables as Markdown."""

    lines = [
        f"`{result.get('command', 'rollsim bench accuracy')}`: {result['scene']} at {result['resolution']} "
        f"({result['output']}), {result['frames']} frames per setting, one core, {result['machine']['cpus']} CPUs; "
        f"SSIM on frames {result['ssim_frames']}.",
        "",
        *markdown_table(table_rows(result), TABLE_HEADER),
        "",
        *[f"- {line}" for line in flat_field_lines(result)],
    ]
    if result["effects_cost"]:
        lines += ["", *markdown_table(cost_table_rows(result), COST_HEADER)]
    return "\n".join(lines)


def output_paths(out_dir: Path, force: bool) -> dict[str, Path]:
    """The output files in ``out_dir``; refuses existing ones without ``force`` (before any work).

    ``out_dir`` may be missing (its parent must exist): it is created when
    the results are written.
    """
    from rollsim.plumbing.outputs import check_file_targets

    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise OutputError(f"{out_dir}: exists and is not a directory")
    if not out_dir.exists() and not out_dir.resolve().parent.is_dir():
        raise OutputError(f"{out_dir}: parent directory {out_dir.resolve().parent} does not exist")
    paths = {name: out_dir / name for name in OUTPUT_FILES}
    if out_dir.exists():
        check_file_targets(paths.values(), force)
    return paths


def write_outputs(result: dict, paths: dict[str, Path], force: bool = False) -> None:
    """CSV tables, JSON, Markdown tables and the Pareto plot, committed together."""
    from rollsim.plumbing.outputs import figure_png, write_files
    from rollsim.report.plots import plot_accuracy_pareto

    write_files({
        paths["accuracy.csv"]: to_csv(accuracy_rows(result), ACCURACY_COLUMNS),
        paths["effects_cost.csv"]: to_csv(result["effects_cost"], COST_COLUMNS),
        paths["accuracy.json"]: json.dumps(result, indent=2, allow_nan=False) + "\n",
        paths["accuracy.md"]: format_markdown(result) + "\n",
        paths["accuracy_pareto.png"]: figure_png(lambda f: plot_accuracy_pareto(result["knobs"], f)),
    }, force=force)


def command_line(args) -> str:
    """The command that reproduces a run (without --force)."""
    words = ["rollsim", "bench", "accuracy", args.scene, "--frames", str(args.frames)]
    for item in args.overrides:
        words += ["--set", item]
    if args.knobs:
        words += ["--knobs", *args.knobs]
    if args.effects is not None:
        words += ["--effects", *args.effects]
    if args.out:
        words += ["--out", args.out]
    return shlex.join(words)


def main(args) -> int:
    from rollsim.bench.variants import knob_by_name
    from rollsim.scene import load_scene

    from rollsim.scene.effects import EFFECT_NAMES

    knobs = [knob_by_name(name) for name in args.knobs] if args.knobs else list(KNOBS)
    unknown = sorted(set(args.effects or ()) - set(EFFECT_NAMES))
    if unknown:
        raise RollsimError(f"unknown effect {', '.join(unknown)}; effects: {', '.join(EFFECT_NAMES)}")
    scene = load_scene(args.scene, args.overrides)
    paths = output_paths(Path(args.out), args.force) if args.out else None
    progress = None if args.quiet else (lambda text: print(text, file=sys.stderr, flush=True))
    result = bench_accuracy(scene, args.frames, knobs, args.effects, progress=progress)
    result = {"command": command_line(args), **result}
    print(format_accuracy(result))
    if paths is not None:
        write_outputs(result, paths, force=args.force)
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0
