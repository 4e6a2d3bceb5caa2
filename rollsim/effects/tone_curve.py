"""``tone_curve``: a display gamma for ``gray8`` output.

The curve acts inside the core's gray8 conversion, before rounding to 8
bits: the hook sets ``setup.gray8_gamma`` and the output stage's table
lookup applies it (:func:`rollsim.sensor.adc.dn_to_gray8`). No stage of its
own, so it costs nothing per frame.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup
    from rollsim.scene.model import Scene


class ToneCurve(EffectParams):
    """Display gamma for ``gray8`` output: value ** (1 / gamma)."""

    gamma: float = Field(2.2, gt=0, le=10)


def check(scene: Scene, params: ToneCurve) -> str | None:
    if scene.camera.output != "gray8":
        return "effects.tone_curve: applies to camera.output = 'gray8' only"
    return None


def prepare(setup: SceneSetup, params: ToneCurve) -> SceneSetup:
    return replace(setup, gray8_gamma=params.gamma)


EFFECT = Effect(name="tone_curve", params=ToneCurve, prepare=prepare, check=check, writes=("setup.gray8_gamma",))
