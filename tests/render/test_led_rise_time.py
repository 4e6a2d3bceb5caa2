"""led_rise_time: a first-order LED against closed forms."""

import dataclasses

import numpy as np
import pytest

from rollsim.render import RenderPipeline
from rollsim.transmitter import Waveform
from rollsim.transmitter.led_response import exposure_exact, exposure_sampled, led_output

from conftest import SingleChip, make_scene

CLOCK_HZ = 8000.0
T_C = 1.0 / CLOCK_HZ


class _Step:
    """Chip source: OFF before chip 0, ON from chip 0 on."""

    def values(self, chip):
        return (np.asarray(chip) >= 0).astype(np.uint8)

    def ones_before(self, chip):
        return np.maximum(np.asarray(chip, dtype=np.int64), 0)


def _step_response_integral(t, tau):
    """∫_{-inf}^{t} y for a unit step at 0: t − τ(1 − e^{−t/τ}) for t ≥ 0."""
    t = np.asarray(t, dtype=float)
    u = np.maximum(t, 0.0)
    return np.where(t > 0, u + tau * np.expm1(-u / tau), 0.0)


def _pipeline_with_waveform(scene, chips):
    pipeline = RenderPipeline(scene)
    tx = dataclasses.replace(pipeline.setup.transmitter, waveform=Waveform(chips, CLOCK_HZ))
    return RenderPipeline.from_setup(dataclasses.replace(pipeline.setup, transmitter=tx))


@pytest.mark.parametrize("tau_us", [0.5, 5.0, 80.0, 2000.0])
def test_single_step_matches_the_closed_form(tau_us):
    tau = tau_us * 1e-6
    wave = Waveform(_Step(), CLOCK_HZ)
    t = np.linspace(-3e-4, 5e-3, 301)
    np.testing.assert_allclose(led_output(wave, t, tau), np.where(t >= 0, -np.expm1(-np.maximum(t, 0) / tau), 0.0),
                               rtol=1e-12, atol=1e-15)
    for t_exp in (1e-6, 1e-4, 3e-3):
        a = np.linspace(-2e-4, 4e-3, 97)
        expected = _step_response_integral(a + t_exp, tau) - _step_response_integral(a, tau)
        np.testing.assert_allclose(exposure_exact(wave, a, a + t_exp, tau), expected, rtol=1e-11, atol=1e-12 * t_exp)


@pytest.mark.parametrize("tau_us", [2.0, 30.0, 400.0])
@pytest.mark.parametrize("exposure_us", [40.0, 300.0])
def test_isolated_chip_through_the_pipeline(tau_us, exposure_us):
    """One ON chip [t_on, t_on + T_c]: y = 1 − e^{−u/τ} while ON, then decays;
    each row gets F(end) − F(start) with F the closed-form running integral."""
    tau, t_exp = tau_us * 1e-6, exposure_us * 1e-6
    scene = make_scene(effects={"led_rise_time": {"tau_us": tau_us}},
                       camera={"row_time_us": 10.0, "exposure_us": exposure_us, "height_px": 600, "width_px": 16},
                       led={"size_mm": 100.0})
    chip_on = 10
    state = _pipeline_with_waveform(scene, SingleChip(chip_on)).run_stages(0)
    t_on, t_off = chip_on * T_C, (chip_on + 1) * T_C

    def F(t):
        during = _step_response_integral(np.minimum(t, t_off) - t_on, tau)
        after = np.where(t > t_off, -tau * np.expm1(-T_C / tau) * -np.expm1(-np.maximum(t - t_off, 0) / tau), 0.0)
        return during + after

    starts = np.arange(600) * 10e-6
    np.testing.assert_allclose(state.led_exposure_s, F(starts + t_exp) - F(starts), rtol=1e-10, atol=1e-12 * t_exp)
    # Conservation: the LED emits exactly the chip's light, only later.
    assert float(F(np.array(1.0))) == pytest.approx(T_C, rel=1e-12)


@pytest.mark.parametrize("tau_us", [1.0, 60.0, 8000.0])
def test_light_is_conserved_over_whole_periods(tau_us):
    """Square wave in steady state: over any window of whole periods y(b) = y(a),
    so ∫ y = ∫ s = half the window, for any τ."""
    scene = make_scene(effects={"led_rise_time": {"tau_us": tau_us}},
                       camera={"row_time_us": 10.0, "exposure_us": 1e6 * 6 * T_C, "height_px": 300, "width_px": 16},
                       link={"pattern": "square", "clock_hz": CLOCK_HZ, "start_offset_us": 37.0})
    state = RenderPipeline(scene).run_stages(3)
    np.testing.assert_allclose(state.led_exposure_s, 3 * T_C, rtol=1e-11)


def test_slow_phosphor_washes_the_stripes_out():
    """A slow phosphor (τ = 8 ms, like the K2SiF6:Mn4+ red phosphor of some white
    LEDs) under a square wave swings between a/(1+a) and 1/(1+a), a = e^{−T_c/τ}:
    a stripe contrast of (1−a)/(1+a) = 0.78 % that no decoder can read."""
    tau = 8e-3
    a = np.exp(-T_C / tau)
    scene = make_scene(effects={"led_rise_time": {"tau_us": 8000.0}},
                       camera={"row_time_us": 5.0, "exposure_us": 1.0, "height_px": 400, "width_px": 16},
                       link={"pattern": "square", "clock_hz": CLOCK_HZ, "start_offset_us": 1.0})
    pipeline = RenderPipeline(scene)
    wave = pipeline.setup.transmitter.waveform
    edges = wave.start_s + 500 * T_C + np.arange(6) * T_C  # even chips are ON: ON starts at even edges
    np.testing.assert_allclose(led_output(wave, edges, tau), np.where(np.arange(6) % 2 == 0, a, 1.0) / (1 + a), rtol=1e-12)
    # Some rows' 1 us windows end on a chip edge, where y peaks.
    rows = pipeline.run_stages(2).led_exposure_s / 1e-6
    assert rows.min() >= a / (1 + a) - 1e-12 and rows.max() <= 1 / (1 + a) + 1e-12
    assert (rows.max() - rows.min()) / (rows.max() + rows.min()) == pytest.approx((1 - a) / (1 + a), rel=0.02)


def test_tau_to_zero_recovers_the_step_render():
    effects = {"ambient": {}}
    sections = dict(camera={"height_px": 300, "width_px": 64, "exposure_us": 100.0}, led={"size_mm": 40.0})
    step = RenderPipeline(make_scene(effects=effects, **sections))
    fast = RenderPipeline(make_scene(effects={**effects, "led_rise_time": {"tau_us": 1e-6}}, **sections))
    for k in range(2):
        a, b = step.run_stages(k), fast.run_stages(k)
        # The closed form differs from ∫ s by τ·(y(b) − y(a)), at most τ.
        np.testing.assert_allclose(b.led_exposure_s, a.led_exposure_s, rtol=0, atol=1.001e-12)
        assert np.array_equal(a.image, b.image)


def test_sampled_converges_to_exact():
    """Midpoint rule with K samples per window against the exact integral, on
    the data waveform: O(1/K) while t_exp/K > τ (y looks like steps), then
    O(1/K²)."""
    errors = {}
    for tau_us in (5.0, 60.0):
        sections = dict(camera={"height_px": 1080, "width_px": 16, "exposure_us": 100.0}, led={"size_mm": 100.0})
        exact = RenderPipeline(make_scene(effects={"led_rise_time": {"tau_us": tau_us}}, **sections)).run_stages(1)
        for K in (4, 16, 64, 256):
            scene = make_scene(effects={"led_rise_time": {"tau_us": tau_us, "method": "sampled", "samples": K}}, **sections)
            sampled = RenderPipeline(scene).run_stages(1)
            errors[tau_us, K] = np.abs(sampled.led_exposure_s - exact.led_exposure_s).max() / 100e-6
    # Largest error over the rows, relative to the exposure, at K = 4, 16, 64, 256:
    # τ = 5 us: 4.8e-2, 6.5e-3, 3.4e-4, 2.7e-5; τ = 60 us: 1.2e-2, 8.3e-4, 4.8e-5, 3.2e-6.
    for tau_us in (5.0, 60.0):
        seq = [errors[tau_us, K] for K in (4, 16, 64, 256)]
        assert all(later < earlier / 3 for earlier, later in zip(seq, seq[1:]))
    assert errors[5.0, 256] < 5e-5 and errors[60.0, 256] < 5e-6


def test_long_history_is_exact_and_finite():
    """τ far beyond a frame walks a long history in chunks (here 1.3 million
    chips); the light still matches the closed form of a chip long past."""
    wave = Waveform(SingleChip(-100), CLOCK_HZ)
    tau = 4.0
    t = np.array([0.0, 1e-3, 2e-3])
    t_off = -99 * T_C
    expected = -np.expm1(-T_C / tau) * np.exp(-(t - t_off) / tau)
    np.testing.assert_allclose(led_output(wave, t, tau), expected, rtol=1e-9)
    assert np.all(np.isfinite(exposure_sampled(wave, t, t + 1e-4, tau, 8)))


@pytest.mark.parametrize("tau_us", [1e-9, 1e6])
def test_extreme_time_constants_stay_finite_and_bounded(tau_us):
    for method in ("exact", "sampled"):
        scene = make_scene(effects={"led_rise_time": {"tau_us": tau_us, "method": method}}, led={"off_level": 0.2})
        rows = RenderPipeline(scene).run_stages(4).led_exposure_s / scene.camera.exposure_s
        assert np.all(np.isfinite(rows)) and rows.min() >= 0.2 - 1e-9 and rows.max() <= 1 + 1e-9


def test_rise_time_stage_is_named_and_absent_when_unlisted():
    assert "led_rise_time[exact]" in RenderPipeline(make_scene(effects={"led_rise_time": {}})).stage_names
    assert not any(n.startswith("led_rise_time") for n in RenderPipeline(make_scene()).stage_names)
