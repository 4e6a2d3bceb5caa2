"""How a rendered sequence is encoded: codec, rate control, GOP, preset and chroma.

The defaults are what a phone records at 1080p30: H.264 at about 17 Mb/s,
one key frame a second (a GOP of the frame rate's frames), 4:2:0 chroma.
No B-frames, as phones' hardware encoders mostly code; CABAC entropy
coding and the deblocking filter, as they code in the Main and High
profiles. The encoder is FFmpeg's libx264 (libx265 for HEVC) as PyAV's
wheels ship it, at its ``superfast`` preset. The ``fastdecode`` tuning
(CAVLC, no deblocking) decodes in a third of the time but reads far worse
at low bitrates (docs/video.md gives the figures and the commands).
The encoder runs :data:`ENCODER_THREADS` threads whatever the machine, so
that a file's bytes do not depend on its cores.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Optional

from rollsim.errors import RollsimError, short_repr

__all__ = ["CHROMA_FORMATS", "CONTAINERS", "DEFAULT_BITRATE_BPS", "ENCODERS", "ENCODER_THREADS", "MAX_B_FRAMES",
           "PRESETS", "TUNES", "VideoSettings", "check_encoder", "check_frames", "described_settings", "encoder_and_format",
           "frame_size_problem", "parse_bitrate"]

CONTAINERS = ("mp4", "mkv")
# The codec names users give, and FFmpeg's encoders for them.
ENCODERS = {"h264": "libx264", "hevc": "libx265"}
# Chroma: 4:2:0 as phones record; 4:4:4 keeps every colour sample; grey
# (luma only) where the codec allows.
CHROMA_FORMATS = ("420", "444", "gray")
PRESETS = ("ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow", "slower", "veryslow")
# A phone's 1080p30 H.264 recording: about 17 Mb/s.
DEFAULT_BITRATE_BPS = 17_000_000
DEFAULT_PRESET = "superfast"
# x264's and x265's tunings they share; "none" leaves the preset as it is.
TUNES = ("none", "fastdecode", "zerolatency", "grain", "psnr", "ssim")
# The preset's own: CABAC and the deblocking filter, as a phone's encoder codes.
DEFAULT_TUNE = "none"
# B-frames between reference frames: x264 and x265 take 0 … 16.
MAX_B_FRAMES = 16
# Encoder threads, fixed: x264's frame threads shape its rate control's
# decisions, so their number (by default the machine's cores) would change the bytes.
ENCODER_THREADS = 2
# x264's and x265's constant-rate-factor scale (0: lossless in x264).
MAX_CRF = 51

_BITRATE = re.compile(r"^\s*(\d+(?:\.\d*)?|\.\d+)\s*([kKmMgG]?)\s*(?:b/s|bps)?\s*$")
_SCALE = {"": 1.0, "k": 1e3, "m": 1e6, "g": 1e9}


def parse_bitrate(text: str) -> int:
    """Bits per second from ``17M``, ``800k``, ``2.5M`` or a plain number.

    Raises
    ------
    RollsimError
        Anything else, or a rate outside 10 kb/s … 1 Gb/s.
    """
    match = _BITRATE.match(str(text))
    if match is None:
        raise RollsimError(f"--bitrate = {short_repr(text)}: expected bits per second like 17M, 800k or 2500000")
    bps = float(match.group(1)) * _SCALE[match.group(2).lower()]
    if not 1e4 <= bps <= 1e9:
        raise RollsimError(f"--bitrate = {short_repr(text)}: must be within 10k and 1G bits per second")
    return int(round(bps))


@dataclass(frozen=True)
class VideoSettings:
    """How frames are encoded.

    Attributes
    ----------
    container : {'mp4', 'mkv'}
    codec : {'h264', 'hevc'}
    crf : int, optional
        Constant rate factor, 0 … 51 (lower: better); replaces the bitrate.
    bitrate_bps : int, optional
        Average bits per second; the default when neither is given is
        :data:`DEFAULT_BITRATE_BPS`.
    gop_frames : int, optional
        Frames from one key frame to the next; None: one second's.
    preset : str
        x264/x265 speed preset (:data:`PRESETS`).
    chroma : {'420', '444', 'gray'}
    tune : str
        x264/x265 tuning (:data:`TUNES`; ``none``: the preset's own).
    b_frames : int
        Consecutive B-frames at most (0: I- and P-frames only, as phones record).
    """

    container: str = "mp4"
    codec: str = "h264"
    crf: Optional[int] = None
    bitrate_bps: Optional[int] = None
    gop_frames: Optional[int] = None
    preset: str = DEFAULT_PRESET
    chroma: str = "420"
    tune: str = DEFAULT_TUNE
    b_frames: int = 0

    def __post_init__(self) -> None:
        if self.container not in CONTAINERS:
            raise RollsimError(f"--container = {short_repr(self.container)}: expected one of {', '.join(CONTAINERS)}")
        if self.codec not in ENCODERS:
            raise RollsimError(f"--codec = {short_repr(self.codec)}: expected one of {', '.join(ENCODERS)}")
        if self.crf is not None and self.bitrate_bps is not None:
            raise RollsimError("--crf and --bitrate: give one rate control, not both")
        if self.crf is not None and not (isinstance(self.crf, int) and 0 <= self.crf <= MAX_CRF):
            raise RollsimError(f"--crf = {short_repr(self.crf)}: must be an integer from 0 to {MAX_CRF}")
        if self.bitrate_bps is not None and not (isinstance(self.bitrate_bps, int) and self.bitrate_bps > 0):
            raise RollsimError(f"--bitrate = {short_repr(self.bitrate_bps)}: must be a positive number of bits per second")
        if self.gop_frames is not None and not (isinstance(self.gop_frames, int) and self.gop_frames >= 1):
            raise RollsimError(f"--gop = {short_repr(self.gop_frames)}: must be a whole number of frames >= 1")
        if self.preset not in PRESETS:
            raise RollsimError(f"--preset = {short_repr(self.preset)}: expected one of {', '.join(PRESETS)}")
        if self.chroma not in CHROMA_FORMATS:
            raise RollsimError(f"--chroma = {short_repr(self.chroma)}: expected one of {', '.join(CHROMA_FORMATS)}")
        if self.tune not in TUNES:
            raise RollsimError(f"--tune = {short_repr(self.tune)}: expected one of {', '.join(TUNES)}")
        if not (isinstance(self.b_frames, int) and 0 <= self.b_frames <= MAX_B_FRAMES):
            raise RollsimError(f"--b-frames = {short_repr(self.b_frames)}: must be a whole number from 0 to "
                               f"{MAX_B_FRAMES}")

    @property
    def encoder(self) -> str:
        """FFmpeg's encoder for :attr:`codec`."""
        return ENCODERS[self.codec]

    def gop_for(self, frame_rate_hz: float) -> int:
        """Frames between key frames at ``frame_rate_hz``: the setting, else one second's."""
        if self.gop_frames is not None:
            return self.gop_frames
        return max(1, int(round(frame_rate_hz))) if math.isfinite(frame_rate_hz) else 30

    def encoder_options(self) -> dict[str, str]:
        """The encoder's options (FFmpeg's libx264 / libx265 names) for these settings, the rate aside."""
        params = f"bframes={self.b_frames}"
        if self.codec == "hevc":  # x265's crf 0 is not lossless by itself, as x264's is
            params = (f"log-level=error:{params}:frame-threads={ENCODER_THREADS}"
                      + (":lossless=1" if self.crf == 0 else ""))
        options = {"preset": self.preset, "x264-params" if self.codec == "h264" else "x265-params": params,
                   "threads": str(ENCODER_THREADS)}
        if self.tune != "none":
            options["tune"] = self.tune
        if self.crf is not None:
            options["crf"] = str(self.crf)
        return options

    def describe(self, frame_rate_hz: Optional[float] = None) -> str:
        """The encoding in words, as the benchmarks give it; with the frame rate, also its GOP,
        as a rendered video's ``encoding`` tag gives it (:func:`described_settings` reads it back)."""
        words = (f"{self.codec} {self.rate_control()} preset {self.preset} tune {self.tune} "
                 f"b-frames {self.b_frames} chroma {self.chroma}")
        return words if frame_rate_hz is None else f"{words} gop {self.gop_for(frame_rate_hz)}"

    def rate_control(self) -> str:
        """The rate control in words, as the docs and metadata give it."""
        if self.crf is not None:
            return f"crf {self.crf}"
        return f"{(self.bitrate_bps or DEFAULT_BITRATE_BPS) / 1e6:g} Mb/s"


# VideoSettings.describe(frame_rate_hz)'s words: "h264 17 Mb/s preset P tune T b-frames N chroma C gop G".
_DESCRIPTION = re.compile(r"^\w+ (?:crf (?P<crf>\d+)|(?P<mbps>\d+(?:\.\d*)?(?:e[-+]?\d+)?) Mb/s) "
                          r"preset (?P<preset>\w+) tune (?P<tune>\w+) b-frames (?P<b_frames>\d+)\b.*\bgop (?P<gop>\d+)\b")


def described_settings(text: str) -> dict:
    """The rate control, preset, tuning, B-frames and GOP that :meth:`VideoSettings.describe`'s
    words (with a frame rate) name, as :class:`VideoSettings` keywords; {} for other text."""
    match = _DESCRIPTION.search(str(text))
    if match is None or match["preset"] not in PRESETS or match["tune"] not in TUNES:
        return {}
    rate = ({"crf": min(int(match["crf"]), MAX_CRF), "bitrate_bps": None} if match["crf"] is not None else
            {"bitrate_bps": int(min(max(float(match["mbps"]) * 1e6, 1e4), 1e9))})
    return {"preset": match["preset"], "tune": match["tune"], "b_frames": min(int(match["b_frames"]), MAX_B_FRAMES),
            "gop_frames": max(1, int(match["gop"])), **rate}


# 4:4:4 colour is coded as RGB (x264's RGB encoder, x265's planar GBR): an
# 8-bit Y'CbCr round trip of RGB loses up to 2 levels however high the bitrate.
_RGB_444 = {"h264": ("libx264rgb", "rgb24"), "hevc": ("libx265", "gbrp")}


def encoder_and_format(settings: VideoSettings, colour: bool) -> tuple[str, str]:
    """FFmpeg's encoder and pixel format for frames of this kind.

    Grey frames: Y'CbCr 4:2:0 or 4:4:4 with flat chroma, or luma only
    (``gray``). Colour frames: Y'CbCr 4:2:0, or RGB for 4:4:4. ``gray``
    asked of colour frames is refused: it would drop their colour silently.
    """
    if settings.chroma == "gray":
        if colour:
            raise RollsimError("--chroma gray: the scene renders colour frames (camera.output rgb8); use 420 or 444")
        return settings.encoder, "gray"
    if settings.chroma == "444":
        return _RGB_444[settings.codec] if colour else (settings.encoder, "yuv444p")
    return settings.encoder, "yuv420p"


# x265 corrupts its heap on frames narrower or lower than this (a glibc abort at 48x64 px).
MIN_HEVC_SIDE_PX = 64


def frame_size_problem(settings: VideoSettings, width_px: int, height_px: int,
                       colour: bool) -> Optional[tuple[str, str, str]]:
    """Why frames of this size cannot be coded so: ``(setting, why, a value that can)``, or None.

    4:2:0 halves the chroma in both directions (an even width and height);
    x265 needs :data:`MIN_HEVC_SIDE_PX` a side. ``setting`` is ``chroma`` or
    ``codec``; the caller names it as its user gives it (an option, a scene key).
    """
    size = f"the frames are {width_px}x{height_px} px"
    if encoder_and_format(settings, colour)[1] == "yuv420p" and (width_px % 2 or height_px % 2):
        return "chroma", f"4:2:0 needs an even width and height, {size}", "444"
    if settings.codec == "hevc" and min(width_px, height_px) < MIN_HEVC_SIDE_PX:
        return "codec", f"x265 needs frames of {MIN_HEVC_SIDE_PX} px or more a side, {size}", "h264"
    return None


def check_frames(settings: VideoSettings, width_px: int, height_px: int, colour: bool) -> None:
    """Refuse, in one line naming the option, frames this machine cannot code so:
    :func:`check_encoder`, then :func:`frame_size_problem`."""
    check_encoder(settings, colour)
    problem = frame_size_problem(settings, width_px, height_px, colour)
    if problem is not None:
        setting, why, instead = problem
        raise RollsimError(f"--{setting} {getattr(settings, setting)}: {why} (use --{setting} {instead})")


def check_encoder(settings: VideoSettings, colour: bool = False) -> None:
    """Refuse, in one line, an encoder or pixel format this machine's PyAV does not have.

    Raises
    ------
    RollsimError
        PyAV missing, or its FFmpeg built without the encoder or the format.
    """
    try:
        import av
    except ImportError as exc:  # pragma: no cover - a dependency
        raise RollsimError(f"video needs PyAV (pip install av): {exc}") from None
    encoder, fmt = encoder_and_format(settings, colour)
    try:
        codec = av.codec.Codec(encoder, "w")
    except Exception:  # PyAV raises its own UnknownCodecError (a ValueError in older wheels)
        raise RollsimError(f"--codec {settings.codec}: this PyAV's FFmpeg has no {encoder} encoder") from None
    formats = {f.name for f in (codec.video_formats or ())}
    if formats and fmt not in formats:
        raise RollsimError(f"--chroma {settings.chroma}: the {encoder} encoder here does not take {fmt}")
