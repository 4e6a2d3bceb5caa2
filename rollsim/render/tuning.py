"""How the bundled scenes' LED size and luminous intensity were chosen.

Two facts of the reference paper meet here:

* Its measured ROI (Fig. 11; CamComSim's ROI_exp table) is far larger than a
  thin lens gives for its 4-5 mm LED: 0.98 of the frame at 5 cm, 0.72 at
  10 cm, where a 4 mm LED images onto 0.23 and 0.11 of the rows of a Nexus 5.
  The paper puts this down to the LED's radiance flooding the lens. rollsim's
  ``led.size_mm`` is the *effective* emitting size, so the paper scenes use
  the size whose thin-lens image spans the measured ROI
  (:func:`effective_led_size_mm`).
* At the paper's ISO 10000 one electron is 22 DN, so a pixel saturates at
  about 44 electrons in 100 µs; a real LED of a few candela would saturate
  everything. The scenes set the luminous intensity so that a fully ON row
  sits at a chosen fraction of the ADC range (:func:`luminous_intensity_for_on_fraction`).
"""

from __future__ import annotations

from rollsim.channel.channels import camcomsim_roi as paper_measured_roi  # the paper's Fig. 11 table
from rollsim.optics import magnification
from rollsim.render.setup import ambient_electron_rates, led_electron_rate


def effective_led_size_mm(scene, roi: float) -> float:
    """LED size whose thin-lens image spans ``roi`` of the frame's rows."""
    cam = scene.camera
    m = magnification(cam.focal_length_mm * 1e-3, scene.link.distance_m)
    return roi * cam.height_px * cam.pixel_pitch_um * 1e-3 / m


def on_level_electrons(scene) -> float:
    """Mean electrons of a fully covered pixel in a fully ON row (no noise).

    The LED at level 1 for the whole exposure, plus ambient light reflected
    by its face when the ``ambient`` effect is on.
    """
    t_exp = scene.camera.exposure_s
    face = ambient_electron_rates(scene)[1] * t_exp if scene.effects.ambient is not None else 0.0
    return led_electron_rate(scene) * t_exp + face


def full_scale_electrons(scene) -> float:
    """Electrons that fill the ADC range above the black level at the set ISO."""
    cam = scene.camera
    return (2**cam.adc_bits - 1 - cam.black_level_dn) / cam.gain_dn_per_e_at_iso


def luminous_intensity_for_on_fraction(scene, fraction: float) -> float:
    """Luminous intensity (cd) that puts a fully ON row at ``fraction`` of full scale.

    The LED signal is linear in the luminous intensity; ambient light on the
    LED face is not, and is kept.
    """
    if not 0 < fraction <= 1:
        raise ValueError(f"fraction must be in (0, 1], got {fraction}")
    t_exp = scene.camera.exposure_s
    face = on_level_electrons(scene) - led_electron_rate(scene) * t_exp
    needed = fraction * full_scale_electrons(scene) - face
    if needed <= 0:
        raise ValueError("ambient light on the LED face alone exceeds that level")
    per_candela = led_electron_rate(scene) * t_exp / scene.led.luminous_intensity_cd
    return needed / per_candela
