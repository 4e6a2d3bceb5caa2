"""The rollsim command line: exit codes, one-line errors, subcommands."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from rollsim.cli import main

BAD = sorted((Path(__file__).parent / "data" / "bad_scenes").glob("*.yaml"))


def test_scenes_lists_bundled_scenes(capsys):
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    assert "paper-default" in out and "paper-10cm" in out


def test_validate_ok(capsys):
    assert main(["validate", "paper-default", "scenes/paper-10cm.yaml"]) == 0
    assert capsys.readouterr().out.count("ok") == 2


@pytest.mark.parametrize("path", BAD, ids=lambda p: p.stem)
def test_validate_bad_scene_exit_2_one_line(path, capsys):
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    expected = path.read_text().splitlines()[0].removeprefix("# expect: ").replace("{path}", str(path))
    assert err.splitlines() == [f"rollsim: error: {expected}"]


def test_validate_reports_every_file(capsys):
    assert main(["validate", "paper-default", str(BAD[0]), str(BAD[1])]) == 2
    captured = capsys.readouterr()
    assert len(captured.err.splitlines()) == 2 and "ok" in captured.out


def test_bad_override_is_one_line(capsys):
    assert main(["describe", "paper-default", "--set", "camera.iso=-3"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "rollsim: error: paper-default: camera.iso = -3: out of range, allowed (0, 1e+07]"
    ]


def test_describe_text_and_json(capsys):
    assert main(["describe", "paper-default"]) == 0
    out = capsys.readouterr().out
    assert "56 chips = 7.0000 ms" in out
    # At ISO 10000 the ADC's range is 43.6 e-: the LED's ON level clips.
    assert "signal     per pixel and exposure: LED ON" in out and "clipped at 43.59 e-" in out
    assert main(["describe", "paper-default", "--json", "--set", "link.strategy=rs", "--set", "link.repeats=2"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["message"]["packets"] == 22
    assert info["schedule"]["emissions_per_round"] == 44
    assert info["schedule"]["first_sequence_numbers"][:3] == [0, 1, 2]
    assert info["signal"]["electrons"]["led_on"] > info["signal"]["electrons"]["led_off"] > 0


def test_describe_predicts_the_link(capsys):
    """ROI, M and N from the geometry (of the geometric LED; with glare, from
    the rows whose stripes clear the noise); p0 and goodput from the MMBP
    closed forms."""
    from rollsim.channel import analytic
    from rollsim.optics import led_rows
    from rollsim.scene import load_scene

    args = ["--set", "link.strategy=rs", "--set", "link.repeats=3", "--set", "link.distance_cm=10"]
    assert main(["describe", "paper-geometric", *args]) == 0
    text = capsys.readouterr().out
    assert "ROI ratio" in text and "M = " in text and "expected goodput" in text and "(geometric image)" in text
    assert main(["describe", "paper-geometric", "--json", *args]) == 0
    link = json.loads(capsys.readouterr().out)["link"]
    scene = load_scene("paper-geometric", [a for a in args if a != "--set"])
    first, last = led_rows(scene)
    assert link["led_rows"] == [first, last]
    assert link["roi_ratio"] == (last - first + 1) / 1080
    window = (last - first + 1) * scene.camera.row_time_s + scene.camera.exposure_s
    slots = analytic.mmbp_slots_from_physics(scene.camera.frame_period_s, window, 0.007)
    assert (link["M"], link["N"]) == (slots.M, slots.N)
    assert link["p0"] == link["p0_rs"] == analytic.mmbp_p0_rs(slots.M, slots.N, 3, 0.001, 22)
    assert link["goodput_bps"] == analytic.mmbp_expected_goodput_bps(slots.M, slots.N, 3, 0.001, 22, "rs", 19, 0.007)
    assert 0 < link["goodput_bps"] < 19 / 0.007  # below one payload per PHY-SDU time
    assert link["mn_from"] == "physics"
    assert main(["describe", "paper-default", "--set", "channel.M=4", "--set", "channel.N=1"]) == 0
    assert "M = 4, N = 1 from the scene" in capsys.readouterr().out


def test_describe_with_glare_counts_the_readable_rows(capsys):
    """With glare the LED's rows are the renderer's: those whose stripes clear the noise."""
    from rollsim.render import RenderPipeline
    from rollsim.scene import load_scene

    assert main(["describe", "paper-default", "--json", "--set", "link.distance_cm=20"]) == 0
    link = json.loads(capsys.readouterr().out)["link"]
    setup = RenderPipeline(load_scene("paper-default", ["link.distance_cm=20"])).setup
    assert link["led_rows"] == list(setup.led_rows) and link["led_rows_from"] == "stripes above the noise"
    assert 0 < link["roi_ratio"] < 1 and link["M"] >= 1


def test_debug_shows_traceback():
    from rollsim.errors import RollsimError

    with pytest.raises(RollsimError):
        main(["--debug", "validate", str(BAD[0])])


def test_console_script_no_traceback():
    result = subprocess.run(
        [sys.executable, "-m", "rollsim", "validate", str(BAD[0])], capture_output=True, text=True
    )
    assert result.returncode == 2
    assert "Traceback" not in result.stderr and len(result.stderr.splitlines()) == 1


def test_no_subcommand_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as info:
        main([])
    assert info.value.code == 2


@pytest.mark.parametrize("argv, line", [
    (["describe", "paper-default", "--set", "link.distance_cm=5", "--set", "link.distance_cm=10"],
     "rollsim: error: --set link.distance_cm: given twice with --set; give it once"),
    (["render", "paper-default", "--out", "out", "--set", "camera.iso=100", "--set", " camera.iso =200"],
     "rollsim: error: --set camera.iso: given twice with --set; give it once"),
    (["sweep", "paper-default", "--set", "link.distance_cm=5", "--grid", "link.distance_cm=5,10", "--out", "out"],
     "rollsim: error: --grid link.distance_cm: given with --set and --grid; give it once"),
])
def test_a_key_given_twice_on_the_command_line_is_refused(tmp_path, monkeypatch, capsys, argv, line):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert capsys.readouterr().err.splitlines() == [line]
    assert list(tmp_path.iterdir()) == []


def test_a_scene_name_no_file_can_have_is_bad_input(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["describe", "a" * 300]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].endswith("...: not a usable scene file name (File name too long)")
    assert len(err[0]) < 200


@pytest.mark.parametrize("command", [["fit-camera", "my_frames/*.png", "--clock-hz", "5000", "--out", "my_camera"],
                                     ["estimate-row-time", "my_frames/*.png", "--clock-hz", "5000"]])
def test_frames_that_do_not_exist_are_named(tmp_path, monkeypatch, capsys, command):
    # A glob the shell left unexpanded: named, not counted as one frame.
    monkeypatch.chdir(tmp_path)
    assert main(command) == 2
    assert capsys.readouterr().err.splitlines() == [
        "rollsim: error: no file matches my_frames/*.png (my_frames does not exist)"]
    assert list(tmp_path.iterdir()) == []
