"""``dsnu``: dark-signal non-uniformity, a fixed offset map.

Each pixel is offset by ``camera.dsnu_e``·z electrons, z a standard normal
of the scene seed, the same in every frame. Registered after ``prnu``,
which shares its slot: the gain map does not scale the offset.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rollsim.effects.base import Effect, NoParams, StageRun, fixed_pattern_map

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup
    from rollsim.render.state import FrameState


def build_stage(setup: SceneSetup, params: NoParams) -> StageRun:
    offset_map = np.float32(setup.scene.camera.dsnu_e) * fixed_pattern_map(setup, "dsnu")

    def run(state: FrameState) -> None:
        state.electrons += offset_map

    return run


EFFECT = Effect(name="dsnu", params=NoParams, slot="fixed_pattern", build_stage=build_stage, writes=("state.electrons",))
