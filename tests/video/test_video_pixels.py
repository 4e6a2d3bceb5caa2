"""rollsim.video.pixels: the plain conversions agree with FFmpeg's general one (swscale) where they replace it."""

from __future__ import annotations

import io
import os
import subprocess
import sys

import numpy as np
import pytest

av = pytest.importorskip("av")

from rollsim.video.pixels import (  # noqa: E402
    RANGE_FULL,
    RANGE_LIMITED,
    SPACE_BT601,
    decoded_array,
    encoder_frame,
    stretch_limited_luma,
)


def _smooth_rgb(height: int = 64, width: int = 96) -> np.ndarray:
    """Colour ramps: 4:2:0's halved chroma loses little of them."""
    y, x = np.mgrid[0:height, 0:width]
    return np.stack([40 + 2 * x, 30 + 3 * y, 200 - x - y], axis=2).clip(0, 255).astype(np.uint8)


def test_the_limited_range_stretch_is_swscales_at_every_level():
    planar = np.full((3, 256), 128, dtype=np.uint8)  # 2 rows of luma 0 … 255, then 4:2:0 chroma
    planar[:2] = np.arange(256, dtype=np.uint8)
    frame = av.VideoFrame.from_ndarray(planar, format="yuv420p")
    np.testing.assert_array_equal(stretch_limited_luma(planar[:2]), frame.to_ndarray(format="gray"))


@pytest.mark.parametrize("pixel_format", ["yuv420p", "yuv444p"])
def test_a_grey_frame_is_its_luma_plane_at_full_range(pixel_format):
    grey = np.random.default_rng(1).integers(0, 256, (48, 64), dtype=np.uint8)
    frame = encoder_frame(grey, pixel_format)
    assert frame.format.name == pixel_format and int(frame.color_range) == RANGE_FULL
    np.testing.assert_array_equal(decoded_array(frame, grey=True), grey)
    np.testing.assert_array_equal(decoded_array(frame, grey=True), frame.to_ndarray(format="gray"))


def test_limited_range_grey_reads_as_swscale_reads_it():
    grey = np.random.default_rng(2).integers(0, 256, (48, 64), dtype=np.uint8)
    frame = av.VideoFrame.from_ndarray(grey, format="gray").reformat(format="yuv420p")  # 16 … 235, untagged
    np.testing.assert_array_equal(decoded_array(frame, grey=True), frame.to_ndarray(format="gray"))
    assert np.abs(decoded_array(frame, grey=True).astype(int) - grey).max() <= 1


def test_colour_is_bt601_limited_range_both_ways():
    rgb = _smooth_rgb()
    frame = encoder_frame(rgb, "yuv420p")
    assert (int(frame.color_range), int(frame.colorspace)) == (RANGE_LIMITED, SPACE_BT601)
    # Luma as swscale makes it from the same RGB (BT.601, 16 … 235), within rounding.
    swscale = av.VideoFrame.from_ndarray(rgb, format="rgb24").reformat(format="yuv420p").to_ndarray()
    assert np.abs(frame.to_ndarray()[:64].astype(int) - swscale[:64]).max() <= 1
    back = decoded_array(frame, grey=False)
    assert back.shape == rgb.shape and back.dtype == np.uint8
    assert np.abs(back.astype(int) - frame.to_ndarray(format="rgb24")).max() <= 3
    assert np.abs(back.astype(int) - rgb).mean() < 1.5


@pytest.mark.parametrize("colorspace, pixel_format", [(1, "yuv420p"), (6, "yuv422p")])
def test_other_colour_layouts_go_through_swscale(colorspace, pixel_format):
    """BT.709 4:2:0 and 4:2:2 are not the plain conversion's: read exactly as swscale reads them."""
    frame = av.VideoFrame.from_ndarray(_smooth_rgb(), format="rgb24").reformat(format=pixel_format)
    frame.colorspace = colorspace
    np.testing.assert_array_equal(decoded_array(frame, grey=False), frame.to_ndarray(format="rgb24"))


_WRITE_ONE_VIDEO = """
import io, sys
import numpy as np
from rollsim.video.settings import VideoSettings
from rollsim.video.write import VideoWriter
rng = np.random.default_rng(3)
buffer = io.BytesIO()
with VideoWriter(buffer, VideoSettings(container="mkv", bitrate_bps=400_000, gop_frames=8), 320, 240, 30.0,
                 False) as writer:
    base = rng.integers(0, 200, (240, 320), dtype=np.uint8)
    for i in range(16):
        writer.write(np.roll(base, 3 * i, axis=0))
sys.stdout.buffer.write(buffer.getvalue())
"""


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity") or len(os.sched_getaffinity(0)) < 2,
                    reason="needs two cores and CPU affinity")
def test_the_bytes_do_not_depend_on_the_cores():
    """The encoder's threads are fixed: on one core and on two, the same video."""
    def written(cores: set) -> bytes:
        return subprocess.run([sys.executable, "-c", _WRITE_ONE_VIDEO], check=True, capture_output=True,
                              preexec_fn=lambda: os.sched_setaffinity(0, cores)).stdout

    cores = sorted(os.sched_getaffinity(0))
    one, two = written({cores[0]}), written(set(cores[:2]))
    assert len(one) > 1000 and one == two
    with av.open(io.BytesIO(one)) as container:
        assert sum(1 for _ in container.decode(video=0)) == 16
