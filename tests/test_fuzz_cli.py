"""The whole command line fuzzed: argv for every subcommand, as a new user (or a script gone wrong) types it.

Hypothesis draws a subcommand (the parser's own list, so a new command is
covered without a change here), a subset of its options and positionals,
and values from a pool that mixes sensible ones (bundled scenes, a small
rendered run, sizes, addresses) with hostile ones (NaN, subnormals, huge
integers, garbage, files of random bytes, paths that do not exist). Each
argv runs as a real process in a sandbox of its own, and must:

* exit 0, 1, 2, or 128 + a signal;
* on an error, print its error line last, and no traceback (one line per
  distinct problem: ``validate`` of several files, a sweep's cells with
  different mistakes; at most :data:`MAX_ERROR_LINES`);
* write nothing outside the outputs it was given (``--out``, ``--json``,
  ``--plot``, ``--markdown``, and the directory ``decode``/``evaluate``
  write into);
* when it is still working after :data:`WORK_S` seconds (a valid command
  doing real work), stop on SIGTERM within :data:`STOP_S` seconds with
  exit 143 and rollsim's one line.

The default run draws :data:`EXAMPLES` argv lists, derandomised so that CI
is repeatable; ``-m slow`` draws :data:`SLOW_EXAMPLES` fresh ones (400, or
``$ROLLSIM_FUZZ_EXAMPLES``).
"""

from __future__ import annotations

import argparse
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from clitools import SMALL, rollsim_env, run_rollsim, tree_state
from rollsim.cli import build_parser

EXAMPLES = 30
MAX_ERROR_LINES = 5
SLOW_EXAMPLES = int(os.environ.get("ROLLSIM_FUZZ_EXAMPLES", "400"))
WORK_S = 8.0
STOP_S = 10.0
# Options whose value is a path rollsim may write.
OUTPUT_OPTIONS = ("--out", "--json", "--plot", "--markdown")
# Commands that write into their DIR argument (decoded.jsonl, outcomes.csv, ...).
WRITES_INTO_DIR = ("decode", "evaluate")

SCENES = ["paper-default", "paper-geometric", "effect-isp", "in/scene.yaml", "in/random.bin", "missing.yaml"]
PATHS = ["run", "run/frames", "run/frames/frame_000000.png", "in/random.bin", "in/empty", "in/garbage.png",
         "in/frames", "missing", "in", "run/decoded.jsonl", "run/truth.jsonl", "run/outcomes.csv"]
OUTPUTS = ["out", "out/a/b", "out.json", "out.png", "out.md", "run", "in/random.bin", "in"]
NUMBERS = ["1", "2", "0", "-1", "3.5", "1e-300", "5e-324", "nan", "inf", "-inf", "1e308", "99999999999999999999",
           "0x10", "", "abc"]
TEXT = ["link.distance_cm=5,10", "link.distance_cm=5:40:5", "camera.exposure_us=5e-324", "link.distance_cm=0",
        "camera.width_px=160", "x=y", "=", "link.clock_hz=nan", "effects.motion={}", "tcp://127.0.0.1:1",
        "http://127.0.0.1:1", "mmbp", "square", "rp", "decoder.pitch:estimate_pitch", "os:system", "ünïcödé", "-"]


def _subcommands(parser: argparse.ArgumentParser, prefix=()) -> dict:
    """``{(command, ...): subparser}`` for every leaf command of the parser."""
    found: dict = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                leaves = _subcommands(sub, (*prefix, name))
                found.update(leaves or {(*prefix, name): sub})
    return found


COMMANDS = _subcommands(build_parser())


def _value(draw, action: argparse.Action) -> list[str]:
    """Words for one option or positional."""
    if action.choices:
        pool = [str(c) for c in action.choices] + ["bogus"]
    elif action.dest in ("out", "json", "plot", "markdown"):
        pool = OUTPUTS
    elif action.dest in ("scene",):
        pool = SCENES
    elif action.dest in ("dir", "frames", "trace", "files", "decoded", "against"):
        pool = PATHS
    elif action.dest in ("overrides", "grid", "zip", "scheduler", "decoder", "pattern", "channel", "format"):
        pool = TEXT
    else:
        pool = NUMBERS + TEXT[:3]
    count = draw(st.integers(1, 3)) if action.nargs in ("+", "*") else 1
    return [draw(st.sampled_from(pool)) for _ in range(count)]


@st.composite
def argvs(draw) -> tuple[tuple, list[str]]:
    command = draw(st.sampled_from(sorted(COMMANDS)))
    parser = COMMANDS[command]
    argv = list(command)
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        required = not action.option_strings or action.required
        if not required and not draw(st.booleans()):
            continue
        if action.option_strings:
            argv.append(action.option_strings[-1])
            if action.nargs == 0:
                continue
        argv.extend(_value(draw, action))
    if draw(st.integers(0, 9)) == 0:  # now and then, a global option first
        argv = [draw(st.sampled_from(["--memory-limit", "--disk-limit"])), draw(st.sampled_from(NUMBERS + ["1G"])),
                *argv]
    return command, argv


@pytest.fixture(scope="module")
def template(tmp_path_factory) -> Path:
    """A sandbox to copy: a small rendered and decoded run, and hostile files."""
    root = tmp_path_factory.mktemp("fuzz-template")
    assert run_rollsim("render", "paper-default", "--out", "run", "--frames", "2", *SMALL, cwd=root).returncode == 0
    assert run_rollsim("decode", "run", cwd=root).returncode == 0
    inputs = root / "in"
    (inputs / "frames").mkdir(parents=True)
    noise = random.Random(46)
    (inputs / "random.bin").write_bytes(bytes(noise.randrange(256) for _ in range(4096)))
    (inputs / "empty").write_bytes(b"")
    (inputs / "garbage.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(noise.randrange(256) for _ in range(512)))
    for k in range(2):
        (inputs / "frames" / f"frame_{k:06d}.png").write_bytes(bytes(noise.randrange(256) for _ in range(300)))
    (inputs / "scene.yaml").write_text("camera:\n  exposure_us: [1, 2\nlink: {distance_cm: -5}\n")
    return root


def _allowed(command: tuple, argv: list[str]) -> list[str]:
    """Sandbox paths this argv may write under."""
    allowed = [argv[i + 1] for i, word in enumerate(argv[:-1]) if word in OUTPUT_OPTIONS]
    if command[0] in WRITES_INTO_DIR:
        allowed += [word for word in argv if word in PATHS]
    return [os.path.normpath(path) for path in allowed]


def _outside(changed: list[str], allowed: list[str]) -> list[str]:
    return [path for path in changed
            if not any(path == a or path.startswith(a + os.sep) or a.startswith(path + os.sep) for a in allowed)]


def _run(argv: list[str], cwd: Path) -> tuple[int, str, bool]:
    """Run rollsim with ``argv``; SIGTERM after :data:`WORK_S`. ``(exit code, stderr, was stopped)``."""
    process = subprocess.Popen([sys.executable, "-m", "rollsim", *argv], cwd=cwd, stdin=subprocess.DEVNULL,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               env=rollsim_env(ROLLSIM_MEMORY_LIMIT="4G"))
    try:
        _, err = process.communicate(timeout=WORK_S)
        return process.returncode, err, False
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGTERM)
        start = time.monotonic()
        try:
            _, err = process.communicate(timeout=STOP_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.communicate()
            pytest.fail(f"{argv}: still running {STOP_S} s after SIGTERM")
        assert time.monotonic() - start < STOP_S
        return process.returncode, err, True


def check_argv(template: Path, sandbox: Path, command: tuple, argv: list[str]) -> None:
    if sandbox.exists():
        shutil.rmtree(sandbox)
    shutil.copytree(template, sandbox)
    before = tree_state(sandbox)
    code, err, stopped = _run(argv, sandbox)
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err, (argv, err[-2000:])
    if stopped and code == -signal.SIGTERM:
        # The signal came after the command had finished and given the
        # signal back to the system's default (Python's shutdown): the
        # shell's 143 without rollsim's line, the work already done.
        pass
    elif stopped:
        assert code == 128 + signal.SIGTERM, (argv, code, lines[-3:])
        assert lines and lines[-1].startswith("rollsim: stopped by SIGTERM"), (argv, lines[-3:])
    else:
        assert code in (0, 1, 2) or 128 < code < 128 + 65, (argv, code, lines[-3:])
        if code in (1, 2):
            errors = [line for line in lines if ": error: " in line]
            assert 1 <= len(errors) <= MAX_ERROR_LINES and lines[-len(errors):] == errors, (argv, lines[-5:])
            assert len(set(errors)) == len(errors) and all(e.startswith("rollsim") for e in errors), (argv, errors)
    after = tree_state(sandbox)
    changed = sorted(path for path in set(before) | set(after) if before.get(path) != after.get(path))
    assert not _outside(changed, _allowed(command, argv)), (argv, _outside(changed, _allowed(command, argv)))


@settings(max_examples=EXAMPLES, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=argvs())
def test_any_argv_exits_cleanly_with_one_line_and_writes_only_its_outputs(template, tmp_path, case):
    command, argv = case
    check_argv(template, tmp_path / "sandbox", command, argv)


@pytest.mark.slow
@settings(max_examples=SLOW_EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=argvs())
def test_any_argv_exits_cleanly_many_examples(template, tmp_path, case):
    command, argv = case
    check_argv(template, tmp_path / "sandbox", command, argv)


def test_the_fuzzer_knows_every_command():
    assert {"render", "run", "decode", "evaluate", "sweep", "paper", "fit-camera"} <= {c[0] for c in COMMANDS}
    assert ("bench", "envelope") in COMMANDS
