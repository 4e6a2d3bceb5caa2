"""motion: per-row LED footprint against closed forms and conservation."""

import math

import numpy as np
import pytest

from rollsim.optics.footprint import footprint
from rollsim.optics.motion import ReflectedWalkPath, SinusoidPath, fold, motion_footprint
from rollsim.render import RenderPipeline
from rollsim.optics.footprint import led_rows_from_coverage

from conftest import make_scene

CAMERA = {"height_px": 400, "width_px": 300, "row_time_us": 20.0, "exposure_us": 60.0}


class _LinearPath:
    """Constant velocity (vx, vy) in px/s from t = 0."""

    def __init__(self, vx, vy):
        self.v = np.array([vx, vy])

    def offset_px(self, t_s):
        return np.asarray(t_s)[:, None] * self.v


def _motion_scene(motion, effects=(), **sections):
    listed = {name: {} for name in effects}
    return make_scene(effects={**listed, "motion": motion}, camera={**CAMERA, **sections.pop("camera", {})},
                      led={"size_mm": 3.0, **sections.pop("led", {})}, **sections)


@pytest.mark.parametrize("motion", [
    {"mode": "random_walk", "amplitude_x_px": 0.0, "amplitude_y_px": 0.0, "step_x_px": 3.0},
    {"mode": "sinusoid", "amplitude_x_px": 0.0, "amplitude_y_px": 0.0},
])
@pytest.mark.parametrize("shape", ["disk", "square"])
def test_zero_amplitude_is_the_static_render_exactly(motion, shape):
    effects = ("ambient", "shot_noise", "read_noise")
    static = RenderPipeline(make_scene(effects=effects, camera=CAMERA, led={"size_mm": 3.0, "shape": shape}))
    moving = RenderPipeline(_motion_scene(motion, effects, led={"shape": shape}))
    for k in (0, 2):
        a, b = static.render(k), moving.render(k)
        # The moving scene's truth also records the LED's centre, here at rest.
        centre = b.truth.pop("led_centre_px")
        assert np.array_equal(a.image, b.image) and a.truth == b.truth
        assert centre == list(static.setup.led_centre_px)


@pytest.mark.parametrize("speed", [-0.4, -0.1, 0.1, 0.3])
@pytest.mark.parametrize("shape", ["disk", "square"])
def test_vertical_velocity_stretches_the_rows_by_one_over_one_minus_v_t_row(speed, shape):
    """Row y sees the centre at c + v·t_row·y; it is covered while
    |y(1 − v·t_row) + 1/2 − c| ≤ D/2, so the footprint spans D/(1 − v·t_row)
    rows and covers A/(1 − v·t_row) of area (speed = v·t_row, rows per row)."""
    t_row, size = 20e-6, 150.0
    v = speed / t_row
    row_times = np.arange(1000) * t_row
    centre = (500.0, 200.0 if speed > 0 else 800.0)
    fp = motion_footprint(_LinearPath(0.0, v), centre, size, shape, (1000, 1000), row_times)
    rows = np.flatnonzero(fp.row_coverage(1000) > 0)
    factor = 1.0 / (1.0 - speed)
    assert rows[-1] - rows[0] + 1 == pytest.approx(size * factor, abs=1.5)
    area = math.pi * size**2 / 4 if shape == "disk" else size**2
    assert fp.coverage.sum() == pytest.approx(area * factor, rel=2e-3)


@pytest.mark.parametrize("shape", ["disk", "square"])
@pytest.mark.parametrize("edge", ["exact", "supersample16"])
def test_horizontal_motion_shears_and_conserves_the_area(shape, edge):
    """A horizontal motion moves each row sideways: the frame's covered area
    is the static one (the same chords), to rounding for the exact edge."""
    row_times = np.arange(600) * 27.8e-6
    static = footprint((400.0, 300.0), 220.0, shape, (600, 800), edge).coverage.sum()
    for path in (_LinearPath(3000.0, 0.0), SinusoidPath((80.0, 0.0), 40.0, (0.3, 0.0))):
        fp = motion_footprint(path, (400.0, 300.0), 220.0, shape, (600, 800), row_times, edge)
        # Supersampling counts samples, which a sideways shift changes a little.
        rtol = 1e-12 if edge == "exact" else 5e-3
        assert fp.coverage.sum() == pytest.approx(static, rel=rtol)
        static_rows = footprint((400.0, 300.0), 220.0, shape, (600, 800), edge).row_coverage(600)
        np.testing.assert_allclose(fp.row_coverage(600), static_rows, rtol=rtol, atol=1e-9)


def test_truth_led_rows_follow_a_vertical_sinusoid():
    motion = {"mode": "sinusoid", "amplitude_x_px": 0.0, "amplitude_y_px": 30.0, "frequency_hz": 7.0}
    pipeline = RenderPipeline(_motion_scene(motion))
    static_first, static_last = RenderPipeline(make_scene(camera=CAMERA, led={"size_mm": 3.0})).setup.led_rows
    path = SinusoidPath((0.0, 30.0), 7.0, (0.0, math.pi / 2))
    shifts = []
    for k in range(4):
        frame = pipeline.render(k)
        first, last = frame.truth["led_rows"]
        state = pipeline.run_stages(k)
        assert (first, last) == led_rows_from_coverage(state.footprint.row_coverage(CAMERA["height_px"]))
        t = frame.truth["start_s"] + np.array([first, last]) * 20e-6 + 30e-6
        dy = path.offset_px(t)[:, 1]
        assert abs(first - (static_first + dy[0])) <= 1.5 and abs(last - (static_last + dy[1])) <= 1.5
        shifts.append(first - static_first)
    assert max(shifts) - min(shifts) > 10


@pytest.mark.parametrize("slope, intercept", [(0.0, 12.5), (0.02, -3.0), (-0.05, 40.0)])
def test_centre_seen_is_the_fixed_point_of_the_rows_offsets(slope, intercept):
    """Offsets growing linearly down the frame (dy = a·y + b, a vertical velocity of a rows per row):
    the row that shows the centre solves y = c_y + a·y + b, y = (c_y + b)/(1 − a), to half a row
    (over 1 − a); x is the rest x plus that row's dx."""
    from rollsim.optics.motion import centre_seen_px

    rows = np.arange(400.0)
    offsets = np.stack([0.1 * rows - 4.0, slope * rows + intercept], axis=1)
    x, y = centre_seen_px(offsets, (150.0, 180.0))
    exact = (180.0 + intercept) / (1.0 - slope)
    assert abs(y - exact) <= 0.5 * abs(slope) / (1.0 - slope) + 1e-9
    # The row is one of the two around the fixed point; x is that row's.
    assert any(x == pytest.approx(150.0 + 0.1 * r - 4.0) and y == pytest.approx(180.0 + slope * r + intercept)
               for r in (math.floor(exact), math.ceil(exact)))


def test_truth_led_centre_follows_the_path():
    """Each frame's recorded centre is the rest centre plus the sinusoid's offset at the time the
    row showing the centre sees it (mid-exposure of that row)."""
    motion = {"mode": "sinusoid", "amplitude_x_px": 12.0, "amplitude_y_px": 30.0, "frequency_hz": 7.0}
    pipeline = RenderPipeline(_motion_scene(motion))
    cx, cy = pipeline.setup.led_centre_px
    path = SinusoidPath((12.0, 30.0), 7.0, (0.0, math.pi / 2))
    for k in range(3):
        truth = pipeline.render(k).truth
        x, y = truth["led_centre_px"]
        row = round(y)
        t = truth["start_s"] + row * 20e-6 + 30e-6
        dx, dy = path.offset_px(np.array([t]))[0]
        assert (x, y) == pytest.approx((cx + dx, cy + dy), abs=1e-9)
        assert abs(row - (cy + dy)) <= 0.5 + 30.0 * 2 * math.pi * 7.0 * 20e-6


def test_ambient_hides_the_background_behind_the_moved_led():
    """Noise-free, LED OFF: pixels covered by this frame's footprint show the
    LED's face, the others the background, in proportion to the coverage."""
    motion = {"mode": "sinusoid", "amplitude_x_px": 40.0, "amplitude_y_px": 10.0, "frequency_hz": 12.0}
    scene = _motion_scene(motion, ("ambient",), link={"pattern": "off"}, environment={"ambient_lux": 5000.0})
    pipeline = RenderPipeline(scene)
    state = pipeline.run_stages(1)
    setup, t_exp = pipeline.setup, scene.camera.exposure_s
    coverage = state.footprint.dense(setup.shape)
    expected = (setup.background_e_per_s * (1 - coverage) + setup.face_e_per_s * coverage) * t_exp
    np.testing.assert_allclose(state.electrons, np.minimum(expected, scene.camera.full_well_e), rtol=1e-12)
    assert not np.array_equal(coverage, setup.footprint.dense(setup.shape))


def test_reflected_walk_stays_in_bounds_and_steps_as_specified():
    path = ReflectedWalkPath(3, (2.0, 0.5), (6.0, 50.0), 1 / 30)
    knots = path.knots_px(np.arange(1, 3001))
    assert np.diff(knots, axis=0).std(axis=0) == pytest.approx([2.0, 0.5], rel=0.05)
    offsets = path.offset_px(np.linspace(0.0, 100.0, 20001))
    assert np.all(np.abs(offsets) <= [6.0, 50.0])
    assert np.abs(offsets[:, 0]).max() > 5.5  # it does reach the bound
    # Continuous across the knots (frame starts), straight in between.
    knots = np.arange(1, 200) / 30
    jump = path.offset_px(knots + 1e-9) - path.offset_px(knots - 1e-9)
    assert np.abs(jump).max() < 1e-5
    x = np.linspace(-40.0, 40.0, 8001)
    folded = fold(x, 6.0)
    assert np.abs(folded).max() <= 6.0 and np.abs(np.diff(folded)).max() <= 0.01 + 1e-12
    np.testing.assert_array_equal(fold(x, 0.0), 0.0)


def test_walk_position_does_not_depend_on_render_order():
    a = ReflectedWalkPath(3, (2.0, 2.0), (6.0, 6.0), 1 / 30)
    b = ReflectedWalkPath(3, (2.0, 2.0), (6.0, 6.0), 1 / 30)
    t = np.array([5000.3, 0.1, 34.2, 2.0])
    first = np.concatenate([a.offset_px(t[i : i + 1]) for i in range(4)])
    second = np.concatenate([b.offset_px(t[i : i + 1]) for i in (3, 1, 0, 2)])[[2, 1, 3, 0]]
    np.testing.assert_array_equal(first, second)


def test_led_leaving_the_frame_gives_no_led_rows():
    motion = {"mode": "sinusoid", "amplitude_x_px": 2000.0, "amplitude_y_px": 0.0, "frequency_hz": 0.01,
              "phase_x_deg": 90.0}
    frame = RenderPipeline(_motion_scene(motion, ("ambient", "shot_noise"))).render(0)
    assert frame.truth["led_rows"] is None and not any(s["fully_visible"] for s in frame.truth["sdus"])
    assert np.isfinite(frame.image.astype(float)).all()


# ------------------------------------------------------------------ handheld


def _handheld(**kw):
    from rollsim.optics.motion import HandheldPath

    args = dict(seed=7, tremor_rms_px=2.0, drift_rms_px=10.0, roll_tremor_rms_rad=0.0, roll_drift_rms_rad=0.0)
    args.update(kw)
    return HandheldPath(**args)


def test_handheld_spectrum_is_the_models():
    """The model's spectrum is what the path's periodogram shows on average over seeds (the phases
    and frequencies are the random draws): over 24 seeds, 100 s sampled at 50 Hz, the power in
    8–12 Hz is the tremor's variance and the power below 1 Hz the drift's (0.1–1 Hz; a window of
    100 s leaks the slowest ones' power into the lowest bins), each within 5 %, and under 1 % of
    the power lies elsewhere."""
    from scipy.signal import periodogram

    fs, seconds = 50.0, 100.0
    t = np.arange(int(fs * seconds)) / fs
    tremor, drift, rest, total = [], [], [], []
    for seed in range(24):
        path = _handheld(seed=seed)
        for axis in (0, 1):
            x = path.axis(axis, t)
            f, power = periodogram(x, fs, window="boxcar", scaling="density", detrend=False)
            df = f[1] - f[0]
            tremor.append(power[(f >= 7.9) & (f <= 12.1)].sum() * df)
            drift.append(power[f <= 1.1].sum() * df)
            rest.append(power[((f > 1.2) & (f < 7.7)) | (f > 12.3)].sum() * df)
            total.append(power.sum() * df)
    assert np.mean(tremor) == pytest.approx(2.0**2, rel=0.05)
    assert np.mean(drift) == pytest.approx(10.0**2, rel=0.05)
    assert np.mean(rest) < 0.01 * np.mean(total)


def test_handheld_roll_turns_the_led_about_the_frame_centre():
    """Roll alone: the offset is θ(t)·(−r_y, r_x) for an LED at r from the centre."""
    path = _handheld(tremor_rms_px=0.0, drift_rms_px=0.0, roll_tremor_rms_rad=1e-3, roll_drift_rms_rad=5e-3,
                     lever_px=(300.0, -120.0))
    t = np.linspace(0.0, 2.0, 500)
    theta = path.axis(2, t)
    offset = path.offset_px(t)
    assert np.allclose(offset[:, 0], -theta * -120.0) and np.allclose(offset[:, 1], theta * 300.0)
    assert np.std(theta) > 1e-3


def test_handheld_path_is_its_seed_and_continuous():
    t = np.linspace(0.0, 1.0, 10001)
    a, b = _handheld().offset_px(t), _handheld().offset_px(t)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, _handheld(seed=8).offset_px(t))
    # 0.1 ms steps: a 12 Hz tremor of 2 px rms moves well under 0.1 px.
    assert np.abs(np.diff(a, axis=0)).max() < 0.1


@pytest.mark.parametrize("start_s", [0.0, 1.234, 3600.0 + 0.017, 1e4 + 0.3])
def test_handheld_on_a_grid_is_the_path_at_those_times(start_s):
    """A frame's rows at fixed times from its start: the tables of the grid's sines shared by every
    frame give the path's own values, to 1e-9 px up to 10⁴ s (where t + τ itself rounds at 1e-12 s)."""
    from rollsim.optics.motion import path_on_grid

    path = _handheld(roll_tremor_rms_rad=1e-3, roll_drift_rms_rad=5e-3, lever_px=(300.0, -120.0))
    tau = np.arange(1100) * 27.8e-6 + 50e-6
    assert np.abs(path_on_grid(path, tau).offset_px(start_s) - path.offset_px(start_s + tau)).max() < 1e-9
    walk = ReflectedWalkPath(3, (2.0, 2.0), (8.0, 8.0), 1 / 30)
    rows_s = np.arange(1100) * 27.8e-6
    # Other paths: the times summed as a frame's rows' always were, start + row + half the exposure.
    assert np.array_equal(path_on_grid(walk, rows_s, 50e-6).offset_px(start_s), walk.offset_px(start_s + rows_s + 50e-6))


def test_handheld_renders_paper_default_with_its_glare():
    """paper-default with a hand holding the phone (and its glare) renders; the LED's rows move."""
    from rollsim.render import render_frames
    from rollsim.scene import load_scene

    scene = load_scene("paper-default", ["link.distance_cm=20", "effects.motion.mode=handheld",
                                         "camera.width_px=640", "camera.height_px=480"])
    images, truth = render_frames(scene, 4)
    assert all(np.isfinite(im).all() for im in images)
    assert len({tuple(t["led_rows"]) for t in truth}) > 1
