"""Per-scene constants of the render, computed once before any frame.

Everything here depends on the scene only, not on the frame: timing, the
transmitter, the LED footprint, and the electron rates of the LED, the
background and the LED's face. Rates are electrons per second for one pixel
fully covered, before the sensor's noise (QE applied).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

import numpy as np

from rollsim.optics import led_centre_px, led_image_size_px, magnification
from rollsim.optics.footprint import Footprint, footprint
from rollsim.optics.radiometry import (
    lambertian_luminance_cd_m2,
    led_luminance_cd_m2,
    photon_rate_per_pixel,
    photons_per_lumen_illuminant,
    photons_per_lumen_monochromatic,
    sensor_illuminance_lx,
)
from rollsim.sensor import RowTiming
from rollsim.transmitter import Transmitter, transmitter_from_scene

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

# A row counts as an LED row when the footprint covers at least this much
# pixel area in it: a sliver at the tangent of a disk carries no usable light.
MIN_ROW_COVERAGE_PX = 0.5


def led_emitting_area_m2(size_m: float, shape: str) -> float:
    """Emitting area of a disk (diameter) or square (side) LED of ``size_m``."""
    return math.pi * (0.5 * size_m) ** 2 if shape == "disk" else size_m**2


def led_sensor_illuminance_lx(scene: Scene) -> float:
    """Sensor-plane illuminance of the LED's image at level 1 (ON), on axis."""
    cam, led = scene.camera, scene.led
    m = magnification(cam.focal_length_mm * 1e-3, scene.link.distance_m)
    luminance = led_luminance_cd_m2(led.luminous_intensity_cd, led_emitting_area_m2(led.size_mm * 1e-3, led.shape))
    return sensor_illuminance_lx(luminance, cam.f_number, cam.lens_transmission, m)


def led_electron_rate(scene: Scene) -> float:
    """Electrons per second in a pixel fully covered by the LED at level 1 (ON)."""
    cam, led = scene.camera, scene.led
    illuminance = led_sensor_illuminance_lx(scene)
    photons = photon_rate_per_pixel(illuminance, cam.pixel_pitch_um * 1e-6, photons_per_lumen_monochromatic(led.peak_wavelength_nm))
    return cast(float, cam.qe * photons)  # a scalar: scalar illuminance and photons per lumen


def ambient_sensor_illuminances_lx(scene: Scene) -> tuple[float, float]:
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


def ambient_electron_rates(scene: Scene) -> tuple[float, float]:
    """Electrons per second per pixel from ambient light: (background, LED face)
    (see :func:`ambient_sensor_illuminances_lx`)."""
    cam = scene.camera
    ppl = photons_per_lumen_illuminant(scene.environment.ambient_illuminant)
    pitch = cam.pixel_pitch_um * 1e-6
    background_lx, face_lx = ambient_sensor_illuminances_lx(scene)
    # Scalars here (scalar illuminances and photons per lumen).
    return (cast(float, cam.qe * photon_rate_per_pixel(background_lx, pitch, ppl)),
            cast(float, cam.qe * photon_rate_per_pixel(face_lx, pitch, ppl)))


def full_scale_electrons(scene: Scene) -> float:
    """Electrons that fill the ADC range above the black level at the set ISO."""
    cam = scene.camera
    return (2**cam.adc_bits - 1 - cam.black_level_dn) / cam.gain_dn_per_e_at_iso


@dataclass(frozen=True)
class SceneSetup:
    """What every frame of a scene shares.

    Attributes
    ----------
    scene : Scene
    timing : RowTiming
    transmitter : Transmitter
    footprint : Footprint
        LED coverage on its bounding box: where the LED's body hides the
        background (and, without ``led_profile`` or ``glare``, where its light falls).
    led_centre_px : (float, float)
    led_size_px : float
    led_rows : (int, int) or None
        First and last LED row (rows covered by at least
        :data:`MIN_ROW_COVERAGE_PX` of pixel area, of the blurred coverage
        when a lens PSF is listed); None if none is.
    led_e_per_s, background_e_per_s, face_e_per_s : float or ndarray
        Electron rates per fully covered pixel (see module docstring): one
        value for every pixel, or an (H, W) map once an effect makes them
        depend on the pixel (vignetting, a colour filter array).
    gain_dn_per_e : float
        Conversion gain at the set ISO.
    prepared : tuple of str or None
        Effects whose per-scene hooks have run
        (:func:`rollsim.render.stages.prepare_setup`); None before.
    led_light : Footprint or None
        Where the LED's light falls, in units of a fully covered pixel at the
        face's mean luminance, when an effect spreads it beyond the footprint
        (``led_profile``, ``glare``); None means ``footprint``.
    """

    scene: Scene
    timing: RowTiming
    transmitter: Transmitter
    footprint: Footprint
    led_centre_px: tuple
    led_size_px: float
    led_rows: tuple | None
    # Scalars, or per-pixel maps once an effect (bayer, vignetting) makes them vary.
    led_e_per_s: float | np.ndarray
    background_e_per_s: float | np.ndarray
    face_e_per_s: float | np.ndarray
    gain_dn_per_e: float
    prepared: tuple | None = None
    led_light: Footprint | None = None

    @property
    def shape(self) -> tuple[int, int]:
        return self.scene.camera.height_px, self.scene.camera.width_px


def led_rows_from_coverage(row_coverage: np.ndarray) -> tuple[int, int] | None:
    """First and last row whose covered area reaches :data:`MIN_ROW_COVERAGE_PX`."""
    rows = np.flatnonzero(row_coverage >= MIN_ROW_COVERAGE_PX)
    return (int(rows[0]), int(rows[-1])) if rows.size else None


def build_setup(scene: Scene) -> SceneSetup:
    """Compute a scene's :class:`SceneSetup`."""
    cam = scene.camera
    centre = led_centre_px(scene)
    size = led_image_size_px(scene)
    fp = footprint(centre, size, scene.led.shape, (cam.height_px, cam.width_px), scene.render.footprint_edge)
    background, face = ambient_electron_rates(scene)
    return SceneSetup(
        scene=scene,
        timing=RowTiming.from_camera(cam),
        transmitter=transmitter_from_scene(scene),
        footprint=fp,
        led_centre_px=centre,
        led_size_px=size,
        led_rows=led_rows_from_coverage(fp.row_coverage(cam.height_px)),
        led_e_per_s=led_electron_rate(scene),
        background_e_per_s=background,
        face_e_per_s=face,
        gain_dn_per_e=cam.gain_dn_per_e_at_iso,
    )
