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
        assert np.array_equal(a.image, b.image) and a.truth == b.truth


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
