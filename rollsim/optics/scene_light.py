"""The light a scene puts on the sensor: illuminances and electron rates.

Sensor-plane illuminances of the LED's image and of ambient light (the
camera equation, :mod:`rollsim.optics.radiometry`) and the electron rates
they give a pixel fully covered, QE applied, before any noise. Everything
here depends on the scene only; the render computes it once per scene.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, cast

from rollsim.optics.geometry import magnification
from rollsim.optics.radiometry import (
    lambertian_luminance_cd_m2,
    led_luminance_cd_m2,
    photon_rate_per_pixel,
    photons_per_lumen_illuminant,
    photons_per_lumen_monochromatic,
    sensor_illuminance_lx,
)

if TYPE_CHECKING:
    from rollsim.scene_sections import SceneSections


def led_emitting_area_m2(size_m: float, shape: str) -> float:
    """Emitting area of a disk (diameter) or square (side) LED of ``size_m``."""
    return math.pi * (0.5 * size_m) ** 2 if shape == "disk" else size_m**2


def led_sensor_illuminance_lx(scene: SceneSections) -> float:
    """Sensor-plane illuminance of the LED's image at level 1 (ON), on axis."""
    cam, led = scene.camera, scene.led
    m = magnification(cam.focal_length_mm * 1e-3, scene.link.distance_m)
    luminance = led_luminance_cd_m2(led.luminous_intensity_cd, led_emitting_area_m2(led.size_mm * 1e-3, led.shape))
    return sensor_illuminance_lx(luminance, cam.f_number, cam.lens_transmission, m)


def led_electron_rate(scene: SceneSections) -> float:
    """Electrons per second in a pixel fully covered by the LED at level 1 (ON)."""
    cam, led = scene.camera, scene.led
    illuminance = led_sensor_illuminance_lx(scene)
    photons = photon_rate_per_pixel(illuminance, cam.pixel_pitch_um * 1e-6, photons_per_lumen_monochromatic(led.peak_wavelength_nm))
    return cast(float, cam.qe * photons)  # a scalar: scalar illuminance and photons per lumen


def ambient_sensor_illuminances_lx(scene: SceneSections) -> tuple[float, float]:
    """Sensor-plane illuminance of ambient light, on axis: (background, LED face).

    The background is Lambertian with ``environment.background_reflectance``
    and the LED's face reflects ambient light with ``led.face_reflectance``.
    The (1 + m)² of the camera equation is the working f-number's: it comes
    from where the sensor sits (v = f·(1 + m) behind the lens, focused on
    the LED), not from where a source is, so the far background, out of
    focus, gets the LED's m too.
    """
    cam, env = scene.camera, scene.environment
    m = magnification(cam.focal_length_mm * 1e-3, scene.link.distance_m)

    def illuminance(reflectance: float, mag: float) -> float:
        luminance = lambertian_luminance_cd_m2(env.ambient_lux, reflectance)
        return sensor_illuminance_lx(luminance, cam.f_number, cam.lens_transmission, mag)

    return illuminance(env.background_reflectance, m), illuminance(scene.led.face_reflectance, m)


def ambient_electron_rates(scene: SceneSections) -> tuple[float, float]:
    """Electrons per second per pixel from ambient light: (background, LED face)
    (see :func:`ambient_sensor_illuminances_lx`)."""
    cam = scene.camera
    ppl = photons_per_lumen_illuminant(scene.environment.ambient_illuminant)
    pitch = cam.pixel_pitch_um * 1e-6
    background_lx, face_lx = ambient_sensor_illuminances_lx(scene)
    # Scalars here (scalar illuminances and photons per lumen).
    return (cast(float, cam.qe * photon_rate_per_pixel(background_lx, pitch, ppl)),
            cast(float, cam.qe * photon_rate_per_pixel(face_lx, pitch, ppl)))

