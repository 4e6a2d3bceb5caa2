"""``bayer``: a Bayer colour filter array with spectral channel responses.

Each pixel's electron rates become its own channel's, recomputed from the
LED's and the illuminant's spectra (:mod:`rollsim.optics.spectral`), so this
hook runs before any hook that scales the rates (it comes first in the
registry). ``camera.output: rgb8`` demosaics the mosaic
(:mod:`rollsim.sensor.cfa`) with ``setup.demosaic``.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Literal

import numpy as np
from pydantic import Field

from rollsim.effects.base import Effect, EffectParams
from rollsim.errors import RollsimError
from rollsim.optics.radiometry import photon_rate_per_pixel
from rollsim.optics.scene_light import ambient_sensor_illuminances_lx, led_sensor_illuminance_lx
from rollsim.optics.spectral import illuminant_electrons_per_lumen, led_electrons_per_lumen
from rollsim.sensor.cfa import cfa_channels

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup


class Bayer(EffectParams):
    """A Bayer colour filter array with spectral channel responses.

    ``pattern``: the top-left 2×2 block. ``demosaic``: OpenCV's
    ``bilinear``, ``edge_aware`` or ``vng`` (for ``camera.output: rgb8``);
    ``edge_aware`` by default, the closest of the three to the full-colour
    image and faster than ``vng`` (``rollsim bench accuracy``).
    ``sensitivities``: the camera spectral sensitivities shipped with
    colour-science, scaled to a peak of ``camera.qe``. ``led_fwhm_nm``: full
    width at half maximum of the LED's spectrum. ``spectral_step_nm``:
    integration step, or ``peak`` to treat the LED as a line at its peak
    wavelength. See :mod:`rollsim.optics.spectral`.
    """

    pattern: Literal["RGGB", "BGGR", "GRBG", "GBRG"] = "RGGB"
    demosaic: Literal["bilinear", "edge_aware", "vng"] = "edge_aware"
    sensitivities: Literal["nikon_5100", "sigma_sdmerill"] = "nikon_5100"
    led_fwhm_nm: float = Field(20.0, gt=0, le=300)
    spectral_step_nm: Literal[1, 5, 10, "peak"] = 1


def prepare(setup: SceneSetup, params: Bayer) -> SceneSetup:
    """Each pixel's electron rates are its own channel's (the monochrome
    rates use QE at the LED's peak wavelength)."""
    scene = setup.scene
    cam = scene.camera
    pitch = cam.pixel_pitch_um * 1e-6
    try:
        led_epl = led_electrons_per_lumen(
            scene.led.peak_wavelength_nm, params.led_fwhm_nm, params.sensitivities, cam.qe, params.spectral_step_nm
        )
    except ValueError:
        raise RollsimError(
            f"effects.bayer.led_fwhm_nm = {params.led_fwhm_nm:g}: the LED's spectrum falls between the "
            f"{params.spectral_step_nm} nm integration steps; widen it or use spectral_step_nm: peak"
        ) from None
    ambient_epl = illuminant_electrons_per_lumen(
        scene.environment.ambient_illuminant, params.sensitivities, cam.qe, params.spectral_step_nm
    )
    background_lx, face_lx = ambient_sensor_illuminances_lx(scene)
    channels = cfa_channels(params.pattern, setup.shape)
    return replace(
        setup,
        led_e_per_s=np.asarray(photon_rate_per_pixel(led_sensor_illuminance_lx(scene), pitch, led_epl))[channels],
        background_e_per_s=np.asarray(photon_rate_per_pixel(background_lx, pitch, ambient_epl))[channels],
        face_e_per_s=np.asarray(photon_rate_per_pixel(face_lx, pitch, ambient_epl))[channels],
        cfa_pattern=params.pattern,
        demosaic=params.demosaic,
    )


EFFECT = Effect(
    name="bayer",
    params=Bayer,
    prepare=prepare,
    writes=("setup.led_e_per_s", "setup.background_e_per_s", "setup.face_e_per_s", "setup.cfa_pattern",
            "setup.demosaic"),
)
