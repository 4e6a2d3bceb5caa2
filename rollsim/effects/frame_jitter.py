"""``frame_jitter``: frame k starts at k·T_f + ε_k.

The law of ε_k and its truncation are in :mod:`rollsim.sensor.frame_jitter`;
this module checks that the camera leaves room for it (frames never
overlap) and adds it to each frame's start.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun
from rollsim.sensor.frame_jitter import TRUNCATION_SIGMAS, FrameJitter as JitterLaw, frame_margin_s, max_std_s

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState
    from rollsim.scene_sections import SceneSections


class FrameJitter(EffectParams):
    """Frame start jitter: standard deviation ``std_us`` of each frame's
    offset (``independent``) or of each frame-to-frame step (``random_walk``).
    See :mod:`rollsim.sensor.frame_jitter`."""

    std_us: float = Field(20.0, ge=0, le=1e6)
    mode: Literal["independent", "random_walk"] = "independent"


def frame_jitter_error(camera, params: FrameJitter) -> str | None:
    """Why ``params`` cannot jitter frames of ``camera`` without overlap, or None.

    Parameters
    ----------
    camera : rollsim.scene_sections.Camera
    params : FrameJitter
    """
    if params.std_us == 0:
        return None
    margin = frame_margin_s(camera.frame_period_s, camera.readout_s, camera.exposure_s)
    limit = max_std_s(margin, params.mode)
    if params.std_us * 1e-6 <= limit:
        return None
    return (
        f"effects.frame_jitter.std_us = {params.std_us:g}: out of range for this camera, allowed [0, {limit * 1e6:.6g}] "
        f"(mode {params.mode}: frames must not overlap; the margin T_f - H*t_row - t_exp is {margin * 1e6:.6g} us "
        f"and the jitter is truncated at {TRUNCATION_SIGMAS:g} std)"
    )


def check(scene: SceneSections, params: FrameJitter) -> str | None:
    return frame_jitter_error(scene.camera, params)


def build_stage(setup: SceneSetup, params: FrameJitter) -> StageRun:
    cam = setup.scene.camera
    margin = frame_margin_s(cam.frame_period_s, cam.readout_s, cam.exposure_s)
    jitter = JitterLaw(setup.scene.seed, params.std_us * 1e-6, params.mode, margin)

    def run(state: FrameState) -> None:
        state.start_s += jitter.offset_s(state.index)

    return run


EFFECT = Effect(
    name="frame_jitter",
    params=FrameJitter,
    slot="timing",
    build_stage=build_stage,
    check=check,
    variant="mode",
    reads=("state.start_s",),
    writes=("state.start_s",),
)
