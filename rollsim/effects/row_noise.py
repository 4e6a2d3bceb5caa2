"""``row_noise``: row temporal noise, an offset per row and frame.

Noise common to a whole row's readout (the row's reference level, supply
noise during its conversion) moves every pixel of the row together and
changes from frame to frame. A rolling-shutter stripe decoder, which
averages along rows, cannot average it away: its row means carry the full
σ, where the pixels' own read noise falls as 1/√W.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState


class RowNoise(EffectParams):
    """Row temporal noise: each row of each frame offset by a normal of
    standard deviation ``std_e`` electrons."""

    std_e: float = Field(1.0, ge=0, le=1e4)


def build_stage(setup: SceneSetup, params: RowNoise) -> StageRun:
    sigma, height = np.float32(params.std_e), setup.shape[0]

    def run(state: FrameState) -> None:
        offsets = state.rng("row_noise").standard_normal(height, dtype=np.float32)
        offsets *= sigma
        state.electrons += offsets[:, None]

    return run


EFFECT = Effect(name="row_noise", params=RowNoise, slot="read", build_stage=build_stage,
                writes=("state.electrons",))
