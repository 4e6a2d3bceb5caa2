"""rollsim bench profile: the parts of a user's wait, read from the run's clock and a profile."""

import cProfile
import json
import pstats

import pytest

from rollsim.bench.profile import PHASES, phase_seconds, spread, stage_seconds, table_rows
from rollsim.cli import main


def test_the_runs_stage_clock_is_read_from_its_time_line():
    stdout = "MMBP fit: M = 3\ntime: render 6.0 s, decode 4.2 s, evaluate 0.0 s, calibrate 1.9 s, report 1.8 s\nreport: x\n"
    assert stage_seconds(stdout) == {"render": 6.0, "decode": 4.2, "evaluate": 0.0, "calibrate": 1.9, "report": 1.8}
    assert stage_seconds("no clock here") == {}


def test_spread_is_the_median_and_the_extremes():
    assert spread([3.0, 1.0, 2.0, 10.0]) == {"median": 2.5, "min": 1.0, "max": 10.0}


def test_a_phase_is_the_cumulative_time_of_its_function_and_zero_when_not_called():
    from rollsim.calibrate.replay import replay_goodput_bps

    profiler = cProfile.Profile()
    profiler.enable()
    replay_goodput_bps([True, False, True] * 200, 2, 5, 19, 3e-3)
    profiler.disable()
    seconds = phase_seconds(pstats.Stats(profiler))
    assert set(seconds) == {label for label, _file, _function in PHASES}
    assert seconds["calibrate: replays (within the goodput table)"] > 0.0
    assert seconds["report: run lengths plot (this process)"] == 0.0


def test_the_table_lists_what_a_user_meets_in_order():
    figure = {"median": 1.0, "min": 0.5, "max": 2.0}
    result = {"scene": "s", "startup": {"python alone": figure}, "run": {"wall": figure, "stages": {"render": figure},
              "outside_stages": figure}, "profiled": {"wall": figure, "phases": {"calibrate: MMBP fit": figure}}}
    rows = table_rows(result)
    assert [what for what, _ in rows][:3] == ["start-up: python alone", "rollsim run s: wall (fresh process)",
                                              "  stage: render"]
    assert rows[0][1] == "1.00 (0.50 … 2.00)"


def test_the_command_refuses_existing_results_before_any_work(tmp_path, capsys):
    (tmp_path / "profile.md").write_text("mine")
    assert main(["bench", "profile", "paper-geometric", "--out", str(tmp_path)]) != 0
    assert "exists" in capsys.readouterr().err
    assert (tmp_path / "profile.md").read_text() == "mine"


@pytest.mark.slow
def test_the_command_profiles_a_small_run(tmp_path):
    out = tmp_path / "profile"
    assert main(["bench", "profile", "paper-geometric", "--frames", "3", "--repeats", "1", "--quiet",
                 "--out", str(out)]) == 0
    result = json.loads((out / "profile.json").read_text())
    assert set(result["run"]["stages"]) == {"render and decode", "evaluate", "calibrate", "report"}
    assert result["profiled"]["phases"]["report: run lengths plot (this process)"]["median"] > 0.0
