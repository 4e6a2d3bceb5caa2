"""``sharpening``: the ISP's unsharp mask.

Phone ISPs sharpen after denoising, which overshoots at a stripe's edges:
the row profile gains a ringing of amplitude a times the edge's detail. The
stage runs on the 8-bit image (:func:`rollsim.isp.sharpen`); on a sinusoid
of f cycles per pixel it multiplies the amplitude by
1 + a·(1 − exp(−2π²σ²f²)).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun, isp_output_error
from rollsim.isp import sharpen

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup
    from rollsim.render.state import FrameState
    from rollsim.scene.model import Scene


class Sharpening(EffectParams):
    """Unsharp masking of the 8-bit image: gain ``amount`` ([0, 5], default 0.5)
    on the detail below a Gaussian of ``sigma_px`` (px, (0, 20], default 1)."""

    amount: float = Field(0.5, ge=0, le=5)
    sigma_px: float = Field(1.0, gt=0, le=20)


def check(scene: Scene, params: Sharpening) -> str | None:
    return isp_output_error(scene, "sharpening")


def build_stage(setup: SceneSetup, params: Sharpening) -> StageRun:
    def run(state: FrameState) -> None:
        state.image = sharpen(state.image, params.amount, params.sigma_px)

    return run


EFFECT = Effect(name="sharpening", params=Sharpening, slot="sharpen", build_stage=build_stage, check=check,
                reads=("state.image",), writes=("state.image",))
