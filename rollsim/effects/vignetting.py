"""``vignetting``: natural vignetting, every electron rate times cos⁴θ.

The field angle θ is that of each pixel seen from the lens, at the
lens-to-sensor distance ``setup.image_distance_m`` (the focus distance's
image plane with ``defocus``). See :mod:`rollsim.optics.vignetting`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Optional

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams
from rollsim.optics.vignetting import cos4_map

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup


class Vignetting(EffectParams):
    """Natural vignetting, cos⁴ of the field angle. ``optical_centre_px``:
    ``[x, y]`` of the optical axis on the sensor; ``null`` = frame centre."""

    optical_centre_px: Optional[list[float]] = Field(None, min_length=2, max_length=2)


def prepare(setup: SceneSetup, params: Vignetting) -> SceneSetup:
    cam = setup.scene.camera
    gain = cos4_map(setup.shape, cam.pixel_pitch_um * 1e-6, setup.image_distance_m, params.optical_centre_px)
    return replace(
        setup,
        led_e_per_s=setup.led_e_per_s * gain,
        background_e_per_s=setup.background_e_per_s * gain,
        face_e_per_s=setup.face_e_per_s * gain,
    )


EFFECT = Effect(
    name="vignetting",
    params=Vignetting,
    prepare=prepare,
    reads=("setup.image_distance_m", "setup.led_e_per_s", "setup.background_e_per_s", "setup.face_e_per_s"),
    writes=("setup.led_e_per_s", "setup.background_e_per_s", "setup.face_e_per_s"),
)
