"""``prnu``: photo-response non-uniformity, a fixed gain map.

Each pixel's gain is 1 + (``camera.prnu_percent`` / 100)·z with z a standard
normal of the camera's identity, the same in every frame. It scales the
mean photo-electrons, before dark current and shot noise: a pixel's
response to light varies, its dark current has a non-uniformity of its
own (``dark_current``), and the shot noise is that of the scaled mean.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rollsim.effects.base import Effect, NoParams, StageRun, fixed_pattern_map

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState


def build_stage(setup: SceneSetup, params: NoParams) -> StageRun:
    gain_map = np.float32(1.0) + np.float32(0.01 * setup.scene.camera.prnu_percent) * fixed_pattern_map(setup, "prnu")

    def run(state: FrameState) -> None:
        if state.means is not None and state.means.accepts("gain"):
            state.means = state.means.with_gain(gain_map)  # the compiled chain applies it block by block
        else:
            state.electrons *= gain_map

    return run


EFFECT = Effect(name="prnu", params=NoParams, slot="photo_response", build_stage=build_stage, writes=("state.electrons",))
