"""``dark_current``: thermally generated electrons, I_d·t_exp in every pixel.

The rate is ``camera.dark_current_e_per_s``; its shot noise is drawn with
the photo-electrons' by ``shot_noise`` (the stage runs before it).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rollsim.effects.base import Effect, NoParams, StageRun

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup
    from rollsim.render.state import FrameState


def build_stage(setup: SceneSetup, params: NoParams) -> StageRun:
    dark = setup.scene.camera.dark_current_e_per_s * setup.timing.exposure_s

    def run(state: FrameState) -> None:
        state.electrons += dark

    return run


EFFECT = Effect(name="dark_current", params=NoParams, slot="dark", build_stage=build_stage, writes=("state.electrons",))
