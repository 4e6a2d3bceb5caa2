"""EMVA 1288: render the standard's data set and measure the camera back.

A flat field (the LED fills the frame with the ``on`` pattern) at eight
exposures with a dark frame pair at each, and 32-frame stacks at one
exposure, lit (about half saturation) and dark. The analysis (:mod:`rollsim.sensor.emva1288`)
must give back the configured K, read noise, dark current, DSNU and PRNU
within 3 %, and a linear response.
"""

import numpy as np
import pytest

from rollsim.render import RenderPipeline
from rollsim.sensor.emva1288 import characterise, pair_mean_and_variance, spatial_variance

from conftest import make_scene

CAMERA = {"height_px": 128, "width_px": 128, "iso": 400.0, "row_time_us": 20.0, "read_noise_e": 2.5,
          "dark_current_e_per_s": 2000.0, "dsnu_e": 3.0, "prnu_percent": 2.0}
EFFECTS = ("shot_noise", "read_noise", "dark_current", "prnu", "dsnu")
EXPOSURES_US = np.linspace(2000.0, 30000.0, 8)
STACK = 32


def frames(pattern, exposure_us, count, first=0):
    scene = make_scene(effects=EFFECTS, camera={**CAMERA, "exposure_us": float(exposure_us)},
                       led={"size_mm": 200.0, "shape": "square", "luminous_intensity_cd": 0.43},
                       link={"pattern": pattern})
    pipeline = RenderPipeline(scene)
    return [pipeline.render(first + k).image for k in range(count)]


@pytest.fixture(scope="module")
def measured():
    bright_pairs = [tuple(frames("on", t, 2)) for t in EXPOSURES_US]
    dark_pairs = [tuple(frames("off", t, 2)) for t in EXPOSURES_US]
    half = EXPOSURES_US[len(EXPOSURES_US) // 2]
    return characterise(EXPOSURES_US * 1e-6, bright_pairs, dark_pairs,
                        frames("on", half, STACK, first=100), frames("off", half, STACK, first=100))


def test_the_series_spans_the_linear_range():
    top = 2**10 - 1
    brightest = frames("on", EXPOSURES_US[-1], 1)[0]
    dimmest = frames("on", EXPOSURES_US[0], 1)[0]
    assert brightest.max() < top and np.mean(brightest) > 0.6 * top  # unsaturated, well lit
    assert np.mean(dimmest) > 64 + 20


def test_gain(measured):
    assert measured.gain_dn_per_e == pytest.approx(0.22 * 400 / 100, rel=0.03)


def test_read_noise(measured):
    assert measured.read_noise_e == pytest.approx(2.5, rel=0.03)


def test_dark_current(measured):
    assert measured.dark_current_e_per_s == pytest.approx(2000.0, rel=0.03)


def test_dsnu(measured):
    assert measured.dsnu_e == pytest.approx(3.0, rel=0.03)


def test_prnu(measured):
    assert measured.prnu_percent == pytest.approx(2.0, rel=0.03)


def test_linearity(measured):
    assert measured.linearity_error_percent < 0.5


def test_pair_statistics_cancel_fixed_patterns():
    rng = np.random.default_rng(2)
    pattern = rng.normal(0, 10, (200, 200))
    a, b = pattern + rng.normal(0, 2, pattern.shape), pattern + rng.normal(0, 2, pattern.shape)
    mean, variance = pair_mean_and_variance(a, b)
    assert variance == pytest.approx(4.0, rel=0.02) and abs(mean) < 0.1
    stack = [pattern + rng.normal(0, 2, pattern.shape) for _ in range(16)]
    assert spatial_variance(stack)[0] == pytest.approx(pattern.var(), rel=0.02)


@pytest.mark.parametrize("bad", [np.zeros((1, 1)), np.zeros((3, 3))])
def test_a_bad_pair_is_refused(bad):
    with pytest.raises(ValueError, match="a pair needs two frames"):
        pair_mean_and_variance(np.zeros((2, 2)), bad)
