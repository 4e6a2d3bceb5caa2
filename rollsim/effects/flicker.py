"""``flicker``: mains flicker of the ambient light.

Each row's mean ambient illuminance over its exposure, relative to the
mean, goes to ``state.ambient_row_factor``, which the ``ambient`` stage
applies. See :mod:`rollsim.sensor.flicker`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun
from rollsim.sensor.flicker import flicker_row_factor

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState


class Flicker(EffectParams):
    """Mains flicker of the ambient light: E(t) = E0·(1 + depth·cos(2π·2f·t + phase)),
    f = ``environment.mains_hz``. See :mod:`rollsim.sensor.flicker`."""

    depth: float = Field(0.3, ge=0, le=1)
    phase_deg: float = Field(0.0, ge=-360, le=360)


def build_stage(setup: SceneSetup, params: Flicker) -> StageRun:
    timing, mains_hz, phase = setup.timing, setup.scene.environment.mains_hz, math.radians(params.phase_deg)

    def run(state: FrameState) -> None:
        start, _ = timing.row_windows(state.start_s)
        state.ambient_row_factor = flicker_row_factor(start, timing.exposure_s, mains_hz, params.depth, phase)

    return run


EFFECT = Effect(
    name="flicker",
    params=Flicker,
    slot="exposure",
    build_stage=build_stage,
    requires=(("ambient", "modulates the ambient light"),),
    reads=("state.start_s",),
    writes=("state.ambient_row_factor",),
)
