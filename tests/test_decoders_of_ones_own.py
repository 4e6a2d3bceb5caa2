"""Anyone's decoder: the decoded-record schema, rollsim decode --decoder, evaluate --decoded/--against,
and the example global-threshold decoder scored against rollsim's."""

import json
import shutil
from pathlib import Path

import pytest

from rollsim.cli import main
from rollsim.errors import RollsimError
from rollsim.stages.records import SCHEMA_VERSION, as_decoded_record, record_error, schema

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = "examples.threshold_decoder:decode"
GOOD = {"frame": 1, "first_row": 10, "last_row": 120.5, "sequence": 3, "bits": "0101", "check_ok": True}


@pytest.fixture(autouse=True)
def _at_the_root(monkeypatch):
    # The example decoder is found from the working directory, as a user's would be.
    monkeypatch.chdir(ROOT)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    out = tmp_path_factory.mktemp("own") / "run"
    assert main(["render", "paper-geometric", "--out", str(out), "--frames", "6", "--workers", "1", "--quiet",
                 "--set", "camera.width_px=480"]) == 0
    return out


def _copy(rendered, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(rendered, run)
    return run


# ------------------------------------------------------------------ schema


def test_the_schema_is_shipped_and_versioned():
    assert schema()["$id"].endswith(f"/{SCHEMA_VERSION}")
    assert set(schema()["required"]) == {"frame", "first_row", "last_row", "sequence", "bits", "check_ok"}
    assert record_error(GOOD) is None
    assert record_error({**GOOD, "my_own_field": [1, 2]}) is None  # a decoder's extras are kept


@pytest.mark.parametrize("change, message", [
    ({"frame": None}, "frame: missing"),
    ({"frame": -1}, "frame = -1: expected >= 0"),
    ({"frame": 1.5}, "frame = 1.5: expected integer"),
    ({"first_row": "10"}, "first_row = '10': expected number"),
    ({"sequence": True}, "sequence = True: expected integer"),
    ({"bits": "01x1"}, "bits = '01x1': expected a string of 0s and 1s"),
    ({"bits": 101}, "bits = 101: expected string"),
    ({"check_ok": "yes"}, "check_ok = 'yes': expected boolean"),
    ({"last_row": None}, "last_row: missing"),
])
def test_each_malformed_record_gets_one_line_naming_its_line_and_field(rendered, tmp_path, capsys, change, message):
    run = _copy(rendered, tmp_path)
    bad = {k: v for k, v in {**GOOD, **change}.items() if not (k in change and change[k] is None)}
    path = tmp_path / "mine.jsonl"
    path.write_text(json.dumps(GOOD) + "\n\n" + json.dumps(bad) + "\n")
    assert main(["evaluate", str(run), "--decoded", str(path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [f"rollsim: error: {path}: line 3: {message}"]
    assert not (run / "outcomes.csv").exists()


def test_a_line_that_is_no_object_or_no_json_is_named(rendered, tmp_path, capsys):
    run = _copy(rendered, tmp_path)
    path = tmp_path / "mine.jsonl"
    for text, message in (("[1, 2]", "line 1: not a JSON object"), ("{oops", "line 1: not valid JSON")):
        path.write_text(text + "\n")
        assert main(["evaluate", str(run), "--decoded", str(path)]) == 2
        assert message in capsys.readouterr().err


def test_a_decoders_record_is_numbered_with_its_frame():
    assert as_decoded_record({**GOOD, "frame": 99}, 4)["frame"] == 4
    with pytest.raises(RollsimError, match="frame 4: decoded record: bits = 'ab'"):
        as_decoded_record({**GOOD, "bits": "ab"}, 4)
    with pytest.raises(RollsimError, match="must be a dict"):
        as_decoded_record([1], 4)


# ------------------------------------------------------------ --decoder


def test_the_example_decoder_is_run_and_scored_like_rollsims(rendered, tmp_path, capsys):
    run = _copy(rendered, tmp_path)
    assert main(["decode", str(run), "--decoder", EXAMPLE, "--quiet", "--workers", "2"]) == 0
    info = json.loads((run / "decode.json").read_text())
    assert info["decoder"] == EXAMPLE
    mine = (run / "decoded.jsonl").read_text()
    shutil.move(run / "decoded.jsonl", tmp_path / "threshold.jsonl")
    (run / "decode.json").unlink()
    # Byte-identical with one worker: the order is the frames', not the workers'.
    assert main(["decode", str(run), "--decoder", EXAMPLE, "--quiet", "--workers", "1"]) == 0
    assert (run / "decoded.jsonl").read_text() == mine
    assert main(["decode", str(run), "--quiet", "--workers", "1", "--force"]) == 0
    capsys.readouterr()
    assert main(["evaluate", str(run), "--against", str(tmp_path / "threshold.jsonl")]) == 0
    out = capsys.readouterr().out
    assert "received by A only" in out
    comparison = json.loads((run / "comparison.json").read_text())
    ours = json.loads((run / "evaluation.json").read_text())["summary"]["counts"]
    assert [a for a, _ in comparison["counts"].values()] == [ours[k] for k in comparison["counts"]]
    # The other side is the threshold decoder's own evaluation.
    assert main(["evaluate", str(run), "--decoded", str(tmp_path / "threshold.jsonl"), "--force"]) == 0
    theirs = json.loads((run / "evaluation.json").read_text())["summary"]["counts"]
    assert [b for _, b in comparison["counts"].values()] == [theirs[k] for k in comparison["counts"]]
    assert theirs["ok"] > 0 and ours["ok"] >= theirs["ok"]
    only = set(comparison["ok_only_a"]) | set(comparison["ok_only_b"])
    assert len(only) == sum(1 for d in comparison["differ"] if "ok" in (d["a"], d["b"]))


@pytest.mark.parametrize("spec, message", [
    ("examples.threshold_decoder", "expected package.module:function"),
    ("no_such_module_here:decode", "cannot import no_such_module_here"),
    ("examples.threshold_decoder:nothing", "examples.threshold_decoder has no nothing"),
    ("examples.threshold_decoder:MIN_SWING", "MIN_SWING is not callable"),
])
def test_a_decoder_that_cannot_be_loaded_is_named(rendered, tmp_path, capsys, spec, message):
    run = _copy(rendered, tmp_path)
    assert main(["decode", str(run), "--decoder", spec, "--quiet"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and message in err[0]
    assert not (run / "decoded.jsonl").exists()


def test_a_decoder_that_fails_or_writes_nonsense_is_named_and_nothing_is_written(rendered, tmp_path, capsys):
    run = _copy(rendered, tmp_path)
    module = tmp_path / "bad_decoders.py"
    module.write_text("def boom(image, settings):\n    raise RuntimeError('no idea')\n\n"
                      "def nonsense(image, settings):\n    return [{'frame': 0, 'bits': 'x'}]\n")
    import sys
    sys.path.insert(0, str(tmp_path))
    try:
        assert main(["decode", str(run), "--decoder", "bad_decoders:boom", "--quiet", "--workers", "1"]) == 2
        err = capsys.readouterr().err
        assert "failed on" in err and "frame_000000.png" in err and "RuntimeError: no idea" in err
        assert main(["decode", str(run), "--decoder", "bad_decoders:nonsense", "--quiet", "--workers", "1"]) == 2
        assert "first_row: missing" in capsys.readouterr().err
    finally:
        sys.path.remove(str(tmp_path))
    assert not (run / "decoded.jsonl").exists()


def test_bench_stress_compares_the_decoders_on_the_same_frames(tmp_path, capsys):
    out = tmp_path / "cmp.md"
    assert main(["bench", "stress", "stress-high-iso", "--frames", "4", "--workers", "1", "--decoder", EXAMPLE,
                 "--markdown", str(out)]) == 0
    text = out.read_text()
    assert f"`{EXAMPLE}`" in text and "ok % other" in text and "stress-high-iso" in text
