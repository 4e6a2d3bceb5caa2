"""Video in and out: frames written to and read from H.264/HEVC files through PyAV.

:mod:`rollsim.video.settings` says how a sequence is encoded (the codec, its
rate control, GOP, preset and chroma), :mod:`rollsim.video.write` streams
frames into a container and :mod:`rollsim.video.read` streams them back out
of any file FFmpeg reads, the right way up.
"""

from rollsim.video.settings import CHROMA_FORMATS, CONTAINERS, ENCODERS, VideoSettings, check_encoder, parse_bitrate

__all__ = ["CHROMA_FORMATS", "CONTAINERS", "ENCODERS", "VideoSettings", "check_encoder", "parse_bitrate"]
