"""``glare``: veiling glare of the lens, a halo around the LED's image.

A fraction of the LED's light is scattered into a Moffat halo
(:mod:`rollsim.optics.glare`) that reaches every row of the frame: the LED's
rows are then those whose stripes clear the noise
(:func:`rollsim.effects.readable.readable_rows`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams
from rollsim.effects.readable import readable_rows
from rollsim.optics.glare import glare_core_px, glared_light

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup


class Glare(EffectParams):
    """Veiling glare of the lens: a fraction ``fraction`` of the LED's light
    is scattered into a Moffat halo of core angle ``core_angle_deg`` whose
    wings fall as θ^(−2·``exponent``). See :mod:`rollsim.optics.glare`."""

    fraction: float = Field(0.05, ge=0, le=1)
    core_angle_deg: float = Field(2.0, gt=0, le=60)
    exponent: float = Field(2.0, gt=1, le=10)


def prepare(setup: SceneSetup, params: Glare) -> SceneSetup:
    cam = setup.scene.camera
    light = setup.footprint if setup.led_light is None else setup.led_light
    core_px = glare_core_px(params.core_angle_deg, cam.focal_length_mm * 1e-3, cam.pixel_pitch_um * 1e-6)
    setup = replace(setup, led_light=glared_light(light, setup.shape, params.fraction, core_px, params.exponent))
    return replace(setup, led_rows=readable_rows(setup))


EFFECT = Effect(
    name="glare",
    params=Glare,
    prepare=prepare,
    reads=("setup.footprint", "setup.led_light"),
    writes=("setup.led_light", "setup.led_rows"),
    # The halo's one FFT convolution per scene: its transform spans the
    # frame plus the light's box (up to 2H x 2W pixels; before the output
    # window, the light's box plus twice the kernel's reach, up to 3H x 3W),
    # held as two complex64 spectra and one float32 plane; the estimate was
    # measured at 253 B/px at 1080p for the larger transform, with the LED's
    # image covering 0.6 of the frame (tests/render/test_render_memory.py
    # keeps it a bound).
    setup_bytes_per_pixel=192,
)
