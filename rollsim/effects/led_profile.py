"""``led_profile``: the LED face's radiance, brighter at its centre.

Reshapes where the LED's light falls (``setup.led_light``), not its body:
the background stays hidden by the footprint alone. See
:mod:`rollsim.optics.emitter`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams
from rollsim.optics.emitter import profiled_light
from rollsim.optics.footprint import led_rows_from_coverage

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup


class LedProfile(EffectParams):
    """The LED face's radiance: a Gaussian of the distance from its centre,
    σ = ``core_sigma_mm`` on the face, truncated at its edge, scaled so that
    the face emits the LED's luminous intensity. See :mod:`rollsim.optics.emitter`."""

    core_sigma_mm: float = Field(1.0, gt=0, le=1e3)


def prepare(setup: SceneSetup, params: LedProfile) -> SceneSetup:
    scene = setup.scene
    light = setup.footprint if setup.led_light is None else setup.led_light
    px_per_mm = setup.led_size_px / scene.led.size_mm  # the image scale, defocus included
    light = profiled_light(light, setup.led_centre_px, params.core_sigma_mm * px_per_mm)
    # The light stays within the footprint: its rows by the footprint's rule.
    return replace(setup, led_light=light, led_rows=led_rows_from_coverage(light.row_coverage(scene.camera.height_px)))


EFFECT = Effect(
    name="led_profile",
    params=LedProfile,
    prepare=prepare,
    reads=("setup.footprint", "setup.led_light", "setup.led_size_px"),
    writes=("setup.led_light", "setup.led_rows"),
)
