"""The mean electrons as parts (rollsim.sensor.means): the compiled chain reads them block by block, the same
bytes as the frame the stages wrote one by one."""

import numpy as np
import pytest

import rollsim.sensor.chain as chain
from rollsim.numerics import jit
from rollsim.render import RenderPipeline
from rollsim.render_contract.state import FrameState
from rollsim.scene import load_scene
from rollsim.sensor.adc import gray8_lut
from rollsim.sensor.chain import Adc, ChainKeys, run_chain
from rollsim.sensor.means import SeparableMeans, materialize
from rollsim.sensor.poisson import PoissonTables

SMALL = ["camera.width_px=320", "camera.height_px=240"]


def _on_frame(values: np.ndarray, rows: slice, cols: slice, shape) -> np.ndarray:
    """``values`` at their box of a frame of zeros."""
    frame = np.zeros(shape)
    frame[rows, cols] = values
    return frame


def stagewise(means: SeparableMeans) -> np.ndarray:
    """The frame written another way than materialize: every part laid on a whole frame first (zeros outside
    its box), then one operation per stage over the whole frame, in the stages' order."""
    coverage = _on_frame(means.coverage, means.rows, means.cols, means.shape)
    signal = _on_frame(means.row_signal[:, None], means.rows, slice(0, 1), (means.shape[0], 1))
    out = coverage * signal  # 0 outside the box, as the LED's signal stage leaves it
    if means.background is not None:
        out = out + np.broadcast_to(means.background, means.shape)
    if means.correction is not None:
        out = out + _on_frame(means.correction, means.face_rows, means.face_cols, means.shape)
    if means.gain is not None:
        out = out * means.gain
    if means.offset is not None:
        out = out + np.broadcast_to(means.offset, means.shape)
    return out


def random_means(rng, shape, light, face, background="level", after=None):
    (r0, r1), (c0, c1) = light
    means = SeparableMeans(shape, slice(r0, r1), slice(c0, c1), rng.random((r1 - r0, c1 - c0)) * 3.0,
                           rng.random(r1 - r0) * 40.0)
    if background:
        (f0, f1), (g0, g1) = face
        level = {"level": lambda: rng.random() * 7.0, "rows": lambda: rng.random((shape[0], 1)) * 7.0,
                 "map": lambda: rng.random(shape) * 7.0}[background]()
        means = means.with_ambient(level, slice(f0, f1), slice(g0, g1), rng.random((f1 - f0, g1 - g0)) * 2.0)
    if after in ("gain", "gain and offset map"):  # PRNU
        means = means.with_gain((1.0 + 0.05 * rng.standard_normal(shape)).astype(np.float32))
    if after == "offset level":  # a uniform dark current
        means = means.with_offset(0.37)
    if after == "gain and offset map":  # a dark-current map
        means = means.with_offset((rng.random(shape) * 3.0).astype(np.float32))
    return means


CASES = [
    ((60, 80), ((10, 50), (20, 70)), ((15, 45), (25, 60))),  # the face inside the light; blocks span rows
    ((60, 80), ((0, 60), (0, 80)), ((20, 30), (0, 80))),  # the light over the whole frame (glare)
    ((60, 80), ((0, 1), (79, 80)), ((0, 1), (79, 80))),  # one corner pixel
    ((60, 80), ((30, 30), (5, 5)), ((30, 30), (5, 5))),  # empty boxes
    ((1, 9), ((0, 1), (2, 7)), ((0, 1), (3, 4))),  # one row
    ((3, 2100), ((1, 3), (1000, 2050)), ((0, 2), (1990, 2100))),  # rows wider than a block
]
KEYS = ChainKeys(np.uint64(21), np.uint64(22))
CHAINS = [dict(shot="poisson", full_well_e=60.0, read_sigma_e=2.0, adc=Adc(3.0, 64, 10), lut=gray8_lut(64, 10)),
          dict(shot="gaussian", read_sigma_e=2.0, adc=Adc(3.0, 64, 10)), dict(shot=None, full_well_e=30.0)]


@pytest.mark.parametrize(("shape", "light", "face"), CASES)
@pytest.mark.parametrize("background", ["level", "rows", "map", None])
@pytest.mark.parametrize("after", [None, "gain", "offset level", "gain and offset map"])
def test_the_frame_written_from_the_parts_is_the_stages(shape, light, face, background, after):
    means = random_means(np.random.default_rng(len(light) + shape[0]), shape, light, face, background, after)
    frame = materialize(means)
    assert frame.dtype == np.float64 and frame.shape == shape
    assert frame.tobytes() == stagewise(means).tobytes()


@pytest.mark.parametrize(("shape", "light", "face"), CASES)
@pytest.mark.parametrize("background", ["level", "rows", "map", None])
@pytest.mark.parametrize("steps", CHAINS, ids=["poisson-gray8", "gaussian-raw", "electrons"])
@pytest.mark.parametrize("after", [None, "gain", "offset level", "gain and offset map"])
def test_the_chain_given_the_parts_renders_the_bytes_of_the_frame(shape, light, face, background, steps, after):
    means = random_means(np.random.default_rng(len(light) + shape[1]), shape, light, face, background, after)
    steps = dict(steps)
    shot = steps.pop("shot")
    from_frame = run_chain(materialize(means), shot, KEYS, **steps)
    from_parts = run_chain(means, shot, KEYS, **steps)
    assert from_parts.shape == shape and from_parts.dtype == from_frame.dtype
    assert from_parts.tobytes() == from_frame.tobytes()
    with jit.numpy_only():  # the twin writes the frame first
        assert run_chain(means, shot, KEYS, **steps).tobytes() == from_frame.tobytes()


def test_a_class_first_met_in_the_parts_writes_the_frame_once_and_keeps_the_bytes(monkeypatch):
    means = random_means(np.random.default_rng(3), (40, 3000), ((2, 38), (10, 2900)), ((5, 30), (20, 2000)))
    expected = run_chain(materialize(means), "poisson", KEYS, read_sigma_e=1.0)
    monkeypatch.setattr(chain, "TABLES", PoissonTables())  # every class met for the first time
    written = []
    monkeypatch.setattr(chain, "materialize", lambda parts: written.append(parts) or materialize(parts))
    assert run_chain(means, "poisson", KEYS, read_sigma_e=1.0).tobytes() == expected.tobytes()
    if jit.numba_module() is not None:
        assert len(written) == 1


def test_a_box_and_its_values_must_agree():
    means = SeparableMeans((10, 10), slice(0, 3), slice(0, 3), np.ones((3, 4)), np.ones(3))
    with pytest.raises(ValueError, match="3 x 3"):
        chain.kernel_parts(means)


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


@pytest.mark.parametrize(("name", "overrides", "stage_name"), [
    ("effect-flicker", [], "ambient"), ("effect-vignetting", ["effects.flicker={}"], "ambient"),
    ("paper-geometric", [], "ambient"), ("effect-row_noise", [], "prnu"), ("effect-row_noise", [], "dark_current"),
    ("effect-row_noise", ["effects.dark_current={}"], "dark_current")])
def test_a_stage_on_the_parts_is_the_frame_it_would_have_written(name, overrides, stage_name):
    """Flicker's level per row (with vignetting, a map), PRNU's gain map and the dark current (a map, or a level)
    join the parts; read as a frame, they are the bytes of the stage working on a frame already written."""
    pipeline = RenderPipeline(load_scene(name, SMALL + overrides))
    stages = pipeline.stages
    at = next(i for i, stage in enumerate(stages) if stage.name == stage_name)
    as_parts, as_frame = FrameState(pipeline.setup, 4), FrameState(pipeline.setup, 4)
    for state in (as_parts, as_frame):
        for stage in stages[:at]:
            stage(state)
    assert as_parts.means is not None
    assert as_frame.electrons.dtype == np.float64  # written before the stage: it works on the frame
    stages[at](as_parts)
    stages[at](as_frame)
    assert as_parts.means is not None and as_frame.means is None
    assert as_parts.electrons.tobytes() == as_frame.electrons.tobytes()


def test_a_gain_or_offset_joins_the_parts_once_and_in_order():
    means = random_means(np.random.default_rng(2), (20, 30), ((2, 9), (3, 12)), ((2, 9), (3, 12)))
    gain = np.ones((20, 30), dtype=np.float32)
    with pytest.raises(ValueError, match="float32 of shape"):
        means.with_gain(gain.astype(np.float64))
    with pytest.raises(ValueError, match="float32 of shape"):
        means.with_offset(np.ones((30, 20), dtype=np.float32))
    offset = means.with_offset(1.5)
    with pytest.raises(ValueError, match="already hold an offset"):
        offset.with_offset(1.0)
    with pytest.raises(ValueError, match="offset applied after"):
        offset.with_gain(gain)  # the gain comes before the offset, as PRNU before dark current
    with pytest.raises(ValueError, match="already hold a gain"):
        means.with_gain(gain).with_gain(gain)
