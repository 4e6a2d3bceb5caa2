"""``video_codec``: the frames as a video recording holds them, through the real encoder and decoder.

Every output (PNG frames, the in-memory API, sweeps) then carries the
codec's artefacts: blocking, the loss of fine noise, 4:2:0 chroma and the
key frame's difference from the frames predicted from it. The frames are
coded a group of pictures (GOP) at a time, from its key frame, by FFmpeg's
libx264 or libx265 (:func:`rollsim.video.roundtrip.gop_round_trip`), so
frame *i* depends on the frames of its own GOP only and a render is
byte-identical for any number of workers. This is the coding ``rollsim
render --container`` writes, except that the rate control starts afresh at
each key frame.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Literal, Optional

from pydantic import Field, field_validator, model_validator

from rollsim.effects.base import Effect, EffectParams
from rollsim.errors import RollsimError
from rollsim.video.settings import DEFAULT_BITRATE_BPS, MAX_B_FRAMES, MAX_CRF, VideoSettings, check_encoder, frame_size_problem

# The frames of a GOP held twice (rendered and decoded) while it is coded:
# bytes per pixel for 30 frames of rgb8, a one-second GOP at 30 frames/s.
GOP_BYTES_PER_PIXEL = 2 * 30 * 3


class VideoCodec(EffectParams):
    """A video encoder and its decoder on the 8-bit frames.

    ``codec``: ``h264`` (libx264) or ``hevc`` (libx265). ``crf`` (0 … 51,
    lower is better, 0 lossless) or ``bitrate_bps`` (average bits per
    second; default 17e6, a phone's 1080p30). ``gop_frames``: frames from
    one key frame to the next (default: one second's). ``preset``: the
    encoder's speed preset (default ``superfast``). ``chroma``: ``420``
    (default), ``444`` or ``gray`` (grey frames only). ``tune``: the
    encoder's tuning (default ``none``: the preset's own).
    ``b_frames``: consecutive B-frames at most (default 0, as phones code).
    """

    codec: Literal["h264", "hevc"] = "h264"
    crf: Optional[int] = Field(None, ge=0, le=MAX_CRF)
    bitrate_bps: Optional[float] = Field(None, ge=1e4, le=1e9)
    gop_frames: Optional[int] = Field(None, ge=1, le=600)
    preset: Literal["ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow", "slower",
                    "veryslow"] = "superfast"  # rollsim.video.settings.DEFAULT_PRESET (a test keeps them one)
    chroma: Literal["420", "444", "gray"] = "420"
    tune: Literal["none", "fastdecode", "zerolatency", "grain", "psnr", "ssim"] = "none"  # TUNES, DEFAULT_TUNE
    b_frames: int = Field(0, ge=0, le=MAX_B_FRAMES)

    @field_validator("chroma", mode="before")
    @classmethod
    def _chroma_as_text(cls, value):
        # --set effects.video_codec.chroma=420 reads as YAML: the number 420.
        return str(value) if isinstance(value, int) and not isinstance(value, bool) else value

    @model_validator(mode="after")
    def _one_rate_control(self) -> "VideoCodec":
        if self.crf is not None and self.bitrate_bps is not None:
            raise ValueError("give crf or bitrate_bps, not both")
        return self


def settings_of(params: VideoCodec) -> VideoSettings:
    """The encoding :class:`rollsim.video.VideoSettings` of the effect's parameters."""
    bitrate = None if params.crf is not None else int(round(params.bitrate_bps or DEFAULT_BITRATE_BPS))
    return VideoSettings(container="mkv", codec=params.codec, crf=params.crf, bitrate_bps=bitrate,
                         gop_frames=params.gop_frames, preset=params.preset, chroma=params.chroma,
                         tune=params.tune, b_frames=params.b_frames)


def params_of(settings: VideoSettings) -> dict:
    """The effect's parameters (keys under ``effects.video_codec``) that code as ``settings`` do:
    :func:`settings_of`'s inverse (the container aside: the effect has none)."""
    params: dict = {"codec": settings.codec, "preset": settings.preset, "chroma": settings.chroma,
                    "tune": settings.tune, "b_frames": settings.b_frames}
    if settings.crf is not None:
        params["crf"] = settings.crf
    else:
        params["bitrate_bps"] = float(settings.bitrate_bps or DEFAULT_BITRATE_BPS)
    if settings.gop_frames is not None:
        params["gop_frames"] = settings.gop_frames
    return params


def check(scene, params: VideoCodec) -> Optional[str]:
    cam = scene.camera
    if cam.output not in ("gray8", "rgb8"):
        return "effects.video_codec: acts on 8-bit output; set camera.output to 'gray8' or 'rgb8'"
    colour = cam.output == "rgb8"
    try:
        settings = settings_of(params)
        check_encoder(settings, colour)
    except RollsimError as exc:
        return f"effects.video_codec: {str(exc).replace('--', '')}"
    problem = frame_size_problem(settings, cam.width_px, cam.height_px, colour)
    if problem is not None:
        setting, why, instead = problem
        return f"effects.video_codec: {why} ({setting}: '{instead}')"
    return None


def prepare(setup, params: VideoCodec):
    return replace(setup, video_codec=settings_of(params))


EFFECT = Effect(
    name="video_codec",
    params=VideoCodec,
    prepare=prepare,
    check=check,
    writes=("setup.video_codec",),
    setup_bytes_per_pixel=GOP_BYTES_PER_PIXEL,
)
