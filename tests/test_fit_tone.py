"""The fit's tone-curve family (linear at γ = 1, sRGB at 2.4) and the noise that tells the two apart."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rollsim.fit.noise import tone_from_noise
from rollsim.fit.tone import SRGB_GAMMA, decode, decode_slope, encode, offset, scene_tone_curve, toe
from rollsim.sensor.tone import ToneCurve, srgb_encode

X = np.linspace(0.0, 1.0, 20001)


def test_the_family_is_linear_at_one_and_srgb_at_2_4():
    np.testing.assert_array_equal(encode(X, 1.0), X)
    # The tangent toe against IEC 61966-2-1's: within 1e-5 of full scale.
    np.testing.assert_allclose(encode(X, SRGB_GAMMA), srgb_encode(X), atol=1e-5)
    assert offset(SRGB_GAMMA) == pytest.approx(0.055)
    x0, slope = toe(SRGB_GAMMA)
    assert slope == pytest.approx(12.92, abs=0.01) and x0 == pytest.approx(0.00304, abs=1e-5)


@pytest.mark.parametrize("gamma", [1.6, 2.4, 3.3, 5.0])
def test_the_toe_meets_the_power_curve_in_value_and_slope(gamma):
    a, (x0, s) = offset(gamma), toe(gamma)
    assert s * x0 == pytest.approx((1 + a) * x0 ** (1 / gamma) - a, rel=1e-12)
    assert s == pytest.approx((1 + a) / gamma * x0 ** (1 / gamma - 1), rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.floats(0.8, 5.0))
def test_decode_inverts_encode_and_its_slope_is_the_derivative(gamma):
    v = encode(X, gamma)
    assert np.all(np.diff(v) >= 0) and v[0] == 0.0 and v[-1] == pytest.approx(1.0)
    np.testing.assert_allclose(decode(v, gamma), X, atol=1e-12)
    mid = np.linspace(0.05, 0.95, 50)
    h = 1e-6
    numeric = (decode(mid + h, gamma) - decode(mid - h, gamma)) / (2 * h)
    np.testing.assert_allclose(decode_slope(mid, gamma), numeric, rtol=1e-5)


@pytest.mark.parametrize("gamma", [1.0, SRGB_GAMMA, 1.8, 3.0])
def test_the_fitted_scene_renders_the_family_s_curve(gamma):
    params = scene_tone_curve(gamma)
    if gamma == 1.0:
        assert params is None
        return
    curve = ToneCurve(kind=params["curve"], gamma=2.2,
                      table=tuple(tuple(p) for p in params.get("table", ())))
    # The table interpolates linearly between points dense near black.
    np.testing.assert_allclose(curve(X), encode(X, gamma), atol=2e-3)


def _noise_points(gamma, read_var=4e-6, gain=2e-4, n=400, seed=0):
    """Noise points (8-bit level, temporal variance) of a camera whose linear variance is
    read_var + gain·u, seen through the family's curve at ``gamma``, each variance measured
    from 60 pixels (its own chi-square spread)."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(0.03, 0.9, n)
    var_lin = read_var + gain * u
    v = encode(u, gamma)
    var_out = var_lin * (255.0 / decode_slope(v, gamma)) ** 2  # in 8-bit levels: dv/du = 1 / decode's slope
    measured = var_out * rng.chisquare(59, n) / 59
    return 255.0 * v, measured


@pytest.mark.parametrize("gamma", [1.0, SRGB_GAMMA])
def test_the_noise_tells_linear_frames_from_srgb_ones(gamma):
    levels, variances = _noise_points(gamma)
    assert tone_from_noise(levels, variances) == gamma


def test_the_noise_does_not_tell_from_a_few_points_or_one_level():
    levels, variances = _noise_points(SRGB_GAMMA, n=5)
    assert tone_from_noise(levels, variances) is None
    flat = np.full(50, 120.0)
    assert tone_from_noise(flat, np.random.default_rng(1).uniform(3, 4, 50)) is None
