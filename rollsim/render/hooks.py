"""Per-scene hooks: effects that change what every frame of a scene shares.

A hook takes a :class:`~rollsim.render.setup.SceneSetup` and returns a new
one; :func:`rollsim.render.stages.prepare_setup` runs the hooks of the listed
effects once, before any stage is built, so these effects cost nothing per
frame beyond the arrays they change:

* :func:`lens_psf` (``blur``, ``defocus``): the LED's coverage map seen
  through the lens PSF, on a larger bounding box; the LED rows follow it.
* :func:`emitter_light` (``led_profile``, ``glare``): where the LED's light
  falls, apart from where its body hides the background.
* :func:`colour_filter_array` (``bayer``): per-pixel electron rates, each
  pixel its own channel's, from spectra.
* :func:`vignetting`: the rates times the cos⁴ map.

The physics lives in :mod:`rollsim.optics.psf`, :mod:`rollsim.optics.spectral`,
:mod:`rollsim.optics.vignetting` and :mod:`rollsim.sensor.cfa`; this module
only maps scene parameters onto them.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from rollsim.errors import RollsimError
from rollsim.optics import magnification
from rollsim.optics.emitter import profiled_light
from rollsim.optics.glare import glare_core_px, glared_light
from rollsim.optics.psf import (
    MAX_DISK_DIAMETER_PX,
    blurred_footprint,
    circle_of_confusion_m,
    defocus_image_scale,
    disk_kernel,
    gaussian_kernel_1d,
)
from rollsim.optics.radiometry import photon_rate_per_pixel
from rollsim.optics.spectral import illuminant_electrons_per_lumen, led_electrons_per_lumen
from rollsim.optics.vignetting import cos4_map, image_distance_m
from rollsim.render.readable import readable_rows
from rollsim.render.setup import ambient_sensor_illuminances_lx, led_rows_from_coverage, led_sensor_illuminance_lx
from rollsim.sensor.cfa import cfa_channels

if TYPE_CHECKING:
    from rollsim.scene.model import Scene
    from rollsim.render.setup import SceneSetup


def blur_kernel(params):
    """The ``blur`` effect's Gaussian kernel: a separable pair or a 2-D array."""
    k = gaussian_kernel_1d(params.sigma_px, params.truncate_sigma)
    return (k, k) if params.kernel == "separable" else k[:, None] * k[None, :]


def defocus_diameter_px(scene: Scene) -> float:
    """The ``defocus`` effect's blur-circle diameter in pixels."""
    cam, params = scene.camera, scene.effects.defocus
    assert params is not None  # a defocus hook runs only when the effect is listed
    c_m = circle_of_confusion_m(cam.focal_length_mm * 1e-3, cam.f_number, scene.link.distance_m, params.focus_distance_m)
    return c_m / (cam.pixel_pitch_um * 1e-6)


def lens_kernels(scene: Scene) -> tuple[list, float]:
    """The scene's lens PSF: its kernels and the image scale v_f/v.

    The kernels are those of ``blur`` and ``defocus``, in that order (they
    convolve; see :func:`rollsim.optics.psf.convolve_full`). With
    ``defocus`` the sensor sits at the focus distance's image plane, so the
    LED's image is v_f/v times larger (1 without ``defocus``). Any code that
    computes an LED footprint (e.g. per frame) passes both to
    :func:`rollsim.optics.psf.blurred_footprint`.
    """
    effects, cam = scene.effects, scene.camera
    kernels, scale = [], 1.0
    if effects.blur is not None:
        kernels.append(blur_kernel(effects.blur))
    if effects.defocus is not None:
        diameter = defocus_diameter_px(scene)
        if diameter > MAX_DISK_DIAMETER_PX:
            raise RollsimError(
                f"effects.defocus.focus_distance_cm = {effects.defocus.focus_distance_cm:g}: the circle of confusion "
                f"is {diameter:.0f} px, larger than the {MAX_DISK_DIAMETER_PX:.0f} px rollsim convolves"
            )
        kernels.append(disk_kernel(diameter))
        scale = defocus_image_scale(cam.focal_length_mm * 1e-3, scene.link.distance_m, effects.defocus.focus_distance_m)
    return kernels, scale


def lens_psf(setup: SceneSetup):
    """``blur`` and/or ``defocus``: the coverage convolved by every listed kernel.

    The image is rescaled by v_f/v (:func:`lens_kernels`) and its light per
    unit area by (v/v_f)², so the LED's light is conserved; the sensor at
    v_f sees the background's irradiance scaled by the same (v/v_f)² (the
    working f-number). The LED rows are
    those of the blurred coverage: a row belongs to the LED when the LED's
    light in it adds up to ``MIN_ROW_COVERAGE_PX`` fully covered pixels,
    the same rule as without a PSF (where it marks the footprint's geometric
    extent). A strong blur thus counts a dim rim: the light is there, with
    its stripes, though a decoder may not find it.
    """
    scene = setup.scene
    kernels, scale = lens_kernels(scene)
    size_px = setup.led_size_px * scale
    fp = blurred_footprint(setup.led_centre_px, size_px, scene.led.shape, setup.shape, kernels, scene.render.footprint_edge)
    return replace(
        setup,
        footprint=fp,
        led_size_px=size_px,
        led_rows=led_rows_from_coverage(fp.row_coverage(scene.camera.height_px)),
        led_e_per_s=setup.led_e_per_s * scale**-2,
        background_e_per_s=setup.background_e_per_s * scale**-2,
        face_e_per_s=setup.face_e_per_s * scale**-2,
    )


def emitter_light(setup: SceneSetup):
    """``led_profile`` and ``glare``: where the LED's light falls on the sensor.

    The face's radiance profile (:func:`rollsim.optics.emitter.profiled_light`)
    and then the lens's veiling glare (:func:`rollsim.optics.glare.glared_light`)
    reshape the LED's light, not its body: the background stays hidden by
    the footprint alone. The LED rows are those of the light, by the rule of
    :func:`lens_psf`, or with ``glare``, whose halo reaches every row, those
    whose stripes clear the noise (:func:`rollsim.render.readable.readable_rows`).
    """
    scene = setup.scene
    cam, effects = scene.camera, scene.effects
    light = setup.footprint
    if effects.led_profile is not None:
        px_per_mm = setup.led_size_px / scene.led.size_mm  # the image scale, defocus included
        light = profiled_light(light, setup.led_centre_px, effects.led_profile.core_sigma_mm * px_per_mm)
    if effects.glare is not None:
        params = effects.glare
        core_px = glare_core_px(params.core_angle_deg, cam.focal_length_mm * 1e-3, cam.pixel_pitch_um * 1e-6)
        light = glared_light(light, setup.shape, params.fraction, core_px, params.exponent)
    setup = replace(setup, led_light=light)
    if effects.glare is None:
        # The light stays within the footprint: the rule of :func:`lens_psf`.
        return replace(setup, led_rows=led_rows_from_coverage(light.row_coverage(cam.height_px)))
    # A halo reaches every row: the LED's rows are those whose stripes clear the noise.
    return replace(setup, led_rows=readable_rows(setup))


def colour_filter_array(setup: SceneSetup):
    """``bayer``: each pixel's electron rates are its own channel's.

    The rates are recomputed from the spectra (the monochrome ones use QE at
    the LED's peak wavelength), so this hook runs before any hook that
    scales them.
    """
    scene = setup.scene
    cam, params = scene.camera, scene.effects.bayer
    assert params is not None  # this hook runs only when bayer is listed
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
    )


def vignetting(setup: SceneSetup):
    """``vignetting``: every rate times cos⁴θ.

    The image distance is the lens-to-sensor distance: that of the LED's
    plane, or of the focus distance when ``defocus`` is listed.
    """
    scene = setup.scene
    cam, effects = scene.camera, scene.effects
    assert effects.vignetting is not None  # this hook runs only when vignetting is listed
    focus_m = effects.defocus.focus_distance_m if effects.defocus is not None else scene.link.distance_m
    f = cam.focal_length_mm * 1e-3
    gain = cos4_map(
        setup.shape, cam.pixel_pitch_um * 1e-6, image_distance_m(f, magnification(f, focus_m)), effects.vignetting.optical_centre_px
    )
    return replace(
        setup,
        led_e_per_s=setup.led_e_per_s * gain,
        background_e_per_s=setup.background_e_per_s * gain,
        face_e_per_s=setup.face_e_per_s * gain,
    )
