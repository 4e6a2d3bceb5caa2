"""Stream frames into a video file: one video frame per rendered frame, in order.

The container is opened once and frames are encoded as they come, so memory
stays flat in the frame count. The scene, its seed, the row time and the
frame rate go into the container's metadata, where :mod:`rollsim.video.read`
finds them again.
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path
from typing import Any, Optional

import numpy as np

from rollsim.video.pixels import RANGE_FULL, RANGE_LIMITED, SPACE_BT601, encoder_frame
from rollsim.video.settings import CONTAINERS, DEFAULT_BITRATE_BPS, VideoSettings, check_frames, encoder_and_format

__all__ = ["VideoWriter", "rendered_video", "video_name"]

# The largest denominator of a frame rate written as a fraction (NTSC's 30000/1001 fits).
_RATE_DENOMINATOR = 1001


def video_name(settings: VideoSettings) -> str:
    """The file a render writes its frames to: ``frames.mp4`` or ``frames.mkv``."""
    return f"frames.{settings.container}"


def rendered_video(directory: Path) -> Optional[Path]:
    """The video a render wrote into ``directory`` (:func:`video_name`, in :data:`CONTAINERS`' order), or None."""
    for container in CONTAINERS:
        path = Path(directory) / video_name(VideoSettings(container=container))
        if path.is_file():
            return path
    return None


class VideoWriter:
    """Encode 8-bit frames, grey (H, W) or RGB (H, W, 3), into ``path``.

    Parameters
    ----------
    path : Path or binary file object
        The file to write (a staging area's: the caller commits it), or a
        seekable buffer (an in-memory round trip).
    settings : VideoSettings
    width_px, height_px : int
        The frames' size.
    frame_rate_hz : float
    colour : bool
        RGB frames (else grey).
    metadata : dict, optional
        Written into the container's tags (strings).
    """

    def __init__(self, path, settings: VideoSettings, width_px: int, height_px: int, frame_rate_hz: float,
                 colour: bool, metadata: Optional[dict] = None):
        import av

        check_frames(settings, width_px, height_px, colour)
        encoder, fmt = encoder_and_format(settings, colour)
        self._shape = (height_px, width_px, 3) if colour else (height_px, width_px)
        # Bit-exact muxing: no random segment UID, date or library version, so
        # the same frames give the same file (the project's determinism).
        options = {"fflags": "+bitexact"}
        if settings.container == "mp4":
            options["movflags"] = "use_metadata_tags"
        target = str(path) if isinstance(path, (str, Path)) else path
        self._container = av.open(target, mode="w", format="mp4" if settings.container == "mp4" else "matroska",
                                  options=options)
        try:
            rate = Fraction(frame_rate_hz).limit_denominator(_RATE_DENOMINATOR)
            # PyAV types add_stream by codec name; an encoder named at run time
            # is typed as any stream, so the video stream is taken as such.
            stream: Any = self._container.add_stream(encoder, rate=rate)
            stream.width, stream.height, stream.pix_fmt = width_px, height_px, fmt
            stream.gop_size = settings.gop_for(frame_rate_hz)
            if settings.crf is None:
                # x264's average-bitrate control, deterministic with threads; its
                # VBV (a phone's CBR-like buffer) is not: frames would differ from run to run.
                stream.bit_rate = settings.bitrate_bps or DEFAULT_BITRATE_BPS
            stream.options = settings.encoder_options()
            stream.thread_type = "AUTO"
            # Grey frames are coded as their levels, 0-255: flagged full range,
            # or a reader takes them for TV range (16-235) and stretches them.
            # Colour 4:2:0 is BT.601 limited range (rollsim.video.pixels).
            self._format = fmt
            if not colour:
                stream.codec_context.color_range = RANGE_FULL
            elif fmt == "yuv420p":
                stream.codec_context.color_range = RANGE_LIMITED
                stream.codec_context.colorspace = SPACE_BT601
            for key, value in (metadata or {}).items():
                self._container.metadata[str(key)] = str(value)
        except BaseException:
            self._container.close()
            raise
        self._stream = stream
        self.frames = 0

    def write(self, image: np.ndarray) -> None:
        """Encode the next frame (uint8, the shape given)."""
        image = np.asarray(image)
        if image.shape != self._shape or image.dtype != np.uint8:
            raise ValueError(f"frame {self.frames}: {image.shape} {image.dtype}, expected {self._shape} uint8")
        frame = encoder_frame(image, self._format)
        frame.pts = self.frames
        for packet in self._stream.encode(frame):
            self._container.mux(packet)
        self.frames += 1

    def close(self) -> None:
        """Flush the encoder and finish the file."""
        try:
            for packet in self._stream.encode():
                self._container.mux(packet)
        finally:
            self._container.close()

    def abort(self) -> None:
        """Close without flushing (the file is left to its staging area)."""
        self._container.close()

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()
