"""Frames to and from a codec's pixel formats, without a general converter where a plain one serves.

FFmpeg's converter (swscale, which PyAV calls for ``from_ndarray`` and
``to_ndarray``) is general and slow at 1080p: 11 ms a frame from RGB to
Y'CbCr 4:2:0 and 2 ms from 4:2:0 to grey on this project's 2-core machine,
against under 1 ms for the same work below (``rollsim bench video`` shows
the whole read). The common cases are therefore done here:

- grey frames are stored as the luma plane, full range (``Y' = level``),
  with neutral chroma; read back, the luma plane is the frame (a
  limited-range file's 16 … 235 are stretched to 0 … 255, as swscale does);
- colour frames go to and from 4:2:0 with OpenCV's BT.601 limited-range
  conversion (the matrix swscale assumes for an untagged file), and are
  tagged BT.601 so that other readers take them so too.

Anything else (other chroma layouts, full-range or BT.709 colour, 10-bit
refused elsewhere) goes through swscale as before.
"""

from __future__ import annotations

import numpy as np

__all__ = ["NEUTRAL_CHROMA", "decoded_array", "encoder_frame", "stretch_limited_luma"]

# The chroma of a grey pixel (Cb = Cr = 128 in 8 bits).
NEUTRAL_CHROMA = 128
# FFmpeg's AVColorRange and AVColorSpace values read and written here.
RANGE_LIMITED, RANGE_FULL = 1, 2
SPACE_BT601 = 6  # SMPTE 170M: BT.601's matrix
_BT601_SPACES = {2, 5, 6}  # unspecified, BT.470BG, SMPTE 170M: all read with BT.601's matrix
# Formats whose first plane is luma at one sample a pixel.
_LUMA_FIRST = {"gray", "yuv420p", "yuvj420p", "yuv422p", "yuvj422p", "yuv444p", "yuvj444p", "yuv411p", "yuv440p",
               "yuvj440p", "nv12", "nv21"}
_FULL_RANGE_FORMATS = {"gray", "yuvj420p", "yuvj422p", "yuvj444p", "yuvj440p"}

# Limited-range luma (16 … 235) to full (0 … 255), rounded and clipped.
_STRETCH_LUT = np.clip(np.round((np.arange(256) - 16) * (255.0 / 219.0)), 0, 255).astype(np.uint8)


def stretch_limited_luma(luma: np.ndarray) -> np.ndarray:
    """Limited-range luma (16 … 235) as full-range levels (0 … 255), uint8."""
    import cv2

    return cv2.LUT(luma, _STRETCH_LUT)


def encoder_frame(image: np.ndarray, pixel_format: str):
    """An ``av.VideoFrame`` of ``pixel_format`` holding ``image`` (uint8, grey (H, W) or RGB (H, W, 3)).

    Grey images in a Y'CbCr format are their luma plane (flagged full
    range); RGB images in ``yuv420p`` are converted with BT.601's
    limited-range matrix (flagged so). Other cases are handed to PyAV as
    grey or RGB, for FFmpeg to convert.
    """
    import av
    import cv2

    colour = image.ndim == 3
    if pixel_format == "yuv420p" and colour:
        planar = np.asarray(cv2.cvtColor(image, cv2.COLOR_RGB2YUV_I420), dtype=np.uint8)
        frame = av.VideoFrame.from_ndarray(planar, format="yuv420p")
        frame.color_range, frame.colorspace = RANGE_LIMITED, SPACE_BT601
        return frame
    if pixel_format == "yuv420p":
        height, width = image.shape
        planar = np.full((height * 3 // 2, width), NEUTRAL_CHROMA, dtype=np.uint8)
        planar[:height] = image
        frame = av.VideoFrame.from_ndarray(planar, format="yuv420p")
    elif pixel_format == "yuv444p" and not colour:
        planar = np.full((3,) + image.shape, NEUTRAL_CHROMA, dtype=np.uint8)
        planar[0] = image
        frame = av.VideoFrame.from_ndarray(planar, format="yuv444p")
    else:
        return av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24" if colour else "gray")
    frame.color_range = RANGE_FULL
    return frame


def _is_full_range(frame) -> bool:
    return int(frame.color_range) == RANGE_FULL or (
        frame.format.name in _FULL_RANGE_FORMATS and int(frame.color_range) != RANGE_LIMITED)


def _luma(frame) -> np.ndarray:
    """The frame's first plane as a (height, width) uint8 array (a copy)."""
    plane = frame.planes[0]
    rows = np.frombuffer(plane, dtype=np.uint8).reshape(plane.height, plane.line_size)
    return np.ascontiguousarray(rows[:, :frame.width])


def decoded_array(frame, grey: bool) -> np.ndarray:
    """A decoded ``av.VideoFrame`` as uint8: grey (H, W) levels, or RGB (H, W, 3).

    Grey: the luma plane, stretched to full range where the file is
    limited range. RGB from limited-range BT.601 4:2:0 (or untagged 4:2:0):
    OpenCV's conversion. Anything else: swscale (PyAV's ``to_ndarray``).
    """
    name = frame.format.name
    if grey and name in _LUMA_FIRST:
        luma = _luma(frame)
        return luma if _is_full_range(frame) else stretch_limited_luma(luma)
    if (not grey and name == "yuv420p" and not _is_full_range(frame)
            and int(frame.colorspace) in _BT601_SPACES and frame.width % 2 == 0 and frame.height % 2 == 0):
        import cv2

        return cv2.cvtColor(frame.to_ndarray(), cv2.COLOR_YUV2RGB_I420)
    return frame.to_ndarray(format="gray" if grey else "rgb24")
