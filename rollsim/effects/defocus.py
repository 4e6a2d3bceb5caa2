"""``defocus``: thin-lens defocus, a disk PSF the size of the circle of confusion.

The sensor sits at the focus distance's image plane, so the LED's image is
v_f/v times larger and its light per unit area (v/v_f)² weaker: the LED's
light is conserved, and the background's irradiance is scaled by the same
(v/v_f)² (the working f-number). See :mod:`rollsim.optics.psf`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams
from rollsim.effects.lens import with_lens_kernel
from rollsim.errors import RollsimError
from rollsim.optics.geometry import magnification
from rollsim.optics.psf import MAX_DISK_DIAMETER_PX, circle_of_confusion_m, defocus_image_scale, disk_kernel
from rollsim.optics.vignetting import image_distance_m

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.scene_sections import SceneSections


class Defocus(EffectParams):
    """Thin-lens defocus: a disk PSF whose diameter is the circle of confusion
    of the LED's distance for a lens focused at ``focus_distance_cm`` with
    aperture f/N (``camera.f_number``). See :mod:`rollsim.optics.psf`."""

    focus_distance_cm: float = Field(gt=0, le=1e5)

    @property
    def focus_distance_m(self) -> float:
        return self.focus_distance_cm * 1e-2


def check(scene: SceneSections, params: Defocus) -> str | None:
    focal_length_mm = scene.camera.focal_length_mm
    if params.focus_distance_cm * 10.0 <= focal_length_mm:
        return (f"effects.defocus.focus_distance_cm = {params.focus_distance_cm:g}: the lens cannot "
                f"focus nearer than its focal length ({focal_length_mm:g} mm)")
    return None


def defocus_diameter_px(scene: SceneSections, params: Defocus) -> float:
    """The blur circle's diameter in pixels."""
    cam = scene.camera
    c_m = circle_of_confusion_m(cam.focal_length_mm * 1e-3, cam.f_number, scene.link.distance_m, params.focus_distance_m)
    return c_m / (cam.pixel_pitch_um * 1e-6)


def prepare(setup: SceneSetup, params: Defocus) -> SceneSetup:
    scene = setup.scene
    diameter = defocus_diameter_px(scene, params)
    if diameter > MAX_DISK_DIAMETER_PX:
        raise RollsimError(
            f"effects.defocus.focus_distance_cm = {params.focus_distance_cm:g}: the circle of confusion "
            f"is {diameter:.0f} px, larger than the {MAX_DISK_DIAMETER_PX:.0f} px rollsim convolves"
        )
    f_m = scene.camera.focal_length_mm * 1e-3
    scale = defocus_image_scale(f_m, scene.link.distance_m, params.focus_distance_m)
    return with_lens_kernel(
        setup,
        disk_kernel(diameter),
        led_size_px=setup.led_size_px * scale,
        led_e_per_s=setup.led_e_per_s * scale**-2,
        background_e_per_s=setup.background_e_per_s * scale**-2,
        face_e_per_s=setup.face_e_per_s * scale**-2,
        image_distance_m=image_distance_m(f_m, magnification(f_m, params.focus_distance_m)),
    )


EFFECT = Effect(
    name="defocus",
    params=Defocus,
    prepare=prepare,
    check=check,
    reads=("setup.lens_kernels", "setup.led_size_px", "setup.led_e_per_s", "setup.background_e_per_s",
           "setup.face_e_per_s"),
    writes=("setup.lens_kernels", "setup.footprint", "setup.led_rows", "setup.led_size_px", "setup.led_e_per_s",
            "setup.background_e_per_s", "setup.face_e_per_s", "setup.image_distance_m"),
)
