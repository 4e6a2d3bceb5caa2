"""Read the frames of a video file, streamed and the right way up.

Any file FFmpeg reads (a phone's MP4/MOV, MKV) is accepted if its video is
8-bit: Y'CbCr at any chroma subsampling, or grey. Frames come out as uint8
arrays: grey where the file is grey or was written by rollsim from grey
frames, RGB otherwise. A portrait recording is turned upright from the
rotation its container gives (its display matrix, or an older muxer's
``rotate`` tag), or as the caller says (``rotate_deg``).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator, Optional

import numpy as np

from rollsim.errors import RollsimError, short_repr
from rollsim.video.pixels import decoded_array

__all__ = ["VIDEO_SUFFIXES", "VideoInfo", "count_video_frames", "is_video_file", "probe_video", "read_video_frames",
           "recording_settings", "stripes_run_along_columns", "upright_frames"]

# Files taken for video by their name (a directory holding one stands for it).
VIDEO_SUFFIXES = (".mp4", ".mkv", ".mov", ".m4v", ".avi", ".webm")
# 8-bit pixel formats read; 10- and 12-bit ones are refused (rollsim's frames are 8-bit).
_EIGHT_BIT = {"yuv420p", "yuvj420p", "yuv422p", "yuvj422p", "yuv444p", "yuvj444p", "nv12", "nv21", "gray",
              "yuv411p", "yuv440p", "yuvj440p", "rgb24", "bgr24", "bgr0", "gbrp"}
_GREY_FORMATS = {"gray"}
# The frame timestamps may step by this fraction of the average step before the
# rate counts as variable (container time bases round the steps).
_RATE_TOLERANCE = 0.02


def is_video_file(path: Path) -> bool:
    """Whether ``path`` is named as a video file (:data:`VIDEO_SUFFIXES`)."""
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


@dataclass(frozen=True)
class VideoInfo:
    """What a video file's header says.

    Attributes
    ----------
    path : Path
    frames : int or None
        The frame count the header gives (None: not given).
    width_px, height_px : int
        As stored (before rotation).
    frame_rate_hz : float
        The average rate.
    codec, pixel_format : str
    rotation_deg : int
        The clockwise turn that shows the frames upright (0, 90, 180, 270),
        from the container's ``rotate`` tag or the display matrix.
    grey : bool
        Frames are read as grey: the file is grey, or rollsim wrote it from grey frames.
    metadata : dict
        The container's tags.
    """

    path: Path
    frames: Optional[int]
    width_px: int
    height_px: int
    frame_rate_hz: float
    codec: str
    pixel_format: str
    rotation_deg: int
    grey: bool
    metadata: dict = field(default_factory=dict)


def _open(path: Path):
    import av

    if not path.is_file():
        raise RollsimError(f"{path}: no such video file")
    try:
        container = av.open(str(path))
    except (av.FFmpegError, ValueError, OSError) as exc:
        raise RollsimError(f"{path}: not a video file FFmpeg can read ({_reason(exc)})") from None
    if not container.streams.video:
        container.close()
        raise RollsimError(f"{path}: holds no video stream")
    return container


def _reason(exc: BaseException) -> str:
    text = str(exc).split(":")[0] if isinstance(exc, OSError) else str(exc)
    return short_repr(text.strip() or type(exc).__name__).strip("'\"")


def _rotation(container, stream) -> int:
    """The clockwise turn (degrees) that shows the frames upright: the container's
    ``rotate`` tag (clockwise, as older FFmpeg muxers wrote it), else the first
    frame's display matrix (which turns the frame counterclockwise by its angle)."""
    tag = stream.metadata.get("rotate")
    if tag is not None:
        try:
            return int(round(float(tag) / 90.0)) * 90 % 360
        except ValueError:
            return 0
    try:
        frame = next(container.decode(stream), None)
    except Exception:  # a file broken past its header is refused where its frames are read
        return 0
    counterclockwise = int(round(getattr(frame, "rotation", 0) or 0))
    return int(round(-counterclockwise / 90.0)) * 90 % 360


def probe_video(path: Path) -> VideoInfo:
    """Read a video file's header.

    Raises
    ------
    RollsimError
        Not a file, not a video FFmpeg reads, no video stream, or a pixel
        format that is not 8-bit.
    """
    path = Path(path)
    container = _open(path)
    try:
        stream = container.streams.video[0]
        ctx = stream.codec_context
        fmt = ctx.pix_fmt or "unknown"
        if fmt not in _EIGHT_BIT:
            depth = " (more than 8 bits a sample)" if any(s in fmt for s in ("10", "12", "16")) else ""
            raise RollsimError(f"{path}: pixel format {fmt}{depth} is not read; rollsim reads 8-bit video")
        rate = float(stream.average_rate) if stream.average_rate else float(stream.guessed_rate or 0)
        if not (math.isfinite(rate) and rate > 0):
            raise RollsimError(f"{path}: no frame rate in the header")
        tags = {str(k).lower(): v for k, v in container.metadata.items()}  # Matroska upper-cases its tags
        grey = fmt in _GREY_FORMATS or tags.get("output") == "gray8"
        return VideoInfo(path, int(stream.frames) or None, int(ctx.width), int(ctx.height), rate, ctx.name, fmt,
                         _rotation(container, stream), grey, tags)
    finally:
        container.close()


def count_video_frames(path: Path) -> int:
    """The frames a video holds, counted from its packets (demuxed, not decoded: fast).

    Raises
    ------
    RollsimError
        As :func:`probe_video`, or data that breaks off (a truncated file).
    """
    import av

    probe_video(path)
    container = _open(Path(path))
    try:
        stream = container.streams.video[0]
        return sum(1 for packet in container.demux(stream) if packet.size)
    except av.FFmpegError as exc:
        raise RollsimError(f"{path}: the video data breaks off ({_reason(exc)}); the file is truncated or corrupt") \
            from None
    finally:
        container.close()


# Packets read for the key frames' spacing (ten seconds at 30 frames/s).
_GOP_PACKETS = 300
_CHROMA = {"yuv420p": "420", "yuvj420p": "420", "nv12": "420", "nv21": "420", "yuv444p": "444", "yuvj444p": "444",
           "gbrp": "444", "gray": "gray"}


# B-frames assumed of a recording that has them (x264's default; the file does not say how many).
_B_FRAMES_GUESS = 3


def recording_settings(path: Path):
    """How a video was encoded, as :class:`rollsim.video.VideoSettings` can redo it, or None.

    The codec (H.264 or HEVC; None for another), its average bitrate (the
    stream's, else the file's size over its duration), the GOP (the median
    spacing of the key frames in the first :data:`_GOP_PACKETS` packets;
    one second's when there is one key frame only), the chroma and whether
    it holds B-frames (then x264's default of 3). The encoder's preset is
    not in the file: rollsim's default stands in, deblocked as a phone's
    encoder codes. A video rollsim rendered names its rate control, preset,
    tuning, B-frames and GOP in its tags: those are taken. Its key frames do
    not give its GOP (x264 adds one at each scene cut, which a moving
    square wave makes of many frames), nor its size its bitrate (the
    average bitrate control overshoots over a short file).
    """
    import av

    from rollsim.video.settings import VideoSettings, described_settings

    info = probe_video(path)
    codec = {"h264": "h264", "hevc": "hevc"}.get(info.codec)
    chroma = _CHROMA.get(info.pixel_format)
    if codec is None or chroma is None:
        return None
    container = _open(Path(path))
    try:
        stream = container.streams.video[0]
        keys, count = [], 0
        for packet in container.demux(stream):
            if not packet.size:
                continue
            if packet.is_keyframe:
                keys.append(count)
            count += 1
            if count >= _GOP_PACKETS:
                break
        bitrate = stream.bit_rate or container.bit_rate
        # The decoder's reorder delay (from the stream's headers): non-zero where B-frames are coded.
        b_frames = _B_FRAMES_GUESS if stream.codec_context.has_b_frames else 0
        if not bitrate and container.duration:
            bitrate = Path(path).stat().st_size * 8 / (container.duration / av.time_base)
    except av.FFmpegError:
        return None
    finally:
        container.close()
    gaps = np.diff(keys)
    gop = int(np.median(gaps)) if gaps.size else None
    if not bitrate or bitrate < 1e4:
        return None
    read = {"bitrate_bps": int(min(bitrate, 1e9)), "b_frames": b_frames, "gop_frames": gop}
    return VideoSettings(container="mkv", codec=codec, chroma=chroma,
                         **(read | described_settings(info.metadata.get("encoding", ""))))


def _upright(image: np.ndarray, clockwise_deg: int) -> np.ndarray:
    """The image turned clockwise by ``clockwise_deg`` (a multiple of 90)."""
    turns = (clockwise_deg // 90) % 4
    return np.ascontiguousarray(np.rot90(image, k=-turns)) if turns else image


def read_video_frames(path: Path, start: int = 0, count: Optional[int] = None, rotate_deg: Optional[int] = None,
                      notes: Optional[list] = None) -> Iterator[np.ndarray]:
    """The frames ``start`` … ``start + count − 1`` of a video, as uint8 arrays, one at a time.

    Parameters
    ----------
    path : Path
    start : int
        The first frame (0-based, in decoding order).
    count : int, optional
        Frames to read (default: to the end).
    rotate_deg : int, optional
        Clockwise turn applied to every frame (a multiple of 90); default:
        the container's rotation, else a quarter turn clockwise where the
        stripes run along the columns (:func:`stripes_run_along_columns`,
        said in ``notes``).
    notes : list, optional
        Lines about what was assumed (a variable frame rate read as
        consecutive frames) are appended here.

    Raises
    ------
    RollsimError
        As :func:`probe_video`; fewer frames than ``start + count``; a file
        that ends inside its data (truncated or corrupt).
    """
    info = probe_video(path)
    if rotate_deg is not None and rotate_deg % 90:
        raise RollsimError(f"--rotate = {rotate_deg}: must be a multiple of 90 degrees")
    turn = info.rotation_deg if rotate_deg is None else rotate_deg % 360
    frames = _decoded_frames(path, info, start, count, turn, notes)
    if rotate_deg is not None or info.rotation_deg:
        yield from frames
        return
    yield from upright_frames(frames, None, str(path), notes)


def upright_frames(frames: Iterable[np.ndarray], rotate_deg: Optional[int], source: str,
                   notes: Optional[list] = None) -> Iterator[np.ndarray]:
    """``frames`` turned clockwise by ``rotate_deg``; where it is None, by a quarter turn if the first two
    frames' stripes run along the columns (:func:`stripes_run_along_columns`: a recording or a still
    turned without saying so), said in ``notes`` as read from ``source``."""
    frames = iter(frames)
    if rotate_deg is not None:
        yield from (_upright(frame, rotate_deg) for frame in frames)
        return
    head = list(itertools.islice(frames, 2))
    # Frames of two sizes are not compared (the reader refuses them in its own words).
    if len(head) == 2 and np.shape(head[0]) == np.shape(head[1]) and stripes_run_along_columns(*head):
        if notes is not None:
            notes.append(f"{source}: the stripes run along the columns: frames turned 90 degrees clockwise "
                         "(--rotate 270 turns them the other way)")
        yield from (_upright(frame, 90) for frame in itertools.chain(head, frames))
    else:
        yield from itertools.chain(head, frames)


# A rolling shutter's stripes make each row one level: between two frames
# the change varies from row to row. Frames whose change varies this many
# times more (in variance) from column to column, and by more than a level,
# were recorded turned.
COLUMN_DOMINANCE = 4.0
MIN_STRIPE_VARIANCE = 1.0


def stripes_run_along_columns(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two consecutive frames' change varies along the columns rather than the rows.

    The difference of the two frames cancels the still scene; its column
    means vary with stripes that run along the columns, its row means with
    stripes that run along the rows, as a rolling shutter makes them.
    """
    d = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    if d.ndim == 3:
        d = d.mean(axis=2)
    along_rows, along_columns = float(d.mean(axis=1).var()), float(d.mean(axis=0).var())
    return along_columns > max(COLUMN_DOMINANCE * along_rows, MIN_STRIPE_VARIANCE)


def _decoded_frames(path: Path, info: VideoInfo, start: int, count: Optional[int], turn: int,
                    notes: Optional[list]) -> Iterator[np.ndarray]:
    """Frames ``start`` … of the video, turned clockwise by ``turn``; the checks of :func:`read_video_frames`."""
    import av

    want = None if count is None else start + count
    container = _open(Path(path))
    seen = 0
    steps: list[int] = []
    last_pts = None
    try:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        try:
            for frame in container.decode(stream):
                if frame.pts is not None:
                    if last_pts is not None:
                        steps.append(frame.pts - last_pts)
                    last_pts = frame.pts
                if seen >= start:
                    yield _upright(decoded_array(frame, info.grey), turn)
                seen += 1
                if want is not None and seen >= want:
                    break
        except av.FFmpegError as exc:
            raise RollsimError(f"{path}: the video data ends or breaks after frame {seen} ({_reason(exc)}); "
                               "the file is truncated or corrupt") from None
    finally:
        container.close()
    if want is not None and seen < want:
        raise RollsimError(f"{path}: holds {seen} frames; frames {start} to {want - 1} were asked for")
    if want is None and info.frames is not None and seen < info.frames:
        raise RollsimError(f"{path}: the header gives {info.frames} frames but {seen} decode; the file is truncated")
    if notes is not None and len(steps) > 2:
        mean_step = float(np.mean(steps))
        if mean_step > 0 and float(np.max(np.abs(np.asarray(steps) - mean_step))) > _RATE_TOLERANCE * mean_step:
            notes.append(f"{path}: variable frame rate (frame steps {min(steps)} to {max(steps)} ticks); "
                         f"frames are read as consecutive at the average {info.frame_rate_hz:.3f} Hz")
