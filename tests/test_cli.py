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
    assert "56 chips = 7.0000 ms" in capsys.readouterr().out
    assert main(["describe", "paper-default", "--json", "--set", "link.strategy=rs", "--set", "link.repeats=2"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["message"]["packets"] == 22
    assert info["schedule"]["emissions_per_round"] == 44
    assert info["schedule"]["first_sequence_numbers"][:3] == [0, 1, 2]


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
