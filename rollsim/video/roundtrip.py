"""Frames through the real encoder and decoder, in memory: what a recording makes of them.

A group of pictures (GOP) is encoded from its key frame to its end by one
encoder and decoded back. Each GOP is coded alone (its rate control starts
afresh), so a frame's result depends only on the frames of its own GOP:
the same for any order or number of workers that render them.
"""

from __future__ import annotations

import io
from typing import Sequence

import numpy as np

from rollsim.video.pixels import decoded_array
from rollsim.video.settings import VideoSettings
from rollsim.video.write import VideoWriter

__all__ = ["gop_round_trip"]


def gop_round_trip(images: Sequence[np.ndarray], settings: VideoSettings, frame_rate_hz: float) -> list[np.ndarray]:
    """``images`` (one GOP: 8-bit, grey or RGB, one size) encoded and decoded.

    Parameters
    ----------
    images : sequence of ndarray
        The frames in order, the first coded as the key frame.
    settings : VideoSettings
        The encoding (its GOP is not used: these frames are one).
    frame_rate_hz : float
        The rate the encoder's rate control spends its bits at.

    Returns
    -------
    list of ndarray
        The decoded frames, uint8, the shape of the inputs.
    """
    import av

    if not images:
        return []
    first = np.asarray(images[0])
    colour = first.ndim == 3
    height, width = first.shape[:2]
    buffer = io.BytesIO()
    with VideoWriter(buffer, settings, width, height, frame_rate_hz, colour) as writer:
        for image in images:
            writer.write(np.asarray(image))
    buffer.seek(0)
    with av.open(buffer, mode="r") as container:
        stream = container.streams.video[0]
        out = [decoded_array(frame, grey=not colour) for frame in container.decode(stream)]
    if len(out) != len(images):  # pragma: no cover - the codec drops no frame of a GOP
        raise RuntimeError(f"the codec returned {len(out)} frames for {len(images)}")
    return out
