"""``led_profile``: the LED face's radiance, brighter at its centre.

Reshapes where the LED's light falls (``setup.led_light``), not its body:
the background stays hidden by the footprint alone. See
:mod:`rollsim.optics.emitter`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Literal, Optional

import numpy as np
from pydantic import Field

from rollsim.effects.base import Effect, EffectParams
from rollsim.optics.emitter import profiled_light, radial_table_light
from rollsim.optics.footprint import led_rows_from_coverage
from rollsim.plumbing.validation import unit_table_error

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.scene_sections import SceneSections


class LedProfile(EffectParams):
    """The LED face's radiance, scaled so that the face emits the LED's
    luminous intensity (see :mod:`rollsim.optics.emitter`).

    ``profile``: ``gaussian`` (default: a Gaussian of the distance from the
    centre, σ = ``core_sigma_mm`` on the face, truncated at its edge) or
    ``table`` (measured: ``radial_table`` is a list of [radius / face
    radius, relative radiance] pairs, radii rising from 0 to 1, as
    ``rollsim fit-camera`` writes it).
    """

    profile: Literal["gaussian", "table"] = "gaussian"
    core_sigma_mm: float = Field(1.0, gt=0, le=1e3)
    radial_table: Optional[list[list[float]]] = None


def radial_table_error(table) -> str | None:
    """Why ``table`` is not a usable radial profile, or None."""
    why = unit_table_error(table, "radius", "radiance")
    if why:
        return why
    radiances = np.asarray(table, dtype=np.float64)[:, 1]
    if np.any(radiances < 0) or not np.any(radiances > 0):
        return "radiances must be >= 0 and not all 0"
    return None


def check(scene: SceneSections, params: LedProfile) -> str | None:
    if params.profile == "table":
        if params.radial_table is None:
            return "effects.led_profile.radial_table: profile 'table' needs a radial_table"
        why = radial_table_error(params.radial_table)
        return f"effects.led_profile.radial_table: {why}" if why else None
    if params.radial_table is not None:
        return "effects.led_profile.radial_table: given, but profile is 'gaussian'; set profile: table"
    return None


def prepare(setup: SceneSetup, params: LedProfile) -> SceneSetup:
    scene = setup.scene
    light = setup.footprint if setup.led_light is None else setup.led_light
    px_per_mm = setup.led_size_px / scene.led.size_mm  # the image scale, defocus included
    if params.profile == "table":
        light = radial_table_light(light, setup.led_centre_px, setup.led_size_px / 2, params.radial_table)
    else:
        light = profiled_light(light, setup.led_centre_px, params.core_sigma_mm * px_per_mm)
    # The light stays within the footprint: its rows by the footprint's rule.
    return replace(setup, led_light=light, led_rows=led_rows_from_coverage(light.row_coverage(scene.camera.height_px)))


EFFECT = Effect(
    name="led_profile",
    params=LedProfile,
    prepare=prepare,
    check=check,
    reads=("setup.footprint", "setup.led_light", "setup.led_size_px"),
    writes=("setup.led_light", "setup.led_rows"),
)
