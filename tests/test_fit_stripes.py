"""rollsim.fit.stripes: the stripe model is smooth in its parameters, and its fit finds them.

The fit differentiates the model by finite differences (steps of about
1e-8 of a parameter), so the model must move with such a step as it does
with a larger one: a kernel stored in float32 (steps of 6e-8) hid the
smoothing's derivative and left σ where it started.
"""

import numpy as np
import pytest

from rollsim.fit.stripes import StripeFit, _smoothed, fit_residuals, fit_stripes, right_way_up, \
    rows_the_model_holds, square_wave_box, stripe_profile, stripe_profiles
from rollsim.fit.tone import encode

PERIOD = 20.0


def _profile(rows, exposure, sigma, phase=3.0, on=0.8, off=0.1, gamma=1.0):
    return stripe_profile(rows, PERIOD, phase, exposure, sigma, gamma, on, off)


@pytest.mark.parametrize("sigma", [0.7, 1.5])
def test_the_profile_moves_with_a_tiny_step_of_the_smoothing(sigma):
    rows = np.arange(200.0)
    tiny, wide = 1e-8, 1e-4
    d_tiny = (_profile(rows, 6.0, sigma + tiny) - _profile(rows, 6.0, sigma)) / tiny
    d_wide = (_profile(rows, 6.0, sigma + wide) - _profile(rows, 6.0, sigma - wide)) / (2 * wide)
    assert np.max(np.abs(d_wide)) > 1.0  # σ matters here
    np.testing.assert_allclose(d_tiny, d_wide, atol=1e-3 * np.max(np.abs(d_wide)) + 1e-4)


@pytest.mark.parametrize("exposure, sigma", [(6.0, 1.5), (3.0, 1.0), (13.0, 1.2)])
def test_the_fit_recovers_the_exposure_and_the_smoothing_of_exact_profiles(exposure, sigma):
    rows = np.arange(40, 360).astype(np.float64)
    profiles = [_profile(rows, exposure, sigma, phase=p) for p in (1.3, 7.9, 12.4, 17.0)]
    fit = fit_stripes(profiles, rows, PERIOD)
    # Up to whole periods and the reflection E <-> P - E, which make the same stripes.
    assert min(abs(fit.exposure_rows - exposure), abs(fit.exposure_rows - (PERIOD - exposure))) < 0.02 * exposure
    assert fit.smoothing_rows == pytest.approx(sigma, abs=0.05)
    assert fit.rms_residual < 0.05


@pytest.mark.parametrize("off", [0.05, 0.17])
def test_the_fit_finds_an_led_far_above_the_clip(off):
    # ON at 14 full scales through sRGB's curve: the ramps between the OFF
    # rows and the clip span a fourteenth of the box, the clipped plateaus
    # the rest. Started at the clip alone, the fit settled on ON ~2.5 and an
    # exposure of 6.9 rows for 5 (the ramps made by the box instead of the
    # smoothing), 4-6 levels of residual on exact profiles.
    rows = np.arange(40, 360).astype(np.float64)
    profiles = [_profile(rows, 5.0, 1.2, phase=p, on=14.0, off=off, gamma=2.4) for p in (1.3, 7.9, 12.4, 17.0)]
    fit = fit_stripes(profiles, rows, PERIOD, gamma=2.4)
    assert fit.exposure_rows == pytest.approx(5.0, rel=0.03)
    assert fit.on > 6.0 and fit.rms_residual < 0.1


def _fit_with(exposure_rows, on, off, gamma=1.0):
    from rollsim.fit.stripes import StripeFit

    return StripeFit(exposure_rows, 0.0, gamma, on, off, (0.0,), (on,), (off,), (0.0,), 0.0, {})


@pytest.mark.parametrize("exposure_rows, on, off, gamma, expected", [
    (5.0, 0.8, 0.1, 1.0, 255 * 0.7),                  # a box within a chip: the full swing
    (15.0, 0.8, 0.1, 1.0, 255 * 0.7 * (2 / 3 - 1 / 3)),  # 1.5 chips: w from 1/3 to 2/3
    (20.0, 0.8, 0.1, 1.0, 0.0),                       # a whole period: no stripes
    (15.0, 6.0, 0.9, 1.0, 0.0),                       # OFF rows clipped too: none shown
    # ON clipped, OFF through the tone curve (γ 2.4: sRGB, 1.055·0.25^(1/2.4) − 0.055)
    (5.0, 3.0, 0.25, 2.4, 255 * (1.0 - (1.055 * 0.25 ** (1 / 2.4) - 0.055))),
])
def test_the_swing_is_what_the_frames_show_of_the_levels(exposure_rows, on, off, gamma, expected):
    """StripeFit.swing_dn against closed forms (period 20 rows: a chip is 10); the fit's
    sRGB is the standard's within 1e-5 of full scale."""
    assert _fit_with(exposure_rows, on, off, gamma).swing_dn(20.0) == pytest.approx(expected, abs=0.01)


def test_a_render_without_stripes_lies_far_from_frames_with_them():
    """rollsim.fit.refine.mismatch: a render whose OFF rows clip too is never the nearest, whatever its levels."""
    from types import SimpleNamespace

    from rollsim.fit.refine import mismatch

    def measured(fit):
        return SimpleNamespace(stripes=fit, stripes_period_rows=20.0, noise_levels=np.zeros(0),
                               noise_variances=np.zeros(0), background=None, background_noise=None)

    frames = measured(_fit_with(14.7, 1.32, 0.49, 2.2))
    shown = measured(_fit_with(14.2, 1.24, 0.58, 2.0))
    clipped = measured(_fit_with(18.4, 1.69, 0.52, 2.4))  # its box never falls below full scale
    assert clipped.stripes.swing_dn(20.0) == 0.0
    assert mismatch(frames, clipped, 2.2) == np.inf
    assert np.isfinite(mismatch(frames, shown, 2.2))


def test_a_wave_fitted_upside_down_is_turned_the_right_way_up():
    """ON below OFF is the same wave half a period on with the levels swapped:
    the profile is unchanged, and the fit says ON of the rows that are ON."""
    rows = np.arange(0.0, 160.0)
    knots = (0.0, 80.0, 159.0)
    upside_down = StripeFit(7.3, 0.9, 1.4, 0.2, 0.6, knots, (0.18, 0.2, 0.25), (0.55, 0.6, 0.62), (3.0, 17.5),
                            0.5, {})
    turned = right_way_up(upside_down, PERIOD)
    assert (turned.on, turned.off) == (0.6, 0.2) and turned.exposure_rows == upside_down.exposure_rows
    for before, after in zip(upside_down.phases_rows, turned.phases_rows):
        a = stripe_profile(rows, PERIOD, before, 7.3, 0.9, 1.4, upside_down.on_knots, upside_down.off_knots,
                           np.asarray(knots))
        b = stripe_profile(rows, PERIOD, after, 7.3, 0.9, 1.4, turned.on_knots, turned.off_knots, np.asarray(knots))
        assert np.max(np.abs(a - b)) < 1e-9
    assert right_way_up(turned, PERIOD) is turned


def test_only_the_ends_the_model_does_not_hold_are_trimmed():
    rng = np.random.default_rng(5)
    residuals = rng.normal(0.0, 1.0, size=(3, 400))
    # Nothing to trim: the whole band.
    assert rows_the_model_holds(residuals, 20.0) == slice(0, 400)
    # A rim at each end (rows 0-29 and 370-399) ten times the noise: cut a period at a time.
    rim = residuals.copy()
    rim[:, :30] *= 10.0
    rim[:, 370:] *= 10.0
    assert rows_the_model_holds(rim, 20.0) == slice(40, 360)
    # A misfit in the middle is not an end: kept.
    middle = residuals.copy()
    middle[:, 180:220] *= 10.0
    assert rows_the_model_holds(middle, 20.0) == slice(0, 400)
    # Trimming that would leave less than half the band: the whole band.
    most = residuals.copy()
    most[:, :240] *= 10.0
    assert rows_the_model_holds(most, 20.0) == slice(0, 400)


def test_the_residuals_of_an_exact_profile_are_nil():
    rows = np.arange(0.0, 200.0)
    fit = fit_stripes([_profile(rows, 6.0, 0.9, phase=p) for p in (2.0, 9.0)], rows, PERIOD)
    residuals = fit_residuals(fit, [_profile(rows, 6.0, 0.9, phase=p) for p in (2.0, 9.0)], rows, PERIOD)
    assert residuals.shape == (2, 200) and np.max(np.abs(residuals)) < 0.05


@pytest.mark.parametrize("smoothing_rows, gamma, binning", [(0.0, 1.0, (1, 0)), (1.3, 2.4, (1, 0)), (0.7, 2.2, (2, 1))])
def test_the_frames_profiles_at_once_are_each_frames_profile(smoothing_rows, gamma, binning):
    # The stripe fit evaluates every frame's profile in one call; each must be
    # the very value the one-frame model gives (the fit's results unchanged).
    rows = np.arange(40, 340)
    knots = np.linspace(40, 339, 5)
    on, off = np.array([1.4, 1.1, 0.9, 1.2, 0.6]), np.array([0.02, 0.05, 0.04, 0.01, 0.03])
    phases = [0.0, 3.7, 11.25, -2.5]
    together = stripe_profiles(rows, 12.3, phases, 4.1, smoothing_rows, gamma, on, off, knots, binning)
    assert together.shape == (len(phases), rows.size)
    k, offset = binning
    exposed = rows - np.mod(rows - offset, k) if k > 1 else rows.astype(np.float64)
    on_rows, off_rows = np.interp(rows, knots, on), np.interp(rows, knots, off)
    for phase, profile in zip(phases, together):
        # One frame's profile, step by step as the model states it.
        level = off_rows + (on_rows - off_rows) * square_wave_box(exposed, 12.3, phase, 4.1)
        alone = _smoothed(255.0 * encode(level, gamma), smoothing_rows)
        assert np.array_equal(profile, alone)
        assert np.array_equal(profile, stripe_profile(rows, 12.3, phase, 4.1, smoothing_rows, gamma, on, off, knots,
                                                      binning))
