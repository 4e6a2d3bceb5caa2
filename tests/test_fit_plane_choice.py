"""A colour camera's fit: which colour plane it reads, and the levels matched before the shape."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from rollsim.bench.fit_camera import BASE_SCENE, HiddenCamera, hidden_scene
from rollsim.fit import fit_camera
from rollsim.fit.camera import LEVEL_MATCH, NoiseFit, Parameters, corrected
from rollsim.fit.channel import MIN_SAMPLED_CNR, plane_shortlist, stripe_contrast_to_noise
from rollsim.fit.refine import exposure_precision, measured_planes, plane_kept, shape_mismatch
from rollsim.render import render_frames
from rollsim.scene import load_scene


def _striped_colour_frames(weights, period_rows=20.0, n=3, shape=(200, 64), seed=0):
    """RGB frames whose channels carry one square wave, scaled by ``weights``, over noise of 2 levels."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        phase = rng.uniform(0, period_rows)
        wave = np.where(np.mod(np.arange(shape[0]) + phase, period_rows) < period_rows / 2, 1.0, 0.0)
        planes = [60.0 + w * 120.0 * wave[:, None] + rng.normal(0, 2.0, shape) for w in weights]
        out.append(np.clip(np.stack(planes, axis=2), 0, 255))
    return out


def test_the_shortlist_is_the_best_plane_and_the_green_one_unless_faint():
    # A red LED: the red plane has the most contrast, blue some (never a
    # candidate but as the best), green enough or too little.
    frames = _striped_colour_frames((1.0, 0.4, 0.3))
    shortlist = plane_shortlist(frames, 20.0)
    assert [name for name, _ in shortlist] == ["red", "green"]
    # Each plane is the frames' channel, as grey.
    assert np.array_equal(shortlist[1][1][0], frames[0][:, :, 1])
    # Green stripes of 0.24 levels over 0.25 of a row's noise: left out.
    faint = _striped_colour_frames((1.0, 0.002, 0.3))
    assert stripe_contrast_to_noise([f[:, :, 1] for f in faint], 20.0) < MIN_SAMPLED_CNR
    assert [name for name, _ in plane_shortlist(faint, 20.0)] == ["red"]
    # A green LED: the green plane alone.
    assert [name for name, _ in plane_shortlist(_striped_colour_frames((0.2, 1.0, 0.1)), 20.0)] == ["green"]


def _measured(exposure_rows, sd_rows):
    return SimpleNamespace(stripes=SimpleNamespace(exposure_rows=exposure_rows,
                                                   uncertainties={"exposure_rows": sd_rows}))


def test_the_plane_whose_stripes_tell_the_exposure_best_is_kept():
    fits = {"red": _measured(4.0, 0.4), "green": _measured(2.0, 0.05), "blue": _measured(3.0, 0.0)}

    def measure_plane(planes):
        if planes == "fails":
            raise ValueError("no pixel is above the background: no LED in the frames")
        return fits[planes]

    # Relative uncertainties: red 10 %, green 2.5 %; blue's singular fit (no
    # uncertainty) tells nothing and is never kept.
    assert exposure_precision(fits["blue"]) == math.inf
    assert exposure_precision(_measured(2.0, math.nan)) == math.inf
    name, planes, m = measured_planes([("red", "red"), ("green", "green"), ("blue", "blue")], measure_plane)[0]
    assert (name, planes, m) == ("green", "green", fits["green"])
    # A plane the fit cannot read is passed over; when none can be, the error is the fit's.
    assert [name for name, _, _ in measured_planes([("red", "fails"), ("blue", "blue")], measure_plane)] == ["blue"]
    with pytest.raises(ValueError, match="no LED"):
        measured_planes([("red", "fails")], measure_plane)
    # Every readable plane is measured, the most precise first (ties in the shortlist's order).
    both = measured_planes([("red", "red"), ("fails", "fails"), ("green", "green")], measure_plane)
    assert [(name, m) for name, _, m in both] == [("green", fits["green"]), ("red", fits["red"])]


def _shape(exposure_rows, smoothing_rows, period_rows=20.0):
    stripes = SimpleNamespace(exposure_rows=exposure_rows, smoothing_rows=smoothing_rows, on=0.8, off=0.05)
    return SimpleNamespace(stripes=stripes, stripes_period_rows=period_rows)


def test_the_shape_mismatch_is_the_exposure_and_smoothing_relative_to_the_exposure():
    # The same stripes: nothing. 1 row more exposure and 0.5 more smoothing at
    # an exposure of 4 rows: (1/4)^2 + (0.5/4)^2.
    assert shape_mismatch(_shape(4.0, 0.5), _shape(4.0, 0.5)) == 0.0
    assert shape_mismatch(_shape(4.0, 0.5), _shape(5.0, 1.0)) == pytest.approx(0.25**2 + 0.125**2)
    # Below a row of exposure the scale is a row (a short box is not told finer).
    assert shape_mismatch(_shape(0.5, 0.0), _shape(1.0, 0.0)) == pytest.approx(0.25)
    # A render read at the reflected exposure (P - E) is the same stripes.
    assert shape_mismatch(_shape(4.0, 0.5), _shape(16.0, 0.5)) == pytest.approx(0.0, abs=1e-12)


def test_a_saturated_red_led_is_fitted_on_its_green_plane():
    # A red LED at 4.6 full scales, 1.6 rows of exposure: its red plane clips,
    # and demosaicing shapes the clipped edges as no box and Gaussian do (the
    # stripe fit's residual is 20 levels there, 1 in green). The red plane
    # has the better contrast-to-noise, the green one tells the exposure.
    cam = HiddenCamera(index=0, width_px=480, height_px=360, row_time_us=8.69, exposure_chips=0.212,
                       clock_hz=15130.0, on_full_scales=4.59, led_diameter_px=150.0, led_x_px=240.0, led_y_px=180.0,
                       background_full_scales=0.0, binning_rows=1, jpeg_quality=None, colour=True, iso=1705.0,
                       read_noise_e=1.47, srgb=False, smoothing_rows=0.745, seed=925264621)
    hidden = hidden_scene(cam)
    images, _ = render_frames(hidden, 4)
    frames = [np.asarray(im) for im in images]
    assert plane_shortlist(frames, cam.period_rows)[0][0] == "red"
    fit = fit_camera(frames, cam.clock_hz, load_scene(BASE_SCENE, []), iterations=0)
    assert fit.channel == "green"
    assert fit.estimates["exposure_us"].value == pytest.approx(hidden.camera.exposure_us, rel=0.15)


def test_fits_whole_stripe_periods_apart_are_not_compared_by_their_shape():
    # Exposures of 30 and 43 rows in a period of 20 (0.65 periods apart): the
    # stripes' shape does not tell them apart, so the first (most precise)
    # plane's fit stands, without a render.
    def fit(channel, exposure_rows):
        camera = SimpleNamespace(exposure_s=exposure_rows * 10e-6, row_time_s=10e-6)
        return SimpleNamespace(channel=channel, scene=SimpleNamespace(camera=camera), period_rows=20.0)

    kept, why = plane_kept([fit("red", 30.0), fit("green", 43.0)], n_frames=6)
    assert kept == 0
    assert why.startswith("the fits' exposures lie 0.65 stripe periods apart")


def test_a_short_exposure_is_fitted_where_its_renders_hold_every_planes_stripes():
    # Seed 5 camera 8 of `rollsim bench fit-camera`: a red LED, 1.53 rows of
    # exposure in a period of 11 rows, smoothing 0.69 rows, in a 27-column
    # crop. Its red plane, sampled on every other row, reads 3.3 rows (more
    # precisely than green reads 1.6), and a render of 3 rows matches it in
    # red; in green it does not.
    cam = HiddenCamera(index=8, width_px=27, height_px=712, row_time_us=34.1598, exposure_chips=0.27647,
                       clock_hz=5303.01, on_full_scales=1.642, led_diameter_px=169.8, led_x_px=13.5,
                       led_y_px=343.6, background_full_scales=0.4432, binning_rows=1, jpeg_quality=93, colour=True,
                       iso=843.3, read_noise_e=1.99, srgb=False, smoothing_rows=0.6911, seed=1209115371)
    hidden = hidden_scene(cam)
    images, _ = render_frames(hidden, 6)
    frames = [np.asarray(im) for im in images]
    lines = []
    fit = fit_camera(frames, cam.clock_hz, load_scene(BASE_SCENE, []), progress=lines.append)
    assert any(line.startswith("exposure") and "(direct, red)" in line for line in lines)
    assert fit.channel == "green"
    assert any(note.startswith("Fitted in the green plane, of the fits in red and green: rendered and read in the "
                               "other plane") for note in fit.notes)
    assert fit.estimates["exposure_us"].value == pytest.approx(hidden.camera.exposure_us, rel=0.10)


def _stripes(exposure_rows, on):
    return SimpleNamespace(exposure_rows=exposure_rows, smoothing_rows=0.5, gamma=1.0, on=on, off=0.01)


def _statistics(exposure_rows, on):
    """What :func:`corrected` reads of a measurement: the stripes (a period of 20 rows), and no noise anchor."""
    return SimpleNamespace(stripes=_stripes(exposure_rows, on), stripes_period_rows=20.0, noise_levels=np.zeros(0),
                           noise_variances=np.zeros(0), background=None, background_noise=None,
                           row_noise=None, column_pattern=None)


@pytest.mark.parametrize("rendered_on, moves", [(0.3, True), (0.5 / LEVEL_MATCH * 1.01, True), (0.9, True),
                                                (0.5 / LEVEL_MATCH * 0.99, False), (0.014, False),
                                                (0.5 * LEVEL_MATCH * 1.01, False)])
def test_the_shape_moves_only_once_the_levels_match(rendered_on, moves):
    p = Parameters(exposure_rows=3.0, smoothing_rows=0.5, gamma=1.0, on_lin=0.5, off_lin=0.01, k_lin=1e-4,
                   read_lin=3e-4, row_lin=None, col_lin=None)
    noise = NoiseFit(1e-4, 3e-4, "frames", "frames", None)
    q = corrected(p, noise, _statistics(3.0, 0.5), _statistics(4.0, rendered_on))
    # The levels always move by the ratio of the frames' to the rendered.
    assert q.on_lin == pytest.approx(min(60.0, 0.5 * 0.5 / rendered_on))
    # The exposure moves by the difference (3 − 4 rows) only at matched levels.
    assert q.exposure_rows == pytest.approx(2.0 if moves else 3.0)


@pytest.mark.parametrize("plane, site", [("red", (0, 0)), ("green", (0, 1)), ("blue", (1, 1))])
def test_a_planes_response_is_the_renders_own_rate_in_that_channel(plane, site):
    # The fitted scene turns a plane's levels into light with these factors:
    # they must be what the render gives a pixel of that channel (RGGB).
    from rollsim.fit.fitted_scene import plane_response
    from rollsim.optics.scene_light import ambient_electron_rates, led_electron_rate
    from rollsim.render.stages import prepare_setup
    from rollsim.render_contract.setup import build_setup

    scene = load_scene(BASE_SCENE, ["camera.output=rgb8", "effects.bayer.pattern=RGGB", "environment.ambient_lux=300"])
    setup = prepare_setup(build_setup(scene))
    led_factor, ambient_factor = plane_response(scene, plane)
    assert led_factor * led_electron_rate(scene) == pytest.approx(float(setup.led_e_per_s[site]), rel=1e-9)
    assert ambient_factor * ambient_electron_rates(scene)[1] == pytest.approx(float(setup.face_e_per_s[site]),
                                                                              rel=1e-9)
    assert plane_response(scene, "grey") == (1.0, 1.0)
