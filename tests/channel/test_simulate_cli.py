"""rollsim simulate: JSON in both formats, one-line errors."""

import json

from rollsim.cli import main


def test_simulate_json_summary(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert main(["simulate", "paper-default", "--runs", "50", "--quiet", "--json", str(out)]) == 0
    summary = json.loads(out.read_text())["summary"]
    assert summary["runs"] == 50 and summary["channel"]["kind"] == "mmbp"
    assert "goodput_bps" in summary["metrics"]
    assert "mmbp channel" in capsys.readouterr().out


def test_simulate_camcomsim_format_keeps_its_field_names(tmp_path):
    out = tmp_path / "c.json"
    args = ["simulate", "paper-default", "--channel", "camcomsim", "--runs", "20", "--quiet",
            "--format", "camcomsim", "--json", str(out)]
    assert main(args) == 0
    data = json.loads(out.read_text())
    assert {"nbTxPhysdu", "nbRxUniquePhysdu", "nbRxPhysdu", "nbInterFgError", "nbIntraFError",
            "duration100Us", "goodputBps", "througputBps"} <= set(data["summary"])
    assert any("packets" in note for note in data["notes"])  # G counts packets in this channel


def test_simulate_is_reproducible_from_the_seed(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    for path in (a, b):
        assert main(["simulate", "paper-default", "--channel", "timed", "--runs", "30", "--seed", "7",
                     "--quiet", "--json", str(path), "--set", "channel.frame_jitter_us=300"]) == 0
    assert a.read_text() == b.read_text()


def test_simulate_bad_scene_is_one_line(capsys):
    assert main(["simulate", "paper-default", "--set", "channel.p_e=2", "--quiet"]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1
