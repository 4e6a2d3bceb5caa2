"""The ``rollsim`` command line.

Bad input (a scene, an override, a path) prints one line per problem on
stderr and exits with code 2; ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Optional, Sequence

from rollsim import __version__
from rollsim.errors import RollsimError

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2


def _add_set_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scene key, e.g. --set camera.exposure_us=50 (repeatable)",
    )


def _add_scene_output_options(parser: argparse.ArgumentParser) -> None:
    """SCENE, --out DIR and the options of commands that render a scene into a directory."""
    parser.add_argument("scene", metavar="SCENE", help="scene file or bundled scene name")
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory (must be empty, or use --force)")
    parser.add_argument("--frames", type=_positive_int, default=None, help="frame count (default: the scene's frames)")
    parser.add_argument("--seed", type=int, default=None, help="override the scene seed")
    parser.add_argument("--force", action="store_true", help="replace a non-empty output directory")
    parser.add_argument("--workers", type=_positive_int, default=None, help="worker processes (default: one per core)")
    parser.add_argument("--quiet", action="store_true", help="no progress")
    _add_set_option(parser)


def cmd_scenes(args) -> int:
    """List the bundled scenes with their one-line descriptions."""
    from rollsim.scene import bundled_scene_paths, read_yaml

    paths = bundled_scene_paths()
    width = max((len(p.stem) for p in paths), default=0)
    for path in paths:
        print(f"{path.stem:<{width}}  {read_yaml(path).get('description', '')}")
    return EXIT_OK


def cmd_validate(args) -> int:
    """Validate scene files: exit 0 if all are valid, 2 with one line per error otherwise."""
    from rollsim.scene import load_scene

    problems: list[str] = []
    for path in args.files:
        try:
            load_scene(path, args.overrides)
        except RollsimError as exc:
            problems += exc.lines
        else:
            print(f"ok    {path}")
    if problems:
        raise RollsimError(problems)
    return EXIT_OK


def cmd_describe(args) -> int:
    """Print a scene's timing, PHY-SDU, schedule and waveform summary."""
    from rollsim.describe import describe_scene, format_description

    scene = _load_scene_args(args)
    info = describe_scene(scene, emissions=args.emissions)
    print(json.dumps(info, indent=2) if args.json else format_description(info))
    return EXIT_OK


def _load_scene_args(args):
    from rollsim.scene import load_scene

    overrides = list(args.overrides)
    if getattr(args, "seed", None) is not None:
        overrides.append(f"seed={args.seed}")
    return load_scene(args.scene, overrides)


def cmd_render(args) -> int:
    """Render a scene to PNG frames, truth.jsonl and scene.resolved.yaml."""
    from tqdm import tqdm

    from rollsim.render.writer import render_to_dir

    scene = _load_scene_args(args)
    n_frames = args.frames if args.frames is not None else scene.frames
    with tqdm(total=n_frames, unit="frame", desc="render", disable=args.quiet or None) as bar:
        summary = render_to_dir(
            scene, Path(args.out), n_frames, force=args.force, workers=args.workers, progress=lambda n: bar.update(1)
        )
    print(f"wrote {summary.frames} frames of {scene.name} to {summary.out_dir} ({summary.workers} workers)")
    return EXIT_OK


def _decode_settings(args, run_dir: Path):
    """Decode settings: --scene, else the render's scene.resolved.yaml, else
    the default link (--set overrides) with --clock-hz / --row-time-us."""
    from rollsim.decode import DecodeSettings, settings_from_scene
    from rollsim.scene import load_scene, scene_from_dict
    from rollsim.transmitter import phy_from_scene

    resolved = run_dir / "scene.resolved.yaml"
    if args.scene is not None:
        scene = load_scene(args.scene, args.overrides)
    elif resolved.exists():
        scene = load_scene(resolved, args.overrides)
    else:
        if args.clock_hz is None:
            raise RollsimError(f"{run_dir}: no scene.resolved.yaml; give --scene FILE or --clock-hz F [--row-time-us T]")
        scene = scene_from_dict({}, "<default link>", args.overrides)
        # Without a row time the decoder estimates the chip pitch itself.
        row_time_s = None if args.row_time_us is None else args.row_time_us * 1e-6
        return DecodeSettings(phy_from_scene(scene), args.clock_hz, row_time_s)
    return settings_from_scene(scene, args.clock_hz, args.row_time_us)


def cmd_decode(args) -> int:
    """Decode the frames of a directory into DIR/decoded.jsonl."""
    from tqdm import tqdm

    from rollsim.decode import decode_directory, frame_files

    run_dir = Path(args.dir)
    settings = _decode_settings(args, run_dir)
    n_files = len(frame_files(run_dir))
    workers = args.workers or _default_workers()
    with tqdm(total=n_files, unit="frame", desc="decode", disable=args.quiet or None) as bar:
        summary = decode_directory(
            run_dir, settings, workers=workers, force=args.force,
            on_error=lambda e: tqdm.write(f"rollsim: skipped frame {e['frame']}: {e['error']}", file=sys.stderr),
            progress=lambda n: bar.update(1),
        )
    print(
        f"decoded {summary.frames} frames of {run_dir}: {summary.sdus} PHY-SDUs, {summary.sdus_ok} passed the check, "
        f"{len(summary.unreadable)} frames unreadable -> {run_dir / 'decoded.jsonl'}"
    )
    return EXIT_OK


def cmd_evaluate(args) -> int:
    """Give every emitted PHY-SDU its outcome; write outcomes.csv and evaluation.json."""
    from rollsim.evaluate import evaluate_directory, format_summary

    result = evaluate_directory(Path(args.dir), force=args.force)
    print(format_summary(result.summary))
    return EXIT_OK


def _png_paths(items: Sequence[str]) -> list[Path]:
    """Files as given; a directory stands for its PNG frames."""
    from rollsim.decode import frame_files

    paths: list[Path] = []
    for item in items:
        path = Path(item)
        paths.extend(frame_files(path) if path.is_dir() else [path])
    return paths


def cmd_estimate_row_time(args) -> int:
    """Row time of a camera from frames of an LED sending the square pattern."""
    from decoder import FrameReadError, RowTimeError, estimate_row_time, read_frame

    if not (math.isfinite(args.clock_hz) and args.clock_hz > 0):
        raise RollsimError(f"--clock-hz = {args.clock_hz}: must be a finite number > 0")
    skipped = []

    def readable_frames():
        for path in _png_paths(args.frames):
            try:
                yield read_frame(path)
            except FrameReadError as exc:
                skipped.append(str(exc))
                print(f"rollsim: skipped frame: {exc}", file=sys.stderr)

    try:
        row_time_s, sigma_s = estimate_row_time(readable_frames(), args.clock_hz)
    except RowTimeError as exc:
        raise RollsimError(str(exc)) from None
    result = {"row_time_us": row_time_s * 1e6, "uncertainty_us": sigma_s * 1e6, "clock_hz": args.clock_hz,
              "frames_unreadable": len(skipped)}
    if args.json:
        _write_text(args.json, json.dumps(result, indent=2, allow_nan=False) + "\n")
    print(f"row time {row_time_s * 1e6:.4f} us +- {sigma_s * 1e6:.4f} us (1 sigma), {len(skipped)} frames unreadable")
    return EXIT_OK


def cmd_calibrate(args) -> int:
    """Fit the MMBP and Gilbert-Elliott models to an outcome trace."""
    from rollsim.calibrate import calibrate, format_calibration, load_trace

    result = calibrate(load_trace(Path(args.trace)), n_packets=args.n_packets)
    print(format_calibration(result))
    if args.json:
        _write_text(args.json, json.dumps(result, indent=2, allow_nan=False) + "\n")
    return EXIT_OK


def cmd_run(args) -> int:
    """The main job: render, decode, evaluate, calibrate and report one scene."""
    from tqdm import tqdm

    from rollsim.evaluate import format_summary
    from rollsim.run import STAGES, run_scene

    scene = _load_scene_args(args)
    n_frames = args.frames if args.frames is not None else scene.frames
    bars: dict = {}

    def on_stage(stage: str, event: str) -> None:
        if event == "start":
            if not args.quiet:
                tqdm.write(f"[{STAGES.index(stage) + 1}/{len(STAGES)}] {stage}", file=sys.stderr)
            if stage in ("render", "decode"):
                bars[stage] = tqdm(total=n_frames, unit="frame", desc=stage, disable=args.quiet or None, leave=False)
        elif stage in bars:
            bars.pop(stage).close()

    def on_frame(stage: str, done: int) -> None:
        bars[stage].update(1)

    def on_skipped(error: dict) -> None:
        tqdm.write(f"rollsim: skipped frame {error['frame']}: {error['error']}", file=sys.stderr)

    try:
        summary = run_scene(scene, Path(args.out), n_frames, force=args.force, workers=args.workers or _default_workers(),
                            on_stage=on_stage, on_frame=on_frame, on_skipped=on_skipped)
    finally:
        for bar in bars.values():
            bar.close()
    print(format_summary(summary.evaluation))
    if summary.calibration is None:
        print(f"calibration not possible: {summary.calibration_error}")
    else:
        mmbp, prediction = summary.calibration["mmbp"], summary.calibration["prediction"]
        print(f"MMBP fit: M = {mmbp['M']}, N = {mmbp['N']}, p_e = {mmbp['p_e']:.4g} "
              f"(95% CI {mmbp['p_e_ci95'][0]:.4g} .. {mmbp['p_e_ci95'][1]:.4g}); "
              f"physics prediction M = {prediction['M']}, N = {prediction['N']}")
    times = ", ".join(f"{stage} {seconds:.1f} s" for stage, seconds in summary.timings.items())
    print(f"time: {times}")
    print(f"report: {summary.out_dir / 'report.md'}")
    return EXIT_OK


def _default_workers() -> int:
    from rollsim.render.writer import default_workers

    return default_workers()


def cmd_analytic(args) -> int:
    """Tables of p0 and P(message) against r under MMBP and Gilbert-Elliott."""
    import csv

    from rollsim.channel.tables import COLUMNS, analytic_table, plot_analytic

    if args.M + args.N < 1:
        raise RollsimError("--M + --N must be at least 1")
    if not 0 <= args.p_e <= 1:
        raise RollsimError(f"--p-e = {args.p_e}: must be in [0, 1]")
    if (args.p is None) != (args.q is None):
        raise RollsimError("give both --p and --q, or neither (then p = M/(M+N), q = 1 - p, the paper's Eq. 1)")
    r_values = range(1, args.r_max + 1)
    rows = analytic_table(args.M, args.N, args.p_e, args.n_packets, r_values, args.p, args.q)
    if args.json:
        payload = {"M": args.M, "N": args.N, "p_e": args.p_e, "n_packets": args.n_packets, "rows": rows}
        _write_text(args.json, json.dumps(payload, indent=2) + "\n")
    else:
        writer = csv.DictWriter(sys.stdout, fieldnames=COLUMNS, lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.12g}" if isinstance(v, float) else v) for k, v in row.items()})
    if args.plot:
        cycle = args.M + args.N
        ratios = {(m, cycle - m): analytic_table(m, cycle - m, args.p_e, args.n_packets, r_values) for m in range(1, cycle)}
        plot_analytic(rows, args.M, args.N, args.p_e, args.n_packets, args.plot, ratios)
    return EXIT_OK


def _write_text(path: str, text: str) -> None:
    from rollsim.outdir import write_text_atomic

    write_text_atomic(Path(path), text)


def cmd_bench(args) -> int:
    """Run a benchmark."""
    return args.bench_main(args)


def cmd_simulate(args) -> int:
    """Broadcast the scene's message over a channel model, in many runs."""
    from tqdm import tqdm

    from rollsim.channel.eventsim import to_camcomsim
    from rollsim.channel.scene_channel import simulate_scene

    scene = _load_scene_args(args)
    try:
        with tqdm(total=args.runs, unit="run", desc=f"simulate {args.channel}", disable=args.quiet or None) as bar:
            result = simulate_scene(
                scene, args.channel, runs=args.runs, seed=args.seed, max_emissions=args.max_emissions,
                workers=args.workers, progress=bar.update,
            )
    except ValueError as exc:
        raise RollsimError(f"{scene.name}: {exc}") from None
    summary = result.summary()
    payload = to_camcomsim(result) if args.format == "camcomsim" else {"summary": summary}
    if args.json:
        _write_text(args.json, json.dumps(payload, indent=2, allow_nan=False) + "\n")
    print(_format_simulation(summary, args.channel))
    return EXIT_OK


def _format_simulation(summary: dict, channel: str) -> str:
    lines = [
        f"{channel} channel, {summary['strategy'].upper()} r={summary['repeats']}, {summary['n_packets']} packets, "
        f"{summary['runs']} runs: {summary['completed_runs']} completed (cap {summary['max_emissions']} emissions)",
        f"{'metric':<18} {'mean':>12} {'std':>12} {'95% CI':>27}",
    ]
    for name, stats in summary["metrics"].items():
        ci = stats.get("ci95")
        ci_text = f"[{ci[0]:.5g}, {ci[1]:.5g}]" if ci else "n/a"
        std = "n/a" if stats.get("std") is None else f"{stats['std']:.5g}"
        lines.append(f"{name:<18} {stats['mean']:>12.5g} {std:>12} {ci_text:>27}")
    lines += [f"note: {note}" for note in summary.get("notes", [])]
    return "\n".join(lines)


def _bench_eventsim_main(args) -> int:
    from rollsim.bench.eventsim import main as bench_main

    return bench_main(args)


def _bench_render_main(args) -> int:
    from rollsim.bench.render import main as bench_main

    return bench_main(args)


def _bench_decode_main(args) -> int:
    from rollsim.bench.decode import main as bench_main

    return bench_main(args)


def _bench_stress_main(args) -> int:
    from rollsim.bench.stress import main as bench_main

    return bench_main(args)


def _bench_accuracy_main(args) -> int:
    from rollsim.bench.accuracy import main as bench_main

    return bench_main(args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rollsim",
        description="Rolling-shutter camera simulator for optical camera communication.",
    )
    parser.add_argument("--version", action="version", version=f"rollsim {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks for errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("scenes", help="list the bundled scenes")
    p.set_defaults(func=cmd_scenes)

    p = sub.add_parser("validate", help="check scene files")
    p.add_argument("files", nargs="+", metavar="FILE", help="scene files or bundled scene names")
    _add_set_option(p)
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("describe", help="summarise a scene's timing, PHY-SDU, schedule and waveform")
    p.add_argument("scene", metavar="SCENE", help="scene file or bundled scene name")
    _add_set_option(p)
    p.add_argument("--emissions", type=int, default=12, help="emissions of the schedule to list (default 12)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=cmd_describe)

    p = sub.add_parser("render", help="render a scene to PNG frames with ground truth")
    _add_scene_output_options(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("run", help="the main job: render, decode, evaluate, calibrate and report a scene")
    _add_scene_output_options(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("decode", help="decode the PHY-SDUs of a directory of frames into DIR/decoded.jsonl")
    p.add_argument("dir", metavar="DIR", help="a render directory (frames/*.png) or a folder of PNG frames")
    p.add_argument("--scene", metavar="FILE", default=None,
                   help="scene giving the link and camera (default: DIR/scene.resolved.yaml)")
    p.add_argument("--clock-hz", type=float, default=None, help="chip rate in Hz (overrides the scene)")
    p.add_argument("--row-time-us", type=float, default=None,
                   help="row time in us (overrides the scene; without a scene and without it, estimated from the frames)")
    p.add_argument("--workers", type=_positive_int, default=None, help="worker processes (default: one per core)")
    p.add_argument("--force", action="store_true", help="replace an existing decoded.jsonl")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_set_option(p)
    p.set_defaults(func=cmd_decode)

    p = sub.add_parser("evaluate", help="outcome of every emitted PHY-SDU against the truth: DIR/outcomes.csv, DIR/evaluation.json")
    p.add_argument("dir", metavar="DIR", help="a rendered and decoded directory")
    p.add_argument("--force", action="store_true", help="replace existing outcomes.csv and evaluation.json")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("estimate-row-time", help="row time of a camera from frames of a square-wave LED")
    p.add_argument("frames", nargs="+", metavar="FRAMES", help="PNG frames, or directories of them")
    p.add_argument("--clock-hz", type=float, required=True, help="chip rate of the square wave in Hz (period 2 chips)")
    p.add_argument("--json", metavar="FILE", help="also write the estimate as JSON")
    p.set_defaults(func=cmd_estimate_row_time)

    p = sub.add_parser("calibrate", help="fit MMBP (M, N, p_e) and Gilbert-Elliott models to an outcome trace")
    p.add_argument("trace", metavar="DIR|TRACE.csv", help="an evaluated render directory, or a CSV with a success column")
    p.add_argument("--n-packets", type=_positive_int, default=None,
                   help="N_p of the whole-message comparison (default: the scene's, else 50)")
    p.add_argument("--json", metavar="FILE", help="also write every figure as JSON")
    p.set_defaults(func=cmd_calibrate)

    p = sub.add_parser("analytic", help="p0 and P(message) against r under MMBP and Gilbert-Elliott (paper Fig. 7-9)")
    p.add_argument("--M", type=_non_negative_int, default=5, help="ON slots per frame (default 5, paper Fig. 8)")
    p.add_argument("--N", type=_non_negative_int, default=2, help="OFF slots per frame (default 2)")
    p.add_argument("--p-e", type=float, default=0.001, help="PHY-SDU error rate in ON slots (default 0.001)")
    p.add_argument("--n-packets", type=_positive_int, default=50, help="packets in the message (default 50)")
    p.add_argument("--r-max", type=_positive_int, default=10, help="largest r (default 10)")
    p.add_argument("--p", type=float, default=None, help="Gilbert-Elliott p (default M/(M+N))")
    p.add_argument("--q", type=float, default=None, help="Gilbert-Elliott q (default 1 - p)")
    p.add_argument("--json", metavar="FILE", help="write JSON instead of CSV on stdout")
    p.add_argument("--plot", metavar="PNG", help="also save a plot like the paper's Fig. 7-9")
    p.set_defaults(func=cmd_analytic)

    bench = sub.add_parser("bench", help="benchmarks: speed and memory on this machine")
    bench_sub = bench.add_subparsers(dest="bench", metavar="BENCHMARK")
    bench_sub.required = True
    p = bench_sub.add_parser("render", help="render ms/frame at 1080p, end-to-end frames/s, peak memory")
    p.add_argument("--frames", type=_positive_int, default=20, help="frames timed per variant (default 20)")
    p.add_argument("--e2e-frames", type=_positive_int, default=120, help="frames of the end-to-end run (default 120)")
    p.add_argument("--rss-frames", type=_positive_int, nargs=2, default=[200, 2000], help="two frame counts for peak memory")
    p.add_argument("--workers", type=_positive_int, default=2, help="workers of the end-to-end runs (default 2)")
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    p.set_defaults(func=cmd_bench, bench_main=_bench_render_main)
    p = bench_sub.add_parser("eventsim", help="event simulator: emissions/s, wall time and memory of the CamComSim workload")
    p.add_argument("--runs", type=_positive_int, default=1000, help="runs (default 1000)")
    p.add_argument("--workers", type=_positive_int, default=None, help="worker processes (default: both cores)")
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    p.set_defaults(func=cmd_bench, bench_main=_bench_eventsim_main)

    p = bench_sub.add_parser("decode", help="decoder ms per 1080p frame in memory (one core), and PNG read time")
    p.add_argument("--frames", type=_positive_int, default=30, help="frames timed per scene (default 30)")
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    p.set_defaults(func=cmd_bench, bench_main=_bench_decode_main)
    p = bench_sub.add_parser("stress", help="decoder outcome rates on the paper, stress and effect scenes (the README table)")
    p.add_argument("scenes", nargs="*", metavar="SCENE", help="scenes (default: every bundled paper-, stress- and effect- scene)")
    p.add_argument("--frames", type=_positive_int, default=100, help="frames per scene (default 100)")
    p.add_argument("--workers", type=_positive_int, default=2, help="scenes in parallel (default 2)")
    p.add_argument("--markdown", metavar="FILE", help="also write the table as Markdown")
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    p.set_defaults(func=cmd_bench, bench_main=_bench_stress_main)
    p = bench_sub.add_parser(
        "accuracy",
        help="what accuracy costs: each fidelity setting against the most accurate one, in time, image error, "
        "noise distribution, decode outcomes and the MMBP fit; and each effect's cost",
    )
    p.add_argument("scene", metavar="SCENE", help="scene file or bundled scene name")
    p.add_argument("--frames", type=_positive_int, default=30, help="frames per setting (default 30)")
    p.add_argument("--knobs", nargs="+", metavar="KNOB", default=None,
                   help="knobs to measure (default all: footprint_edge shot_noise read_noise blur_kernel "
                   "blur_truncation demosaic spectral_step led_rise_time)")
    p.add_argument("--effects", nargs="*", metavar="EFFECT", default=None,
                   help="effects whose own cost to measure (default all; the option alone: none)")
    p.add_argument("--out", metavar="DIR", default=None,
                   help="write accuracy.csv, effects_cost.csv, accuracy.json, accuracy.md and accuracy_pareto.png here")
    p.add_argument("--force", action="store_true", help="replace those files if present")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    _add_set_option(p)
    p.set_defaults(func=cmd_bench, bench_main=_bench_accuracy_main)

    p = sub.add_parser("simulate", help="broadcast the scene's message over a channel model (CamComSim's job)")
    p.add_argument("scene", metavar="SCENE", help="scene file or bundled scene name")
    p.add_argument("--channel", choices=("mmbp", "timed", "camcomsim"), default="mmbp", help="channel model (default mmbp)")
    p.add_argument("--runs", type=_positive_int, default=1000, help="independent runs (default 1000)")
    p.add_argument("--seed", type=_non_negative_int, default=None, help="seed (default: the scene's)")
    p.add_argument("--max-emissions", type=_positive_int, default=50_000, help="cap per run (default 50000, as in the paper)")
    p.add_argument("--workers", type=_positive_int, default=None, help="worker processes (default: both cores)")
    p.add_argument("--json", metavar="FILE", help="write the summary and parameters as JSON")
    p.add_argument("--format", choices=("rollsim", "camcomsim"), default="rollsim",
                   help="JSON field names: rollsim's, or CamComSim's (nbTxPhysdu, ...)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_set_option(p)
    p.set_defaults(func=cmd_simulate)
    return parser


def _int_at_least(minimum: int, words: str):
    """An argparse type: an integer >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = minimum - 1
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected a {words} integer, got {text!r}")
        return value

    return parse


_positive_int = _int_at_least(1, "positive")
_non_negative_int = _int_at_least(0, "non-negative")


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``rollsim`` console script."""
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except RollsimError as exc:
        if args.debug:
            raise
        for line in exc.lines:
            print(f"rollsim: error: {line}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("rollsim: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
