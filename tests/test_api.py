"""The Python API (rollsim.api): its examples run, and it gives what the command line gives."""

import doctest
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

import rollsim
import rollsim as rs
from rollsim import api
from rollsim.cli import main
from rollsim.errors import SceneError
from rollsim.stages.evaluate import outcomes_csv

SCENE, FRAMES, SEED = "paper-default", 6, 3


def test_every_public_name_is_listed_and_documented():
    for name in api.__all__:
        assert name in rollsim.__all__
        assert getattr(api, name).__doc__, name
    assert set(rollsim.__all__) <= set(dir(rollsim))
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        rollsim.nothing  # noqa: B018


@pytest.mark.parametrize("module", [api, rollsim], ids=["rollsim.api", "rollsim"])
def test_the_docstring_examples_run(module):
    failed, attempted = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert attempted > 0 and failed == 0


def test_the_module_names_are_the_api_functions_too():
    import rollsim.calibrate
    import rollsim.render  # noqa: F401  (imported: the package attribute is now the module)
    import rollsim.stages.decode
    import rollsim.stages.evaluate  # noqa: F401  (their modules live below rollsim.stages, not beside rs.decode)

    for name in ("render", "decode", "evaluate", "calibrate"):
        assert callable(getattr(rs, name))
    assert rs.decode is api.decode and rs.evaluate is api.evaluate
    assert len(rs.render(SCENE, n_frames=1)) == 1
    from rollsim.render import iter_frames  # the package is still the package

    assert callable(iter_frames)


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory):
    """The same scene through the command line: render, decode, evaluate, calibrate."""
    root = tmp_path_factory.mktemp("api")
    run = root / "run"
    assert main(["render", SCENE, "--out", str(run), "--frames", str(FRAMES), "--seed", str(SEED),
                 "--quiet", "--workers", "1"]) == 0
    assert main(["decode", str(run), "--quiet", "--workers", "1"]) == 0
    assert main(["evaluate", str(run)]) == 0
    assert main(["calibrate", str(run), "--json", str(root / "calibration.json")]) == 0
    return run


@pytest.fixture(scope="module")
def api_run():
    frames = rs.render(SCENE, n_frames=FRAMES, seed=SEED)
    decoded = rs.decode(frames)
    result = rs.evaluate(frames.truth, decoded)
    return frames, decoded, result


def test_the_api_renders_the_cli_frames_byte_for_byte(cli_run, api_run):
    frames = api_run[0]
    for frame in frames:
        png = cv2.imread(str(cli_run / "frames" / f"frame_{frame.index:06d}.png"), cv2.IMREAD_UNCHANGED)
        assert png is not None and png.dtype == frame.image.dtype
        np.testing.assert_array_equal(png, frame.image)
    truth = [json.loads(line) for line in (cli_run / "truth.jsonl").read_text().splitlines()]
    assert frames.truth.to_records() == truth


def test_the_api_decodes_and_evaluates_as_the_cli(cli_run, api_run):
    _, decoded, result = api_run
    assert decoded == [json.loads(line) for line in (cli_run / "decoded.jsonl").read_text().splitlines()]
    assert outcomes_csv(result.outcomes) == (cli_run / "outcomes.csv").read_text()
    cli = json.loads((cli_run / "evaluation.json").read_text())["summary"]
    # The CLI adds what it checked of the directory: consistency, unreadable frames, warnings.
    assert result.summary == {k: v for k, v in cli.items() if k not in ("consistent", "frames_unreadable", "warnings")}
    assert result.counts["ok"] > 0


def test_the_api_calibrates_as_the_cli(cli_run, api_run):
    fit = rs.calibrate(api_run[2])
    cli = json.loads((cli_run.parent / "calibration.json").read_text())
    assert fit.report["mmbp"] == cli["mmbp"] and fit.report["ge"] == cli["ge"]
    assert (fit.mmbp.M, fit.mmbp.N, fit.mmbp.p_e) == (cli["mmbp"]["M"], cli["mmbp"]["N"], cli["mmbp"]["p_e"])
    # Exact enumeration: one round of r = 1 over a cycle that is all ON slots with p_e = 0 delivers.
    model = api.MmbpModel(fit.mmbp.fit, 1)
    assert 0.0 <= model.p_message(1) <= model.p_message(3) <= 1.0


def test_the_api_simulates_as_the_cli(tmp_path):
    out = tmp_path / "sim.json"
    assert main(["simulate", SCENE, "--runs", "30", "--seed", "4", "--quiet", "--json", str(out)]) == 0
    cli = json.loads(out.read_text())
    summary = rs.simulate(SCENE, runs=30, seed=4).summary()
    assert summary["metrics"]["goodput_bps"] == cli["summary"]["metrics"]["goodput_bps"]


def test_a_decoder_of_ones_own_is_scored_the_same_way(api_run):
    frames, decoded, _ = api_run
    seen = []

    def replay(image, settings):
        # A "decoder" that returns the records rollsim's decoder found in this frame, as dicts.
        index = len(seen)
        seen.append((image.shape, settings.clock_hz))
        return [{k: v for k, v in d.items() if k != "frame"} for d in decoded if d["frame"] == index]

    mine = rs.decode(frames, decoder=replay)
    assert len(seen) == FRAMES and seen[0][1] == frames.scene.link.clock_hz
    assert mine == decoded
    assert rs.evaluate(frames, mine).counts == rs.evaluate(frames.truth, decoded).counts


def test_arrays_need_a_scene():
    image = np.zeros((8, 8), np.uint8)
    with pytest.raises(ValueError, match="scene="):
        rs.decode([image])
    assert rs.decode([image], scene=SCENE) == []


def test_frames_stream_and_materialise(api_run):
    frames = api_run[0]
    again = rs.render(frames.scene, n_frames=2, start=1)
    held = again.materialise()
    assert [f.index for f in held] == [1, 2]
    np.testing.assert_array_equal(held[0].image, next(iter(again)).image)
    assert again.truth[0] == frames.truth[1]
    with pytest.raises(ValueError, match="n_frames"):
        rs.render(SCENE, n_frames=-1)


def test_load_scene_takes_a_scene_overrides_and_a_seed():
    scene = rs.load_scene(SCENE, overrides={"link.distance_cm": 10, "effects.tone_curve.curve": "srgb"}, seed=9)
    assert (scene.link.distance_cm, scene.seed, scene.effects.tone_curve.curve) == (10.0, 9, "srgb")
    again = rs.load_scene(scene, overrides={"camera.exposure_us": 50})
    assert again.camera.exposure_us == 50.0 and again.seed == 9 and rs.load_scene(scene) is scene
    with pytest.raises(SceneError, match="link.distance_cm"):
        rs.load_scene(SCENE, overrides={"link.distance_cm": -1})


def test_tables_where_pandas_is_installed(api_run):
    pd = pytest.importorskip("pandas")
    frames, _, result = api_run
    table = frames.truth.to_dataframe()
    assert isinstance(table, pd.DataFrame)
    assert len(table) == sum(len(f.sdus) for f in frames.truth)
    outcomes = result.to_dataframe()
    assert len(outcomes) == len(result.outcomes) and (outcomes["outcome"] == "ok").sum() == result.counts["ok"]


def test_the_notebook_style_example_runs(tmp_path):
    import runpy

    import cv2

    tour = runpy.run_path(str(Path(__file__).resolve().parents[1] / "examples" / "tour.py"))
    # Eight frames: at 20 cm about one whole PHY-SDU a frame is read, and
    # the aligned fit rounds the mean count per frame, which four frames can
    # put at 0.5 (M = 0).
    rows = tour["tour"](8)
    assert [r["distance_cm"] for r in rows] == list(tour["DISTANCES_CM"])
    assert all(0 <= r["ok"] <= r["fully_visible"] and r["M"] >= 1 for r in rows)
    tour["plot"](rows, str(tmp_path / "tour.png"))
    assert cv2.imread(str(tmp_path / "tour.png")) is not None
