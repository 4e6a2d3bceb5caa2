"""``read_noise``: Gaussian read noise in electrons, σ = ``camera.read_noise_e``."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np

from rollsim.effects.base import Effect, EffectParams, StageRun
from rollsim.gaussian import standard_normal

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup
    from rollsim.render.state import FrameState


class ReadNoise(EffectParams):
    """Read noise, Gaussian in electrons (sigma: ``camera.read_noise_e``).

    ``method``: ``table`` draws from a 65,536-bin quantile table with exact
    tails (Kolmogorov distance 7.6e-6 from the normal, about 3x faster);
    ``exact`` uses numpy's Ziggurat. See :mod:`rollsim.gaussian`.
    """

    method: Literal["table", "exact"] = "table"


def build_stage(setup: SceneSetup, params: ReadNoise) -> StageRun:
    sigma = np.float32(setup.scene.camera.read_noise_e)

    def run(state: FrameState) -> None:
        noise = standard_normal(state.rng("read_noise"), state.electrons.shape, params.method)
        noise *= sigma
        noise += state.electrons
        state.electrons = noise

    return run


EFFECT = Effect(name="read_noise", params=ReadNoise, slot="read", build_stage=build_stage, variant="method",
                writes=("state.electrons",))
