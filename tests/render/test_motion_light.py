"""motion with glare and led_profile: the rest position's light, moved per row, against known answers."""

from __future__ import annotations

import numpy as np
import pytest

from rollsim.numerics.jit import numpy_only
from rollsim.optics.footprint import Footprint
from rollsim.optics.motion import moved_light
from rollsim.render import RenderPipeline, render_frames
from rollsim.scene import load_scene

SHAPE = (240, 320)


def _light(seed=0):
    rng = np.random.default_rng(seed)
    return Footprint(slice(60, 140), slice(90, 200), rng.random((80, 110)))


def _moments(dense):
    y, x = np.mgrid[0:dense.shape[0], 0:dense.shape[1]]
    total = dense.sum()
    mx, my = (dense * x).sum() / total, (dense * y).sum() / total
    return total, mx, my, (dense * (x - mx) ** 2).sum() / total, (dense * (y - my) ** 2).sum() / total


def test_a_whole_pixel_translation_moves_the_light_exactly():
    light = _light()
    moved = moved_light(light, np.tile([[7.0, -4.0]], (SHAPE[0], 1)), SHAPE)
    before, after = light.dense(SHAPE), moved.dense(SHAPE)
    assert np.array_equal(after[56:136, 97:207], before[60:140, 90:200])
    assert after.sum() == pytest.approx(before.sum(), rel=1e-12)


@pytest.mark.parametrize("dx, dy", [(3.37, -2.61), (-0.5, 0.25), (12.9, 8.01)])
def test_a_sub_pixel_translation_keeps_the_sum_and_moves_the_centroid_by_the_offset(dx, dy):
    """Bilinear sampling keeps the light's sum and first moments exactly; its interpolation error is a
    smoothing: each axis's variance grows by f(1 − f), f the offset's fraction of a pixel."""
    light = _light(1)
    moved = moved_light(light, np.tile([[dx, dy]], (SHAPE[0], 1)), SHAPE)
    s0, x0, y0, vx0, vy0 = _moments(light.dense(SHAPE))
    s1, x1, y1, vx1, vy1 = _moments(moved.dense(SHAPE))
    fx, fy = dx - np.floor(dx), dy - np.floor(dy)
    assert s1 == pytest.approx(s0, rel=1e-12)
    assert (x1 - x0, y1 - y0) == pytest.approx((dx, dy), abs=1e-9)
    assert (vx1 - vx0, vy1 - vy0) == pytest.approx((fx * (1 - fx), fy * (1 - fy)), abs=1e-9)


def test_each_row_sees_its_own_offset():
    """The rolling-shutter skew: a horizontal offset growing by 0.5 px a row shears the light, row by row."""
    light = _light(2)
    offsets = np.zeros((SHAPE[0], 2))
    offsets[:, 0] = 0.5 * np.arange(SHAPE[0]) - 40.0
    moved = moved_light(light, offsets, SHAPE).dense(SHAPE)
    before = light.dense(SHAPE)
    for y in (70, 101, 133):
        shift = offsets[y, 0]
        k, f = int(np.floor(shift)), shift - np.floor(shift)
        expected = (1 - f) * np.roll(before[y], k) + f * np.roll(before[y], k + 1)
        assert np.allclose(moved[y, 10:300], expected[10:300], atol=1e-12)


@pytest.mark.parametrize("dx, dy", [(0.0, -100.0), (0.0, 37.5), (-45.25, 0.0), (60.0, -20.5)])
def test_a_light_filling_the_frame_is_continued_past_every_edge_it_reaches(dx, dy):
    """A halo that fills the frame, moved by far more than a pixel: every frame pixel still has light.
    The rows and columns the shift brings in from past an edge repeat that edge's values; the rest is
    the plain shift."""
    rng = np.random.default_rng(4)
    halo = Footprint(slice(0, SHAPE[0]), slice(0, SHAPE[1]), 0.5 + rng.random(SHAPE))
    moved = moved_light(halo, np.tile([[dx, dy]], (SHAPE[0], 1)), SHAPE)
    assert (moved.rows, moved.cols) == (slice(0, SHAPE[0]), slice(0, SHAPE[1]))
    dense = moved.dense(SHAPE)
    assert dense.min() >= 0.5
    # Whole-pixel shifts: each output pixel is the rest pixel at its source, clipped to the frame.
    if dx == int(dx) and dy == int(dy):
        y, x = np.mgrid[0:SHAPE[0], 0:SHAPE[1]]
        source = halo.coverage[np.clip(y - int(dy), 0, SHAPE[0] - 1), np.clip(x - int(dx), 0, SHAPE[1] - 1)]
        assert np.array_equal(dense, source)


def test_compiled_and_numpy_give_the_same_bits():
    light = _light(3)
    offsets = np.stack([np.linspace(-3.3, 9.1, SHAPE[0]), np.linspace(2.2, -5.7, SHAPE[0])], axis=1)
    compiled = moved_light(light, offsets, SHAPE)
    with numpy_only():
        plain = moved_light(light, offsets, SHAPE)
    assert (compiled.rows, compiled.cols) == (plain.rows, plain.cols)
    assert np.array_equal(compiled.coverage, plain.coverage)


def _noise_free(scene_name, overrides):
    return load_scene(scene_name, [*overrides, "effects.shot_noise=false", "effects.read_noise=false",
                                   "camera.output=raw16", "camera.width_px=640", "camera.height_px=480"])


@pytest.mark.parametrize("light_effect", ["glare", "led_profile"])
def test_a_still_offset_renders_the_led_moved_with_its_light(light_effect):
    """A sinusoid of 1e-4 Hz at phase 90° holds the LED at its amplitude (to 1e-9 px) for the whole
    frame: the frame equals the still frame with the LED placed there (the halo or the face's profile
    moved with it, within one DN away from the frame's edges), and the truth's LED rows move by the
    vertical offset. A 3 mm LED, its disk inside the 640 x 480 frame: only its halo reaches the edges,
    where the rest light is continued from the edge's values (within 12 px of the edges it may differ)."""
    dx, dy = 7.0, 5.0
    base = ["led.shape=disk", "led.size_mm=3", f"effects.{light_effect}={{}}", "environment.ambient_lux=0"]
    moving = _noise_free("paper-geometric", [*base, "effects.motion.mode=sinusoid", "effects.motion.frequency_hz=0.0001",
                                             f"effects.motion.amplitude_x_px={dx}", f"effects.motion.amplitude_y_px={dy}",
                                             "effects.motion.phase_x_deg=90", "effects.motion.phase_y_deg=90"])
    still = RenderPipeline(_noise_free("paper-geometric", base)).setup
    cx, cy = still.led_centre_px
    placed = _noise_free("paper-geometric", [*base, f"led.position_px=[{cx + dx},{cy + dy}]"])
    (image, ), (truth, ) = render_frames(moving, 1)
    (expected, ), (placed_truth, ) = render_frames(placed, 1)
    inner = (slice(12, -12), slice(12, -12))
    difference = np.abs(image.astype(np.int64) - expected.astype(np.int64))[inner]
    assert difference.max() <= 1 and np.mean(difference > 0) < 0.01
    rest = RenderPipeline(moving).setup.led_rows
    # Rows that the shift brings in from past the frame's edge continue the edge row (moved_light).
    first = rest[0] if rest[0] == 0 else min(rest[0] + int(dy), 479)
    assert tuple(truth["led_rows"]) == (first, min(rest[1] + int(dy), 479))
    assert np.abs(np.subtract(truth["led_rows"], placed_truth["led_rows"])).max() <= 1
    # The truth records where the frame shows the LED's centre; a still scene's truth has no such key.
    assert truth["led_centre_px"] == pytest.approx([cx + dx, cy + dy], abs=1e-6)
    assert "led_centre_px" not in placed_truth


def test_motion_with_glare_and_a_profile_renders_the_paper_scene():
    """paper-default at 20 cm (its fitted glare) with a hand's walk and a Gaussian face: frames render,
    the LED rows move from frame to frame, and every value is finite."""
    scene = load_scene("paper-default", ["link.distance_cm=20", "effects.motion={}", "effects.motion.amplitude_y_px=20",
                                         "effects.motion.step_y_px=6", "effects.led_profile={}",
                                         "camera.width_px=640", "camera.height_px=480"])
    images, truth = render_frames(scene, 4)
    assert all(np.isfinite(im).all() for im in images)
    assert len({tuple(t["led_rows"]) for t in truth}) > 1
