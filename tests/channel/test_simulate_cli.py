"""rollsim simulate: JSON in both formats, one-line errors."""

import json

from rollsim.channel.eventsim import CAMCOMSIM_RUN_FIELDS
from rollsim.cli import main


def test_simulate_json_summary(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert main(["simulate", "paper-default", "--runs", "50", "--quiet", "--json", str(out)]) == 0
    summary = json.loads(out.read_text())["summary"]
    assert summary["runs"] == 50 and summary["channel"]["kind"] == "mmbp"
    assert "goodput_bps" in summary["metrics"]
    assert "mmbp channel" in capsys.readouterr().out


def test_simulate_camcomsim_format_is_camcomsims_result_file(tmp_path):
    out = tmp_path / "c.json"
    args = ["simulate", "paper-default", "--channel", "camcomsim", "--runs", "20", "--quiet",
            "--format", "camcomsim", "--json", str(out)]
    assert main(args) == 0
    rows = json.loads(out.read_text())
    assert isinstance(rows, list) and len(rows) == 20  # a bare list, one object per run
    assert tuple(rows[0]) == CAMCOMSIM_RUN_FIELDS
    assert rows[0]["simuParams"]["simuNbIteration"] == 20
    assert rows[0]["simuParams"]["savePath"] == str(tmp_path)


def test_simulate_camcomsim_log_workload_wraps_with_a_warning(tmp_path, capsys):
    out = tmp_path / "log.json"
    args = ["simulate", "paper-default", "--channel", "camcomsim", "--runs", "5", "--quiet", "--json", str(out),
            "--set", "link.message_bytes=1000", "--set", "link.header_bits=5"]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "warning" in err and "wrap" in err
    assert json.loads(out.read_text())["summary"]["n_packets"] == 422
    assert main(["simulate", "paper-default", "--runs", "5", "--quiet", "--set", "link.message_bytes=1000"]) == 2
    assert "too few for 422 packets" in capsys.readouterr().err


def test_simulate_camcomsim_errors_are_one_line(capsys):
    base = ["simulate", "paper-default", "--channel", "camcomsim", "--runs", "5", "--quiet"]
    assert main([*base, "--set", "link.strategy=rs", "--set", "link.repeats=4"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "only the RP strategy" in err[0]
    assert main([*base, "--format", "camcomsim"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "--json" in err[0]


def test_simulate_camcomsim_far_link_warns_about_the_cap(capsys):
    args = ["simulate", "paper-default", "--channel", "camcomsim", "--runs", "4", "--quiet",
            "--max-emissions", "200", "--set", "link.distance_cm=35"]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "never receives" in err and "4 of 4 runs reached the cap" in err


def test_simulate_is_reproducible_from_the_seed(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    for path in (a, b):
        assert main(["simulate", "paper-default", "--channel", "timed", "--runs", "30", "--seed", "7",
                     "--quiet", "--json", str(path), "--set", "channel.frame_jitter_us=300"]) == 0
    assert a.read_text() == b.read_text()


def test_simulate_bad_scene_is_one_line(capsys):
    assert main(["simulate", "paper-default", "--set", "channel.p_e=2", "--quiet"]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1
