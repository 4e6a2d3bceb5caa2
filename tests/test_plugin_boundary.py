"""A decoder of one's own is untrusted: its records are checked at the boundary, and its
exits, exceptions and endless frames stop the run with one line naming it and the frame.

Every case: exit 2, one line on stderr, no traceback, and neither decoded.jsonl
nor decode.json afterwards; with one worker (the plug-in runs in the command's
own process) and with two (in worker processes).
"""

import json
import os
import signal
import time

import pytest

from clitools import assert_one_error
from rollsim.cli import main
from rollsim.stages.decode import DecodeSettings, decode_directory, plugin_records, settings_from_scene
from rollsim.errors import Interrupted, RollsimError
from rollsim.stages.records import run_identifier
from rollsim.scene import load_scene

GOOD = "{'first_row': 1, 'last_row': 9, 'sequence': 0, 'bits': '0101010101010101010', 'check_ok': True}"
PLUGINS = f"""
import os, sys, time

GOOD = {GOOD}

def nan_row(image, settings):
    return [dict(GOOD, first_row=float('nan'))]

def inf_extra(image, settings):
    return [dict(GOOD, diagnostics={{'snr': [1.0, float('-inf')]}})]

def numpy_extra(image, settings):
    import numpy
    return [dict(GOOD, level=numpy.float32(1.5))]

def exits(image, settings):
    sys.exit(0)

def interrupts(image, settings):
    raise KeyboardInterrupt

def generator_exit(image, settings):
    raise GeneratorExit

class Odd(BaseException):
    pass

def base_exception(image, settings):
    raise Odd('odd')

def fails(image, settings):
    raise ValueError('no idea')

def returns_none(image, settings):
    pass

def returns_a_number(image, settings):
    return 5

def returns_a_dict(image, settings):
    return GOOD

def raises_midway(image, settings):
    yield GOOD
    raise RuntimeError('midway')

def endless(image, settings):
    while True:
        yield GOOD

class Found:
    def to_record(self):
        raise OSError('to_record failed')

def bad_to_record(image, settings):
    return [Found()]

def sleeps(image, settings):
    time.sleep(30)
    return []

def stubborn(image, settings):
    # Catches the deadline itself and carries on: its frame still fails.
    try:
        time.sleep(30)
    except BaseException:
        pass
    return []

def in_c(image, settings):
    # One C call, with no way back into Python until it returns.
    sum(range(20_000_000))
    return []

def dies(image, settings):
    os._exit(0)

def good(image, settings):
    return [dict(GOOD, run='not mine', frame=99)]
"""
IMPORT_EXITS = "import sys\nsys.exit(3)\n"


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    # Ten frames: two chunks, so that two workers really are two processes.
    out = tmp_path_factory.mktemp("plugins") / "run"
    assert main(["render", "paper-default", "--out", str(out), "--frames", "10", "--workers", "1", "--quiet",
                 "--set", "camera.width_px=32", "--set", "camera.height_px=64"]) == 0
    return out


@pytest.fixture(scope="module")
def plugins(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plugin_modules")
    (folder / "hostile_plugins.py").write_text(PLUGINS)
    (folder / "exits_on_import.py").write_text(IMPORT_EXITS)
    return folder


@pytest.fixture
def run_dir(rendered, tmp_path, plugins, monkeypatch):
    import shutil

    monkeypatch.syspath_prepend(str(plugins))
    run = tmp_path / "run"
    shutil.copytree(rendered, run)
    return run


def _decode(capsys, run, spec, workers):
    code = main(["decode", str(run), "--decoder", spec, "--quiet", "--workers", str(workers)])
    return code, capsys.readouterr().err


def _nothing_committed(run):
    assert not (run / "decoded.jsonl").exists() and not (run / "decode.json").exists()
    assert not [p.name for p in run.iterdir() if p.name.startswith(".") and p.name != ".rollsim-output.json"]


CASES = {
    "nan_row": ["frame 0: decoded record: first_row = nan: not a finite number"],
    "inf_extra": ["frame 0: decoded record: diagnostics.snr.1 = -inf: not a finite number"],
    "numpy_extra": ["frame 0: decoded record: level = ", "1.5", ": not a JSON value (float32)"],
    "exits": ["failed on frame 0", "called sys.exit(0)"],
    "interrupts": ["failed on frame 0", "KeyboardInterrupt"],
    "generator_exit": ["failed on frame 0", "GeneratorExit"],
    "base_exception": ["failed on frame 0", "Odd: odd"],
    "fails": ["failed on frame 0", "ValueError: no idea"],
    "returns_none": ["frame 0: returned None, not an iterable of records"],
    "returns_a_number": ["frame 0: returned 5, not an iterable of records"],
    "returns_a_dict": ["frame 0: returned {", "not an iterable of records"],
    "raises_midway": ["failed on frame 0", "RuntimeError: midway"],
    "endless": ["frame 0: returned more than 100000 records"],
    "bad_to_record": ["failed on frame 0", "OSError: to_record failed"],
}


@pytest.mark.parametrize("workers", [1, 2])
@pytest.mark.parametrize("name", list(CASES))
def test_a_plugins_exit_exception_or_nonsense_stops_the_run_with_one_line(run_dir, capsys, name, workers):
    spec = f"hostile_plugins:{name}"
    code, err = _decode(capsys, run_dir, spec, workers)
    assert_one_error(err, 2, f"--decoder {spec}", *CASES[name])
    assert code == 2
    _nothing_committed(run_dir)


def test_a_plugin_that_exits_on_import_is_named(run_dir, capsys):
    code, err = _decode(capsys, run_dir, "exits_on_import:decode", 1)
    assert_one_error(err, 2, "--decoder exits_on_import:decode: cannot import exits_on_import", "sys.exit(3)")
    _nothing_committed(run_dir)


def test_a_worker_killed_by_its_plugin_is_one_line(run_dir, capsys):
    code, err = _decode(capsys, run_dir, "hostile_plugins:dies", 2)
    assert_one_error(err, 2, "--decoder hostile_plugins:dies: a worker process died", "frame_000000.png")
    _nothing_committed(run_dir)


def test_the_commands_own_interrupt_is_not_the_plugins(run_dir):
    # Interrupted is SIGINT/SIGTERM reaching rollsim: it passes through, to exit 128 + N.
    def interrupted(image, settings):
        raise Interrupted(signal.SIGTERM)

    settings = DecodeSettings(settings_from_scene(load_scene(run_dir / "scene.resolved.yaml")).phy, decoder="mine:x")
    with pytest.raises(Interrupted):
        plugin_records(interrupted, None, settings, 3, "f.png")


def test_a_plugins_records_carry_the_frame_and_the_run_not_its_own(run_dir, capsys):
    code, err = _decode(capsys, run_dir, "hostile_plugins:good", 2)
    assert code == 0, err
    records = [json.loads(line) for line in (run_dir / "decoded.jsonl").read_text().splitlines()]
    assert [r["frame"] for r in records] == list(range(10))
    assert {r["run"] for r in records} == {run_identifier(run_dir)}


# --------------------------------------------------------------- deadlines


def _settings(run, spec, timeout):
    base = settings_from_scene(load_scene(run / "scene.resolved.yaml"))
    return DecodeSettings(base.phy, base.clock_hz, base.row_time_s, decoder=spec, decoder_timeout_s=timeout)


@pytest.mark.parametrize("workers", [1, 2])
@pytest.mark.parametrize("name", ["sleeps", "stubborn"])
def test_a_frame_past_its_deadline_stops_the_run(run_dir, name, workers):
    spec = f"hostile_plugins:{name}"
    start = time.monotonic()
    with pytest.raises(RollsimError) as caught:
        decode_directory(run_dir, _settings(run_dir, spec, None), workers=workers, timeout_s=0.3)
    assert time.monotonic() - start < 10
    assert str(caught.value) == f"--decoder {spec}: frame 0 took more than 0.3 s (--decoder-timeout)"
    _nothing_committed(run_dir)


def test_the_deadline_puts_back_the_callers_alarm(run_dir):
    # With one worker the plug-in runs in the caller's process: its SIGALRM
    # handler and timer are as they were, less the time spent.
    rang = []
    previous = signal.signal(signal.SIGALRM, lambda signum, frame: rang.append(signum))
    try:
        signal.setitimer(signal.ITIMER_REAL, 50.0)
        summary = decode_directory(run_dir, _settings(run_dir, "hostile_plugins:good", 5.0), workers=1)
        assert summary.sdus == 10
        remaining, _ = signal.setitimer(signal.ITIMER_REAL, 0)
        assert 40.0 < remaining < 50.0
        assert signal.getsignal(signal.SIGALRM).__name__ == "<lambda>"
        assert not rang
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def test_a_plugin_inside_one_c_call_is_stopped_only_when_the_call_returns(run_dir):
    # The documented limit of a SIGALRM deadline: Python handles the signal
    # between bytecodes, so the C call runs to its end first.
    settings = _settings(run_dir, "hostile_plugins:in_c", 0.01)
    import hostile_plugins

    start = time.monotonic()
    with pytest.raises(RollsimError, match="frame 4 took more than 0.01 s"):
        plugin_records(hostile_plugins.in_c, None, settings, 4, "f.png")
    assert time.monotonic() - start > 0.05  # sum(range(2e7)) takes about 0.3 s


def test_a_deadline_needs_a_plugin_and_a_positive_finite_value(run_dir):
    with pytest.raises(RollsimError, match="applies to a decoder of your own"):
        decode_directory(run_dir, _settings(run_dir, None, None), timeout_s=1.0)
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(RollsimError, match="decoder_timeout_s = "):
            _settings(run_dir, "hostile_plugins:good", bad)


def test_a_pipe_for_a_resolved_scene_is_refused_not_waited_on(run_dir):
    (run_dir / "scene.resolved.yaml").unlink()
    os.mkfifo(run_dir / "scene.resolved.yaml")
    with pytest.raises(RollsimError, match="scene.resolved.yaml: not a resolved scene"):
        run_identifier(run_dir)


# -------------------------------------------------------------- provenance


def test_evaluate_refuses_records_of_another_render_unless_allowed(run_dir, tmp_path, capsys):
    from rollsim.stages.evaluate import evaluate_directory

    code, err = _decode(capsys, run_dir, "hostile_plugins:good", 1)
    assert code == 0, err
    lines = (run_dir / "decoded.jsonl").read_text().splitlines()
    own = run_identifier(run_dir)
    # Another render: the same frames' records, from a render of another seed.
    foreign = tmp_path / "foreign.jsonl"
    foreign.write_text("\n".join([lines[0].replace(own, "0" * 16), *lines[1:]]) + "\n")
    assert main(["evaluate", str(run_dir), "--decoded", str(foreign)]) == 2
    assert_one_error(capsys.readouterr().err, 2, f"{foreign}: line 1: run = '0000000000000000': records of another "
                     f"render (this directory's is '{own}')", "--allow-other-run")
    assert not (run_dir / "evaluation.json").exists()
    assert main(["evaluate", str(run_dir), "--decoded", str(foreign), "--allow-other-run"]) == 0
    (run_dir / "evaluation.json").unlink()
    (run_dir / "outcomes.csv").unlink()
    # Allowed: scored, with a warning and consistent: false.
    result = evaluate_directory(run_dir, decoded_file=foreign, allow_foreign=True)
    assert result.summary["consistent"] is False
    assert result.summary["warnings"] == [f"1 of 10 records of {foreign} are of another render (run '0000000000000000', "
                                          f"this directory's is '{own}'); scored as asked, so these figures may not "
                                          "be this render's"]
    # Another decoder's records, without provenance, are scored as before.
    anonymous = tmp_path / "anonymous.jsonl"
    anonymous.write_text("".join(json.dumps({k: v for k, v in json.loads(line).items() if k != "run"}) + "\n"
                                 for line in lines))
    assert main(["evaluate", str(run_dir), "--decoded", str(anonymous), "--force"]) == 0
    assert json.loads((run_dir / "evaluation.json").read_text())["summary"]["consistent"] is True


def test_the_run_is_the_scene_less_its_frame_count(run_dir, tmp_path):
    from rollsim.stages.records import scene_run_identifier

    scene = load_scene(run_dir / "scene.resolved.yaml")
    assert scene_run_identifier(scene) == run_identifier(run_dir)
    assert scene_run_identifier(scene.model_copy(update={"frames": 3})) == run_identifier(run_dir)
    assert scene_run_identifier(scene.model_copy(update={"seed": scene.seed + 1})) != run_identifier(run_dir)
    assert run_identifier(tmp_path) is None


def test_decoder_timeout_on_the_command_line(run_dir, capsys):
    start = time.perf_counter()
    code = main(["decode", str(run_dir), "--decoder", "hostile_plugins:sleeps", "--decoder-timeout", "0.3", "--quiet",
                 "--workers", "1"])
    assert_one_error(capsys.readouterr().err, 2,
                     "--decoder hostile_plugins:sleeps: frame 0 took more than 0.3 s (--decoder-timeout)")
    assert code == 2 and time.perf_counter() - start < 10
    _nothing_committed(run_dir)
    assert main(["decode", str(run_dir), "--decoder", "hostile_plugins:good", "--decoder-timeout", "nan"]) == 2
    assert "must be a finite number > 0" in capsys.readouterr().err
