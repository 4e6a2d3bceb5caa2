"""``prnu``: photo-response non-uniformity, a fixed gain map.

Each pixel's gain is 1 + (``camera.prnu_percent`` / 100)·z with z a standard
normal of the scene seed, the same in every frame.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rollsim.effects.base import Effect, NoParams, StageRun, fixed_pattern_map

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup
    from rollsim.render.state import FrameState


def build_stage(setup: SceneSetup, params: NoParams) -> StageRun:
    gain_map = np.float32(1.0) + np.float32(0.01 * setup.scene.camera.prnu_percent) * fixed_pattern_map(setup, "prnu")

    def run(state: FrameState) -> None:
        state.electrons *= gain_map

    return run


EFFECT = Effect(name="prnu", params=NoParams, slot="fixed_pattern", build_stage=build_stage, writes=("state.electrons",))
