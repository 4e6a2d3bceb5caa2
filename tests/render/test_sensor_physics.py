"""Photon transfer, read noise and the ideal render against the analytic DN."""

import numpy as np
import pytest

from rollsim.optics.footprint import footprint
from rollsim.render import RenderPipeline

from conftest import make_scene


def _flat_field_scene(intensity_cd, iso=10000.0, effects=("shot_noise", "read_noise")):
    # The LED fills the whole 120 x 160 frame with the "on" pattern.
    return make_scene(
        effects=effects,
        camera={"height_px": 120, "width_px": 160, "iso": iso, "output": "raw16"},
        led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": intensity_cd},
        link={"pattern": "on"},
    )


def test_photon_transfer_slope_is_the_conversion_gain():
    """Variance against mean of flat fields at 8 levels: slope K·ISO/base_ISO.

    EMVA 1288 method: the temporal variance is half the variance of the
    difference of two frames, which removes any fixed pattern."""
    # ISO 3200: K = 7.04 DN/e-; 10 to 90 electrons keep every level more than
    # 3 sigma away from both ADC clips, which would bias the variance.
    means, variances = [], []
    for intensity in np.linspace(1.9, 17.0, 8):
        pipeline = RenderPipeline(_flat_field_scene(intensity, iso=3200.0))
        a, b = (pipeline.render(k).image.astype(float) for k in (0, 1))
        black = pipeline.setup.scene.camera.black_level_dn
        means.append(0.5 * (a.mean() + b.mean()) - black)
        variances.append(np.var(a - b) / 2)
    top = 2**10 - 1 - 64
    assert max(means) < 0.8 * top and min(means) > 0.05 * top  # unsaturated, well lit
    slope = np.polyfit(means, variances, 1)[0]
    expected = 0.22 * 3200 / 100
    assert slope == pytest.approx(expected, rel=0.03)


@pytest.mark.parametrize("method", ["table", "exact"])
def test_dark_frames_give_the_read_noise(method):
    pipeline = RenderPipeline(_flat_field_scene(0.0, iso=1000.0, effects={"read_noise": {"method": method}}))
    gain = pipeline.setup.gain_dn_per_e
    a, b = (pipeline.render(k).image.astype(float) for k in (0, 1))
    # Quantisation adds 1/12 DN² to each frame's variance.
    sigma_e = np.sqrt(np.var(a - b) / 2 - 1 / 12) / gain
    assert sigma_e == pytest.approx(2.0, rel=0.05)


def _analytic_led_exposure(scene, frame):
    """∫ s dt per row for the square pattern by direct chip overlap (no S(t))."""
    cam, clock = scene.camera, scene.link.clock_hz
    t_row, t_exp = cam.row_time_s, cam.exposure_s
    t_k = frame * cam.frame_period_s
    out = np.zeros(cam.height_px)
    for y in range(cam.height_px):
        a, b = t_k + y * t_row, t_k + y * t_row + t_exp
        for chip in range(int(np.floor(a * clock)), int(np.floor(b * clock)) + 1):
            lo, hi = max(a, chip / clock), min(b, (chip + 1) / clock)
            if hi > lo and chip % 2 == 0:
                out[y] += hi - lo
    return out


@pytest.mark.parametrize("output", ["raw16", "gray8"])
def test_ideal_render_equals_the_noiseless_analytic_dn(output):
    scene = make_scene(
        camera={"height_px": 150, "width_px": 140, "output": output, "exposure_us": 70.0},
        led={"size_mm": 8.0, "luminous_intensity_cd": 0.2},
        link={"pattern": "square"},
    )
    pipeline = RenderPipeline(scene)
    assert pipeline.stage_names == ("frame_start", "led_exposure", "led_signal", "full_well", "adc", output)
    setup, cam = pipeline.setup, scene.camera
    for frame in (0, 7):
        cov = footprint(setup.led_centre_px, setup.led_size_px, "disk", (cam.height_px, cam.width_px)).dense((cam.height_px, cam.width_px))
        electrons = np.clip(cov * setup.led_e_per_s * _analytic_led_exposure(scene, frame)[:, None], 0, cam.full_well_e)
        dn = np.clip(np.floor(electrons * setup.gain_dn_per_e + cam.black_level_dn + 0.5), 0, 1023)  # round half up
        if output == "gray8":
            expected = np.rint(np.clip((dn - 64) / (1023 - 64), 0, 1) * 255)
        else:
            expected = dn
        image = pipeline.render(frame).image
        assert np.array_equal(image, expected.astype(image.dtype))
        assert 0 < image.max() and (output == "raw16" or image.max() <= 255)


def test_full_well_and_adc_clip():
    scene = make_scene(effects=("shot_noise",), camera={"height_px": 40, "width_px": 40, "iso": 100.0},
                       led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": 2000.0}, link={"pattern": "on"})
    image = RenderPipeline(scene).render(0).image
    # 4500 e- full well x 0.22 DN/e- = 990 DN + 64 black level, clipped at 1023.
    assert image.max() == 1023 and image.min() == 1023


def test_tone_curve_brightens_mid_tones():
    base = make_scene(camera={"height_px": 60, "width_px": 60, "output": "gray8"},
                      led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": 4.0}, link={"pattern": "on"})
    toned = make_scene(effects=("tone_curve",), camera={"height_px": 60, "width_px": 60, "output": "gray8"},
                       led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": 4.0}, link={"pattern": "on"})
    v = RenderPipeline(base).render(0).image.astype(float).mean() / 255
    v_toned = RenderPipeline(toned).render(0).image.astype(float).mean() / 255
    assert 0.05 < v < 0.9
    assert v_toned == pytest.approx(v ** (1 / 2.2), abs=2 / 255)


def test_prnu_and_dsnu_are_fixed_per_seed():
    scene = make_scene(effects=("prnu", "dsnu"), camera={"height_px": 50, "width_px": 50, "iso": 1000.0},
                       led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": 4.0}, link={"pattern": "on"})
    pipeline = RenderPipeline(scene)
    a, b = pipeline.render(0).image, pipeline.render(1).image
    assert np.array_equal(a, b)  # no temporal noise: the pattern is fixed
    assert a.std() > 0
    other = RenderPipeline(make_scene(effects=("prnu", "dsnu"), seed=6, camera={"height_px": 50, "width_px": 50, "iso": 1000.0},
                                      led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": 4.0},
                                      link={"pattern": "on"})).render(0).image
    assert not np.array_equal(a, other)


def test_unlisted_effects_are_absent_from_the_pipeline():
    names = RenderPipeline(make_scene(effects=("read_noise",))).stage_names
    assert "read_noise[table]" in names
    assert not any(n.startswith(("shot_noise", "ambient", "prnu", "dsnu", "dark_current")) for n in names)


def test_signal_budget_matches_a_noiseless_render():
    from rollsim.stages.describe import signal_budget

    scene = make_scene(effects=("ambient",), camera={"height_px": 40, "width_px": 40, "iso": 400.0},
                       led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": 0.3, "off_level": 0.25},
                       link={"pattern": "on"})
    budget = signal_budget(scene)
    assert budget["electrons"]["led_on"] == pytest.approx(scene.camera.qe * budget["photons"]["led_on"])
    assert budget["electrons"]["led_off"] < budget["electrons"]["led_on"] and not budget["clipped"]
    pipeline = RenderPipeline(scene)
    image = pipeline.render(0).image.astype(float)
    rendered_e = (image - scene.camera.black_level_dn) / pipeline.setup.gain_dn_per_e
    assert rendered_e.mean() == pytest.approx(budget["electrons"]["led_on"], abs=0.5 / pipeline.setup.gain_dn_per_e)
    off = RenderPipeline(make_scene(effects=("ambient",), camera={"height_px": 40, "width_px": 40, "iso": 400.0},
                                    led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": 0.3,
                                         "off_level": 0.25}, link={"pattern": "off"}))
    off_e = (off.render(0).image.astype(float) - scene.camera.black_level_dn) / pipeline.setup.gain_dn_per_e
    assert off_e.mean() == pytest.approx(budget["electrons"]["led_off"], abs=0.5 / pipeline.setup.gain_dn_per_e)
    # Noiseless but for quantisation: SNR = gap / sqrt(1/12) DN, in electrons.
    gap = budget["electrons"]["led_on"] - budget["electrons"]["led_off"]
    assert budget["snr_pixel"] == pytest.approx(gap * pipeline.setup.gain_dn_per_e * np.sqrt(12.0))
