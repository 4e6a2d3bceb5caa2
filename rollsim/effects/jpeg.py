"""``jpeg``: the frame compressed as a JPEG and decoded, as a camera app saves it.

The frame written to PNG is then the decoded JPEG, with the codec's
blocking and ringing (:func:`rollsim.isp.jpeg_round_trip`: libjpeg's
bits, a grey frame computed without the entropy coding). A stripe decoder
reads frames like these from a phone's camera app or a video's I-frames.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from rollsim.effects.base import EffectParams, isp_effect
from rollsim.isp import jpeg_round_trip


class Jpeg(EffectParams):
    """JPEG compression at ``quality`` (1 … 100, default 90, as OpenCV's and libjpeg's)."""

    quality: int = Field(90, ge=1, le=100)


def apply(image: np.ndarray, params: Jpeg) -> np.ndarray:
    return jpeg_round_trip(image, params.quality)


EFFECT = isp_effect("jpeg", Jpeg, "compress", apply)
