"""``dsnu``: dark-signal non-uniformity of the offset, a fixed offset map.

Each pixel is offset by ``camera.dsnu_e``·z electrons, z a standard normal
of the camera's identity, the same in every frame. EMVA 1288 counts it in
the dark signal, as an offset: it is added after the full-well clip (whose
floor at 0 e⁻ would otherwise cut its negative half) and reaches the ADC,
where the black level carries it. The dark current's own non-uniformity,
which grows with exposure, is the ``dark_current`` effect's.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rollsim.effects.base import Effect, NoParams, StageRun, fixed_pattern_map

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState


def build_stage(setup: SceneSetup, params: NoParams) -> StageRun:
    offset_map = np.float32(setup.scene.camera.dsnu_e) * fixed_pattern_map(setup, "dsnu")

    def run(state: FrameState) -> None:
        state.electrons += offset_map

    return run


EFFECT = Effect(name="dsnu", params=NoParams, slot="offset", build_stage=build_stage, writes=("state.electrons",))
