"""``column_fpn``: column fixed-pattern noise, an offset per column.

Column-parallel readout gives each column its own amplifier and ADC
offset: a pattern of vertical lines, fixed by the camera's identity and the
same in every frame. It is an offset of the dark signal, added after the
full-well clip with the DSNU. A stripe decoder, which averages along rows,
sees it as a fixed profile across the LED's columns.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun, fixed_pattern_rng

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState


class ColumnFpn(EffectParams):
    """Column fixed-pattern noise: each column offset by a normal of standard
    deviation ``std_e`` electrons, fixed by the camera's identity."""

    std_e: float = Field(1.0, ge=0, le=1e4)


def column_offsets_e(setup: SceneSetup, params: ColumnFpn) -> np.ndarray:
    """The offset of every column in electrons, shape (W,), float32."""
    width = setup.shape[1]
    return np.float32(params.std_e) * fixed_pattern_rng(setup, "column_fpn").standard_normal(width, dtype=np.float32)


def build_stage(setup: SceneSetup, params: ColumnFpn) -> StageRun:
    offsets = column_offsets_e(setup, params)

    def run(state: FrameState) -> None:
        state.electrons += offsets  # broadcast along the rows

    return run


EFFECT = Effect(name="column_fpn", params=ColumnFpn, slot="offset", build_stage=build_stage,
                writes=("state.electrons",))
