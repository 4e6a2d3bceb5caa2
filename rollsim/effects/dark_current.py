"""``dark_current``: thermally generated electrons, I_d·t_exp per pixel.

The mean rate is ``camera.dark_current_e_per_s`` at 25 °C; it doubles every
``doubling_c`` degrees (an Arrhenius law's usual approximation for silicon
near room temperature). Each pixel's rate varies around it: a lognormal map
of relative standard deviation ``nonuniformity_percent`` (positive, and
skewed as measured dark-current histograms are), and a fraction
``hot_pixel_fraction`` of hot pixels ``hot_pixel_factor`` times the mean.
Both maps are fixed by the camera's identity, so the dark signal's
non-uniformity grows with exposure and temperature. Its shot noise is drawn
with the photo-electrons' by ``shot_noise`` (the stage runs before it).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun, fixed_pattern_rng
from rollsim.numerics.portable_math import exp  # numpy's differs in the last bit between CPUs

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState

REFERENCE_TEMPERATURE_C = 25.0


class DarkCurrent(EffectParams):
    """Dark current: mean ``camera.dark_current_e_per_s`` at 25 °C, scaled to
    ``temperature_c`` (doubling every ``doubling_c`` degrees); each pixel's
    rate a lognormal of relative standard deviation ``nonuniformity_percent``,
    and a fraction ``hot_pixel_fraction`` of pixels at ``hot_pixel_factor``
    times the mean."""

    temperature_c: float = Field(REFERENCE_TEMPERATURE_C, ge=-60, le=150)
    doubling_c: float = Field(7.0, gt=0, le=100)
    nonuniformity_percent: float = Field(0.0, ge=0, le=1000)
    hot_pixel_fraction: float = Field(0.0, ge=0, le=1)
    hot_pixel_factor: float = Field(100.0, ge=1, le=1e6)


def temperature_factor(temperature_c: float, doubling_c: float) -> float:
    """Dark current at ``temperature_c`` relative to 25 °C: 2^((T − 25) / T_d)."""
    return 2.0 ** ((temperature_c - REFERENCE_TEMPERATURE_C) / doubling_c)


def lognormal_unit_mean(rng: np.random.Generator, shape: tuple[int, int], relative_std: float) -> np.ndarray:
    """Lognormal values of mean 1 and standard deviation ``relative_std``, float32.

    ln X ~ N(−s²/2, s²) with s² = ln(1 + relative_std²).
    """
    s2 = math.log1p(relative_std**2)
    values = rng.standard_normal(shape, dtype=np.float32)
    values *= np.float32(math.sqrt(s2))
    values += np.float32(-0.5 * s2)
    return exp(values).astype(np.float32)


def dark_rate_map(setup: SceneSetup, params: DarkCurrent) -> float | np.ndarray:
    """Each pixel's dark current in e⁻/s: a float when every pixel shares it."""
    rate = setup.scene.camera.dark_current_e_per_s * temperature_factor(params.temperature_c, params.doubling_c)
    if params.nonuniformity_percent == 0 and params.hot_pixel_fraction == 0:
        return rate
    relative = np.ones(setup.shape, dtype=np.float32)
    if params.nonuniformity_percent > 0:
        relative = lognormal_unit_mean(fixed_pattern_rng(setup, "dark_signal"), setup.shape,
                                       0.01 * params.nonuniformity_percent)
    if params.hot_pixel_fraction > 0:
        hot = fixed_pattern_rng(setup, "hot_pixels").random(setup.shape) < params.hot_pixel_fraction
        relative[hot] = np.float32(params.hot_pixel_factor)
    return np.float32(rate) * relative


def build_stage(setup: SceneSetup, params: DarkCurrent) -> StageRun:
    dark = dark_rate_map(setup, params) * setup.timing.exposure_s

    def run(state: FrameState) -> None:
        if state.means is not None and state.means.accepts("offset"):
            state.means = state.means.with_offset(dark)  # the compiled chain adds it block by block
        else:
            state.electrons += dark

    return run


EFFECT = Effect(name="dark_current", params=DarkCurrent, slot="dark", build_stage=build_stage,
                writes=("state.electrons",))
