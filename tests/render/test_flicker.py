"""flicker: mains-modulated ambient light integrated per row."""

import math
from fractions import Fraction

import numpy as np
import pytest
from scipy.integrate import quad

from rollsim.render import RenderPipeline
from rollsim.sensor.flicker import flicker_row_factor

from conftest import make_scene

CAMERA = {"height_px": 1000, "width_px": 40, "row_time_us": 30.0, "exposure_us": 100.0}


def _scene(flicker=None, mains_hz=50.0, **sections):
    effects = {"ambient": {}}
    if flicker is not None:
        effects["flicker"] = flicker
    return make_scene(effects=effects, camera={**CAMERA, **sections.pop("camera", {})},
                      environment={"mains_hz": mains_hz, "ambient_lux": 2000.0}, led={"size_mm": 3.0}, **sections)


@pytest.mark.parametrize("mains_hz", [50.0, 60.0, 59.7])
@pytest.mark.parametrize("exposure_s", [1e-5, 1e-4, 3.1e-3, 1 / 100, 0.02])
def test_row_factor_matches_quadrature(mains_hz, exposure_s):
    depth, phase = 0.7, 1.1
    starts = np.array([0.0, 1.234e-3, 0.5, 3600.0 + 1e-4])
    got = flicker_row_factor(starts, exposure_s, mains_hz, depth, phase)
    w = 2 * math.pi * 2 * mains_hz
    for t0, value in zip(starts, got):
        # Integrate over phase, reduced exactly (rational arithmetic), so the
        # reference stays accurate an hour into a run.
        p0 = 2 * math.pi * float((2 * Fraction(mains_hz) * (Fraction(float(t0)) + Fraction(exposure_s) / 2)) % 1) \
            - w * exposure_s / 2
        integral = quad(lambda p: 1 + depth * math.cos(p + phase), p0, p0 + w * exposure_s, limit=200)[0] / w
        assert value == pytest.approx(integral / exposure_s, rel=1e-10, abs=1e-12)
    if exposure_s in (1 / 100, 0.02) and mains_hz == 50.0:
        # A whole number of flicker periods sees the mean light.
        np.testing.assert_allclose(got, 1.0, atol=1e-15)


@pytest.mark.parametrize("mains_hz", [50.0, 60.0])
def test_bands_have_a_period_of_one_over_two_f_t_row(mains_hz):
    scene = _scene({"depth": 0.5}, mains_hz, camera={"output": "gray8"})
    frame = RenderPipeline(scene).render(1)
    profile = frame.image[:, :5].astype(float).mean(axis=1)  # background, left of the LED
    spectrum = np.abs(np.fft.rfft((profile - profile.mean()) * np.hanning(profile.size), n=1 << 16))
    period_rows = (1 << 16) / np.argmax(spectrum)
    expected = 1 / (2 * mains_hz * 30e-6)  # 333.3 rows at 50 Hz, 277.8 at 60 Hz
    assert period_rows == pytest.approx(expected, rel=0.02)
    assert profile.max() - profile.min() > 40  # visible bands


def test_only_the_ambient_terms_are_modulated():
    """Electrons with flicker − without = (factor(y) − 1)·ambient(y, x), where
    ambient is the background and the light the LED's face reflects; the LED's
    own light is untouched."""
    plain, flickering = _scene(), _scene({"depth": 0.4, "phase_deg": 30.0})
    a, b = RenderPipeline(plain).run_stages(2), RenderPipeline(flickering).run_stages(2)
    setup = RenderPipeline(plain).setup
    t_exp = plain.camera.exposure_s
    coverage = setup.footprint.dense(setup.shape)
    ambient = (setup.background_e_per_s * (1 - coverage) + setup.face_e_per_s * coverage) * t_exp
    start = np.arange(1000) * 30e-6 + 2 / 30
    factor = flicker_row_factor(start, t_exp, 50.0, 0.4, math.radians(30.0))
    np.testing.assert_allclose(b.electrons - a.electrons, (factor - 1)[:, None] * ambient, rtol=1e-9, atol=1e-9)
    assert np.ptp(factor) > 0.5


def test_depth_zero_is_the_static_render_exactly():
    static = RenderPipeline(make_scene(effects=("ambient", "shot_noise"), camera=CAMERA, led={"size_mm": 3.0}))
    flat = RenderPipeline(make_scene(effects={"ambient": {}, "shot_noise": {}, "flicker": {"depth": 0.0}},
                                     camera=CAMERA, led={"size_mm": 3.0}))
    assert "flicker" in flat.stage_names and "flicker" not in static.stage_names
    for k in (0, 1):
        a, b = static.render(k), flat.render(k)
        assert np.array_equal(a.image, b.image) and a.truth == b.truth


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"depth": 3.0}, "depth"),
    ({"depth": -0.1}, "depth"),
    ({"mains_hz": 0.0}, "mains_hz"),
    ({"exposure_s": -1e-4}, "exposure_s"),
    ({"phase_rad": float("inf")}, "phase_rad"),
])
def test_flicker_refuses_impossible_arguments_naming_them(kwargs, field):
    args = {"t_start_s": np.zeros(3), "exposure_s": 1e-4, "mains_hz": 50.0, "depth": 0.3, **kwargs}
    with pytest.raises(ValueError, match=f"^{field} must be"):
        flicker_row_factor(**args)
