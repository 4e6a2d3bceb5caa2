"""``rollsim simulate --channel fitted``: the event simulator on each model a calibration fitted."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rollsim.calibrate import Trace, calibrate
from rollsim.channel.scene_channel import sdu_duration_from_scene
from rollsim.cli import main
from rollsim.scene import load_scene

SCENE = "paper-geometric"


@pytest.fixture(scope="module")
def calibration_file(tmp_path_factory):
    """A calibration of a synthetic trace on the scene's clocks: a window of 3.3 PHY-SDUs, its
    first tenth of a PHY-SDU read half the time, the rest at 0.97."""
    scene = load_scene(SCENE)
    frame_s, sdu_s = scene.camera.frame_period_s, sdu_duration_from_scene(scene)
    rng = np.random.default_rng(4)
    frames = frame_s * np.arange(301)
    start = 0.0013 + sdu_s * np.arange(int(300 * frame_s / sdu_s))
    offset = np.mod(start, frame_s)
    q = np.where((offset >= 0.002) & (offset < 0.002 + 0.1 * sdu_s), 0.5,
                 np.where((offset >= 0.002 + 0.1 * sdu_s) & (offset < 0.002 + 3.3 * sdu_s), 0.97, 0.0))
    trace = Trace(rng.random(start.size) < q, start, frames, scene, "synthetic")
    result = calibrate(trace)
    path = tmp_path_factory.mktemp("fitted") / "cal.json"
    path.write_text(json.dumps(result))
    return path


@pytest.mark.parametrize("model", ["position", "mmbp", "ge"])
def test_simulated_goodput_is_the_models_prediction(calibration_file, tmp_path, model, capsys):
    """The event simulator's mean goodput on a fitted model lies within its 99.9 % interval of the
    figure the calibration predicted for that model at the scene's strategy and r (exact for the
    periodic models; for Gilbert-Elliott, a long simulated trace replayed)."""
    calibration = json.loads(calibration_file.read_text())
    scene = load_scene(SCENE)
    link = scene.link
    out = tmp_path / "sim.json"
    assert main(["simulate", SCENE, "--channel", "fitted", "--calibration", str(calibration_file), "--model", model,
                 "--runs", "1500", "--workers", "1", "--quiet", "--json", str(out)]) == 0
    assert f"fitted {model} channel" in capsys.readouterr().out
    summary = json.loads(out.read_text())["summary"]
    goodput = summary["metrics"]["goodput_bps"]
    (row,) = [g for g in calibration["goodput"]
              if g["model"] == model and g["strategy"] == link.strategy and g["r"] == link.repeats]
    half = 3.29 * goodput["std"] / math.sqrt(summary["runs"])
    # The GE figure is itself simulated: allow its own spread too (a trace 20x the measured one).
    slack = 0.02 * row["predicted_bps"] if model == "ge" else 0.0
    assert abs(goodput["mean"] - row["predicted_bps"]) <= half + slack, (goodput, row)


def test_the_default_model_is_the_selected_one(calibration_file, capsys):
    calibration = json.loads(calibration_file.read_text())
    assert main(["simulate", SCENE, "--channel", "fitted", "--calibration", str(calibration_file),
                 "--runs", "50", "--workers", "1", "--quiet"]) == 0
    assert f"fitted {calibration['selected_by_heldout']} channel" in capsys.readouterr().out


@pytest.mark.parametrize("arguments, message", [
    (["--channel", "fitted"], "--channel fitted: give --calibration FILE"),
    (["--calibration", "{cal}"], "--calibration: only with --channel fitted"),
    (["--model", "ge"], "--model: only with --channel fitted"),
    (["--channel", "fitted", "--calibration", "{bad}"], "not a calibration JSON"),
    (["--channel", "fitted", "--calibration", "{missing}"], "does not exist"),
    (["--channel", "fitted", "--calibration", "{cal}", "--model", "position", "--set", "link.clock_hz=4000"],
     "the position model was fitted to PHY-SDUs of"),
])
def test_bad_requests_are_one_line(calibration_file, tmp_path, capsys, arguments, message):
    bad = tmp_path / "bad.json"
    bad.write_text("{\"not\": 1}")
    names = {"cal": calibration_file, "bad": bad, "missing": tmp_path / "nothing.json"}
    arguments = [a.format(**names) for a in arguments]
    assert main(["simulate", SCENE, "--runs", "10", "--quiet", *arguments]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_a_trace_without_frames_has_no_position_model(tmp_path, capsys):
    """A bare CSV trace has no frame times: the position model is not fitted, and asking for it says why."""
    csv = tmp_path / "trace.csv"
    csv.write_text("success\n" + "\n".join("1" if k % 5 < 3 else "0" for k in range(600)) + "\n")
    cal = tmp_path / "cal.json"
    assert main(["calibrate", str(csv), "--json", str(cal)]) == 0
    capsys.readouterr()
    assert json.loads(cal.read_text())["position"] is None
    assert main(["simulate", SCENE, "--channel", "fitted", "--calibration", str(cal), "--model", "position",
                 "--runs", "10", "--quiet"]) == 2
    assert "has no position model" in capsys.readouterr().err
