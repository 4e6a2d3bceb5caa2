"""``jpeg``: the frame compressed as a JPEG and decoded, as a camera app saves it.

The frame written to PNG is then the decoded JPEG, with the codec's
blocking and ringing (:func:`rollsim.isp.jpeg_round_trip`, OpenCV's
libjpeg). A stripe decoder reads frames like these from a phone's camera
app or a video's I-frames.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun, isp_output_error
from rollsim.isp import jpeg_round_trip

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup
    from rollsim.render.state import FrameState
    from rollsim.scene.model import Scene


class Jpeg(EffectParams):
    """JPEG compression at ``quality`` (1 … 100, default 90, as OpenCV's and libjpeg's)."""

    quality: int = Field(90, ge=1, le=100)


def check(scene: Scene, params: Jpeg) -> str | None:
    return isp_output_error(scene, "jpeg")


def build_stage(setup: SceneSetup, params: Jpeg) -> StageRun:
    def run(state: FrameState) -> None:
        state.image = jpeg_round_trip(state.image, params.quality)

    return run


EFFECT = Effect(name="jpeg", params=Jpeg, slot="compress", build_stage=build_stage, check=check,
                reads=("state.image",), writes=("state.image",))
