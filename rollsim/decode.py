"""Decode a directory of frames into ``decoded.jsonl``.

The receiver itself is the :mod:`decoder` package; this module is the glue
that runs it over a render directory (or any folder of PNG frames) and
writes the results:

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

import json
import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, Optional

from rollsim.errors import RollsimError
from rollsim.outputs import staged_files
from rollsim.parallel import chunked, ordered_chunk_map
from rollsim.protocol import PhyFormat
from rollsim.transmitter import phy_from_scene

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

DECODED_NAME = "decoded.jsonl"
SUMMARY_NAME = "decode.json"
CHUNK_FRAMES = 8


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
    """

    phy: PhyFormat
    clock_hz: Optional[float] = None
    row_time_s: Optional[float] = None
    decoder: Optional[str] = None
    exposure_s: Optional[float] = None

    def __post_init__(self):
        for name, value in (("clock_hz", self.clock_hz), ("row_time_s", self.row_time_s),
                            ("exposure_s", self.exposure_s)):
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


def frame_files(directory: Path) -> list[Path]:
    """The PNG frames of a directory: ``DIR/frames/*.png``, else ``DIR/*.png``, sorted by name.

    Raises
    ------
    RollsimError
        No such directory, or no PNG in it.
    """
    directory = Path(directory)
    if not directory.is_dir():
        raise RollsimError(f"{directory}: not a directory")
    sub = directory / "frames"
    folder = sub if sub.is_dir() else directory
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() == ".png" and not p.name.startswith("."))
    if not files:
        raise RollsimError(f"{folder}: no PNG frames")
    return files


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

    from rollsim.budget import memory_budget_bytes

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
    except Exception as exc:  # any error of the user's module is reported, not raised
        raise RollsimError(f"--decoder {spec}: cannot import {module_name} ({type(exc).__name__}: {exc})") from None
    function = getattr(module, name, None)
    if function is None:
        raise RollsimError(f"--decoder {spec}: {module_name} has no {name}")
    if not callable(function):
        raise RollsimError(f"--decoder {spec}: {name} is not callable")
    return function


def _decode_chunk_with(chunk: list[tuple[int, str]], settings: DecodeSettings,
                       max_pixels: int) -> list[tuple[int, list[dict], Optional[dict]]]:
    """:func:`_decode_chunk` for a decoder other than rollsim's (``settings.decoder``)."""
    from decoder import FrameDecode, FrameError, read_frame

    from rollsim.protocol.frames import frame_index_from_name
    from rollsim.records import as_decoded_record

    function = load_decoder(str(settings.decoder))
    out: list[tuple[int, list[dict], Optional[dict]]] = []
    for position, source in chunk:
        index = frame_index_from_name(source, position)
        try:
            image = read_frame(source, max_pixels)
        except FrameError as exc:
            out.append((index, [], FrameDecode(index, source, (), str(exc)).error_record()))
            continue
        try:
            found = list(function(image, settings))
        except Exception as exc:  # the user's decoder failed on this frame: say where, and stop
            raise RollsimError(f"--decoder {settings.decoder}: failed on {source} "
                               f"({type(exc).__name__}: {exc})") from None
        try:
            records = [as_decoded_record(f, index) for f in found]
        except RollsimError as exc:
            raise RollsimError(f"--decoder {settings.decoder}: {source}: {exc}") from None
        out.append((index, records, None))
    return out


def _decode_chunk(chunk: list[tuple[int, str]], settings: DecodeSettings,
                  max_pixels: int) -> list[tuple[int, list[dict], Optional[dict]]]:
    from decoder import decode_frames

    if settings.decoder is not None:
        return _decode_chunk_with(chunk, settings, max_pixels)
    first = chunk[0][0]
    out = []
    for result in decode_frames([path for _, path in chunk], settings.phy, settings.clock_hz, settings.row_time_s,
                                first_frame=first, max_pixels=max_pixels, exposure_s=settings.exposure_s):
        out.append((result.frame, result.to_records(), result.error_record()))
    return out


def iter_decoded(paths: list[Path], settings: DecodeSettings, workers: int = 1) -> Iterator[tuple[int, list[dict], Optional[dict]]]:
    """Decode frame files; yield ``(frame, records, error)`` in file order.

    A file's frame index is the last number in its name, else its position.
    ``error`` is None for a frame that was read, else a record naming the
    file and what is wrong with it (a frame too large for the memory budget
    is one of these: :func:`frame_pixel_limit`).
    """
    chunks = chunked(list(enumerate(os.fspath(p) for p in paths)), CHUNK_FRAMES)
    yield from ordered_chunk_map(_decode_chunk, chunks, workers, settings, frame_pixel_limit(workers))


def _relative_error(error: dict, run_dir: Path) -> dict:
    """An error record naming its file relative to the run directory."""
    source = error["source"]
    try:
        relative = str(Path(source).relative_to(run_dir))
    except ValueError:
        return error
    return {**error, "source": relative, "error": error["error"].replace(source, relative, 1)}


def decode_directory(
    run_dir: Path,
    settings: DecodeSettings,
    *,
    workers: int = 1,
    force: bool = False,
    on_error: Optional[Callable[[dict], None]] = None,
    progress: Optional[Callable[[int], None]] = None,
) -> DecodeSummary:
    """Decode every frame of ``run_dir``; write ``decoded.jsonl`` and ``decode.json``.

    Both files are committed together (:mod:`rollsim.outputs`): an
    interrupted decode (a full disk, a signal) leaves neither, and the
    next one starts afresh.

    Parameters
    ----------
    run_dir : Path
        A render directory (frames in ``frames/``) or a folder of PNGs.
    settings : DecodeSettings
    workers : int
        Processes.
    force : bool
        Replace existing outputs; without it they are never overwritten.
    on_error : callable, optional
        Called with the error record of each unreadable frame, as it comes.
    progress : callable, optional
        Called with the number of frames done after each frame.

    Returns
    -------
    DecodeSummary
    """
    run_dir = Path(run_dir)
    files = frame_files(run_dir)
    targets = [run_dir / DECODED_NAME, run_dir / SUMMARY_NAME]
    summary = DecodeSummary(settings, frames=len(files))
    with staged_files(targets, force) as staged:
        with staged.open(targets[0]) as out:
            for done, (_, records, error) in enumerate(iter_decoded(files, settings, workers), start=1):
                for record in records:
                    out.write(json.dumps(record, separators=(",", ":"), allow_nan=False) + "\n")
                summary.sdus += len(records)
                summary.sdus_ok += sum(1 for r in records if r["check_ok"])
                if error is not None:
                    error = _relative_error(error, run_dir)
                    summary.unreadable.append(error)
                    if on_error is not None:
                        on_error(error)
                if progress is not None:
                    progress(done)
        staged.write(targets[1], json.dumps(summary.as_dict(), indent=2, allow_nan=False) + "\n")
    return summary


# rollsim.decode(...) is the Python API's function (rollsim.api).
from rollsim.callable_module import make_callable  # noqa: E402

make_callable(__name__)
