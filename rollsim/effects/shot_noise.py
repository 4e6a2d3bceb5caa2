"""``shot_noise``: photon shot noise on the mean electrons.

``poisson`` draws the exact Poisson count of every pixel
(:mod:`rollsim.sensor.poisson`); ``gaussian`` its approximation N(μ, μ),
one table normal deviate per pixel (:mod:`rollsim.gaussian`). A colour
filter array's mosaic (``setup.cfa_pattern``) is sampled by CFA phase,
where the Poisson sampler's fast runs of equal means are.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np

from rollsim.effects.base import Effect, EffectParams, StageRun
from rollsim.gaussian import standard_normal
from rollsim.sensor.cfa import poisson_by_phase
from rollsim.sensor.poisson import poisson

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup
    from rollsim.render.state import FrameState


class ShotNoise(EffectParams):
    """Photon shot noise. ``method``: exact Poisson, or its Gaussian approximation."""

    method: Literal["poisson", "gaussian"] = "poisson"


def build_stage(setup: SceneSetup, params: ShotNoise) -> StageRun:
    if params.method == "poisson":
        sampler = poisson if setup.cfa_pattern is None else poisson_by_phase

        def run(state: FrameState) -> None:
            state.electrons = sampler(state.rng("shot_noise"), state.electrons)

        return run

    def run_gaussian(state: FrameState) -> None:
        mean = state.electrons.astype(np.float32)
        noise = standard_normal(state.rng("shot_noise"), mean.shape, "table")
        noise *= np.sqrt(mean)
        noise += mean
        state.electrons = noise

    return run_gaussian


EFFECT = Effect(
    name="shot_noise",
    params=ShotNoise,
    slot="shot",
    build_stage=build_stage,
    variant="method",
    reads=("setup.cfa_pattern",),
    writes=("state.electrons",),
)
