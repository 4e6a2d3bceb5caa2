"""The ``rollsim`` command line.

Bad input (a scene, an override, a path) prints one line per problem on
stderr and exits with code 2; an operating-system failure (a full disk, a
read-only target) or an output that could not be committed prints one line
and exits with 1; SIGINT and SIGTERM stop every worker, remove the staging
area and exit with 128 + the signal. ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
from pathlib import Path
from typing import Optional, Sequence

from rollsim.version import __version__
from rollsim.errors import EXIT_FAILURE, Interrupted, RollsimError, clip

EXIT_OK = 0
EXIT_BAD_INPUT = 2


# ------------------------------------------------------------ option helpers


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (the usage is one ``--help`` away)."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {clip(message, 300)} (see {self.prog} --help)\n")


def _int_at_least(minimum: int, words: str, maximum: Optional[int] = None):
    """An argparse type: an integer >= ``minimum`` (and <= ``maximum``)."""

    def parse(text: str) -> int:
        try:
            value = int(text) if len(text) <= 30 else minimum - 1
        except ValueError:
            value = minimum - 1
        if value < minimum or (maximum is not None and value > maximum):
            bound = f" up to {maximum}" if maximum is not None else ""
            raise argparse.ArgumentTypeError(f"expected a {words} integer{bound}, got {text[:40]!r}")
        return value

    return parse


# Counts past 2**53 are not exact as the floats that sizes and times become;
# seeds are 63-bit; no machine runs more than 1024 worker processes.
_positive_int = _int_at_least(1, "positive", 2**53)
_non_negative_int = _int_at_least(0, "non-negative", 2**63 - 1)
_workers = _int_at_least(1, "positive", 1024)


def _check_probability(name: str, value: Optional[float]) -> None:
    """A probability option: a finite number in [0, 1] (NaN and inf refused)."""
    if value is not None and not 0.0 <= value <= 1.0:
        raise RollsimError(f"{name} = {value}: must be in [0, 1]")


def _add_set_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scene key, e.g. --set camera.exposure_us=50 (repeatable)",
    )


def _add_scheduler_options(parser: argparse.ArgumentParser) -> None:
    """``--scheduler ADDRESS`` and the deadline of the connection to it."""
    parser.add_argument("--scheduler", metavar="ADDRESS", default=None,
                        help="a running Dask scheduler, e.g. tcp://10.0.0.1:8786, instead of a local cluster")
    parser.add_argument("--connect-timeout", metavar="SECONDS", type=float, default=None,
                        help="how long to wait for the scheduler to answer as Dask does "
                        "(default: $ROLLSIM_CONNECT_TIMEOUT, else 10)")


def _add_force(parser: argparse.ArgumentParser, what: str = "an existing output file") -> None:
    parser.add_argument("--force", action="store_true", help=f"replace {what}")


def _add_json_file(parser: argparse.ArgumentParser, help_text: str = "also write the figures as JSON") -> None:
    parser.add_argument("--json", metavar="FILE", help=help_text)


def _add_scene_output_options(parser: argparse.ArgumentParser) -> None:
    """SCENE, --out DIR and the options of commands that render a scene into a directory."""
    parser.add_argument("scene", metavar="SCENE", help="scene file or bundled scene name")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="output directory, made with its missing parents (must be empty, or use --force)")
    parser.add_argument("--frames", type=_positive_int, default=None, help="frame count (default: the scene's frames)")
    parser.add_argument("--seed", type=_non_negative_int, default=None, help="override the scene seed")
    _add_force(parser, "a previous rollsim result in the output directory (never anything else)")
    parser.add_argument("--workers", type=_workers, default=None, help="worker processes (default: one per core)")
    parser.add_argument("--quiet", action="store_true", help="no progress")
    _add_set_option(parser)
    _inputs(parser, scenes=["scene"])


def _inputs(parser: argparse.ArgumentParser, paths: Sequence[str] = (), scenes: Sequence[str] = ()) -> None:
    """Name a command's arguments that are input paths, checked to exist before any work (:func:`_check_inputs`).

    ``scenes`` may be a bundled scene's name instead of a file.
    """
    parser.set_defaults(input_paths=tuple(paths), input_scenes=tuple(scenes))


def _check_inputs(args) -> None:
    """Refuse input paths that do not exist, one line each naming it (an unexpanded glob named as one)."""
    from rollsim.plumbing.validation import missing_path

    problems: list[str] = []
    for names, check in ((getattr(args, "input_paths", ()), missing_path),
                         (getattr(args, "input_scenes", ()), _missing_scene)):
        for name in names:
            value = getattr(args, name, None)
            for item in value if isinstance(value, list) else [value]:
                problem = None if item is None else check(item)
                if problem is not None:
                    problems.append(problem)
    if problems:
        raise RollsimError(list(dict.fromkeys(problems)))


def _missing_scene(scene: str) -> Optional[str]:
    # Imported here, when a command has a scene to check: rollsim.scene loads
    # the scene models and the effects registry (about 0.9 s).
    from rollsim.scene.bundled import missing_scene

    return missing_scene(scene)


def _check_repeated_keys(args) -> None:
    """A scene key given twice: with ``--set``, or with ``--set`` and a sweep's ``--grid`` or ``--zip``
    (whose values replace the ``--set`` one in every cell)."""
    from rollsim.scene.loader import refuse_repeated_keys

    given = [("--set", item) for item in getattr(args, "overrides", None) or []]
    refuse_repeated_keys(given + [(option, item) for option in ("--grid", "--zip")
                                  for item in getattr(args, option[2:], None) or []])


def _file_outputs(args) -> list:
    """The file outputs a command was asked for (``--json FILE``, ``--plot``, ``--markdown``)."""
    paths = [getattr(args, "json", None), getattr(args, "plot", None), getattr(args, "markdown", None)]
    return [p for p in paths if isinstance(p, str)]


def _check_outputs(args) -> None:
    """Refuse unusable output files before any work."""
    from rollsim.plumbing.outputs import check_file_targets

    check_file_targets(_file_outputs(args), getattr(args, "force", False))


def _write_outputs(args, contents: dict) -> None:
    """Write the command's output files, all or none (``{path: text or bytes}``)."""
    from rollsim.plumbing.outputs import write_files

    contents = {path: data for path, data in contents.items() if path}
    if contents:
        write_files(contents, force=getattr(args, "force", False))


def _json_text(payload) -> str:
    return json.dumps(payload, indent=2, allow_nan=False) + "\n"


def _scene_path(args) -> Optional[Path]:
    """The scene file a command reads (an input the output must not hold)."""
    from rollsim.scene.bundled import resolve_scene_path

    path = resolve_scene_path(args.scene)
    return path if path.exists() else None


def _load_scene_args(args):
    """The scene of a command: file or bundled name, ``--set``, ``--seed`` and ``--frames``."""
    from rollsim.scene import load_scene

    overrides = list(args.overrides)
    if getattr(args, "seed", None) is not None:
        overrides.append(f"seed={args.seed}")
    if getattr(args, "frames", None) is not None:
        # Through the scene, so that validation sees the run's real length.
        overrides.append(f"frames={args.frames}")
    return load_scene(args.scene, overrides)


def _default_workers() -> int:
    from rollsim.plumbing.parallel import default_workers

    return default_workers()


# ---------------------------------------------------------------- commands


def cmd_scenes(args) -> int:
    """List the bundled scenes with their one-line descriptions."""
    from rollsim.errors import clip
    from rollsim.scene import bundled_scene_paths, read_yaml

    paths = bundled_scene_paths()
    width = max((len(p.stem) for p in paths), default=0)
    for path in paths:
        print(f"{path.stem:<{width}}  {clip(read_yaml(path).get('description', ''), 200)}")
    return EXIT_OK


def cmd_validate(args) -> int:
    """Validate scene files: exit 0 if all are valid, 2 with one line per error otherwise."""
    from rollsim.scene import load_scene

    problems: list[str] = []
    for path in dict.fromkeys(args.files):  # a file named twice is checked once
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
    from rollsim.stages.describe import describe_scene, format_description

    scene = _load_scene_args(args)
    # The text shows the scene's own strategy only: no rlnc figures (and no
    # scipy.special import, 0.3 s) for an RP or RS scene.
    info = describe_scene(scene, emissions=args.emissions, rlnc=args.json)
    print(json.dumps(info, indent=2) if args.json else format_description(info))
    return EXIT_OK


class _NoBar:
    """What a progress bar that shows nothing does: nothing."""

    def __enter__(self) -> _NoBar:
        return self

    def __exit__(self, *exc) -> None:
        return None

    def update(self, n: int = 1) -> None:
        return None


def _progress_bar(quiet: bool, **options):
    """A tqdm bar on standard error, or :class:`_NoBar` where tqdm would show nothing.

    tqdm hides its bar when ``quiet`` or when standard error is not a
    terminal (``disable=None``); tqdm is imported only to be shown (it takes
    about 60 ms of start-up).
    """
    if quiet or (hasattr(sys.stderr, "isatty") and not sys.stderr.isatty()):  # tqdm's own test
        return _NoBar()
    from tqdm import tqdm

    return tqdm(disable=None, **options)


def cmd_render(args) -> int:
    """Render a scene to PNG frames (or one video), truth.jsonl and scene.resolved.yaml."""
    from rollsim.render.writer import render_to_dir

    video = _video_settings(args)
    scene = _load_scene_args(args)
    with _progress_bar(args.quiet, total=scene.frames, unit="frame", desc="render") as bar:
        summary = render_to_dir(
            scene, Path(args.out), scene.frames, force=args.force, workers=args.workers,
            progress=lambda n: bar.update(1), inputs=[_scene_path(args)], video=video,
        )
    what = "frames" if video is None else f"frames ({video.codec} {video.rate_control()}, {video.chroma}) in a video"
    print(f"wrote {summary.frames} {what} of {scene.name} to {summary.out_dir} ({summary.workers} workers)")
    return EXIT_OK


def _decode_settings(args, run_dir: Path):
    """Decode settings: --scene, else the render's scene.resolved.yaml, else
    the default link (--set overrides) with --clock-hz / --row-time-us."""
    from rollsim.stages.decode import DecodeSettings, settings_from_scene
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
        exposure_s = None if args.exposure_us is None else args.exposure_us * 1e-6
        return DecodeSettings(phy_from_scene(scene), args.clock_hz, row_time_s, exposure_s=exposure_s)
    return settings_from_scene(scene, args.clock_hz, args.row_time_us, args.exposure_us)


def _video_frames_asked(video: Path, start: int, count: Optional[int]) -> Optional[int]:
    """How many of a video's frames ``--start``/``--frames`` ask for (None: not known from the header);
    a range beyond the header's frame count is refused here, before any decoding."""
    from rollsim.video.read import probe_video

    info = probe_video(video)
    if info.frames is not None and start + (count or 1) > info.frames:
        raise RollsimError(f"{video}: holds {info.frames} frames; --start {start} --frames {count or 1} asks beyond")
    if count is not None:
        return count
    return None if info.frames is None else info.frames - start


def _add_video_range(parser: argparse.ArgumentParser, default: str = "to the end") -> None:
    """--start and --frames: the frames of a video to read (``default`` says how many without --frames)."""
    parser.add_argument("--start", type=_non_negative_int, default=0, help="video input: first frame to read (default 0)")
    parser.add_argument("--frames", dest="video_frames", type=_positive_int, default=None,
                        help=f"video input: frames to read (default: {default})")


def cmd_decode(args) -> int:
    """Decode the frames of a directory into DIR/decoded.jsonl."""
    from tqdm import tqdm

    from rollsim.stages.decode import decode_directory, frame_files, frame_video

    run_dir = Path(args.dir)
    video = frame_video(run_dir)
    if video is None:
        n_files: Optional[int] = len(frame_files(run_dir))  # first: a missing directory is named as such
    else:
        n_files = _video_frames_asked(video, args.start, args.video_frames)
    settings = _decode_settings(args, video.parent if video == run_dir else run_dir)
    if args.decoder is not None:
        from dataclasses import replace

        from rollsim.stages.decode import load_decoder

        load_decoder(args.decoder)  # here first: a wrong name fails before any frame
        settings = replace(settings, decoder=args.decoder)
    workers = args.workers or _default_workers()
    with tqdm(total=n_files, unit="frame", desc="decode", disable=args.quiet or None) as bar:
        notes: list[str] = []
        summary = decode_directory(
            run_dir, settings, workers=workers, force=args.force, timeout_s=args.decoder_timeout,
            on_error=lambda e: tqdm.write(f"rollsim: skipped frame {e['frame']}: {e['error']}", file=sys.stderr),
            progress=lambda n: bar.update(1), start=args.start, count=args.video_frames, notes=notes,
            rotate_deg=args.rotate,
        )
    for line in notes:
        print(f"rollsim: note: {line}", file=sys.stderr)
    print(
        f"decoded {summary.frames} frames of {run_dir}: {summary.sdus} PHY-SDUs, {summary.sdus_ok} passed the check, "
        f"{len(summary.unreadable)} frames unreadable -> {run_dir / 'decoded.jsonl'}"
    )
    return EXIT_OK


def cmd_evaluate(args) -> int:
    """Give every emitted PHY-SDU its outcome; write outcomes.csv and evaluation.json."""
    from rollsim.stages.evaluate import evaluate_directory, format_summary
    from rollsim.plumbing.outputs import is_staging

    if is_staging(Path(args.dir)):
        raise RollsimError(f"{args.dir}: the staging area of an unfinished run; evaluate a finished render directory")
    decoded = Path(args.decoded) if args.decoded is not None else None
    against = Path(args.against) if args.against is not None else None
    result = evaluate_directory(Path(args.dir), force=args.force, decoded_file=decoded, against=against,
                                allow_foreign=args.allow_other_run)
    for warning in result.summary.get("warnings", []):
        print(f"rollsim: warning: {warning}", file=sys.stderr)
    print(format_summary(result.summary))
    if against is not None:
        from rollsim.stages.compare import format_comparison

        print()
        print(format_comparison(json.loads((Path(args.dir) / "comparison.json").read_text(encoding="utf-8"))))
    return EXIT_OK


def cmd_inspect(args) -> int:
    """Draw one frame of a run with its truth's PHY-SDUs by outcome and the rows the decoder read."""
    from rollsim.plumbing.outputs import check_file_targets
    from rollsim.report.annotate import inspect_run, png_bytes

    check_file_targets([args.out], args.force)  # before the frame is read and drawn
    decoded = Path(args.decoded) if args.decoded is not None else None
    image = inspect_run(Path(args.dir), args.frame, decoded)
    _write_outputs(args, {args.out: png_bytes(image)})
    print(f"wrote {args.out}: frame {args.frame} of {args.dir} ({image.shape[1]}x{image.shape[0]} px)")
    return EXIT_OK


def _png_paths(items: Sequence[str]) -> list[Path]:
    """Files as given (each checked to exist: :func:`_check_inputs`); a directory stands for its PNG or JPEG frames."""
    from rollsim.stages.decode import frame_files

    paths: list[Path] = []
    for item in items:
        path = Path(item)
        paths.extend(frame_files(path) if path.is_dir() else [path])
    return paths


# Frames fit-camera reads from a video without --frames: its fit uses six
# frames for the stripes and frame pairs for the noise; more add time.
VIDEO_FIT_FRAMES = 10


def _input_video(items: Sequence[str]) -> Optional[Path]:
    """The video file that the FRAMES arguments stand for (one file, or a directory holding one), else None."""
    from rollsim.stages.decode import frame_video

    if len(items) != 1:
        for item in items:
            if frame_video(Path(item)) is not None and Path(item).is_file():
                raise RollsimError(f"{item}: a video is read alone; give it as the only FRAMES argument")
        return None
    return frame_video(Path(items[0]))


def _video_input_frames(video: Path, args, default_count: Optional[int], notes: list):
    """The frames of ``video`` that --start/--frames pick (without --frames, at most
    ``default_count``, None: to the end), streamed, upright (--rotate)."""
    import itertools

    from rollsim.video.read import read_video_frames

    if args.video_frames is not None:
        _video_frames_asked(video, args.start, args.video_frames)
        return read_video_frames(video, args.start, args.video_frames, rotate_deg=args.rotate, notes=notes)
    available = _video_frames_asked(video, args.start, None)  # None: the header does not say
    frames = read_video_frames(video, args.start, None, rotate_deg=args.rotate, notes=notes)
    if default_count is None or (available is not None and available <= default_count):
        return frames
    return itertools.islice(frames, default_count)


def _add_video_input(parser: argparse.ArgumentParser, default: str = "to the end", stills: bool = True) -> None:
    """--start, --frames and --rotate for a video given as FRAMES (``stills``: --rotate turns stills too)."""
    _add_video_range(parser, default)
    parser.add_argument("--rotate", type=int, choices=(0, 90, 180, 270), default=None,
                        help="turn each frame clockwise by this many degrees (default: a video's rotation in its "
                             "container, else a quarter turn where the stripes run along the columns)" if stills
                        else "video input: turn each frame clockwise by this many degrees (default: the "
                             "container's rotation, else a quarter turn where the stripes run along the columns)")


def cmd_estimate_row_time(args) -> int:
    """Row time of a camera from frames of an LED sending the square pattern."""
    from decoder import FrameReadError, RowTimeError, estimate_row_time, read_frame

    from rollsim.stages.decode import frame_pixel_limit
    from rollsim.video.read import upright_frames

    if not (math.isfinite(args.clock_hz) and args.clock_hz > 0):
        raise RollsimError(f"--clock-hz = {args.clock_hz}: must be a finite number > 0")
    skipped: list[str] = []
    max_pixels = frame_pixel_limit(workers=1)
    video = _input_video(args.frames)
    notes: list[str] = []

    def readable_frames():
        if video is not None:
            yield from _video_input_frames(video, args, None, notes)
            return
        for path in _png_paths(args.frames):
            try:
                yield read_frame(path, max_pixels=max_pixels)
            except FrameReadError as exc:
                skipped.append(str(exc))
                print(f"rollsim: skipped frame: {exc}", file=sys.stderr)

    frames = readable_frames() if video is not None else upright_frames(readable_frames(), args.rotate,
                                                                          " ".join(args.frames), notes)
    try:
        row_time_s, sigma_s = estimate_row_time(frames, args.clock_hz)
    except RowTimeError as exc:
        raise RollsimError(str(exc)) from None
    for line in notes:
        print(f"rollsim: note: {line}", file=sys.stderr)
    result = {"row_time_us": row_time_s * 1e6, "uncertainty_us": sigma_s * 1e6, "clock_hz": args.clock_hz,
              "frames_unreadable": len(skipped)}
    _write_outputs(args, {args.json: _json_text(result)})
    print(f"row time {row_time_s * 1e6:.4f} us +- {sigma_s * 1e6:.4f} us (1 sigma), {len(skipped)} frames unreadable")
    return EXIT_OK


def cmd_fit_camera(args) -> int:
    """Fit a camera, its ISP and the LED's image to real frames of a square-wave LED."""
    import numpy as np

    from decoder import FrameReadError, RowTimeError, read_frame

    from rollsim.stages.decode import frame_pixel_limit
    from rollsim.fit import Known, fit_camera
    from rollsim.fit.refine import MAX_BINNING_ROWS
    from rollsim.fit.tone import NAMED_GAMMAS
    from rollsim.fit.report import FILES, fit_outputs
    from rollsim.plumbing.outputs import check_directory_files, write_files
    from rollsim.scene import load_scene

    if not (math.isfinite(args.clock_hz) and args.clock_hz > 0):
        raise RollsimError(f"--clock-hz = {args.clock_hz}: must be a finite number > 0")
    if args.pattern != "square":
        raise RollsimError(f"--pattern = {args.pattern!r}: only 'square' is fitted")
    if args.exposure_us is not None and not (math.isfinite(args.exposure_us) and args.exposure_us > 0):
        raise RollsimError(f"--exposure-us = {args.exposure_us}: must be a finite number > 0")
    if args.binning_rows is not None and not 1 <= args.binning_rows <= MAX_BINNING_ROWS:
        raise RollsimError(f"--binning-rows = {args.binning_rows}: must be 1 to {MAX_BINNING_ROWS}")
    video = _input_video(args.frames)
    paths = [] if video is not None else _png_paths(args.frames)
    if video is None and len(paths) < 2:
        raise RollsimError(f"fit-camera needs at least two frames, got {len(paths)}")
    out = Path(args.out)
    check_directory_files(out, FILES, args.force)  # before the work, not after; made when written
    exposure_us, exposure_how = _still_exposure(paths, args.exposure_us)
    frames = []
    notes: list[str] = []
    recording = frame_rate_hz = None
    if video is not None:
        from rollsim.video.read import probe_video, recording_settings

        recording, frame_rate_hz = recording_settings(video), probe_video(video).frame_rate_hz
        frames = list(_video_input_frames(video, args, VIDEO_FIT_FRAMES, notes))
        for line in notes:
            print(f"rollsim: note: {line}", file=sys.stderr)
        if len(frames) < 2:
            raise RollsimError(f"fit-camera needs at least two frames, got {len(frames)} from {video}")
        paths = [Path(f"{video}#{args.start + i}") for i in range(len(frames))]
    for path in paths if video is None else ():
        try:
            image = read_frame(path, max_pixels=frame_pixel_limit(workers=1))
        except FrameReadError as exc:
            raise RollsimError(str(exc)) from None
        if image.dtype != np.uint8:
            raise RollsimError(f"{path}: fit-camera reads 8-bit frames (a camera's processed output), got 16-bit")
        frames.append(image)
    if video is None:
        from rollsim.video.read import upright_frames

        frames = list(upright_frames(frames, args.rotate, " ".join(args.frames), notes))
        for line in notes:
            print(f"rollsim: note: {line}", file=sys.stderr)
    height = np.asarray(frames[0]).shape[0]
    if args.binning_rows is not None and height % args.binning_rows:
        raise RollsimError(f"--binning-rows = {args.binning_rows}: does not divide the frames' height, {height} rows")
    base = load_scene(args.scene, args.overrides)
    frame_period_us = 1e6 / (frame_rate_hz or base.camera.frame_rate_hz)
    if exposure_us is not None and exposure_us >= frame_period_us:
        told = f"--exposure-us = {exposure_us:g}" if args.exposure_us is not None else \
            f"the stills' EXIF exposure time ({exposure_us:g} us)"
        raise RollsimError(f"{told}: not shorter than the frame period {frame_period_us:.1f} us" + (
            "" if video is not None else f" (the base scene's {base.camera.frame_rate_hz:g} frames/s; "
                                         "--set camera.frame_rate_hz=... lowers it)"))
    if exposure_us is not None and args.exposure_us is None:
        print(f"rollsim: fit-camera: exposure {exposure_how}", file=sys.stderr)
    try:
        fit = fit_camera(frames, args.clock_hz, base, iterations=args.iterations,
                         progress=lambda line: print(f"rollsim: fit-camera: {line}", file=sys.stderr, flush=True),
                         recording=recording, frame_rate_hz=frame_rate_hz,
                         known=Known(exposure_us, None if args.tone is None else NAMED_GAMMAS[args.tone],
                                     exposure_how=exposure_how, binning_rows=args.binning_rows))
        comparison = fit.checked()
    except (ValueError, RowTimeError) as exc:
        raise RollsimError(f"fit-camera: {exc}") from None
    write_files({str(k): v for k, v in fit_outputs(out, fit, comparison, args.clock_hz,
                                                   [str(p) for p in paths]).items()}, force=args.force)
    est = fit.estimates
    print(f"row time {est['row_time_us'].value:.4f} us, exposure {est['exposure_us'].value:.1f} us, "
          f"ISO {est['iso'].value:.0f}, read noise {est['read_noise_e'].value:.2f} e-, "
          f"LED at ({est['led_centre_x_px'].value:.1f}, {est['led_centre_y_px'].value:.1f}) px, "
          f"diameter {est['led_diameter_px'].value:.1f} px")
    if fit.channel != "grey":
        print(f"colour frames: fitted on their {fit.channel} plane")
    if video is not None:
        print(f"video: rendered through {recording.codec} at {recording.rate_control()}, GOP "
              f"{recording.gop_frames or 'one second'}, {recording.chroma}, as the file was encoded" if recording
              else "video: its codec is not one rollsim renders (h264, hevc); fitted without it")
    missing = [name for name, e in est.items() if e.source == "not identified"]
    if missing:
        print("not identified from these frames (the base scene's values, or a bound; reasons in report.md): "
              f"{', '.join(missing)}")
    print(f"row-profile correlation with the fit: mean {np.mean(comparison.correlations):.4f}; "
          f"wrote {out / 'camera.yaml'}, fit.json, report.md, profiles.png, frames.png")
    return EXIT_OK


def _still_exposure(paths: Sequence[Path], given_us: Optional[float]) -> tuple[Optional[float], str]:
    """The exposure the fit holds (µs, or None: fitted) and how it was told: ``--exposure-us``, else the
    one exposure the stills' EXIF records; refused in one line where the stills record different ones."""
    from rollsim.fit.camera import HELD_AS_GIVEN
    from rollsim.fit.exif import exposure_how, locked_exposure_us, still_settings

    settings = [still_settings(p) for p in paths]  # their headers only; none for a video's frames
    try:
        recorded = locked_exposure_us(settings) if paths else None
    except ValueError as exc:
        if given_us is None:
            raise RollsimError(f"fit-camera: {exc}") from None
        recorded = None
    if given_us is not None:
        if recorded is not None and abs(recorded - given_us) > 1e-3 * given_us:
            print(f"rollsim: note: --exposure-us {given_us:g} held; the stills' EXIF records {recorded:g} us",
                  file=sys.stderr)
        return given_us, HELD_AS_GIVEN
    if recorded is None:
        return None, ""
    return recorded, exposure_how(recorded, settings)


def cmd_calibrate(args) -> int:
    """Fit the MMBP, Gilbert-Elliott and position models to an outcome trace."""
    from rollsim.calibrate import calibrate, format_calibration, load_trace

    result = calibrate(load_trace(Path(args.trace)), n_packets=args.n_packets)
    print(format_calibration(result))
    _write_outputs(args, {args.json: _json_text(result)})
    return EXIT_OK


def cmd_run(args) -> int:
    """The main job: render, decode, evaluate, calibrate and report one scene."""
    from tqdm import tqdm

    from rollsim.stages.evaluate import format_summary
    from rollsim.report.run import STAGES, run_scene

    scene = _load_scene_args(args)
    n_frames = scene.frames
    bars: dict = {}

    def on_stage(stage: str, event: str) -> None:
        if event == "start":
            if not args.quiet:
                tqdm.write(f"[{STAGES.index(stage) + 1}/{len(STAGES)}] {stage}", file=sys.stderr)
            if stage == "render and decode":
                bars[stage] = tqdm(total=n_frames, unit="frame", desc=stage, disable=args.quiet or None, leave=False)
        elif stage in bars:
            bars.pop(stage).close()

    def on_frame(stage: str, done: int) -> None:
        bars[stage].update(1)

    def on_skipped(error: dict) -> None:
        tqdm.write(f"rollsim: skipped frame {error['frame']}: {error['error']}", file=sys.stderr)

    try:
        summary = run_scene(scene, Path(args.out), n_frames, force=args.force, workers=args.workers or _default_workers(),
                            on_stage=on_stage, on_frame=on_frame, on_skipped=on_skipped, inputs=[_scene_path(args)])
    finally:
        for bar in bars.values():
            bar.close()
    print(format_summary(summary.evaluation))
    if summary.calibration is None:
        print(f"calibration not possible: {summary.calibration_error}")
    else:
        mmbp, prediction = summary.calibration["mmbp"], summary.calibration["prediction"]
        from rollsim.calibrate import p_e_text

        print(f"MMBP fit: M = {mmbp['M']}, N = {mmbp['N']}, {p_e_text(mmbp)}; "
              f"physics prediction M = {prediction['M']}, N = {prediction['N']}")
        selected, agreement = summary.calibration.get("selected_by_heldout"), summary.calibration.get("goodput_agreement")
        if selected and agreement:
            counts = agreement[selected]
            print(f"selected by held-out likelihood: {selected}; its goodput agrees with the replayed trace in "
                  f"{counts['agree']} of {counts['rows']} (RP and RS at r = 1-6, and rlnc where the header allows)")
    times = ", ".join(f"{stage} {seconds:.1f} s" for stage, seconds in summary.timings.items())
    print(f"time: {times}")
    print(f"report: {summary.out_dir / 'report.md'}")
    return EXIT_OK


def cmd_analytic(args) -> int:
    """Tables of p0 and P(message) against r under MMBP and Gilbert-Elliott."""
    import csv

    from rollsim.channel.tables import COLUMNS, analytic_table, plot_analytic, ratio_splits

    if args.M + args.N < 1:
        raise RollsimError("--M + --N must be at least 1")
    for name, value in (("--p-e", args.p_e), ("--p", args.p), ("--q", args.q)):
        _check_probability(name, value)
    if (args.p is None) != (args.q is None):
        raise RollsimError("give both --p and --q, or neither (then p = M/(M+N), q = 1 - p, the paper's Eq. 1)")
    if args.p is not None and args.p + args.q == 0:
        raise RollsimError("--p + --q must be > 0 (with p = q = 0 the chain has no stationary state)")
    if args.plot and Path(args.plot).suffix.lower() != ".png":
        raise RollsimError(f"--plot {args.plot}: the plot is a PNG; give a file name ending in .png")
    r_values = range(1, args.r_max + 1)
    try:
        rows = analytic_table(args.M, args.N, args.p_e, args.n_packets, r_values, args.p, args.q)
    except ValueError as exc:
        raise RollsimError(str(exc)) from None
    contents: dict[str, str | bytes] = {}
    if args.json:
        contents[args.json] = _json_text({"M": args.M, "N": args.N, "p_e": args.p_e, "n_packets": args.n_packets,
                                          "rows": rows})
    else:
        writer = csv.DictWriter(sys.stdout, fieldnames=COLUMNS, lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.12g}" if isinstance(v, float) else v) for k, v in row.items()})
    if args.plot:
        from rollsim.plumbing.outputs import figure_png

        ratios = {(m, n): analytic_table(m, n, args.p_e, args.n_packets, r_values) for m, n in ratio_splits(args.M + args.N)}
        contents[args.plot] = figure_png(lambda f: plot_analytic(rows, args.M, args.N, args.p_e, args.n_packets, f, ratios))
    _write_outputs(args, contents)
    return EXIT_OK


def cmd_bench(args) -> int:
    """Run a benchmark (its ``--out``'s missing parent folders made first, and removed if it fails)."""
    from rollsim.plumbing.outputs import parent_folders

    with parent_folders([getattr(args, "out", None)]):
        return args.bench_main(args)


def _simulation_warning(text: str) -> None:
    print(f"rollsim: warning: {text}", file=sys.stderr)


def cmd_simulate(args) -> int:
    """Broadcast the scene's message over a channel model, in many runs.

    The scene is loaded with the rules the channel does without relaxed
    (``scene_relaxations``: for ``camcomsim``, sequence numbers that wrap
    and distances down to 0), each relaxation in use said in a warning.
    ``--format camcomsim`` writes CamComSim's own result file (a bare list
    of per-run objects, compact as CamComSim writes it).
    """
    from tqdm import tqdm

    from rollsim.channel.eventsim import simulate_broadcast, to_camcomsim
    from rollsim.channel.scene_channel import (
        broadcast_from_scene,
        camcomsim_parameters,
        check_runs_first,
        scene_relaxations,
    )
    from rollsim.scene import load_scene

    camcomsim_file = args.format == "camcomsim"
    if camcomsim_file and not args.json:
        raise RollsimError("--format camcomsim: sets the layout of the JSON file; give --json FILE too")
    fitted = args.channel == "fitted"
    if fitted != (args.calibration is not None):
        raise RollsimError("--channel fitted: give --calibration FILE" if fitted else
                           "--calibration: only with --channel fitted")
    if args.model is not None and not fitted:
        raise RollsimError("--model: only with --channel fitted")
    calibration = None
    if fitted:
        from rollsim.calibrate.fitted_channel import read_calibration

        calibration = read_calibration(args.calibration)  # before the scene: a bad file is refused first
    kind = "mmbp" if fitted else args.channel
    overrides = [*args.overrides, *([f"seed={args.seed}"] if args.seed is not None else [])]
    scene = load_scene(args.scene, overrides, relax=scene_relaxations(kind))
    try:
        check_runs_first(scene, args.runs, args.workers, args.max_emissions, camcomsim_file)
        setup = broadcast_from_scene(scene, kind)
        label = args.channel
        if calibration is not None:
            setup, label = _fitted_setup(setup, calibration, args)
        for warning in setup.warnings:
            _simulation_warning(warning)
        with tqdm(total=args.runs, unit="run", desc=f"simulate {label}", disable=args.quiet or None) as bar:
            result = simulate_broadcast(
                setup.channel, setup.schedule, header_bits=setup.header_bits, payload_bits=setup.payload_bits,
                runs=args.runs, seed=scene.seed, max_emissions=args.max_emissions, workers=args.workers,
                progress=bar.update, record_loss_streaks=camcomsim_file,
            )
    except ValueError as exc:
        raise RollsimError(f"{scene.name}: {exc}") from None
    capped = result.runs - int(result.completed.sum())
    if capped:
        _simulation_warning(
            f"{capped} of {result.runs} runs reached the cap of {result.max_emissions} emissions before the message "
            "was complete; they count with goodput 0, as in CamComSim (paper sec. 6.3.1)"
        )
    summary = result.summary()
    if camcomsim_file:
        save_path = os.path.dirname(args.json) or "./"  # CamComSim's default directory
        params = camcomsim_parameters(scene, result, save_path=save_path, verbose=0 if args.quiet else 1)
        text = json.dumps(to_camcomsim(result, params), separators=(",", ":"), allow_nan=False) + "\n"
    else:
        text = _json_text({"summary": summary})
    _write_outputs(args, {args.json: text})
    print(_format_simulation(summary, label))
    return EXIT_OK


def _fitted_setup(setup, calibration: dict, args):
    """The scene's broadcast over the channel a calibration fitted (``--channel fitted``), and its label."""
    from dataclasses import replace

    from rollsim.calibrate.fitted_channel import channel_from_calibration

    channel, name = channel_from_calibration(calibration, setup.channel.emission_duration_s, args.model,
                                             source=str(args.calibration))
    return replace(setup, channel=channel), f"fitted {name}"


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


def cmd_paper(args) -> int:
    """Run the paper's experiments through rollsim's three layers; write paper.json and report.md."""
    from rollsim.paper import PaperOptions, run_paper

    options = PaperOptions.make(args.quick, args.frames, args.runs)
    given = [("--frames", args.frames), ("--runs", args.runs), ("--workers", args.workers),
             ("--scheduler", args.scheduler)]
    command = " ".join(["rollsim paper --out", str(args.out), *(["--quick"] if args.quick else []),
                        *(f"{flag} {value}" for flag, value in given if value is not None)])

    def say(text: str) -> None:
        if not args.quiet:
            print(f"rollsim paper: {text}", file=sys.stderr)

    document = run_paper(Path(args.out), options, workers=args.workers, scheduler=args.scheduler, force=args.force,
                         command=command, progress=say)
    compared = [row for row in document if row["deviation"] is not None]
    print(f"wrote {len(document)} comparisons ({len(compared)} with a deviation from the paper) to {args.out}/paper.json and "
          f"{args.out}/report.md")
    return EXIT_OK


def cmd_sweep(args) -> int:
    """Run a sweep of a scene over a grid of keys, on Dask."""
    from tqdm import tqdm

    from rollsim.sweeps import run_sweep, spec_from_arguments
    from rollsim.sweeps.engine import dashboard_link
    from rollsim.sweeps.journal import describe_progress

    options = {"runs": args.runs, "frames": args.frames, "channel": args.channel, "seed": args.seed,
               "max_emissions": args.max_emissions, "keep_frames": True if args.keep_frames else None}
    spec = spec_from_arguments(args.scene, grid=args.grid, zipped=args.zip, overrides=args.overrides,
                               stage=args.stage, options=options)
    bar = None
    state = {"done": 0, "total": 0}

    def on_start(todo: int, total: int, client) -> None:
        nonlocal bar
        state["total"] = total
        state["done"] = total - todo
        link = dashboard_link(client)
        if link and not args.quiet:
            print(f"rollsim: Dask dashboard: {link}", file=sys.stderr)
        bar = tqdm(total=total, initial=total - todo, unit="cell", desc=f"sweep {spec.stage}",
                   disable=args.quiet or None)

    def progress(n: int) -> None:
        state["done"] += n
        if bar is not None:  # on_start made it before any cell finished
            bar.update(n)

    try:
        result = run_sweep(spec, Path(args.out), workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                           force=args.force, progress=progress, on_start=on_start)
    except Interrupted as exc:
        if state["total"]:
            exc.note = describe_progress(state["done"], state["total"], Path(args.out))
        raise
    finally:
        if bar is not None:
            bar.close()
    ok = len(result.rows) - result.failed
    print(f"{len(result.rows)} cells ({result.computed} computed now): {ok} ok, {result.failed} failed -> "
          f"{result.out_dir / 'results.parquet'}, results.csv, report.md")
    for row in result.rows:
        if row["status"] != "ok":
            print(f"  cell {row['cell']} failed: {row['error']}")
            break
    return EXIT_OK


def _bench_main(module: str):
    """The ``main`` of ``rollsim.bench.<module>``, imported when the benchmark runs."""

    def run(args) -> int:
        from importlib import import_module

        return import_module(f"rollsim.bench.{module.replace('-', '_')}").main(args)

    return run


# ------------------------------------------------------------------ parser


def _add_scene_commands(sub) -> None:
    p = sub.add_parser("scenes", help="list the bundled scenes")
    p.set_defaults(func=cmd_scenes)

    p = sub.add_parser("validate", help="check scene files")
    p.add_argument("files", nargs="+", metavar="FILE", help="scene files or bundled scene names")
    _add_set_option(p)
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("describe", help="summarise a scene's timing, PHY-SDU, schedule and waveform")
    p.add_argument("scene", metavar="SCENE", help="scene file or bundled scene name")
    _add_set_option(p)
    p.add_argument("--emissions", type=_non_negative_int, default=12, help="emissions of the schedule to list (default 12)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    _inputs(p, scenes=["scene"])
    p.set_defaults(func=cmd_describe)


def _add_video_options(parser: argparse.ArgumentParser) -> None:
    """--container and the encoding options of a rendered video (docs/video.md)."""
    from rollsim.video.settings import CHROMA_FORMATS, CONTAINERS, ENCODERS, MAX_B_FRAMES, PRESETS, TUNES

    g = parser.add_argument_group("video (instead of PNG frames)")
    g.add_argument("--container", choices=CONTAINERS, default=None,
                   help="write the frames as DIR/frames.mp4 or .mkv (default: PNG frames)")
    g.add_argument("--codec", choices=tuple(ENCODERS), default=None, help="video codec (default h264)")
    rate = g.add_mutually_exclusive_group()
    rate.add_argument("--crf", type=int, default=None, help="constant rate factor 0-51 (0: lossless h264)")
    rate.add_argument("--bitrate", default=None, metavar="BPS", help="average bitrate, e.g. 17M (default 17M)")
    g.add_argument("--gop", type=_positive_int, default=None, help="frames between key frames (default: one second's)")
    g.add_argument("--preset", choices=PRESETS, default=None, help="encoder speed preset (default superfast)")
    g.add_argument("--chroma", choices=CHROMA_FORMATS, default=None, help="chroma subsampling (default 420)")
    g.add_argument("--tune", choices=TUNES, default=None, help="encoder tuning (default none: the preset's own)")
    g.add_argument("--b-frames", type=int, default=None, metavar="N",
                   help=f"consecutive B-frames at most, 0-{MAX_B_FRAMES} (default 0, as phones record)")


def _video_settings(args):
    """The video settings of ``render``'s options (None: PNG frames); refused in one line when inconsistent."""
    from rollsim.video.settings import VideoSettings, parse_bitrate

    options = {"codec": args.codec, "crf": args.crf, "bitrate_bps": None if args.bitrate is None else
               parse_bitrate(args.bitrate), "gop_frames": args.gop, "preset": args.preset, "chroma": args.chroma,
               "tune": args.tune, "b_frames": args.b_frames}
    given = {key: value for key, value in options.items() if value is not None}
    if args.container is None:
        if given:
            names = ", ".join("--" + {"bitrate_bps": "bitrate", "gop_frames": "gop", "b_frames": "b-frames"}.get(k, k)
                              for k in given)
            raise RollsimError(f"{names}: video options need --container mp4 or mkv")
        return None
    return VideoSettings(container=args.container, **given)


def _add_pixel_commands(sub) -> None:
    p = sub.add_parser("render", help="render a scene to PNG frames (or a video) with ground truth")
    _add_scene_output_options(p)
    _add_video_options(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("run", help="the main job: render, decode, evaluate, calibrate and report a scene")
    _add_scene_output_options(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("decode", help="decode the PHY-SDUs of a directory of frames into DIR/decoded.jsonl")
    p.add_argument("dir", metavar="DIR", help="a render directory (frames/*.png or frames.mp4), a folder of PNG "
                   "or JPEG frames, or a video file")
    _add_video_input(p, stills=False)
    p.add_argument("--scene", metavar="FILE", default=None,
                   help="scene giving the link and camera (default: DIR/scene.resolved.yaml)")
    p.add_argument("--clock-hz", type=float, default=None, help="chip rate in Hz (overrides the scene)")
    p.add_argument("--row-time-us", type=float, default=None,
                   help="row time in us (overrides the scene; without a scene and without it, estimated from the frames)")
    p.add_argument("--exposure-us", type=float, default=None,
                   help="exposure in us (overrides the scene); exposures longer than a chip are read by sequence "
                        "detection")
    p.add_argument("--workers", type=_workers, default=None, help="worker processes (default: one per core)")
    p.add_argument("--decoder", metavar="MODULE:FUNCTION", default=None,
                   help="a decoder of your own: FUNCTION(image, settings) returning records of decoded.jsonl's "
                        "schema (default: rollsim's decoder)")
    p.add_argument("--decoder-timeout", metavar="SECONDS", type=float, default=None,
                   help="stop the run when the --decoder takes longer than SECONDS on one frame")
    _add_force(p, "existing decoded.jsonl and decode.json")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_set_option(p)
    _inputs(p, paths=["dir"], scenes=["scene"])
    p.set_defaults(func=cmd_decode)

    p = sub.add_parser("evaluate", help="outcome of every emitted PHY-SDU against the truth: DIR/outcomes.csv, DIR/evaluation.json")
    p.add_argument("dir", metavar="DIR", help="a rendered and decoded directory")
    p.add_argument("--decoded", metavar="FILE.jsonl", default=None,
                   help="the decoded PHY-SDUs to score, any decoder's (default: DIR/decoded.jsonl); "
                        "checked line by line against rollsim/schemas/decoded-phy-sdu.schema.json")
    p.add_argument("--against", metavar="FILE.jsonl", default=None,
                   help="a second decoder's PHY-SDUs on the same frames: compare outcome by outcome "
                        "into DIR/comparison.json")
    p.add_argument("--allow-other-run", action="store_true",
                   help="score decoded records that name another render too (with a warning)")
    _add_force(p, "existing outcomes.csv, evaluation.json and comparison.json")
    _inputs(p, paths=["dir", "decoded", "against"])
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("inspect", help="one frame drawn with its truth's PHY-SDUs by outcome and the rows read")
    p.add_argument("dir", metavar="DIR", help="a render directory (frames, truth.jsonl; decoded.jsonl if decoded)")
    p.add_argument("--frame", type=_non_negative_int, default=0, help="the frame's number (default 0)")
    p.add_argument("--out", required=True, metavar="FILE.png",
                   help="the annotated frame (PNG), made with its missing parent folders")
    p.add_argument("--decoded", metavar="FILE.jsonl", default=None,
                   help="another decoder's records to draw (default: DIR/decoded.jsonl where it exists)")
    _add_force(p, "an existing FILE.png")
    _inputs(p, paths=["dir", "decoded"])
    p.set_defaults(func=cmd_inspect)

    p = sub.add_parser("estimate-row-time", help="row time of a camera from frames of a square-wave LED")
    p.add_argument("frames", nargs="+", metavar="FRAMES",
                   help="PNG or JPEG frames, or directories of them, or one video")
    _add_video_input(p)
    p.add_argument("--clock-hz", type=float, required=True, help="chip rate of the square wave in Hz (period 2 chips)")
    _add_json_file(p, "also write the estimate as JSON")
    _add_force(p)
    _inputs(p, paths=["frames"])
    p.set_defaults(func=cmd_estimate_row_time)

    p = sub.add_parser("fit-camera", help="fit a camera, its ISP and the LED's image to real frames of a square-wave LED")
    p.add_argument("frames", nargs="+", metavar="FRAMES",
                   help="8-bit PNG or JPEG frames, consecutive, or directories of them, or one video")
    _add_video_input(p, f"{VIDEO_FIT_FRAMES}")
    p.add_argument("--clock-hz", type=float, required=True, help="chip rate of the square wave in Hz (period 2 chips)")
    p.add_argument("--pattern", choices=["square"], default="square", help="what the LED sends (default square)")
    p.add_argument("--exposure-us", type=float, default=None, metavar="US",
                   help="the camera's exposure in us, where known (set by hand): held, not fitted (default: "
                        "the stills' EXIF ExposureTime where they record one, else fitted)")
    p.add_argument("--tone", choices=["linear", "srgb"], default=None,
                   help="the camera's tone curve, where known (linear: raw or machine-vision output; srgb: a "
                        "phone's or webcam's): held, not fitted")
    p.add_argument("--binning-rows", type=int, default=None, metavar="K",
                   help="rows the sensor reads as one, where known (a binned sensor mode, 1-8): held, not "
                        "detected (default: seen in the frames where JPEG and smoothing leave it)")
    p.add_argument("--scene", default="paper-geometric",
                   help="base scene whose optics, LED geometry and distance are kept (default paper-geometric)")
    p.add_argument("--iterations", type=_non_negative_int, default=4,
                   help="rounds of refinement by rendering the fit (default 4; 0: direct estimates); the noise is then matched alone")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="output directory, made with its missing parents: camera.yaml, fit.json, report.md")
    _add_force(p, "existing camera.yaml, fit.json, report.md, profiles.png and frames.png")
    _add_set_option(p)
    _inputs(p, paths=["frames"], scenes=["scene"])
    p.set_defaults(func=cmd_fit_camera)

    p = sub.add_parser("calibrate", help="fit the MMBP (M, N, p_e), Gilbert-Elliott and position models to an outcome trace")
    p.add_argument("trace", metavar="DIR|TRACE.csv", help="an evaluated render directory, or a CSV with a success column")
    p.add_argument("--n-packets", type=_positive_int, default=None,
                   help="N_p of the whole-message comparison (default: the scene's, else 50)")
    _add_json_file(p, "also write every figure as JSON")
    _add_force(p)
    _inputs(p, paths=["trace"])
    p.set_defaults(func=cmd_calibrate)


def _add_channel_commands(sub) -> None:
    p = sub.add_parser("analytic", help="p0 and P(message) against r under MMBP and Gilbert-Elliott (paper Fig. 7-9)")
    p.add_argument("--M", type=_non_negative_int, default=5, help="ON slots per frame (default 5, paper Fig. 8)")
    p.add_argument("--N", type=_non_negative_int, default=2, help="OFF slots per frame (default 2)")
    p.add_argument("--p-e", type=float, default=0.001, help="PHY-SDU error rate in ON slots (default 0.001)")
    p.add_argument("--n-packets", type=_positive_int, default=50, help="packets in the message (default 50)")
    p.add_argument("--r-max", type=_int_at_least(1, "positive", 10_000), default=10, help="largest r (default 10)")
    p.add_argument("--p", type=float, default=None, help="Gilbert-Elliott p (default M/(M+N))")
    p.add_argument("--q", type=float, default=None, help="Gilbert-Elliott q (default 1 - p)")
    _add_json_file(p, "write JSON instead of CSV on stdout")
    p.add_argument("--plot", metavar="PNG", help="also save a plot like the paper's Fig. 7-9")
    _add_force(p)
    p.set_defaults(func=cmd_analytic)

    p = sub.add_parser("simulate", help="broadcast the scene's message over a channel model (CamComSim's job)")
    p.add_argument("scene", metavar="SCENE", help="scene file or bundled scene name")
    p.add_argument("--channel", choices=("mmbp", "timed", "camcomsim", "fitted"), default="mmbp",
                   help="channel model (default mmbp); fitted: a model from --calibration")
    p.add_argument("--calibration", default=None, metavar="FILE",
                   help="fitted: a calibration JSON (rollsim calibrate --json, or a run's calibration.json)")
    p.add_argument("--model", choices=("mmbp", "ge", "position"), default=None,
                   help="fitted: which fitted model (default: the one the held-out likelihood selected)")
    p.add_argument("--runs", type=_positive_int, default=1000, help="independent runs (default 1000)")
    p.add_argument("--seed", type=_non_negative_int, default=None, help="seed (default: the scene's)")
    p.add_argument("--max-emissions", type=_positive_int, default=50_000, help="cap per run (default 50000, as in the paper)")
    p.add_argument("--workers", type=_workers, default=None, help="worker processes (default: both cores)")
    _add_json_file(p, "write the summary and parameters as JSON")
    _add_force(p)
    p.add_argument("--format", choices=("rollsim", "camcomsim"), default="rollsim",
                   help="layout of the --json file: rollsim's summary, or CamComSim's result file (a list of runs "
                   "with nbTxPhysdu, ..., simuParams)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_set_option(p)
    _inputs(p, paths=["calibration"], scenes=["scene"])
    p.set_defaults(func=cmd_simulate)


def _add_sweep_command(sub) -> None:
    p = sub.add_parser("sweep", help="a scene over a grid of keys, on Dask: a table of every cell, plots, resume")
    p.add_argument("scene", metavar="SCENE", help="scene file or bundled name, or a sweep file (YAML with scene and grid)")
    p.add_argument("--grid", action="append", default=[], metavar="KEY=VALUES",
                   help="a swept key: 5,10,15 or start:stop:step or geom:start:stop:count (repeatable: the product)")
    p.add_argument("--zip", action="append", default=[], metavar="KEY=VALUES",
                   help="keys varied together, equally many values each (repeatable)")
    p.add_argument("--stage", choices=("analytic", "simulate", "run", "envelope"), default=None,
                   help="analytic (no rendering), simulate (event simulator) or run (pixel pipeline); default analytic")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory, made with its missing parents")
    p.add_argument("--runs", type=_positive_int, default=None, help="simulate: runs per cell (default 1000)")
    p.add_argument("--channel", choices=("mmbp", "timed", "camcomsim"), default=None,
                   help="simulate: channel model (default mmbp)")
    p.add_argument("--max-emissions", type=_positive_int, default=None, help="simulate: cap per run (default 50000)")
    p.add_argument("--frames", type=_positive_int, default=None, help="run: frames per cell (default 100)")
    p.add_argument("--keep-frames", action="store_true", help="run: also write each cell's PNG frames")
    p.add_argument("--seed", type=_non_negative_int, default=None, help="sweep seed (default: the scene's)")
    p.add_argument("--workers", type=_workers, default=None, help="local Dask workers (default: one per core)")
    _add_scheduler_options(p)
    p.add_argument("--resume", action="store_true", help="continue the sweep in DIR: only missing or failed cells run")
    _add_force(p, "a previous rollsim result in DIR")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_set_option(p)
    _inputs(p, scenes=["scene"])
    p.set_defaults(func=cmd_sweep)


def _add_paper_command(sub) -> None:
    p = sub.add_parser("paper", help="every experiment of the reference paper through rollsim: paper.json and a report")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory, made with its missing parents")
    p.add_argument("--quick", action="store_true",
                   help="a reduced run (60 frames, 200 runs, the pixel pipeline on distances only): a few minutes")
    p.add_argument("--frames", type=_positive_int, default=None, help="frames per pixel setting (default 300; quick 60)")
    p.add_argument("--runs", type=_positive_int, default=None, help="runs per event setting (default 1000; quick 200)")
    p.add_argument("--workers", type=_workers, default=None, help="local Dask workers (default: one per core)")
    _add_scheduler_options(p)
    _add_force(p, "a previous rollsim result in DIR")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=cmd_paper)


def _add_bench_commands(sub) -> None:
    bench = sub.add_parser("bench", help="benchmarks: speed and memory on this machine")
    bench_sub = bench.add_subparsers(dest="bench", metavar="BENCHMARK")
    bench_sub.required = True

    def add(name: str, help_text: str):
        p = bench_sub.add_parser(name, help=help_text)
        p.set_defaults(func=cmd_bench, bench_main=_bench_main(name))
        return p

    p = add("render", "render speed at 1080p against its targets: stage profile, PNG floor and end-to-end frames/s, "
            "each effect's cost, in-memory render + decode, start-up, peak memory")
    p.add_argument("--scene", default="paper-geometric", help="scene file or bundled scene name (default paper-geometric)")
    _add_set_option(p)
    _inputs(p, scenes=["scene"])
    p.add_argument("--quick", action="store_true",
                   help="a rough check in a few minutes: 5 frames per figure, 3 per effect, one in-memory run of "
                   "10, one end-to-end run of 40, memory at 50 and 250 frames, one start-up run (options given "
                   "still count)")
    p.add_argument("--frames", type=_positive_int, default=None,
                   help="frames timed for the stage profile, each render variant and the PNG encoding (default 20)")
    p.add_argument("--effect-frames", type=_positive_int, default=None,
                   help="frames with and without each effect (default 6)")
    p.add_argument("--effects", nargs="*", metavar="EFFECT", default=None,
                   help="effects whose cost to measure (default all; the option alone: none)")
    p.add_argument("--decode-frames", type=_positive_int, default=None,
                   help="frames rendered and decoded in memory, on one core and per worker (default 30)")
    p.add_argument("--decode-repeats", type=_positive_int, default=None,
                   help="runs of the workers rendering and decoding in memory (default 3)")
    p.add_argument("--e2e-frames", type=_positive_int, default=None, help="frames of each end-to-end run (default 120)")
    p.add_argument("--e2e-repeats", type=_positive_int, default=None, help="end-to-end runs (default 3)")
    p.add_argument("--rss-frames", type=_positive_int, nargs=2, default=None, metavar=("FEW", "MANY"),
                   help="frame counts of the two peak-memory runs (default 200 2000)")
    p.add_argument("--startup-runs", type=_positive_int, default=None, help="runs of each start-up command (default 3)")
    p.add_argument("--workers", type=_workers, default=2,
                   help="workers of the end-to-end, in-memory and memory runs (default 2)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    _add_json_file(p)
    _add_force(p)

    p = add("eventsim", "event simulator: emissions/s, wall time and memory of the CamComSim workload")
    p.add_argument("--runs", type=_positive_int, default=1000, help="runs (default 1000)")
    p.add_argument("--workers", type=_workers, default=None, help="worker processes (default: both cores)")
    _add_json_file(p)
    _add_force(p)

    p = add("decode", "decoder ms per 1080p frame in memory (one core), and PNG read time")
    p.add_argument("--frames", type=_positive_int, default=30, help="frames timed per scene (default 30)")
    _add_json_file(p)
    _add_force(p)

    p = add("video", "video at 1080p: rendering to H.264 (frames/s) per encoding, and reading it back (ms/frame)")
    p.add_argument("--frames", type=_positive_int, default=150, help="frames rendered per run (default 150)")
    p.add_argument("--workers", type=_workers, default=None, help="render workers (default 2)")
    _add_json_file(p)
    _add_force(p)

    p = add("stress", "decoder outcome rates on the paper, stress and effect scenes (the table in docs/evaluation.md)")
    p.add_argument("scenes", nargs="*", metavar="SCENE", help="scenes (default: every bundled paper-, stress- and effect- scene)")
    _inputs(p, scenes=["scenes"])
    p.add_argument("--frames", type=_positive_int, default=100, help="frames per scene (default 100)")
    p.add_argument("--workers", type=_workers, default=2, help="scenes in parallel (default 2)")
    p.add_argument("--decoder", metavar="MODULE:FUNCTION", default=None,
                   help="also decode the same frames with this decoder and compare it with rollsim's")
    p.add_argument("--markdown", metavar="FILE", help="also write the table as Markdown")
    _add_json_file(p)
    _add_force(p, "existing output files")

    p = add("sweep", "sweep cost: analytic 10,000 cells, simulate 100 x 1,000 runs, run stage speed-up and overhead")
    p.add_argument("--frames", type=_positive_int, default=100, help="frames per run-stage cell (default 100)")
    p.add_argument("--repeats", type=_positive_int, default=3, help="run-stage repeats, 1 and 2 workers alternating (default 3)")
    _add_json_file(p)
    _add_force(p)

    p = add("envelope", "where the decoder works: ok %% of fully visible PHY-SDUs, decoder against a genie-aided "
            "receiver, along exposure, stripe SNR, blur, defocus, rows per chip, LED/background, saturation and hand shake")
    p.add_argument("--frames", type=_positive_int, default=None, help="frames per cell (default 16; quick 2)")
    p.add_argument("--maps", metavar="NAME,...", default=None,
                   help="maps to run (default all: exposure,snr,blur,defocus,rows_per_chip,contrast,saturation,shake)")
    p.add_argument("--quick", action="store_true", help="two points per map, two frames per cell (a check, not results)")
    p.add_argument("--seed", type=int, default=None, help="sweep seed of every map (default: each scene's)")
    p.add_argument("--workers", type=_workers, default=None, help="local Dask workers (default: one per core)")
    _add_scheduler_options(p)
    p.add_argument("--out", metavar="DIR", default=None,
                   help="write MAP.csv and MAP.png per map, envelope.md (the boundaries) and envelope.json (all) here")
    _add_json_file(p)
    _add_force(p, "those files if present")
    p.add_argument("--quiet", action="store_true", help="no progress lines")

    p = add("fit-camera", "the camera fit on hidden cameras drawn at random: fitted or refused, each parameter's "
            "error, the re-rendered frames' row-profile correlation and the time, against the targets")
    p.add_argument("--seed", type=int, default=1, help="seed the hidden cameras are drawn from (default 1)")
    p.add_argument("--cameras", type=_positive_int, default=40, help="hidden cameras (default 40)")
    p.add_argument("--video", action="store_true",
                   help="record each camera's frames as a phone's H.264 video (17 Mb/s at 1080p30, the same "
                        "bits per pixel for other sizes), and fit them as such")
    p.add_argument("--known", action="append", choices=["exposure", "tone", "binning"], default=[],
                   help="tell the fit each hidden camera's exposure, tone curve or binning, as a user who knows "
                        "it does (fit-camera --exposure-us, --tone, --binning-rows); repeatable")
    p.add_argument("--max-height", type=_positive_int, default=2160,
                   help="largest frame height drawn, px (default 2160; smaller for a quick check)")
    p.add_argument("--workers", type=_workers, default=1, help="cameras fitted in parallel (default 1: one core)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    _add_json_file(p)
    _add_force(p)

    p = add("profile", "where a user's wait goes: start-up, rollsim run's stages as a fresh process, and the "
            "run profiled in this process by phase (set-up, kernels, workers, each part of the calibration, each plot)")
    p.add_argument("scene", metavar="SCENE", nargs="?", default="paper-default",
                   help="scene file or bundled scene name (default paper-default)")
    _inputs(p, scenes=["scene"])
    p.add_argument("--frames", type=_positive_int, default=None, help="frames of each run (default: the scene's)")
    p.add_argument("--repeats", type=_positive_int, default=3, help="runs of each figure (default 3)")
    p.add_argument("--workers", type=_workers, default=2, help="workers of the profiled run (default 2)")
    p.add_argument("--out", metavar="DIR", default=None, help="write profile.md and profile.json here")
    _add_force(p, "those files if present")
    p.add_argument("--quiet", action="store_true", help="no progress lines")

    p = add("waits", "the waits a user meets, each against its target: paper, run, render against its engine, "
            "the tour's sweep, describe, one frame's render on one core (docs/speed.md)")
    p.add_argument("--repeats", type=_positive_int, default=3, help="runs of each row (default 3)")
    p.add_argument("--only", nargs="+", metavar="WAIT", default=None,
                   help="measure these rows only: paper paper-quick run render sweep describe default-effects blooming")
    p.add_argument("--all", action="store_true", help="every row, the full paper's (minutes a run) too")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    _add_json_file(p)
    _add_force(p, "the --json file if present")

    p = add("accuracy", "what accuracy costs: each fidelity setting against the most accurate one, in time, image "
            "error, noise distribution, decode outcomes and the MMBP fit; and each effect's cost")
    p.add_argument("scene", metavar="SCENE", help="scene file or bundled scene name")
    _inputs(p, scenes=["scene"])
    p.add_argument("--frames", type=_positive_int, default=30, help="frames per setting (default 30)")
    p.add_argument("--knobs", nargs="+", metavar="KNOB", default=None,
                   help="knobs to measure (default all: footprint_edge shot_noise read_noise blur_kernel "
                   "blur_truncation demosaic spectral_step led_rise_time)")
    p.add_argument("--effects", nargs="*", metavar="EFFECT", default=None,
                   help="effects whose own cost to measure (default all; the option alone: none)")
    p.add_argument("--out", metavar="DIR", default=None,
                   help="write accuracy.csv, effects_cost.csv, accuracy.json, accuracy.md and accuracy_pareto.png here")
    _add_force(p, "those files if present")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    _add_set_option(p)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="rollsim",
        description="Rolling-shutter camera simulator for optical camera communication.",
    )
    parser.add_argument("--version", action="version", version=f"rollsim {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks for errors")
    parser.add_argument("--memory-limit", metavar="SIZE", default=None,
                        help="memory budget (e.g. 4G, 500M); inputs that need more are refused before any work "
                        "(default: $ROLLSIM_MEMORY_LIMIT, else half the available memory)")
    parser.add_argument("--disk-limit", metavar="SIZE", default=None,
                        help="disk budget (e.g. 20G); outputs estimated to need more are refused before any work "
                        "(default: $ROLLSIM_DISK_LIMIT, else the free space less 5 %% of the disk, at most 1 GiB)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    _add_scene_commands(sub)
    _add_pixel_commands(sub)
    _add_channel_commands(sub)
    _add_sweep_command(sub)
    _add_paper_command(sub)
    _add_bench_commands(sub)
    return parser


# -------------------------------------------------------------------- main


def _report(lines: Sequence[str]) -> None:
    for line in lines:
        print(f"rollsim: error: {line}", file=sys.stderr)


def _run(args) -> int:
    from rollsim.plumbing.budget import DISK_ENV_VAR, ENV_VAR, parse_size

    if args.memory_limit is not None:
        # In the environment, so that worker processes keep to it too.
        os.environ[ENV_VAR] = str(parse_size(args.memory_limit, "--memory-limit"))
    if args.disk_limit is not None:
        os.environ[DISK_ENV_VAR] = str(parse_size(args.disk_limit, "--disk-limit"))
    if getattr(args, "connect_timeout", None) is not None:
        from rollsim.sweeps.scheduler import ENV_VAR as TIMEOUT_VAR, connect_timeout_s

        # Every stage that connects (a sweep, the paper's, the envelope's) reads it there.
        os.environ[TIMEOUT_VAR] = repr(connect_timeout_s(args.connect_timeout))
    _check_repeated_keys(args)
    _check_inputs(args)
    _check_outputs(args)
    return args.func(args)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``rollsim`` console script."""
    from rollsim.plumbing import signals
    from rollsim.plumbing.budget import DISK_ENV_VAR, ENV_VAR
    from rollsim.plumbing.outputs import describe_os_error

    args = build_parser().parse_args(argv)
    # rollsim.sweeps.scheduler.ENV_VAR, named here: importing it loads rollsim.sweeps (0.2 s) for every command.
    saved_environ = {name: os.environ.get(name) for name in (ENV_VAR, DISK_ENV_VAR, "ROLLSIM_CONNECT_TIMEOUT")}
    saved_handlers = signals.install_handlers()
    try:
        return _run(args)
    except RollsimError as exc:
        if args.debug:
            raise
        _report(exc.lines)
        return exc.exit_code
    except Interrupted as exc:
        print(f"rollsim: stopped by {signal.Signals(exc.signum).name}; {exc.note}", file=sys.stderr)
        return 128 + exc.signum
    except KeyboardInterrupt:
        print("rollsim: interrupted; nothing was written", file=sys.stderr)
        return 128 + signal.SIGINT
    except BrokenPipeError:
        # The reader of our output went away (`rollsim analytic | head`):
        # stop quietly, as command-line tools do.
        with_devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(with_devnull, sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    except MemoryError:
        if args.debug:
            raise
        _report(["out of memory; lower the sizes or the workers, or set --memory-limit so that inputs this large "
                 "are refused before they start"])
        return EXIT_FAILURE
    except OSError as exc:
        if args.debug:
            raise
        _report([describe_os_error(exc)])
        return EXIT_FAILURE
    finally:
        signals.restore_handlers(saved_handlers)
        for name, value in saved_environ.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


if __name__ == "__main__":
    sys.exit(main())
