"""rollsim bench waits: the user-facing waits, each measured and held against its target."""

import json

import pytest

from rollsim.bench.waits import KEYS, WAITS, Wait, chosen, summary, table_rows
from rollsim.cli import main


def test_the_rows_are_the_waits_a_user_meets_with_their_targets():
    assert KEYS == ("paper", "paper-quick", "run", "render", "sweep", "describe", "default-effects", "blooming")
    targets = {w.key: (w.comparison, w.target, w.unit) for w in WAITS}
    assert targets["run"] == ("<=", 7.0, "s") and targets["render"] == (">=", 0.9, "x")
    assert targets["paper"] == ("<=", 180.0, "s") and targets["blooming"] == ("<=", 15.0, "ms/frame")


def test_a_row_is_met_by_its_median_in_the_targets_direction():
    at_most, at_least = Wait("a", "a", "<=", 1.0, "s"), Wait("b", "b", ">=", 0.9, "x")
    row = summary(at_most, [0.8, 1.5, 0.9])
    assert (row["median"], row["min"], row["max"], row["met"]) == (0.9, 0.8, 1.5, True)
    assert not summary(at_most, [1.1, 1.2, 0.5])["met"]
    assert summary(at_least, [0.95, 0.7, 0.92])["met"] and not summary(at_least, [0.85, 0.95, 0.8])["met"]
    assert table_rows({"rows": [row]}) == [("a", "0.90 (0.80 … 1.50) s", "<= 1 s", "yes")]


def test_the_full_paper_is_measured_only_when_asked():
    assert "paper" not in [w.key for w in chosen()]
    assert [w.key for w in chosen(everything=True)] == list(KEYS)
    assert [w.key for w in chosen(["describe", "run"])] == ["run", "describe"]  # the table's order
    with pytest.raises(ValueError, match="--only nope: no such wait"):
        chosen(["nope"])


def test_an_unknown_row_and_an_existing_json_are_refused_before_any_work(tmp_path, capsys):
    assert main(["bench", "waits", "--only", "nope"]) == 2
    assert "no such wait" in capsys.readouterr().err
    mine = tmp_path / "waits.json"
    mine.write_text("mine")
    assert main(["bench", "waits", "--only", "describe", "--json", str(mine), "--quiet"]) != 0
    assert mine.read_text() == "mine"


def test_describe_is_timed_as_a_fresh_process(tmp_path, capsys):
    out = tmp_path / "waits.json"
    assert main(["bench", "waits", "--only", "describe", "--repeats", "2", "--quiet", "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    (row,) = result["rows"]
    assert row["key"] == "describe" and len(row["values"]) == 2 and 0.05 < row["min"] <= row["median"] < 30
    assert "rollsim describe paper-default" in capsys.readouterr().out


def test_the_modules_bytecode_is_written_whatever_the_environment_says(monkeypatch):
    # A fresh process then reads rollsim's modules compiled, as after an install's first run,
    # even where PYTHONDONTWRITEBYTECODE stops the import system from writing them.
    import importlib.util
    from pathlib import Path

    import rollsim.version
    from rollsim.bench.common import write_bytecode

    monkeypatch.setenv("PYTHONDONTWRITEBYTECODE", "1")
    cached = Path(importlib.util.cache_from_source(rollsim.version.__file__))
    cached.unlink(missing_ok=True)
    write_bytecode()
    assert cached.is_file() and cached.stat().st_size > 0
