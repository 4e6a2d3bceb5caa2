"""Bayer CFA, spectral channel rates and demosaiced RGB output."""

import numpy as np
import pytest
from PIL import Image

from decoder.io import read_frame
from rollsim.cli import main
from rollsim.errors import RollsimError
from rollsim.optics.radiometry import photons_per_lumen_illuminant, photons_per_lumen_monochromatic
from rollsim.optics.spectral import (
    CAMERA_SENSITIVITIES,
    _sensitivity_table,
    camera_qe,
    electrons_per_lumen,
    illuminant_spectrum,
    led_electrons_per_lumen,
    led_spectrum,
    wavelength_grid_nm,
)
from rollsim.render import RenderPipeline
from rollsim.sensor.cfa import CFA_PATTERNS, DEMOSAIC_METHODS, cfa_channels, demosaic

from conftest import make_scene

# A fully lit frame (the LED covers it) sending a chip-rate square wave.
STRIPES = dict(
    camera={"height_px": 120, "width_px": 96, "output": "rgb8"},
    led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": 12.0},
    link={"pattern": "square", "clock_hz": 2000.0},
)


@pytest.mark.parametrize("pattern", CFA_PATTERNS)
@pytest.mark.parametrize("method", DEMOSAIC_METHODS)
def test_each_pattern_demosaics_its_red_sites_to_red(pattern, method):
    channels = cfa_channels(pattern, (8, 10))
    assert [int(channels[y, x]) for y in (0, 1) for x in (0, 1)] == ["RGB".index(c) for c in pattern]
    mosaic = np.where(channels == 0, 200, 0).astype(np.uint8)
    rgb = demosaic(mosaic, pattern, method)[3:5, 3:5].reshape(-1, 3)
    assert np.all(rgb[:, 0] == 200) and np.all(rgb[:, 1:] <= 30)


def test_led_spectrum_has_the_requested_fwhm():
    """colour's Ohno (2005) width is not the FWHM; the requested FWHM is."""
    power = led_spectrum(630.0, 20.0, wavelength_grid_nm(1))
    assert power.max() == 1.0 and power[630 - 360] == 1.0
    assert power[620 - 360] == pytest.approx(0.5, abs=1e-12) and power[640 - 360] == pytest.approx(0.5, abs=1e-12)


@pytest.mark.parametrize("name", sorted(CAMERA_SENSITIVITIES))
def test_camera_qe_peaks_at_the_camera_qe(name):
    wavelengths, _ = _sensitivity_table(name)
    qe = camera_qe(name, 0.6, wavelengths)
    assert qe.max() == pytest.approx(0.6, rel=1e-15) and qe.min() >= 0
    assert np.all(camera_qe(name, 0.6, [300.0, 900.0]) == 0)


def test_peak_step_is_the_monochromatic_line():
    qe = camera_qe("nikon_5100", 0.6, [630.0])[0]
    expected = qe * photons_per_lumen_monochromatic(630.0)
    np.testing.assert_allclose(led_electrons_per_lumen(630.0, 20.0, "nikon_5100", 0.6, "peak"), expected, rtol=1e-15)
    # A very narrow LED integrated at 1 nm converges to the line.
    narrow = led_electrons_per_lumen(630.0, 0.3, "nikon_5100", 0.6, 1)
    np.testing.assert_allclose(narrow, expected, rtol=1e-6)


@pytest.mark.parametrize("illuminant", ["FL2", "FL11", "A"])
def test_flat_qe_gives_the_monochrome_photons_per_lumen(illuminant):
    """Cross-check against radiometry's independent integration (colour's
    luminous flux): with a flat QE every channel converts qe photons per lumen.
    (D65 is left out: 2.6% of its photons lie below 360 nm, outside the
    integration grid, where none of the camera datasets has any response.)"""
    grid = wavelength_grid_nm(1)
    power = illuminant_spectrum(illuminant, grid)
    flat = np.full((grid.size, 3), 0.6)
    np.testing.assert_allclose(electrons_per_lumen(power, flat, grid), 0.6 * photons_per_lumen_illuminant(illuminant), rtol=2e-3)


def test_spectral_steps_agree_and_a_red_led_lands_in_red():
    fine = led_electrons_per_lumen(630.0, 20.0, "nikon_5100", 0.6, 1)
    for step in (5, 10):
        np.testing.assert_allclose(led_electrons_per_lumen(630.0, 20.0, "nikon_5100", 0.6, step), fine, rtol=0.05)
    assert fine[0] > 8 * fine[1] and fine[0] > 50 * fine[2]


def _render(output="rgb8"):
    sections = {**STRIPES, "camera": {**STRIPES["camera"], "output": output}}
    return RenderPipeline(make_scene(effects={"bayer": {"demosaic": "bilinear"}}, **sections))


def test_red_led_lands_mostly_in_the_red_sites_of_the_mosaic():
    pipeline = _render("raw16")
    image = pipeline.render(0).image.astype(float) - 64
    channels = cfa_channels("RGGB", image.shape)
    means = [image[channels == c].mean() for c in range(3)]
    assert means[0] > 8 * means[1] and means[0] > 30 * means[2]


def test_demosaiced_red_stripes_show_the_bayer_row_pairs():
    """Red sites sit on even rows only (RGGB), so bilinear demosaicing measures
    red on even rows and makes every odd row's red the mean of the rows
    above and below: the stripes' red profile is straight between even rows."""
    pipeline = _render()
    rgb = pipeline.render(0).image
    mosaic = pipeline.run_stages(0).dn
    assert rgb.shape == (120, 96, 3) and rgb.dtype == np.uint8
    interior = slice(8, 88)
    red = rgb[:, interior, 0].astype(float).mean(axis=1)
    assert rgb[:, interior, 0].std(axis=1).max() == 0  # noiseless: constant along rows
    even, odd = red[2:-2:2], red[3:-2:2]
    assert np.all(np.abs(odd - 0.5 * (red[2:-3:2] + red[4:-1:2])) <= 0.5 + 1e-9)
    # Even rows carry the measured red sites (8-bit, black level removed).
    measured = np.rint((mosaic[2:-2:2, 8].astype(float) - 64) / (1023 - 64) * 255)
    np.testing.assert_array_equal(even, measured)
    assert np.ptp(red) > 100 and rgb[:, interior, 1:].max() < 0.2 * red.max()


def test_led_narrower_than_the_integration_step_is_a_clear_error():
    scene = make_scene(effects={"bayer": {"led_fwhm_nm": 0.01}}, led={"peak_wavelength_nm": 630.4})
    with pytest.raises(RollsimError, match="effects.bayer.led_fwhm_nm = 0.01: the LED's spectrum falls between"):
        RenderPipeline(scene)


def test_mono_path_is_untouched_without_bayer():
    plain = RenderPipeline(make_scene(camera={"output": "raw16"}))
    assert plain.setup.prepared == () and np.ndim(plain.setup.led_e_per_s) == 0


def test_rgb8_png_on_disk_holds_true_rgb(tmp_path):
    out = tmp_path / "run"
    args = ["render", "effect-bayer", "--frames", "1", "--out", str(out), "--quiet",
            "--set", "camera.width_px=96", "--set", "camera.height_px=540", "--set", "camera.row_time_us=40"]
    assert main(args) == 0
    png = out / "frames" / "frame_000000.png"
    with Image.open(png) as im:
        assert im.mode == "RGB"
        on_disk = np.asarray(im)
    led = on_disk[200:340, 30:66].reshape(-1, 3).astype(float).mean(axis=0)
    assert led[0] > 3 * led[1] and led[0] > 3 * led[2]  # red, read by a reader that is not OpenCV
    assert np.array_equal(read_frame(png), on_disk)
