"""Optics: thin lens, footprint coverage, radiometry against known values."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rollsim.optics import covered_rows, image_size_px, magnification
from rollsim.optics.footprint import footprint
from rollsim.optics.photopic import V_1924, photopic_efficiency
from rollsim.optics.radiometry import (
    AMBIENT_ILLUMINANTS,
    lambertian_luminance_cd_m2,
    led_luminance_cd_m2,
    photon_rate_per_pixel,
    photons_per_lumen_illuminant,
    photons_per_lumen_monochromatic,
    photons_per_lumen_spectrum,
    sensor_illuminance_lx,
)


def test_magnification_and_divergence():
    assert magnification(4e-3, 0.05) == pytest.approx(4 / 46)
    with pytest.raises(ValueError, match="thin lens diverges"):
        magnification(4e-3, 4e-3)
    assert image_size_px(4e-3, 3.97e-3, 0.05, 1.4e-6) == pytest.approx(4e-3 * 3.97 / 46.03 / 1.4e-6)


def test_covered_rows_clip_to_the_frame():
    assert covered_rows(540.0, 100.0, 1080) == (490, 589)
    assert covered_rows(10.0, 100.0, 1080) == (0, 59)
    first, last = covered_rows(-500.0, 10.0, 1080)
    assert first > last


@settings(max_examples=60, deadline=None)
@given(
    cx=st.floats(-20, 80),
    cy=st.floats(-20, 80),
    size=st.floats(0.01, 120),
)
def test_exact_disk_coverage_is_the_clipped_disk_area(cx, cy, size):
    """The covered areas sum to the disk's area inside the frame, which a
    fine quadrature of the disk's chords gives independently."""
    fp = footprint((cx, cy), size, "disk", (60, 60))
    assert np.all((fp.coverage >= 0) & (fp.coverage <= 1))
    r = size / 2
    x = np.linspace(max(0.0, cx - r), min(60.0, cx + r), 20001)
    half = np.sqrt(np.maximum(r * r - (x - cx) ** 2, 0))
    chord = np.clip(np.minimum(cy + half, 60) - np.maximum(cy - half, 0), 0, None)
    expected = np.trapezoid(chord, x) if x.size > 1 and x[-1] > x[0] else 0.0
    assert fp.coverage.sum() == pytest.approx(expected, rel=1e-4, abs=1e-4)


def test_disk_wholly_inside_has_area_pi_r_squared():
    fp = footprint((50.3, 47.9), 31.7, "disk", (100, 100))
    assert fp.coverage.sum() == pytest.approx(math.pi * 31.7**2 / 4, rel=1e-12)


def test_supersampling_converges_to_exact():
    exact = footprint((20.2, 19.6), 17.3, "disk", (40, 40)).coverage
    errors = [
        np.abs(footprint((20.2, 19.6), 17.3, "disk", (40, 40), edge).coverage - exact).max()
        for edge in ("supersample1", "supersample4", "supersample16")
    ]
    assert errors[0] > errors[2] and errors[2] < 0.1


def test_square_coverage_is_separable_and_exact():
    fp = footprint((10.25, 10.75), 4.5, "square", (20, 20))
    assert fp.coverage.sum() == pytest.approx(4.5**2)
    assert fp.coverage.max() == 1.0


def test_photons_per_lumen_at_555_nm():
    # 1 lm at 555 nm is 1/683 W; one photon carries h c / λ.
    expected = (1 / 683) / (6.62607015e-34 * 299792458.0 / 555e-9)
    assert photons_per_lumen_monochromatic(555.0) == pytest.approx(expected, rel=1e-6)
    # V(630) = 0.265: red light needs more photons per lumen.
    assert photons_per_lumen_monochromatic(630.0) == pytest.approx(expected * 630 / 555 / 0.265, rel=1e-3)


def test_photons_per_lumen_of_white_illuminants_lies_between_green_and_red():
    for name in ("FL2", "D65", "A"):
        value = photons_per_lumen_illuminant(name)
        assert photons_per_lumen_monochromatic(555.0) < value < photons_per_lumen_monochromatic(650.0)


def test_photopic_efficiency_is_colour_sciences_to_the_bit():
    """V(λ) read without importing colour-science: its table, and its Sprague values at and between the
    nodes and beyond the ends."""
    import colour

    v = colour.colorimetry.SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    assert V_1924 == tuple(v.values.tolist()) and tuple(v.wavelengths) == tuple(range(360, 831))
    wavelengths = [*np.arange(355.0, 835.5, 0.5), *np.random.default_rng(0).uniform(360.0, 830.0, 300),
                   359.9999999, 360.0000001, 829.9999999, 830.0000001]
    assert [photopic_efficiency(float(w)) for w in wavelengths] == [float(v[float(w)]) for w in wavelengths]
    with pytest.raises(ValueError, match="finite"):
        photopic_efficiency(float("nan"))


@pytest.mark.parametrize("name", AMBIENT_ILLUMINANTS)
def test_listed_photons_per_lumen_of_the_illuminants_are_colour_sciences(name):
    import colour

    assert photons_per_lumen_illuminant(name) == photons_per_lumen_spectrum(colour.SDS_ILLUMINANTS[name])


def test_camera_equation():
    # L = 1000 cd/m2 at f/2, T = 1, m = 0: E = π 1000 / 16.
    assert sensor_illuminance_lx(1000.0, 2.0, 1.0) == pytest.approx(math.pi * 1000 / 16)
    assert sensor_illuminance_lx(1000.0, 2.0, 1.0, 1.0) == pytest.approx(math.pi * 1000 / 64)


@pytest.mark.parametrize("distance_cm", [5.0, 10.0, 50.0])
def test_ambient_surfaces_of_equal_luminance_give_equal_irradiance(distance_cm):
    """Irradiance from an extended Lambertian surface depends on its luminance
    and on where the sensor sits (the working f-number N·(1 + m), the lens
    focused on the LED), not on how far the surface is: the distant
    background and the LED's face, of equal reflectance, give the same."""
    from rollsim.optics.scene_light import ambient_sensor_illuminances_lx
    from rollsim.scene import load_scene

    scene = load_scene("paper-default", [f"link.distance_cm={distance_cm}", "led.face_reflectance=0.5",
                                         "environment.background_reflectance=0.5"])
    background, face = ambient_sensor_illuminances_lx(scene)
    cam = scene.camera
    m = magnification(cam.focal_length_mm * 1e-3, distance_cm * 1e-2)
    luminance = 0.5 * scene.environment.ambient_lux / math.pi
    expected = math.pi * luminance * cam.lens_transmission / (4 * cam.f_number**2 * (1 + m) ** 2)
    assert background == pytest.approx(face, rel=1e-15) and background == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize(("call", "field"), [
    (lambda: sensor_illuminance_lx(100, -2.0, 0.9), "f_number"),
    (lambda: sensor_illuminance_lx(100, 2.0, 1.5), "transmission"),
    (lambda: sensor_illuminance_lx(-1.0, 2.0, 0.9), "luminance_cd_m2"),
    (lambda: sensor_illuminance_lx(100, 2.0, 0.9, magnification=float("nan")), "magnification"),
    (lambda: lambertian_luminance_cd_m2(650, 1.2), "reflectance"),
    (lambda: lambertian_luminance_cd_m2(np.array([1.0, -1.0]), 0.5), "illuminance_lx"),
    (lambda: photon_rate_per_pixel(10.0, 0.0, 4e15), "pixel_pitch_m"),
    (lambda: photon_rate_per_pixel(10.0, 1e-6, np.array([1.0, np.inf, 2.0])), "photons_per_lumen"),
    (lambda: led_luminance_cd_m2(-0.1, 1e-5), "luminous_intensity_cd"),
])
def test_radiometry_refuses_impossible_arguments_naming_them(call, field):
    with pytest.raises(ValueError, match=f"^{field} must be"):
        call()


def test_radiometry_accepts_arrays_where_light_varies():
    lux = np.array([0.0, 10.0, 100.0])
    assert np.allclose(lambertian_luminance_cd_m2(lux, 0.5), 0.5 * lux / math.pi)
    assert np.allclose(photon_rate_per_pixel(lux, 1e-6, 4e15), lux * 1e-12 * 4e15)


def direct_disk_corner_area(x, y, r):
    """The corner area as computed before its primitives were shared: every
    primitive evaluated on the full broadcast arrays."""
    from rollsim.optics.footprint import _chord_primitive as H

    x = np.clip(x, -r, r)
    yc = np.clip(y, -r, r)
    a = np.sqrt(np.maximum(r * r - yc * yc, 0.0))
    middle = np.clip(x, -a, a)
    inner = yc * (middle + a) + H(middle, r) - H(-a, r)
    outer = 2.0 * (H(np.minimum(x, -a), r) + np.maximum(H(x, r) - H(a, r), 0.0))
    return inner + np.where(yc >= 0, outer, 0.0)


def test_disk_corner_area_shares_its_primitives_to_the_bit():
    from rollsim.optics.footprint import _disk_corner_area

    rng = np.random.default_rng(11)
    for r in (0.3, 1.0, 7.0, 12.0, 530.0, 1e4):
        for centre in ((0.0, 0.0), (3.0, -2.0), tuple(rng.uniform(-2 * r, 2 * r, 2))):
            xs = np.arange(-int(1.5 * r) - 2, int(1.5 * r) + 3, max(1, int(r) // 40), dtype=float) - centre[0]
            ys = np.arange(-int(1.5 * r) - 2, int(1.5 * r) + 3, max(1, int(r) // 40), dtype=float) - centre[1]
            grid = _disk_corner_area(xs[None, :], ys[:, None], r)
            assert grid.tobytes() == direct_disk_corner_area(xs[None, :], ys[:, None], r).tobytes()
        x, y = rng.uniform(-2 * r, 2 * r, (2, 500))
        assert _disk_corner_area(x, y, r).tobytes() == direct_disk_corner_area(x, y, r).tobytes()


def test_disk_footprint_by_row_blocks_is_one_grid():
    """_disk_exact works 32 rows at a time: the coverage of one grid of corners."""
    from rollsim.optics.footprint import _disk_exact, _snap

    xs = np.arange(0, 301, dtype=float) - 150.3
    ys = np.arange(0, 101, dtype=float) - 40.7  # 100 rows: four blocks, the last one short
    G = direct_disk_corner_area(xs[None, :], ys[:, None], 120.0)
    whole = _snap(G[1:, 1:] - G[1:, :-1] - G[:-1, 1:] + G[:-1, :-1], 120.0)
    assert _disk_exact(xs, ys, 120.0).tobytes() == whole.tobytes()
