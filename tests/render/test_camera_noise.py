"""The sensor's noise sources against their definitions: DSNU, dark signal,
row and column noise, and the camera's identity apart from the noise seed."""

import numpy as np
import pytest

from rollsim.effects.dark_current import lognormal_unit_mean, temperature_factor
from rollsim.render import RenderPipeline
from rollsim.scene import PRESETS
from rollsim.sensor.adc import electrons_to_dn

from conftest import make_scene

SIZE = {"height_px": 256, "width_px": 256}


def dark_scene(effects, iso=1000.0, seed=5, **camera):
    """No light: the LED off and no ambient light; raw16 at ``iso``."""
    scene = make_scene(effects=effects, camera={**SIZE, "iso": iso, **camera}, link={"pattern": "off"})
    return scene.model_copy(update={"seed": seed})


def electrons_of(pipeline, frame=0):
    """A frame in electrons above the black level."""
    cam = pipeline.setup.scene.camera
    return (pipeline.render(frame).image.astype(float) - cam.black_level_dn) / pipeline.setup.gain_dn_per_e


# ------------------------------------------------------------------ presets


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_the_full_well_fills_the_adc_at_base_iso(name):
    values = PRESETS[name].as_dict()
    gain, black, bits, full_well = values["gain_dn_per_e"], values["black_level_dn"], values["adc_bits"], values["full_well_e"]
    top = 2**bits - 1
    assert electrons_to_dn(np.array([full_well]), gain, black, bits)[0] == top  # an integer count, too
    # Neither clips first: the full well lands within one electron of the top code.
    assert abs(full_well * gain + black - top) <= gain


# --------------------------------------------------------------------- DSNU


def test_dsnu_survives_the_full_well_clip():
    """EMVA 1288's DSNU is the dark image's spatial deviation: all of it,
    negative offsets included, reaches the DN."""
    pipeline = RenderPipeline(dark_scene({"dsnu": {}}, dsnu_e=2.0))
    dark = electrons_of(pipeline)
    # Quantisation adds 1/12 DN² to the variance.
    dsnu = np.sqrt(dark.var() - 1 / 12 / pipeline.setup.gain_dn_per_e**2)
    assert dsnu == pytest.approx(2.0, rel=0.02)
    # Symmetric about the black level: the negative half was not cut.
    below, above = (dark < 0).mean(), (dark > 0).mean()
    assert abs(dark.mean()) < 0.05 and below > 0.4 and below == pytest.approx(above, abs=0.01)


def test_prnu_scales_the_light_not_the_dark_signal():
    dark_only = electrons_of(RenderPipeline(dark_scene({"dark_current": {}}, dark_current_e_per_s=5e4, exposure_us=1000.0)))
    with_prnu = electrons_of(RenderPipeline(dark_scene({"dark_current": {}, "prnu": {}}, dark_current_e_per_s=5e4,
                                                       exposure_us=1000.0, prnu_percent=5.0)))
    assert np.array_equal(dark_only, with_prnu)


# -------------------------------------------------------------- dark signal


def test_lognormal_map_has_unit_mean_and_the_asked_deviation():
    values = lognormal_unit_mean(np.random.default_rng(1), (1000, 1000), 0.4)
    assert values.min() > 0
    assert values.mean() == pytest.approx(1.0, abs=0.002) and values.std() == pytest.approx(0.4, rel=0.01)


def test_dark_current_doubles_every_doubling_temperature():
    assert temperature_factor(25.0, 7.0) == 1.0
    assert temperature_factor(32.0, 7.0) == pytest.approx(2.0) and temperature_factor(11.0, 7.0) == pytest.approx(0.25)
    dark = {"temperature_c": 39.0}
    cool = electrons_of(RenderPipeline(dark_scene({"dark_current": {}}, dark_current_e_per_s=1e4, exposure_us=1000.0)))
    warm = electrons_of(RenderPipeline(dark_scene({"dark_current": dark}, dark_current_e_per_s=1e4, exposure_us=1000.0)))
    assert cool.mean() == pytest.approx(10.0, abs=0.3) and warm.mean() == pytest.approx(40.0, abs=0.3)


def test_dark_signal_non_uniformity_grows_with_exposure():
    """Without shot noise the dark image is the rate map times t_exp: its
    spatial deviation is nonuniformity × mean, at every exposure."""
    effects = {"dark_current": {"nonuniformity_percent": 30.0}}
    spreads = []
    for exposure_us in (500.0, 2000.0):
        dark = electrons_of(RenderPipeline(dark_scene(effects, iso=400.0, dark_current_e_per_s=2e4, exposure_us=exposure_us)))
        mean_e = 2e4 * exposure_us * 1e-6
        assert dark.mean() == pytest.approx(mean_e, rel=0.01)
        spreads.append(dark.std())
        assert dark.std() == pytest.approx(0.3 * mean_e, rel=0.03)
    assert spreads[1] == pytest.approx(4 * spreads[0], rel=0.03)


def test_hot_pixels():
    effects = {"dark_current": {"hot_pixel_fraction": 0.01, "hot_pixel_factor": 50.0}}
    dark = electrons_of(RenderPipeline(dark_scene(effects, iso=400.0, dark_current_e_per_s=1e4, exposure_us=1000.0)))
    hot = dark > 100  # 10 e- in a normal pixel, 500 in a hot one
    assert hot.mean() == pytest.approx(0.01, rel=0.1)
    assert np.median(dark[hot]) == pytest.approx(500, rel=0.01) and np.median(dark[~hot]) == pytest.approx(10, rel=0.05)


# -------------------------------------------------------------- row, column


def test_column_fpn_is_a_fixed_offset_per_column():
    pipeline = RenderPipeline(dark_scene({"column_fpn": {"std_e": 3.0}, "read_noise": {}}))
    a, b = electrons_of(pipeline, 0), electrons_of(pipeline, 1)
    columns = a.mean(axis=0)
    # 256 columns: the deviation's standard error is 4.4 %; the read noise adds 2/16 e-.
    assert columns.std() == pytest.approx(3.0, rel=0.15)
    assert np.corrcoef(columns, b.mean(axis=0))[0, 1] > 0.99  # the same in every frame
    assert a.mean(axis=1).std() < 0.3  # nothing along the rows


def test_row_noise_moves_whole_rows_and_changes_every_frame():
    pipeline = RenderPipeline(dark_scene({"row_noise": {"std_e": 3.0}}))
    a, b = electrons_of(pipeline, 0), electrons_of(pipeline, 1)
    rows = a.mean(axis=1)
    assert rows.std() == pytest.approx(3.0, rel=0.15)
    # Every pixel of a row moves together (up to the ADC's rounding) ...
    assert np.abs(a - rows[:, None]).max() <= 0.5 / pipeline.setup.gain_dn_per_e + 1e-9
    # ... and the next frame's rows are new draws.
    assert abs(np.corrcoef(rows, b.mean(axis=1))[0, 1]) < 0.2


# ---------------------------------------------------------------- identity


FIXED = {"prnu": {}, "dsnu": {}, "column_fpn": {}, "dark_current": {"nonuniformity_percent": 20.0, "hot_pixel_fraction": 0.001}}
TEMPORAL = {"shot_noise": {}, "read_noise": {}, "row_noise": {}}


def lit_scene(effects, seed, identity_seed):
    scene = make_scene(effects=effects, camera={**SIZE, "iso": 400.0, "identity_seed": identity_seed, "prnu_percent": 3.0,
                                                "dsnu_e": 3.0, "dark_current_e_per_s": 2e4, "exposure_us": 500.0},
                       led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": 0.05}, link={"pattern": "on"})
    return scene.model_copy(update={"seed": seed})


def test_the_same_camera_gives_the_same_fixed_patterns_whatever_the_noise_seed():
    first = RenderPipeline(lit_scene(FIXED, seed=1, identity_seed=7)).render(0).image
    assert first.std() > 0
    assert np.array_equal(first, RenderPipeline(lit_scene(FIXED, seed=2, identity_seed=7)).render(0).image)
    assert not np.array_equal(first, RenderPipeline(lit_scene(FIXED, seed=1, identity_seed=8)).render(0).image)


def test_new_noise_seeds_give_uncorrelated_noise_on_the_same_camera():
    def difference(seed):
        pipeline = RenderPipeline(lit_scene({**FIXED, **TEMPORAL}, seed=seed, identity_seed=7))
        return (pipeline.render(0).image.astype(float) - pipeline.render(1).image.astype(float)).ravel()

    one, again, other = difference(1), difference(1), difference(2)
    assert np.corrcoef(one, again)[0, 1] == pytest.approx(1.0)  # the same scene and seed replay
    assert abs(np.corrcoef(one, other)[0, 1]) < 0.02


def test_without_an_identity_seed_the_scene_seed_is_the_camera():
    a = RenderPipeline(lit_scene(FIXED, seed=4, identity_seed=None)).render(0).image
    assert np.array_equal(a, RenderPipeline(lit_scene(FIXED, seed=1, identity_seed=4)).render(0).image)
