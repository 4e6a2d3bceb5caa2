"""Natural vignetting (cos⁴) against hand-computed values."""

import math

import numpy as np
import pytest

from rollsim.optics.vignetting import cos4_map
from rollsim.render import RenderPipeline

from conftest import make_scene


def test_cos4_map_at_a_known_pixel_and_at_the_centre():
    pitch, v = 1.4e-6, 4.2e-3
    gain = cos4_map((101, 151), pitch, v)
    # Frame centre (75.5, 50.5) is the centre of pixel (75, 50).
    assert gain[50, 75] == 1.0 and gain.max() == 1.0
    r = pitch * math.hypot(0.5 - 75.5, 0.5 - 50.5)  # pixel (0, 0)
    assert gain[0, 0] == pytest.approx(math.cos(math.atan(r / v)) ** 4, rel=1e-14)
    r = pitch * math.hypot(140.5 - 75.5, 90.5 - 50.5)  # pixel (x=140, y=90)
    assert gain[90, 140] == pytest.approx(math.cos(math.atan(r / v)) ** 4, rel=1e-14)
    shifted = cos4_map((101, 151), pitch, v, centre_px=(10.5, 20.5))
    assert shifted[20, 10] == 1.0


def _flat_scene(effects):
    # Ambient light only (the LED far outside the frame), no noise, raw DN:
    # the background shows the map. 10 um pixels give a wide field.
    return make_scene(effects=effects, camera={"height_px": 121, "width_px": 161, "iso": 400.0, "pixel_pitch_um": 10.0},
                      led={"size_mm": 1.0, "position_px": [-5000.0, -5000.0]})


def test_vignetting_darkens_the_background_by_the_map():
    plain = RenderPipeline(_flat_scene(["ambient"]))
    vignetted = RenderPipeline(_flat_scene({"ambient": {}, "vignetting": {}}))
    setup = vignetted.setup
    assert np.ndim(plain.setup.background_e_per_s) == 0  # no map without the effect
    cam = setup.scene.camera
    f, d = cam.focal_length_mm * 1e-3, setup.scene.link.distance_m
    v = f * (1 + f / (d - f))  # the image distance of the LED's plane
    expected = plain.setup.background_e_per_s * cos4_map((121, 161), 10e-6, v)
    np.testing.assert_allclose(setup.background_e_per_s, expected, rtol=1e-15)
    image = vignetted.render(0).image.astype(float) - cam.black_level_dn
    centre, corner = image[60, 80], image[0, 0]
    assert corner / centre == pytest.approx(expected[0, 0] / expected[60, 80], abs=2 / centre)
    assert expected[0, 0] < 0.92 * expected[60, 80]


def test_vignetting_uses_the_focus_distance_when_defocused():
    scene = make_scene(effects={"vignetting": {}, "defocus": {"focus_distance_cm": 50.0}})
    setup = RenderPipeline(scene).setup
    f = 3.97e-3
    v = f * (1 + f / (0.5 - f))
    base = RenderPipeline(make_scene(effects={"defocus": {"focus_distance_cm": 50.0}})).setup
    np.testing.assert_allclose(setup.led_e_per_s, base.led_e_per_s * cos4_map((200, 160), 1.4e-6, v), rtol=1e-15)
