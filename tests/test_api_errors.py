"""The Python API refuses a bad argument at its boundary: a TypeError or ValueError of rollsim's, one line naming it.

A table gives each public function and method bad arguments and checks the
error's kind, that its one line names the function and the argument, and
that the failed call left nothing behind (in the working directory or the
temporary directory). A property test then throws values of many types at
every argument and checks that the only outcomes are success or such an
error: never an AttributeError, KeyError, ... from inside.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rollsim as rs
from rollsim import api
from rollsim.errors import ApiArgumentError, RollsimError

SCENE = "paper-geometric"
# A short error line: the function, the argument, what was expected and a short quote of what was given.
MAX_LINE = 400


@pytest.fixture(scope="module")
def world():
    """Valid objects of every kind the API passes around, from one rendered frame."""
    scene = rs.load_scene(SCENE)
    frames = rs.render(scene, n_frames=1)
    decoded = rs.decode(frames)
    result = rs.evaluate(frames, decoded)
    return SimpleNamespace(scene=scene, frames=frames, decoded=decoded, result=result, fit=rs.calibrate(result),
                           image=np.zeros((16, 16), np.uint8))


@pytest.fixture
def clean(tmp_path, monkeypatch):
    """A fresh working directory and temporary directory; a function that asserts both are still empty."""
    work, temp = tmp_path / "work", tmp_path / "temp"
    work.mkdir()
    temp.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.setattr(tempfile, "tempdir", str(temp))

    def check():
        assert os.listdir(work) == []
        assert [n for n in os.listdir(tempfile.gettempdir()) if n.startswith("rollsim")] == []
        assert os.listdir(temp) == []

    return check


def _record(**changes):
    record = {"frame": 0, "start_s": 0.0, "row_time_s": 1e-5, "exposure_s": 1e-4, "led_rows": None, "sdus": []}
    return {**record, **changes}


T, V = TypeError, ValueError
# (function as the message names it, argument, call, kind)
CASES = [
    ("load_scene", "scene", lambda w: rs.load_scene(None), T),
    ("load_scene", "scene", lambda w: rs.load_scene(5), T),
    ("load_scene", "scene", lambda w: rs.load_scene(""), V),
    ("load_scene", "scene", lambda w: rs.load_scene("a\0b"), V),
    ("load_scene", "scene", lambda w: rs.load_scene("x" * 5000), V),
    ("load_scene", "overrides", lambda w: rs.load_scene(SCENE, overrides=["link.distance_cm=5"]), T),
    ("load_scene", "overrides key", lambda w: rs.load_scene(SCENE, overrides={1: 2}), T),
    ("load_scene", "overrides key", lambda w: rs.load_scene(SCENE, overrides={"a=b": 2}), V),
    ("load_scene", "overrides['link.distance_cm']", lambda w: rs.load_scene(SCENE, overrides={"link.distance_cm": float("nan")}), V),
    ("load_scene", "overrides['link.distance_cm']", lambda w: rs.load_scene(SCENE, overrides={"link.distance_cm": object()}), T),
    ("load_scene", "seed", lambda w: rs.load_scene(SCENE, seed=True), T),
    ("load_scene", "seed", lambda w: rs.load_scene(SCENE, seed=1.0), T),
    ("load_scene", "seed", lambda w: rs.load_scene(SCENE, seed=-1), V),
    ("load_scene", "seed", lambda w: rs.load_scene(SCENE, seed=2**63), V),
    ("render", "scene", lambda w: rs.render(None), T),
    ("render", "scene", lambda w: rs.render([SCENE]), T),
    ("render", "n_frames", lambda w: rs.render(w.scene, n_frames="10"), T),
    ("render", "n_frames", lambda w: rs.render(w.scene, n_frames=True), T),
    ("render", "n_frames", lambda w: rs.render(w.scene, n_frames=2.0), T),
    ("render", "n_frames", lambda w: rs.render(w.scene, n_frames=float("inf")), T),
    ("render", "n_frames", lambda w: rs.render(w.scene, n_frames=-1), V),
    ("render", "n_frames", lambda w: rs.render(w.scene, n_frames=10**30), V),
    ("render", "start", lambda w: rs.render(w.scene, n_frames=1, start=None), T),
    ("render", "start", lambda w: rs.render(w.scene, n_frames=1, start=-2), V),
    ("render", "seed", lambda w: rs.render(w.scene, n_frames=1, seed="1"), T),
    ("Frames", "scene", lambda w: rs.Frames(SCENE, 1), T),
    ("Frames", "n_frames", lambda w: rs.Frames(w.scene, None), T),
    ("Frames", "start", lambda w: rs.Frames(w.scene, 1, -1), V),
    ("Truth", "frames", lambda w: rs.Truth(None, w.scene), T),
    ("Truth", "frames[0]", lambda w: rs.Truth([{}], w.scene), T),
    ("Truth", "scene", lambda w: rs.Truth([], None), T),
    ("FrameTruth.from_record", "record", lambda w: rs.FrameTruth.from_record(None), T),
    ("FrameTruth.from_record", "record", lambda w: rs.FrameTruth.from_record({}), V),
    ("FrameTruth.from_record", "record", lambda w: rs.FrameTruth.from_record(_record(start_s="x")), V),
    ("FrameTruth.from_record", "record", lambda w: rs.FrameTruth.from_record(_record(sdus=[{"tx": 1}])), V),
    ("FrameTruth.from_record", "record", lambda w: rs.FrameTruth.from_record(_record(sdus=None)), V),
    ("show", "frame", lambda w: rs.show(None), T),
    ("show", "frame", lambda w: rs.show(np.zeros(4, np.uint8)), V),
    ("show", "frame", lambda w: rs.show(np.zeros((4, 4, 4), np.uint8)), V),
    ("show", "truth", lambda w: rs.show(np.zeros((4, 4), np.uint8), truth=5), T),
    ("show", "truth", lambda w: rs.show(np.zeros((4, 4), np.uint8), truth={"frame": 0}), V),
    ("show", "decoded", lambda w: rs.show(np.zeros((4, 4), np.uint8), decoded=5), T),
    ("show", "decoded[0]", lambda w: rs.show(np.zeros((4, 4), np.uint8), decoded=[{"frame": 0}]), V),
    ("AnnotatedFrame.save", "path", lambda w: rs.show(np.zeros((4, 4), np.uint8)).save(None), T),
    ("decode", "frames", lambda w: rs.decode(None), T),
    ("decode", "frames", lambda w: rs.decode("frames"), T),
    ("decode", "frames", lambda w: rs.decode({"a": 1}, scene=SCENE), T),
    ("decode", "frames[0]", lambda w: rs.decode([None], scene=SCENE), T),
    ("decode", "frames[0]", lambda w: rs.decode([["a", "b"]], scene=SCENE), T),
    ("decode", "frames[0]", lambda w: rs.decode([np.zeros(5)], scene=SCENE), V),
    ("decode", "frames[0]", lambda w: rs.decode([[[1, 2], [3]]], scene=SCENE), V),
    ("decode", "frames[1]", lambda w: rs.decode([w.image, np.full((16, 16), np.nan)], scene=SCENE), V),
    ("decode", "scene", lambda w: rs.decode([w.image]), V),
    ("decode", "scene", lambda w: rs.decode([w.image], scene=3), T),
    ("decode", "decoder", lambda w: rs.decode([w.image], scene=SCENE, decoder="mine"), T),
    ("decode", "decoder", lambda w: rs.decode([w.image], scene=SCENE, decoder=lambda image, settings: None), T),
    ("decode", "decoder", lambda w: rs.decode([w.image], scene=SCENE, decoder=lambda image, settings: [5]), V),
    ("decode", "decoder", lambda w: rs.decode([w.image], scene=SCENE, decoder=lambda image, settings: [{"x": 1}]), V),
    ("evaluate", "truth", lambda w: rs.evaluate(None, None), T),
    ("evaluate", "truth", lambda w: rs.evaluate(w.decoded, w.decoded), T),
    ("evaluate", "decoded", lambda w: rs.evaluate(w.frames, None), T),
    ("evaluate", "decoded", lambda w: rs.evaluate(w.frames, "decoded.jsonl"), T),
    ("evaluate", "decoded[0]", lambda w: rs.evaluate(w.frames, [1]), T),
    ("evaluate", "decoded[0]", lambda w: rs.evaluate(w.frames, [{}]), V),
    ("evaluate", "decoded[0]", lambda w: rs.evaluate(w.frames, [{**w.decoded[0], "first_row": "x"}]), V),
    ("Result", "evaluation", lambda w: rs.Result(None, w.result.truth), T),
    ("calibrate", "result", lambda w: rs.calibrate(None), T),
    ("calibrate", "result", lambda w: rs.calibrate(w.frames), T),
    ("calibrate", "n_packets", lambda w: rs.calibrate(w.result, n_packets=0), V),
    ("calibrate", "n_packets", lambda w: rs.calibrate(w.result, n_packets="22"), T),
    ("calibrate", "seed", lambda w: rs.calibrate(w.result, seed=None), T),
    ("MmbpModel", "n_packets", lambda w: rs.MmbpModel(w.fit.mmbp.fit, 0), V),
    ("MmbpModel", "fit", lambda w: rs.MmbpModel(None, 1), T),
    ("MmbpModel.p_message", "r", lambda w: w.fit.mmbp.p_message(0), V),
    ("MmbpModel.p_message", "r", lambda w: w.fit.mmbp.p_message(True), T),
    ("MmbpModel.p_message", "r", lambda w: w.fit.mmbp.p_message(float("nan")), T),
    ("MmbpModel.p_message", "strategy", lambda w: w.fit.mmbp.p_message(1, "xx"), V),
    ("MmbpModel.p_message", "strategy", lambda w: w.fit.mmbp.p_message(1, None), T),
    ("MmbpModel.p_message", "n_packets", lambda w: w.fit.mmbp.p_message(1, "rp", -3), V),
    ("simulate", "scene", lambda w: rs.simulate(None), T),
    ("simulate", "channel", lambda w: rs.simulate(w.scene, channel="fast"), V),
    ("simulate", "channel", lambda w: rs.simulate(w.scene, channel=1), T),
    ("simulate", "runs", lambda w: rs.simulate(w.scene, runs=0), V),
    ("simulate", "runs", lambda w: rs.simulate(w.scene, runs=np.float64(10)), T),
    ("simulate", "seed", lambda w: rs.simulate(w.scene, runs=2, seed=-5), V),
    ("simulate", "workers", lambda w: rs.simulate(w.scene, runs=2, workers=0), V),
    ("sweep", "scene", lambda w: rs.sweep(None), T),
    ("sweep", "grid", lambda w: rs.sweep(SCENE, grid=[("link.distance_cm", [5])]), T),
    ("sweep", "grid['link.distance_cm']", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": 5}), T),
    ("sweep", "stage", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, stage="fast"), V),
    ("sweep", "overrides[0]", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, overrides=[1]), T),
    ("sweep", "runs", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, runs=0), V),
    ("sweep", "connect_timeout_s", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, connect_timeout_s=7200),
     V),
    ("sweep", "keep_frames", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, keep_frames="yes"), T),
    ("sweep", "channel", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, channel="fast"), V),
    ("sweep", "bogus", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, bogus=1), T),
    ("sweep", "out", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, out=""), V),
    ("sweep", "workers", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, workers=1025), V),
    ("sweep", "connect_timeout_s", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, connect_timeout_s=float("nan")), V),
    ("sweep", "connect_timeout_s", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, connect_timeout_s=10**400), V),
    ("sweep", "connect_timeout_s", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, connect_timeout_s=True), T),
    ("sweep", "resume", lambda w: rs.sweep(SCENE, grid={"link.distance_cm": [5]}, resume=None), T),
]


def _id(case) -> str:
    return f"{case[0]}-{case[1]}"


def _assert_one_line(error: BaseException) -> str:
    message = str(error)
    assert message and "\n" not in message and len(message) <= MAX_LINE, message
    return message


@pytest.mark.parametrize("where, name, call, kind", CASES, ids=[f"{_id(c)}-{n}" for n, c in enumerate(CASES)])
def test_a_bad_argument_is_refused_by_name(world, clean, where, name, call, kind):
    with pytest.raises(kind) as caught:
        call(world)
    assert isinstance(caught.value, ApiArgumentError)
    assert _assert_one_line(caught.value).startswith(f"rollsim.{where}: {name}: ")
    clean()


def test_every_public_function_and_method_has_a_case():
    functions = {name for name in api.__all__ if name[0].islower()}
    methods = {"Frames", "Truth", "Result", "MmbpModel", "MmbpModel.p_message", "FrameTruth.from_record",
               "AnnotatedFrame.save"}
    assert {case[0] for case in CASES} == functions | methods


def test_a_failed_sweep_leaves_no_temporary_directory(clean):
    # The cells are checked after the default output directory is made:
    # an unknown key fails there, and the directory goes with the call.
    with pytest.raises(RollsimError, match="unknown key"):
        rs.sweep(SCENE, grid={"link.nothing": [5]}, workers=1)
    clean()


def test_numpy_integers_are_integers(world):
    frames = rs.render(world.scene, n_frames=np.int64(2), start=np.uint8(1), seed=np.int32(4))
    assert (frames.n_frames, frames.start, frames.scene.seed) == (2, 1, 4)
    assert type(frames.n_frames) is int
    assert 0.0 <= world.fit.mmbp.p_message(np.int16(2), "rs", np.int64(3)) <= 1.0
    scene = rs.load_scene(SCENE, overrides={"link.distance_cm": np.float32(7), "seed": np.int64(3)})
    assert (scene.link.distance_cm, scene.seed) == (7.0, 3)


def test_a_path_names_a_scene_file(tmp_path):
    from rollsim.scene import scene_to_dict

    import yaml

    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump(scene_to_dict(rs.load_scene(SCENE))))
    assert rs.load_scene(path).camera == rs.load_scene(str(path)).camera
    with pytest.raises(RollsimError, match="none.yaml: does not exist"):
        rs.load_scene(tmp_path / "none.yaml")


# ------------------------------------------------------------- property test

# Values of many types: the few integers that are valid and cheap (a
# valid huge count would run for hours, which is the user's right),
# integers out of every range, floats with NaN and inf, strings with
# garbage and paths that do not exist, containers and numpy values.
VALUES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-3, 3),
    st.sampled_from([2**53 + 1, 2**63, 10**30, -(10**30)]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=20),
    st.sampled_from(["", "\0", ".", "/", "/no/such/scene.yaml", "x" * 300, "rp", "mmbp", "analytic", "=", "seed"]),
    st.builds(Path, st.sampled_from(["/no/such/dir", ".", "scene.yaml"])),
    st.lists(st.one_of(st.integers(-3, 3), st.text(max_size=3)), max_size=3),
    st.dictionaries(st.text(max_size=12), st.one_of(st.integers(-3, 3), st.floats()), max_size=2),
    st.sampled_from([np.int64(2), np.uint8(1), np.float64("nan"), np.bool_(True), np.zeros(3),
                     np.zeros((2, 2)), np.zeros((16, 16), np.uint8), np.array(["a"])]),
)


def _either(valid):
    """A valid value or any of :data:`VALUES`."""
    return st.one_of(st.just(valid), VALUES)


# Each function with a strategy per argument. The valid values are small:
# one frame's truth, a 16x16 image, two simulated runs.
CALLS = {
    "load_scene": lambda w: dict(scene=_either(SCENE), overrides=_either({"link.distance_cm": 7}), seed=_either(2)),
    "render": lambda w: dict(scene=_either(w.scene), n_frames=_either(1), seed=_either(None), start=_either(0)),
    "decode": lambda w: dict(frames=_either([w.image]), scene=_either(SCENE), decoder=_either(None)),
    "evaluate": lambda w: dict(truth=_either(w.frames.truth), decoded=_either(w.decoded)),
    "calibrate": lambda w: dict(result=VALUES, n_packets=_either(None), seed=_either(1)),
    "simulate": lambda w: dict(scene=_either(w.scene), channel=_either("mmbp"), runs=_either(2), seed=_either(1),
                               workers=_either(1)),
    # Never a bundled name: a sweep that starts runs a Dask cluster.
    "sweep": lambda w: dict(scene=VALUES.filter(lambda v: not (isinstance(v, str) and v.isalpha())),
                            grid=_either({"link.distance_cm": [5]}), stage=_either("analytic"),
                            runs=_either(2), seed=_either(1), connect_timeout_s=_either(None)),
    "Frames": lambda w: dict(scene=_either(w.scene), n_frames=_either(1), start=_either(0)),
    "Truth": lambda w: dict(frames=_either(list(w.frames.truth)), scene=_either(w.scene)),
    "FrameTruth.from_record": lambda w: dict(record=_either(w.frames.truth[0].to_record())),
    "MmbpModel.p_message": lambda w: dict(r=_either(2), strategy=_either("rp"), n_packets=_either(None)),
}
TARGETS = {"Frames": lambda w: rs.Frames, "Truth": lambda w: rs.Truth,
           "FrameTruth.from_record": lambda w: rs.FrameTruth.from_record,
           "MmbpModel.p_message": lambda w: w.fit.mmbp.p_message}


def _call_survives(world, name: str, kwargs: dict) -> None:
    """Call ``name`` with ``kwargs``: it succeeds, or raises one of rollsim's errors or a TypeError or ValueError in one line."""
    target = TARGETS[name](world) if name in TARGETS else getattr(rs, name)
    try:
        target(**kwargs)
    except (RollsimError, TypeError, ValueError) as error:
        message = _assert_one_line(error)
        # Not a message from inside ("'NoneType' object is not iterable"): ours name the function.
        assert isinstance(error, RollsimError) or message.startswith("rollsim."), repr(error)


def _survives(world, name: str, max_examples: int) -> None:
    @settings(max_examples=max_examples, deadline=None, database=None,
              suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
    @given(st.fixed_dictionaries(CALLS[name](world)))
    def run(kwargs):
        _call_survives(world, name, kwargs)

    run()


@pytest.mark.parametrize("name", sorted(CALLS))
def test_any_argument_gives_success_or_a_one_line_error(world, clean, name):
    _survives(world, name, 50)
    clean()


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CALLS))
def test_any_argument_gives_success_or_a_one_line_error_at_length(world, clean, name):
    _survives(world, name, 1000)
    clean()
