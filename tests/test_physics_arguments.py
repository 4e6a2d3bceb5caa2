"""Public physics functions refuse impossible arguments with a one-line ValueError naming the field."""

import numpy as np
import pytest

from rollsim.optics.glare import glare_core_px, moffat_mass_beyond
from rollsim.optics.psf import circle_of_confusion_m, defocus_image_scale
from rollsim.optics.vignetting import image_distance_m
from rollsim.sensor.adc import electrons_to_dn
from rollsim.sensor.blooming import bloom

CASES = [
    (lambda: glare_core_px(0.0, 4e-3, 1.4e-6), "core_angle_deg"),
    (lambda: glare_core_px(95.0, 4e-3, 1.4e-6), "core_angle_deg"),
    (lambda: glare_core_px(4.2, -4e-3, 1.4e-6), "focal_length_m"),
    (lambda: glare_core_px(4.2, 4e-3, 0.0), "pixel_pitch_m"),
    (lambda: moffat_mass_beyond(-1.0, 10.0, 2.0), "radius_px"),
    (lambda: moffat_mass_beyond(5.0, 0.0, 2.0), "core_px"),
    (lambda: moffat_mass_beyond(5.0, 10.0, 1.0), "exponent"),
    (lambda: circle_of_confusion_m(4e-3, 2.0, 3e-3, 1.0), "distance_m"),
    (lambda: circle_of_confusion_m(4e-3, 2.0, 0.05, 2e-3), "focus_distance_m"),
    (lambda: circle_of_confusion_m(4e-3, 0.0, 0.05, 1.0), "f_number"),
    (lambda: defocus_image_scale(4e-3, 0.05, float("nan")), "focus_distance_m"),
    (lambda: image_distance_m(4e-3, -0.5), "magnification"),
    (lambda: bloom(np.zeros((4, 4)), 0.0), "full_well_e"),
    (lambda: bloom(np.zeros((4, 4)), 1000.0, spill_fraction=1.5), "spill_fraction"),
    (lambda: electrons_to_dn(np.zeros(3, np.float32), -0.2, 64, 10), "gain_dn_per_e"),
    (lambda: electrons_to_dn(np.zeros(3, np.float32), 0.2, -1, 10), "black_level_dn"),
    (lambda: electrons_to_dn(np.zeros(3, np.float32), 0.2, 64, 17), "adc_bits"),
]


@pytest.mark.parametrize(("call", "field"), CASES, ids=[f"{i}-{f}" for i, (_, f) in enumerate(CASES)])
def test_impossible_arguments_are_refused_naming_the_field(call, field):
    with pytest.raises(ValueError, match=f"^{field}"):
        call()


def test_possible_arguments_still_give_the_known_answers():
    # f·tan θ / pitch; the Moffat mass beyond r0 at β = 2 is 1/2; v = f(1 + m).
    assert glare_core_px(45.0, 1.4e-3, 1.4e-6) == pytest.approx(1000.0)
    assert moffat_mass_beyond(10.0, 10.0, 2.0) == pytest.approx(0.5)
    assert image_distance_m(4e-3, 0.25) == pytest.approx(5e-3)
    assert circle_of_confusion_m(4e-3, 2.0, 1.0, 1.0) == 0.0
    dn = electrons_to_dn(np.array([0.0, 10.0, 1e9], np.float64), 0.5, 64, 10)
    assert dn.tolist() == [64, 69, 1023]
