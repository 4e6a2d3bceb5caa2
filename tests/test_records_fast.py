"""Reading records fast: the fast check is the schema's check, bad lines are found at once.

The fast check of a decoded record (rollsim.stages.records.is_decoded_record) must
accept and refuse exactly what the jsonschema validator does, plus the values
JSON cannot hold (NaN, infinities, anything json.dumps refuses): hypothesis
generates records, valid and not, and compares the two.
"""

import json
import math
import sys
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from jsonschema import Draft202012Validator

from rollsim.errors import RollsimError
from rollsim.stages.records import (MAX_DEPTH, MAX_VALUES, as_decoded_record, is_decoded_record, iter_jsonl, read_decoded,
                             read_jsonl, record_error, schema)

GOOD = {"frame": 1, "first_row": 10, "last_row": 120.5, "first_row_f": 9.5, "last_row_f": 121.0, "sequence": 3,
        "bits": "0101", "check_ok": True, "confidence": 0.5, "status": "ok", "region": 0, "run": "0123456789abcdef"}
LINE = json.dumps(GOOD, separators=(",", ":"))


def _plain_json(value, depth=0) -> bool:
    """What json.dumps(allow_nan=False) writes and reads back as it was: the oracle for the values."""
    if isinstance(value, dict):
        return all(isinstance(k, str) for k in value) and all(_plain_json(v, depth + 1) for v in value.values())
    if isinstance(value, (list, tuple)):
        return all(_plain_json(v, depth + 1) for v in value)
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return True
    if isinstance(value, int):
        try:
            float(value)
        except OverflowError:
            return False
        return True
    return isinstance(value, float) and math.isfinite(value)


def _oracle(record) -> bool:
    try:
        json.dumps(record, allow_nan=False)
    except (ValueError, TypeError):
        return False
    # JSON values first: the validator cannot compare a complex number with its minimum.
    return _plain_json(record) and Draft202012Validator(schema()).is_valid(record)


numbers = st.one_of(
    st.integers(-5, 5), st.integers(-(2**70), 2**70), st.just(10**400), st.just(-(10**400)),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0.0, -0.0, 1.0, -1.0, 3.0, 2.5, 1e308]),
    st.builds(np.float64, st.floats(allow_nan=True)), st.builds(np.int64, st.integers(-5, 5)),
    st.builds(np.float32, st.floats(width=32)), st.just(1 + 2j),
)
scalars = st.one_of(numbers, st.booleans(), st.none(), st.text(max_size=6), st.sampled_from(["", "01", "0101\n", "10x", "\n"]))
values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=3) | st.tuples(inner) | st.dictionaries(
    st.text(max_size=3) | st.integers(0, 3), inner, max_size=3), max_leaves=8)
names = st.sampled_from(sorted(GOOD) + ["extra", "diag"])


@st.composite
def records(draw):
    if draw(st.integers(0, 20)) == 0:
        return draw(values)  # not even an object, perhaps
    record = dict(GOOD)
    for name in draw(st.lists(names, max_size=4)):
        if draw(st.booleans()):
            record.pop(name, None)
        else:
            record[name] = draw(values)
    return record


@settings(max_examples=3000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(record=records())
def test_the_fast_check_accepts_and_refuses_what_the_schema_and_json_do(record):
    expected = _oracle(record)
    assert is_decoded_record(record) == expected
    assert (record_error(record) is None) == expected


@pytest.mark.parametrize("change, message", [
    ({"first_row": float("nan")}, "first_row = nan: not a finite number"),
    ({"confidence": float("inf")}, "confidence = inf: not a finite number"),
    ({"x": [1, {"y": -math.inf}]}, "x.1.y = -inf: not a finite number"),
    ({"last_row": 10**400}, "0000: not a finite number (beyond a 64-bit float)"),
    ({"x": np.float32(1)}, ": not a JSON value (float32)"),  # its value as numpy prints it (set by other tests)
    ({"x": {1, 2}}, "x = {1, 2}: not a JSON value (set)"),
    ({"x": {3: 1}}, "x.3: an object key must be a string"),
    ({"run": 5}, "run = 5: expected string"),
])
def test_values_json_cannot_hold_are_named(change, message):
    assert record_error({**GOOD, **change}).endswith(message)
    assert not is_decoded_record({**GOOD, **change})


def test_a_record_holding_itself_or_nested_deep_or_huge_is_refused_in_bounded_time():
    looped: list = []
    looped.append(looped)
    deep: list = []
    inner = deep
    for _ in range(MAX_DEPTH + 1):
        inner.append([])
        inner = inner[0]
    for extra, message in ((looped, f"nested deeper than {MAX_DEPTH} levels"),
                           (deep, f"nested deeper than {MAX_DEPTH} levels"),
                           (list(range(MAX_VALUES)), f"the record: more than {MAX_VALUES} values")):
        start = time.perf_counter()
        assert message in record_error({**GOOD, "x": extra})
        assert not is_decoded_record({**GOOD, "x": extra})
        assert time.perf_counter() - start < 2.0
    assert is_decoded_record({**GOOD, "x": list(range(MAX_VALUES - 100))})


def test_a_plugins_numbers_that_are_not_json_are_refused_at_the_boundary():
    with pytest.raises(RollsimError, match="frame 2: decoded record: first_row = nan: not a finite number"):
        as_decoded_record({**GOOD, "first_row": float("nan")}, 2)
    assert as_decoded_record({**GOOD, "run": "theirs"}, 2, "mine")["run"] == "mine"
    assert "run" not in as_decoded_record({**GOOD, "run": "theirs"}, 2)


# --------------------------------------------------------------- files


def test_nan_literals_on_disk_are_refused_with_the_line_and_field(tmp_path):
    path = tmp_path / "d.jsonl"
    path.write_text(LINE + "\n" + LINE.replace('"first_row":10', '"first_row":NaN') + "\n")
    with pytest.raises(RollsimError, match=r"d.jsonl: line 2: first_row = nan: not a finite number$"):
        read_decoded(path)
    path.write_text(LINE.replace('"confidence":0.5', '"confidence":-Infinity') + "\n")
    with pytest.raises(RollsimError, match="line 1: confidence = -inf: not a finite number"):
        read_decoded(path)


@pytest.mark.parametrize("line, message", [
    (b"{oops", "line 3: not valid JSON (Expecting property name enclosed in double quotes)"),
    (b'{"a": "\xff"}', "line 3: not UTF-8 text (invalid start byte at byte 7)"),
    (b"[" * 100_000, "line 3: not valid JSON (maximum recursion depth exceeded"),
    (b"1" * 5000, "line 3: not valid JSON (Exceeds the limit (4300 digits)"),
])
def test_a_garbage_line_is_named_by_its_number(tmp_path, line, message):
    path = tmp_path / "d.jsonl"
    path.write_bytes(LINE.encode() + b"\n  \n" + line + b"\n" + LINE.encode() + b"\n")
    with pytest.raises(RollsimError) as caught:
        read_jsonl(path)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_blank_lines_and_crlf_are_read_as_before(tmp_path):
    path = tmp_path / "d.jsonl"
    path.write_bytes(f"{LINE}\r\n\r\n \u00a0\n{LINE}".encode())
    assert [n for n, _ in iter_jsonl(path)] == [1, 4]
    assert read_decoded(path) == [GOOD, GOOD]


def test_records_of_another_run_are_refused_with_the_line_unless_allowed(tmp_path):
    path = tmp_path / "d.jsonl"
    others = {k: v for k, v in GOOD.items() if k != "run"}
    path.write_text("\n".join(json.dumps(r) for r in (GOOD, others, {**GOOD, "run": "fedcba9876543210"})) + "\n")
    with pytest.raises(RollsimError, match="line 3: run = 'fedcba9876543210': records of another render"):
        read_decoded(path, "0123456789abcdef")
    assert len(read_decoded(path)) == 3


def _million_lines(path, first: str, line: str = LINE) -> None:
    with open(path, "w") as out:
        out.write(first + "\n")
        block = (line + "\n") * 10_000
        for _ in range(100):
            out.write(block)


@pytest.mark.parametrize("first, message", [("{oops", "line 1: not valid JSON"),
                                            (LINE.replace('"bits":"0101"', '"bits":"01x1"'), "line 1: bits = '01x1'")])
def test_a_bad_first_line_of_a_million_is_refused_at_once(tmp_path, monkeypatch, first, message):
    # The memory budget (checked from the file's size, before reading) is
    # set high: this test is about reading, on any machine.
    monkeypatch.setenv("ROLLSIM_MEMORY_LIMIT", "1T")
    path = tmp_path / "decoded.jsonl"
    _million_lines(path, first)
    for read in (read_jsonl, read_decoded) if "oops" in first else (read_decoded,):
        start = time.perf_counter()
        with pytest.raises(RollsimError, match=message):
            read(path)
        assert time.perf_counter() - start < 1.0  # O(1): a generous bound for a busy machine


def _throughput(what: str, n: int, call) -> None:
    start, cpu = time.perf_counter(), time.process_time()
    call()
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    print(f"\n{what}: {n / wall:,.0f} records/s ({n / cpu:,.0f} per CPU second; {wall:.2f} s for {n:,})")


@pytest.mark.benchmark
def test_benchmark_a_million_valid_records(tmp_path, monkeypatch):
    """read_decoded, and evaluate --decoded as a whole, on 1,000,000 records of rollsim's decoder."""
    from rollsim.cli import main
    from rollsim.stages.evaluate import evaluate_directory

    monkeypatch.setenv("ROLLSIM_MEMORY_LIMIT", "1T")
    run = tmp_path / "run"
    assert main(["render", "paper-default", "--out", str(run), "--frames", "10", "--workers", "1", "--quiet",
                 "--set", "camera.width_px=64"]) == 0
    assert main(["decode", str(run), "--workers", "1", "--quiet"]) == 0
    own = (run / "decoded.jsonl").read_text().splitlines()
    path = tmp_path / "decoded.jsonl"
    with open(path, "w") as out:
        for i in range(1_000_000):
            out.write(own[i % len(own)] + "\n")
    _throughput("read_decoded", 1_000_000, lambda: read_decoded(path))
    _throughput("evaluate --decoded", 1_000_000,
                lambda: evaluate_directory(run, force=True, decoded_file=path))
    print(f"Python {sys.version.split()[0]}")
