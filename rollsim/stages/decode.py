"""Decode a directory of frames into ``decoded.jsonl``.

The receiver itself is the :mod:`decoder` package; this module is the glue
that runs it over a render directory (or any folder of PNG frames, or a
video file: :func:`frame_video`) and writes the results:

``decoded.jsonl``
    One line per PHY-SDU found, ``ok`` or not (see
    :meth:`decoder.DecodedPhySdu.to_record`).
``decode.json``
    What was decoded with which settings, the frame count, and every frame
    that could not be read, by name.

A corrupt or unreadable frame is reported, skipped and counted; the run goes
on. Frames are decoded in chunks by worker processes, in a bounded window so
that memory stays flat, and written in frame order, so the output does not
depend on the number of workers.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import signal
import threading
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterator, Optional

from rollsim.errors import Interrupted, RollsimError, clip, short_repr
from rollsim.plumbing.outputs import staged_files
from rollsim.plumbing.parallel import chunked, ordered_chunk_map
from rollsim.protocol import PhyFormat
from rollsim.stages.records import run_identifier
from rollsim.transmitter import phy_from_scene
from rollsim.plumbing.validation import missing_path

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

DECODED_NAME = "decoded.jsonl"
SUMMARY_NAME = "decode.json"
CHUNK_FRAMES = 8
# The most records a decoder may return for one frame: a PHY-SDU spans rows,
# so a frame holds a few hundred at most; more is a decoder gone wrong (an
# endless generator), stopped before it fills the memory or the disk.
MAX_RECORDS_PER_FRAME = 100_000


@dataclass(frozen=True)
class DecodeSettings:
    """What the decoder is told about the link and the camera.

    Attributes
    ----------
    phy : PhyFormat
        PHY-SDU layout.
    clock_hz : float or None
        Chip rate in Hz.
    row_time_s : float or None
        Row time in seconds. Without it (or without ``clock_hz``) the chip
        pitch is estimated from the frame (:mod:`decoder.pitch`).
    decoder : str or None
        ``package.module:function`` of a decoder other than rollsim's
        (:func:`load_decoder`); None for rollsim's.
    exposure_s : float or None
        Exposure time in seconds. With the chip pitch, rollsim's decoder
        reads exposures longer than a chip by sequence detection
        (:mod:`decoder.equalise`); without it, by thresholding.
    decoder_timeout_s : float or None
        The most seconds ``decoder`` may take on one frame (calling it and
        reading what it returns); None for no limit. See
        :func:`plugin_records` for what it can and cannot stop.
    """

    phy: PhyFormat
    clock_hz: Optional[float] = None
    row_time_s: Optional[float] = None
    decoder: Optional[str] = None
    exposure_s: Optional[float] = None
    decoder_timeout_s: Optional[float] = None

    def __post_init__(self):
        for name, value in (("clock_hz", self.clock_hz), ("row_time_s", self.row_time_s),
                            ("exposure_s", self.exposure_s), ("decoder_timeout_s", self.decoder_timeout_s)):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise RollsimError(f"{name} = {value}: must be a finite number > 0")

    def as_dict(self) -> dict:
        return {"phy": asdict(self.phy), "clock_hz": self.clock_hz, "row_time_s": self.row_time_s,
                "exposure_s": self.exposure_s, "decoder": self.decoder or "rollsim"}


@dataclass
class DecodeSummary:
    """What a decode run did.

    Attributes
    ----------
    frames : int
        Frame files found.
    sdus, sdus_ok : int
        PHY-SDUs written to ``decoded.jsonl``, and those whose check passed.
    unreadable : list of dict
        ``{"frame", "source", "error"}`` for every frame that was skipped.
    """

    settings: DecodeSettings
    frames: int = 0
    sdus: int = 0
    sdus_ok: int = 0
    unreadable: list = field(default_factory=list)

    def as_dict(self) -> dict:
        return {
            **self.settings.as_dict(),
            "frames": self.frames,
            "frames_unreadable": len(self.unreadable),
            "sdus": self.sdus,
            "sdus_ok": self.sdus_ok,
            "unreadable": self.unreadable,
        }


def settings_from_scene(scene: Scene, clock_hz: Optional[float] = None, row_time_us: Optional[float] = None,
                        exposure_us: Optional[float] = None) -> DecodeSettings:
    """Decode settings from a scene; ``clock_hz``, ``row_time_us`` and ``exposure_us`` override it."""
    clock = scene.link.clock_hz if clock_hz is None else clock_hz
    row_time_s = scene.camera.row_time_s if row_time_us is None else row_time_us * 1e-6
    exposure_s = (scene.camera.exposure_us if exposure_us is None else exposure_us) * 1e-6
    return DecodeSettings(phy_from_scene(scene), float(clock), float(row_time_s), exposure_s=float(exposure_s))


# Frame files by kind, from their names' suffixes (case aside).
FRAME_SUFFIXES = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG"}


def is_frame_file(path: Path) -> bool:
    """Whether ``path`` is named as a frame file (PNG or JPEG), not hidden."""
    return path.suffix.lower() in FRAME_SUFFIXES and not path.name.startswith(".")


def frame_files(directory: Path) -> list[Path]:
    """The frames of a directory: ``DIR/frames/*.png``, else ``DIR/*.png`` or ``DIR/*.jpg`` (``.jpeg``), sorted by name.

    Raises
    ------
    RollsimError
        No such directory, no frame file in it, or PNG and JPEG frames
        side by side (a render's frames and a camera's stills are not one
        sequence: which is meant is not guessed).
    """
    directory = Path(directory)
    if not directory.is_dir():
        raise RollsimError(missing_path(directory) or f"{directory}: not a directory")
    sub = directory / "frames"
    folder = sub if sub.is_dir() else directory
    files = sorted(p for p in folder.iterdir() if is_frame_file(p))
    if not files:
        raise RollsimError(f"{folder}: no PNG or JPEG frames")
    kinds = sorted({FRAME_SUFFIXES[p.suffix.lower()] for p in files})
    if len(kinds) > 1:
        counts = ", ".join(f"{sum(FRAME_SUFFIXES[p.suffix.lower()] == k for p in files)} {k}" for k in kinds)
        raise RollsimError(f"{folder}: holds both PNG and JPEG frames ({counts}); give the files of one kind")
    return files


def frame_video(path: Path) -> Optional[Path]:
    """The video file ``path`` stands for, or None where it holds PNG or JPEG frames.

    ``path`` itself when it is named as a video (:data:`rollsim.video.read.VIDEO_SUFFIXES`);
    for a directory without PNG frames, its one video file (``frames.mp4`` or
    ``frames.mkv`` of a render first).

    Raises
    ------
    RollsimError
        A directory holding several videos and no render's.
    """
    from rollsim.video.read import is_video_file

    path = Path(path)
    if path.is_file() or not path.exists():
        return path if is_video_file(path) else None
    folder = path / "frames" if (path / "frames").is_dir() else path
    if any(is_frame_file(p) for p in folder.iterdir()):
        return None
    videos = sorted(p for p in path.iterdir() if p.is_file() and is_video_file(p) and not p.name.startswith("."))
    rendered = [p for p in videos if p.stem == "frames"]
    if len(rendered) == 1 or len(videos) == 1:
        return (rendered or videos)[0]
    if len(videos) > 1:
        raise RollsimError(f"{path}: holds {len(videos)} videos ({', '.join(p.name for p in videos[:3])}); "
                           "give the file")
    return None


def video_chunks(video: Path, start: int = 0, count: Optional[int] = None, size: int = 8,
                 notes: Optional[list] = None, rotate_deg: Optional[int] = None) -> Iterator[list[tuple[int, Any]]]:
    """``(frame index, image)`` pairs of a video's frames ``start`` … in chunks of ``size``, streamed
    (upright: :func:`rollsim.video.read.read_video_frames`)."""
    from rollsim.video.read import read_video_frames

    frames = enumerate(read_video_frames(video, start, count, rotate_deg=rotate_deg, notes=notes), start=start)
    while True:
        chunk = list(itertools.islice(frames, size))
        if not chunk:
            return
        yield chunk


# Peak bytes per pixel of one process decoding a frame, beyond the decoded
# image itself: 2.0 B/px measured for gray and 3.3 for RGB frames (peak
# resident memory at 1920x1080); generous, because a real camera's frame
# may hold several LED regions (tests/render/test_render_memory.py).
DECODE_BYTES_PER_PIXEL = 24
# The largest decoded PNG: RGBA, 16 bits per sample.
_MAX_PNG_BYTES_PER_PIXEL = 8


def frame_pixel_limit(workers: int = 1) -> int:
    """The most pixels a frame may have for ``workers`` processes to decode within the memory budget."""
    from decoder import MAX_FRAME_PIXELS

    from rollsim.plumbing.budget import memory_budget_bytes

    per_pixel = DECODE_BYTES_PER_PIXEL + _MAX_PNG_BYTES_PER_PIXEL
    return max(1, min(MAX_FRAME_PIXELS, memory_budget_bytes() // (per_pixel * max(1, workers))))


def load_decoder(spec: str) -> Callable:
    """The decoder ``package.module:function``: ``function(image, settings) -> iterable of records``.

    Raises
    ------
    RollsimError
        One line naming ``spec`` and what is wrong: no ``:``, a module that
        cannot be imported, no such function, or not callable.
    """
    import importlib
    import sys

    module_name, sep, name = str(spec).partition(":")
    if not sep or not module_name or not name:
        raise RollsimError(f"--decoder {spec}: expected package.module:function")
    # As other module:function loaders do, the working directory is searched
    # too, so a decoder in a file beside the user's frames is found.
    if os.getcwd() not in sys.path:
        sys.path.append(os.getcwd())
    try:
        module = importlib.import_module(module_name)
    except Interrupted:
        raise
    except BaseException as exc:  # sys.exit() at import too: the user's module is reported, never obeyed
        raise RollsimError(f"--decoder {spec}: cannot import {module_name} ({_what_happened(exc)})") from None
    function = getattr(module, name, None)
    if function is None:
        raise RollsimError(f"--decoder {spec}: {module_name} has no {name}")
    if not callable(function):
        raise RollsimError(f"--decoder {spec}: {name} is not callable")
    return function


def _what_happened(exc: BaseException) -> str:
    """A plug-in's exception in a few words: its type and message, and what a SystemExit means."""
    if isinstance(exc, SystemExit):
        return f"called sys.exit({short_repr(exc.code)})"
    message = clip(" ".join(str(exc).split()), 160)
    return f"{type(exc).__name__}: {message}" if message else type(exc).__name__


class _Deadline(BaseException):
    """A frame's deadline passed (raised by SIGALRM). Not an Exception, so a plug-in's ``except Exception`` lets it by."""


# setitimer refuses delays beyond its own range; no deadline is that long.
_MAX_TIMER_S = 1e8


class _Alarm:
    """A SIGALRM timer that raises :class:`_Deadline` while armed, and puts back what it replaced.

    The previous SIGALRM handler and timer are restored by :meth:`stop`
    (that timer less the time spent here), so the alarm may run in the
    command's own process or in a caller's.
    """

    def __init__(self, seconds: float):
        self.seconds = min(seconds, _MAX_TIMER_S)
        self.armed = False
        self.passed = False
        self.started = False
        self.previous: Any = None
        self.earlier = (0.0, 0.0)
        self.began = 0.0

    def _ring(self, signum, frame):
        self.passed = True
        if self.armed:
            raise _Deadline

    def start(self) -> None:
        """Note the handler and timer in place, then arm (refused outside the main thread)."""
        if threading.current_thread() is not threading.main_thread():
            raise RollsimError("decoder_timeout_s: a deadline needs the main thread (it is a SIGALRM timer)")
        self.earlier = signal.getitimer(signal.ITIMER_REAL)
        self.began = time.monotonic()
        self.previous = signal.signal(signal.SIGALRM, self._ring)
        self.started = True
        self.armed = True
        signal.setitimer(signal.ITIMER_REAL, self.seconds)

    def stop(self) -> None:
        """Disarm, and put back the handler and timer :meth:`start` found."""
        if not self.started:
            return
        signal.setitimer(signal.ITIMER_REAL, 0)
        # None: a handler not set from Python, which Python cannot put back; the default is the nearest.
        signal.signal(signal.SIGALRM, signal.SIG_DFL if self.previous is None else self.previous)
        delay, interval = self.earlier
        if delay > 0:
            signal.setitimer(signal.ITIMER_REAL, max(1e-6, delay - (time.monotonic() - self.began)), interval)


def _within(seconds: Optional[float], call: Callable[[], list]) -> tuple[list, bool]:
    """``call()`` under a deadline of ``seconds`` (None: none); its result and whether the deadline passed.

    Raises
    ------
    _Deadline
        The deadline passed during ``call``.
    """
    if seconds is None:
        return call(), False
    alarm = _Alarm(seconds)
    try:
        alarm.start()
        result = call()
    finally:
        # Disarmed before stop() is called: an alarm ringing from here on
        # (at stop's first line, say) only notes the time, so the handler
        # and timer are always put back.
        try:
            alarm.armed = False
        finally:
            alarm.stop()
    return result, alarm.passed


def _too_slow(settings: DecodeSettings, index: int) -> RollsimError:
    return RollsimError(f"--decoder {settings.decoder}: frame {index} took more than "
                        f"{settings.decoder_timeout_s:g} s (--decoder-timeout)")


def _records_of(found, index: int, run: Optional[str]) -> list[dict]:
    """What a plug-in returned for frame ``index``, as checked ``decoded.jsonl`` records.

    Runs the plug-in's code too (a generator's body, ``to_record``), so it is
    called under the same guard and deadline as the plug-in itself.
    """
    from rollsim.stages.records import as_decoded_record

    not_records = RollsimError(f"frame {index}: returned {short_repr(found)}, not an iterable of records "
                               "(a list of dicts, say)")
    if found is None or isinstance(found, (dict, str, bytes)):  # iterable, but not of records
        raise not_records
    try:
        items = iter(found)
    except TypeError:
        raise not_records from None
    found = list(itertools.islice(items, MAX_RECORDS_PER_FRAME + 1))
    if len(found) > MAX_RECORDS_PER_FRAME:
        raise RollsimError(f"frame {index}: returned more than {MAX_RECORDS_PER_FRAME} records")
    return [as_decoded_record(f, index, run) for f in found]


def plugin_records(function: Callable, image, settings: DecodeSettings, index: int, source: str,
                   run: Optional[str] = None) -> list[dict]:
    """Run a decoder of one's own on one frame; its records, checked, or one line saying why not.

    Parameters
    ----------
    function : callable
        ``function(image, settings) -> iterable of records`` (:func:`load_decoder`).
    image : ndarray
    settings : DecodeSettings
        ``settings.decoder`` names the plug-in in messages;
        ``settings.decoder_timeout_s`` is the frame's deadline.
    index : int
        The frame's index (numbers the records).
    source : str
        The frame's file, for messages.
    run : str, optional
        The render's identifier, written into every record.

    Raises
    ------
    RollsimError
        Naming the plug-in and the frame: anything the plug-in raised,
        ``sys.exit()``, ``KeyboardInterrupt`` and ``GeneratorExit``
        included; a return value that is no iterable of records; a record
        off the schema (naming the field: NaN and infinities too); the
        deadline passed.
    Interrupted
        SIGINT or SIGTERM reached the command meanwhile: the command's own
        signal handling, passed on.

    Notes
    -----
    The deadline is a SIGALRM timer in the process that runs the plug-in
    (a worker's main thread, or the command's with one worker). Python runs
    signal handlers between bytecodes only, so a plug-in inside a C call
    (``sum(range(10**10))``, a numpy operation, a ``ctypes`` call) is stopped
    when that call returns, and one that never returns is never stopped;
    nor is one that catches every ``BaseException`` and carries on (its
    frame still fails when it returns). Sleeping, waiting on I/O and
    matching regular expressions are interrupted on time.
    """
    name = f"--decoder {settings.decoder}"
    try:
        records, late = _within(settings.decoder_timeout_s,
                                lambda: _records_of(function(image, settings), index, run))
    except _Deadline:
        raise _too_slow(settings, index) from None
    except Interrupted:
        raise
    except RollsimError as exc:
        raise RollsimError(f"{name}: {source}: {exc}") from None
    except BaseException as exc:  # the plug-in's exit or exception is reported, never obeyed
        raise RollsimError(f"{name}: failed on frame {index} ({source}): {_what_happened(exc)}") from None
    if late:  # the plug-in caught the deadline itself and went on
        raise _too_slow(settings, index)
    return records


def _decode_chunk_with(chunk: list[tuple[int, str]], settings: DecodeSettings, max_pixels: int,
                       run: Optional[str] = None) -> list[tuple[int, list[dict], Optional[dict]]]:
    """:func:`_decode_chunk` for a decoder other than rollsim's (``settings.decoder``)."""
    from decoder import FrameDecode, FrameError, read_frame

    from rollsim.protocol.frames import frame_index_from_name

    function = load_decoder(str(settings.decoder))
    out: list[tuple[int, list[dict], Optional[dict]]] = []
    for position, source in chunk:
        if not isinstance(source, str):  # a video's frame, already read
            out.append((position, plugin_records(function, source, settings, position, f"frame {position}", run), None))
            continue
        index = frame_index_from_name(source, position)
        try:
            image = read_frame(source, max_pixels)
        except FrameError as exc:
            out.append((index, [], FrameDecode(index, source, (), str(exc)).error_record()))
            continue
        out.append((index, plugin_records(function, image, settings, index, source, run), None))
    return out


def _decoded_frames(frames: list, settings: DecodeSettings, first_frame: int, run: Optional[str] = None,
                    **options) -> Iterator[tuple[int, list[dict], Optional[dict]]]:
    """rollsim's decoder on frames (paths or arrays) numbered from ``first_frame``: per frame, its index, its
    records (with the render's identifier ``run``, if given) and its error record (None when it was read)."""
    from decoder import decode_frames

    provenance = {} if run is None else {"run": run}
    for result in decode_frames(frames, settings.phy, settings.clock_hz, settings.row_time_s, first_frame=first_frame,
                                exposure_s=settings.exposure_s, **options):
        yield result.frame, [{**r, **provenance} for r in result.to_records()], result.error_record()


def _decode_chunk(chunk: list[tuple[int, str]], settings: DecodeSettings, max_pixels: int,
                  run: Optional[str] = None) -> list[tuple[int, list[dict], Optional[dict]]]:
    if settings.decoder is not None:
        return _decode_chunk_with(chunk, settings, max_pixels, run)
    return list(_decoded_frames([path for _, path in chunk], settings, chunk[0][0], run, max_pixels=max_pixels))


def iter_decoded(paths: list[Path], settings: DecodeSettings, workers: int = 1,
                 run: Optional[str] = None, chunks: Optional[Iterator[list]] = None,
                 ) -> Iterator[tuple[int, list[dict], Optional[dict]]]:
    """Decode frame files; yield ``(frame, records, error)`` in file order.

    A file's frame index is the last number in its name, else its position.
    ``error`` is None for a frame that was read, else a record naming the
    file and what is wrong with it (a frame too large for the memory budget
    is one of these: :func:`frame_pixel_limit`). Every record carries
    ``run`` when given (:func:`rollsim.stages.records.run_identifier`).
    ``chunks`` (``(frame index, image)`` pairs: :func:`video_chunks`) replaces
    ``paths``: a video's frames, read here and decoded by the workers.

    Raises
    ------
    RollsimError
        A decoder of one's own failed (:func:`plugin_records`), or a worker
        process died (killed by the system, or by a decoder's ``os._exit``
        or crash).
    """
    from concurrent.futures.process import BrokenProcessPool

    if chunks is None:
        chunks = chunked(list(enumerate(os.fspath(p) for p in paths)), CHUNK_FRAMES)
    done = 0
    try:
        for item in ordered_chunk_map(_decode_chunk, chunks, workers, settings, frame_pixel_limit(workers), run):
            done += 1
            yield item
    except BrokenProcessPool:
        who = f"--decoder {settings.decoder}" if settings.decoder else "decode"
        first = os.path.basename(paths[min(done, len(paths) - 1)]) if paths else f"frame {done}"
        raise RollsimError(f"{who}: a worker process died while decoding the frames from {first} on (killed, "
                           "out of memory, or the decoder exited or crashed)") from None


def _relative_error(error: dict, run_dir: Path) -> dict:
    """An error record naming its file relative to the run directory."""
    source = error["source"]
    try:
        relative = str(Path(source).relative_to(run_dir))
    except ValueError:
        return error
    return {**error, "source": relative, "error": error["error"].replace(source, relative, 1)}


@dataclass(frozen=True)
class FrameDecoder:
    """rollsim's decoder on a frame in memory, with the records :func:`decode_directory` writes for it.

    The frame a render has just made is the array its PNG holds (PNG is
    lossless, and :func:`decoder.read_frame` gives back the rendered array),
    so decoding it before the PNG is read back gives the same records, and
    saves reading the file (``rollsim run`` decodes in the render's workers).
    Picklable: the workers receive it.

    Parameters
    ----------
    settings : DecodeSettings
        rollsim's decoder's settings (``settings.decoder`` must be None).
    run : str, optional
        The render's identifier, written into every record
        (:func:`rollsim.stages.records.scene_run_identifier`).
    """

    settings: DecodeSettings
    run: Optional[str] = None

    def __post_init__(self) -> None:
        if self.settings.decoder is not None:
            raise ValueError("FrameDecoder runs rollsim's decoder; a decoder of one's own goes through "
                             "decode_directory (its deadline and checks)")

    def __call__(self, index: int, image, source: str) -> tuple[list[dict], Optional[dict]]:
        """Records of frame ``index`` and its error record (None when it was read); ``source`` names it."""
        _, records, error = next(_decoded_frames([image], self.settings, index, self.run))
        return records, None if error is None else {**error, "source": source}


class DecodedRecords:
    """``decoded.jsonl`` written frame by frame, in frame order, and the summary ``decode.json`` holds.

    Parameters
    ----------
    out : text file
        ``decoded.jsonl``, open for writing.
    summary : DecodeSummary
        Counted into as frames are added.
    run_dir : Path
        Error records name their file relative to it.
    on_error : callable, optional
        Called with the error record of each unreadable frame.
    """

    def __init__(self, out, summary: DecodeSummary, run_dir: Path, on_error: Optional[Callable[[dict], None]] = None):
        self.out, self.summary, self.run_dir, self.on_error = out, summary, Path(run_dir), on_error

    def add(self, records: list[dict], error: Optional[dict]) -> None:
        """One frame's records (written) and its error record (counted, reported), or None."""
        for record in records:
            self.out.write(json.dumps(record, separators=(",", ":"), allow_nan=False) + "\n")
        self.summary.sdus += len(records)
        self.summary.sdus_ok += sum(1 for r in records if r["check_ok"])
        if error is not None:
            error = _relative_error(error, self.run_dir)
            self.summary.unreadable.append(error)
            if self.on_error is not None:
                self.on_error(error)


def summary_text(summary: DecodeSummary) -> str:
    """``decode.json``'s text."""
    return json.dumps(summary.as_dict(), indent=2, allow_nan=False) + "\n"


def decode_directory(
    run_dir: Path,
    settings: DecodeSettings,
    *,
    workers: int = 1,
    force: bool = False,
    on_error: Optional[Callable[[dict], None]] = None,
    progress: Optional[Callable[[int], None]] = None,
    timeout_s: Optional[float] = None,
    start: int = 0,
    count: Optional[int] = None,
    notes: Optional[list] = None,
    rotate_deg: Optional[int] = None,
) -> DecodeSummary:
    """Decode every frame of ``run_dir``; write ``decoded.jsonl`` and ``decode.json``.

    Both files are committed together (:mod:`rollsim.plumbing.outputs`): an
    interrupted decode (a full disk, a signal) leaves neither, and the
    next one starts afresh.

    Parameters
    ----------
    run_dir : Path
        A render directory (frames in ``frames/`` or one video), a folder of
        PNGs, or a video file (outputs beside it).
    settings : DecodeSettings
    workers : int
        Processes.
    force : bool
        Replace existing outputs; without it they are never overwritten.
    on_error : callable, optional
        Called with the error record of each unreadable frame, as it comes.
    progress : callable, optional
        Called with the number of frames done after each frame.
    timeout_s : float, optional
        The most seconds a decoder of one's own (``settings.decoder``) may
        take on one frame; replaces ``settings.decoder_timeout_s`` when given.
    start, count : int
        A video's frames to decode: from ``start``, ``count`` of them (None: to the end).
    notes : list, optional
        Lines about what reading a video assumed (:func:`rollsim.video.read.read_video_frames`).
    rotate_deg : int, optional
        A video's frames turned clockwise by this much (default: as its container says).

    Returns
    -------
    DecodeSummary

    Raises
    ------
    RollsimError
        No frames; an existing output without ``force``; a decoder of one's
        own that failed, exited, returned records off the schema or passed
        its deadline (:func:`plugin_records`): nothing is written then.
    """
    run_dir = Path(run_dir)
    if timeout_s is not None:
        settings = replace(settings, decoder_timeout_s=timeout_s)
    if settings.decoder_timeout_s is not None and settings.decoder is None:
        raise RollsimError("--decoder-timeout: applies to a decoder of your own (--decoder) only")
    video = frame_video(run_dir)
    if video is not None:
        from rollsim.video.read import probe_video

        probe_video(video)  # a file that is not video is refused before any output
        run_dir = video.parent if video == run_dir else run_dir
        files: list[Path] = []
        chunks = video_chunks(video, start, count, CHUNK_FRAMES, notes, rotate_deg)
    else:
        files, chunks = frame_files(run_dir), None
    run = run_identifier(run_dir)
    targets = [run_dir / DECODED_NAME, run_dir / SUMMARY_NAME]
    summary = DecodeSummary(settings, frames=len(files))
    with staged_files(targets, force) as staged:
        with staged.open(targets[0]) as out:
            written = DecodedRecords(out, summary, run_dir, on_error)
            done = 0
            for done, (_, records, error) in enumerate(iter_decoded(files, settings, workers, run, chunks), start=1):
                written.add(records, error)
                if progress is not None:
                    progress(done)
            summary.frames = done
        staged.write(targets[1], summary_text(summary))
    return summary

