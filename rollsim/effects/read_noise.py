"""``read_noise``: Gaussian read noise in electrons, σ = ``camera.read_noise_e``."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, Optional

import numpy as np

from rollsim.effects.base import Effect, EffectParams, StageRun
from rollsim.numerics.gaussian import standard_normal
from rollsim.sensor.chain import ChainKeys, ChainStep, run_chain

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState

STREAM = "read_noise"


class ReadNoise(EffectParams):
    """Read noise, Gaussian in electrons (sigma: ``camera.read_noise_e``).

    ``method``: ``table`` draws each deviate from one 32-bit counter word
    through a 65,536-bin quantile table with quantile tails out to ±6.34σ
    (Kolmogorov distance 7.6e-6 from the normal;
    :func:`rollsim.numerics.gaussian.normal_from_word`), in the sensor chain's one
    pass (:mod:`rollsim.sensor.chain`); ``exact`` uses numpy's Ziggurat.
    """

    method: Literal["table", "exact"] = "table"


def build_stage(setup: SceneSetup, params: ReadNoise) -> StageRun:
    sigma_e = float(setup.scene.camera.read_noise_e)
    if params.method == "table":

        def run_table(state: FrameState) -> None:
            keys = ChainKeys(read=state.counter_key(STREAM))
            state.electrons = run_chain(state.electrons, None, keys, read_sigma_e=sigma_e)

        return run_table
    sigma = np.float32(sigma_e)

    def run(state: FrameState) -> None:
        noise = standard_normal(state.rng(STREAM), state.electrons.shape, "exact")
        noise *= sigma
        noise += state.electrons
        state.electrons = noise

    return run


def chain_step(setup: SceneSetup, params: ReadNoise) -> Optional[ChainStep]:
    if params.method != "table":
        return None
    return ChainStep("read", float(setup.scene.camera.read_noise_e), STREAM)


EFFECT = Effect(name="read_noise", params=ReadNoise, slot="read", build_stage=build_stage, variant="method",
                chain_step=chain_step, writes=("state.electrons",))
