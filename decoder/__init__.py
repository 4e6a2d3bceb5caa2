"""OpenCV stripe decoder for rolling-shutter OCC frames.

It imports only :mod:`rollsim.protocol` from rollsim, so that it also runs on
frames from a real camera.

Stages, one module each: :mod:`decoder.io` (reading frames),
:mod:`decoder.region` (LED footprints, whose parts across a long
exposure's flat band :mod:`decoder.bridging` joins), :mod:`decoder.profile` (row means),
:mod:`decoder.binarize` (local threshold and erasures), :mod:`decoder.timing`
(clock recovery), :mod:`decoder.framing` (SYNC, line code, check) and
:mod:`decoder.pipeline` (the whole chain); :mod:`decoder.equalise` detects
chip sequences through an exposure longer than a chip (or where
thresholding left PHY-SDUs unread); :mod:`decoder.rowtime` calibrates the
row time from square-wave frames. :mod:`decoder.kernels` compiles the block
means and the modulation map's noise power where numba is available (the
same numbers as its OpenCV and numpy fallbacks), and
:mod:`decoder.order_stats` takes medians and percentiles as numpy does,
without its per-call overhead.
"""

from decoder.io import MAX_FRAME_PIXELS, FrameError, FrameReadError, as_frame_array, png_header, read_frame
from decoder.pipeline import (
    RegionView,
    decode_frame,
    decode_frames,
    decode_profile,
    inspect_frame,
    stripe_row_fraction,
    views_stripe_fraction,
)
from decoder.records import STATUSES, DecodedPhySdu, FrameDecode
from decoder.rowtime import RowTimeError, estimate_row_time

__all__ = [
    "MAX_FRAME_PIXELS",
    "STATUSES",
    "DecodedPhySdu",
    "FrameDecode",
    "FrameError",
    "FrameReadError",
    "RegionView",
    "RowTimeError",
    "as_frame_array",
    "decode_frame",
    "decode_frames",
    "decode_profile",
    "estimate_row_time",
    "inspect_frame",
    "png_header",
    "read_frame",
    "stripe_row_fraction",
    "views_stripe_fraction",
]
