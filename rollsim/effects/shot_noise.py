"""``shot_noise``: photon shot noise on the mean electrons.

``poisson`` draws the exact Poisson count of every pixel, whether pixels
share a mean or each has its own (:mod:`rollsim.sensor.poisson`);
``gaussian`` its approximation N(μ, μ), μ + √μ·z with z from the normal
word table (:func:`rollsim.numerics.gaussian.normal_from_word`). Both draw from the
frame's ``shot_noise`` stream through a counter-based generator, in the
sensor chain's one pass when the stages after it allow
(:mod:`rollsim.sensor.chain`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from rollsim.effects.base import Effect, EffectParams, StageRun
from rollsim.sensor.chain import ChainKeys, ChainStep, run_chain

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState

STREAM = "shot_noise"


class ShotNoise(EffectParams):
    """Photon shot noise. ``method``: exact Poisson, or its Gaussian approximation."""

    method: Literal["poisson", "gaussian"] = "poisson"


def build_stage(setup: SceneSetup, params: ShotNoise) -> StageRun:
    method = params.method

    def run(state: FrameState) -> None:
        state.electrons = run_chain(state.means_or_electrons, method, ChainKeys(shot=state.counter_key(STREAM)))

    return run


def chain_step(setup: SceneSetup, params: ShotNoise) -> ChainStep:
    return ChainStep("shot", params.method, STREAM)


EFFECT = Effect(
    name="shot_noise",
    params=ShotNoise,
    slot="shot",
    build_stage=build_stage,
    chain_step=chain_step,
    variant="method",
    writes=("state.electrons",),
)
