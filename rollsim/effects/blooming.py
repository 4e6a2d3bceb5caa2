"""``blooming``: charge above full well spills along columns.

See :mod:`rollsim.sensor.blooming`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun
from rollsim.sensor.blooming import bloom

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState


class Blooming(EffectParams):
    """Charge above ``camera.full_well_e`` spills along columns; a fraction
    ``spill_fraction`` of the excess spills (1: no anti-blooming drain), the
    rest drains away. See :mod:`rollsim.sensor.blooming`."""

    spill_fraction: float = Field(1.0, ge=0, le=1)


def build_stage(setup: SceneSetup, params: Blooming) -> StageRun:
    full_well = setup.scene.camera.full_well_e

    def run(state: FrameState) -> None:
        bloom(state.electrons, full_well, params.spill_fraction)

    return run


EFFECT = Effect(name="blooming", params=Blooming, slot="blooming", build_stage=build_stage, writes=("state.electrons",))
