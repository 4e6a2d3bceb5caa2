"""``isp_smoothing``: the ISP's noise filter, a Gaussian mostly down the columns.

Phone and Raspberry Pi ISPs denoise the luma with filters that also smooth
across rows, widening a rolling-shutter stripe's edges beyond the exposure
box (a real camera's 10–90 % edge rise of ~5 rows at 9.1 µs per row). The
stage runs on the 8-bit image (:func:`rollsim.isp.smooth`); a step edge's
10–90 % rise grows by 2.563 σ.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun, isp_output_error
from rollsim.isp import smooth

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup
    from rollsim.render.state import FrameState
    from rollsim.scene.model import Scene


class IspSmoothing(EffectParams):
    """Gaussian smoothing of the 8-bit image: ``sigma_rows_px`` (px, [0, 50],
    default 1) across rows, ``sigma_cols_px`` (px, [0, 50], default 0) along them."""

    sigma_rows_px: float = Field(1.0, ge=0, le=50)
    sigma_cols_px: float = Field(0.0, ge=0, le=50)


def check(scene: Scene, params: IspSmoothing) -> str | None:
    return isp_output_error(scene, "isp_smoothing")


def build_stage(setup: SceneSetup, params: IspSmoothing) -> StageRun:
    def run(state: FrameState) -> None:
        state.image = smooth(state.image, params.sigma_rows_px, params.sigma_cols_px)

    return run


EFFECT = Effect(name="isp_smoothing", params=IspSmoothing, slot="denoise", build_stage=build_stage, check=check,
                reads=("state.image",), writes=("state.image",))
