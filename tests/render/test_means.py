"""The mean electrons as parts (rollsim.render.means): written in one pass, the bytes of the stages one by one."""

import numpy as np
import pytest

from rollsim import jit
from rollsim.render import RenderPipeline
from rollsim.render.means import SeparableMeans, _materialize_numpy, materialize
from rollsim.render.state import FrameState
from rollsim.scene import load_scene

SMALL = ["camera.width_px=320", "camera.height_px=240"]


def stagewise(means: SeparableMeans) -> np.ndarray:
    """The frame as the LED's signal and the ambient stages wrote it, one pass each."""
    out = np.zeros(means.shape)
    out[means.rows, means.cols] = means.coverage * means.row_signal[:, None]
    if means.background is not None:
        out += means.background
    if means.correction is not None:
        out[means.face_rows, means.face_cols] += means.correction
    return out


def random_means(rng, shape, light, face, background="level"):
    (r0, r1), (c0, c1) = light
    means = SeparableMeans(shape, slice(r0, r1), slice(c0, c1), rng.random((r1 - r0, c1 - c0)) * 3.0,
                           rng.random(r1 - r0) * 40.0)
    if background:
        (f0, f1), (g0, g1) = face
        level = rng.random() * 7.0 if background == "level" else rng.random(shape) * 7.0
        means = means.with_ambient(level, slice(f0, f1), slice(g0, g1), rng.standard_normal((f1 - f0, g1 - g0)))
    return means


CASES = [
    ((60, 80), ((10, 50), (20, 70)), ((15, 45), (25, 60))),  # the face inside the light
    ((60, 80), ((0, 60), (0, 80)), ((20, 30), (0, 80))),  # the light over the whole frame (glare)
    ((60, 80), ((0, 1), (79, 80)), ((0, 1), (79, 80))),  # one corner pixel
    ((60, 80), ((30, 30), (5, 5)), ((30, 30), (5, 5))),  # empty boxes
    ((1, 9), ((0, 1), (2, 7)), ((0, 1), (3, 4))),
]


@pytest.mark.parametrize(("shape", "light", "face"), CASES)
@pytest.mark.parametrize("background", ["level", "map", None])
def test_the_compiled_pass_writes_the_stages_bytes(shape, light, face, background):
    means = random_means(np.random.default_rng(len(light) + shape[0]), shape, light, face, background)
    expected = stagewise(means)
    assert _materialize_numpy(means).tobytes() == expected.tobytes()
    got = materialize(means)
    assert got.dtype == np.float64 and got.shape == shape and got.tobytes() == expected.tobytes()
    with jit.numpy_only():
        assert materialize(means).tobytes() == expected.tobytes()


def test_a_box_and_its_values_must_agree():
    means = SeparableMeans((10, 10), slice(0, 3), slice(0, 3), np.ones((3, 4)), np.ones(3))
    if jit.numba_module() is None:
        pytest.skip("numba is not used here")
    with pytest.raises(ValueError, match="3 x 3"):
        materialize(means)


def test_ambient_joins_the_parts_once_with_a_level_or_a_map_of_the_frame():
    means = random_means(np.random.default_rng(1), (20, 30), ((2, 9), (3, 12)), ((2, 9), (3, 12)))
    with pytest.raises(ValueError, match="already"):
        means.with_ambient(1.0, slice(0, 1), slice(0, 1), np.zeros((1, 1)))
    bare = random_means(np.random.default_rng(1), (20, 30), ((2, 9), (3, 12)), None, background=None)
    with pytest.raises(ValueError, match="shape"):
        bare.with_ambient(np.ones((30, 20)), slice(0, 1), slice(0, 1), np.zeros((1, 1)))


def test_reading_the_electrons_writes_the_frame_once_and_setting_them_drops_the_parts():
    pipeline = RenderPipeline(load_scene("paper-geometric", SMALL))
    state = FrameState(pipeline.setup, 2)
    for stage in pipeline.stages[:4]:  # frame start, the LED's exposure and signal, ambient light
        stage(state)
    assert state.means is not None and state.means.background is not None
    parts = state.means
    frame = state.electrons
    assert state.means is None and state.electrons is frame
    assert frame.tobytes() == stagewise(parts).tobytes()
    state.means = parts
    state.electrons = np.zeros(3)
    assert state.means is None and state.electrons.shape == (3,)


@pytest.mark.parametrize("name", ["paper-geometric", "paper-default", "effect-vignetting", "effect-flicker", "effect-motion",
                                  "stress-partly-out", "effect-bayer"])
def test_every_scene_renders_the_same_frames_with_the_parts_written_stage_by_stage(name, monkeypatch):
    """With the parts written as the stages once wrote them (a pass each), a render's frames are unchanged."""
    scene = load_scene(name, SMALL)
    frames = [RenderPipeline(scene).render(i).image for i in (0, 3)]
    monkeypatch.setattr(FrameState, "electrons", property(
        lambda self: _stagewise_electrons(self), FrameState.electrons.fset))
    assert all(np.array_equal(a, RenderPipeline(scene).render(i).image) for a, i in zip(frames, (0, 3)))


def _stagewise_electrons(state):
    if state.means is not None:
        state._electrons = stagewise(state.means)
        state.means = None
    return state._electrons
