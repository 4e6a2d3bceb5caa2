"""Hostile input: every case gives one line on stderr, the right exit code, no
traceback, and changes no file outside its target.

The memory cases run in a real process under a 1 GiB address-space limit
and must fail (or answer) within 5 s, without allocating what they ask for.
"""

import json
import struct
import zlib

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from clitools import GIB, SMALL, assert_one_error, run_rollsim, tree_state
from rollsim.cli import main
from rollsim.errors import SceneError
from rollsim.scene import scene_from_dict
from rollsim.scene.loader import MAX_YAML_DEPTH, parse_overrides


def _main(capsys, *argv):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.err


def _unchanged_around(tmp_path, capsys, argv, code, *fragments, cwd=None, monkeypatch=None):
    """Run ``argv`` in-process; one error line, exit ``code``, nothing under tmp_path changed."""
    if cwd is not None:
        monkeypatch.chdir(cwd)
    before = tree_state(tmp_path)
    got, err = _main(capsys, *argv)
    assert_one_error(err, code, *fragments)
    assert got == code
    assert tree_state(tmp_path) == before
    return err


# ------------------------------------------------------------- scene files

ALIAS_BOMB = "name: bomb\n" + "\n".join(
    f"{name}: &{name} [{', '.join(['*' + prev] * 10)}]" for prev, name in zip("abcdefgh", "bcdefghi")
).replace("b: &b [*a", 'a: &a ["x", "x", "x", "x", "x", "x", "x", "x", "x", "x"]\nb: &b [*a') + "\ndescription: *i\n"


@pytest.mark.parametrize(
    "text, fragments",
    [
        ("? [a, b]\n: 1\n", ["line 1", "a key must be a plain value"]),
        ("seed: " + "7" * 5000 + "\n", ["an integer of 5000 digits"]),
        ("camera: " + "[" * 100_000 + "]" * 100_000 + "\n", [f"nested deeper than {MAX_YAML_DEPTH} levels"]),
        (ALIAS_BOMB, ["expands to more than 100000 values"]),
        ("name: x\nname: y\n", ["duplicate key 'name'"]),
        ("description: [" + "x, " * 100 + "]\n", ["description = ['x', 'x', 'x', 'x', 'x', 'x', ...]: must be a string"]),
        ("camera:\n  preset: [a]\n", ["camera.preset = ['a']: must be a preset name"]),
        ("effects: [[blur]]\n", ["effects: ['blur']: a list of effects holds effect names"]),
        ("\x00\x01", ["YAML error"]),
        (b"\xff\xfe", ["not UTF-8 text"]),
    ],
    ids=["complex-key", "5000-digits", "100k-nesting", "alias-bomb", "duplicate", "long-value", "preset-list",
         "effects-nested-list", "nul-bytes", "not-utf8"],
)
def test_bad_scene_files_are_one_line(tmp_path, capsys, monkeypatch, text, fragments):
    scene = tmp_path / "scene.yaml"
    scene.write_bytes(text if isinstance(text, bytes) else text.encode())
    err = _unchanged_around(tmp_path, capsys, ["validate", scene], 2, str(scene), *fragments)
    # The message, not the temporary folder's name (longer under pytest-xdist), is bounded.
    assert len(err.replace(str(scene), "scene.yaml")) < 400


def test_a_device_a_directory_and_a_huge_file_are_not_inputs(tmp_path, capsys, monkeypatch):
    _unchanged_around(tmp_path, capsys, ["validate", "/dev/zero"], 2, "/dev/zero: not a regular file")
    _unchanged_around(tmp_path, capsys, ["calibrate", "/dev/zero"], 2, "/dev/zero: not a regular file")
    _unchanged_around(tmp_path, capsys, ["decode", tmp_path / "nope"], 2, "nope: does not exist")
    _unchanged_around(tmp_path, capsys, ["describe", tmp_path], 2, "is a directory")
    big = tmp_path / "big.yaml"
    big.write_text("description: " + "x" * (2 << 20) + "\n")
    _unchanged_around(tmp_path, capsys, ["validate", big], 2, "larger than 1024 KiB")


@pytest.mark.parametrize(
    "override, fragments",
    [
        ("camera.preset=[a]", ["camera.preset = ['a']: must be a preset name"]),
        ("effects=[[a]]", ["effects: ['a']: a list of effects holds effect names"]),
        ("seed=" + "9" * 5000, ["an integer of 5000 digits"]),
        ("link.distance_cm=" + "[" * 1000, ["cannot parse the value"]),
        ("link={a: [1]}", ["link.a: unknown key"]),
        ("link.clock_hz=1e-300", ["link.clock_hz = 1e-300", "allowed [0.1, 1e+07] for this run"]),
        ("link.clock_hz=.nan", ["link.clock_hz = nan"]),
        ("camera.frame_rate_hz=1e-300", ["camera.frame_rate_hz = 1e-300: out of range, allowed [0.01, 10000]"]),
        ("camera.row_time_us=1e-300", ["camera.row_time_us = 1e-300: out of range, allowed [0.001, 100000]"]),
        ("camera.ifg_ratio=0.999999999999", ["gives a row time of", "at least 1 ns per row"]),
        ("frames=1000000000", ["frames = 1000000000", "beyond the 2**53"]),
    ],
)
def test_bad_overrides_are_one_line(tmp_path, capsys, monkeypatch, override, fragments):
    extra = ["--set", "camera.frame_rate_hz=0.01", "--set", "link.clock_hz=1e7", "--set", "camera.row_time_us=1",
             "--set", "camera.exposure_us=100"] if override.startswith("frames=") else []
    err = _unchanged_around(tmp_path, capsys, ["describe", "paper-default", *extra, "--set", override], 2, *fragments)
    assert len(err) < 400


scalars = st.one_of(st.none(), st.booleans(), st.integers(-(10**30), 10**30), st.floats(allow_nan=True),
                    st.text(max_size=20))
values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner,
                                                                                           max_size=4), max_leaves=20)
SECTIONS = ["camera", "led", "link", "environment", "channel", "render", "effects", "seed", "frames", "name"]


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.dictionaries(st.sampled_from(SECTIONS) | st.text(max_size=8), values, max_size=5))
def test_any_scene_data_is_valid_or_one_line_per_problem(data):
    try:
        scene_from_dict(data, "fuzz.yaml")
    except SceneError as exc:
        assert exc.lines and all("\n" not in line and len(line) < 600 for line in exc.lines)


@settings(max_examples=300, deadline=None)
@given(text=st.text(max_size=60))
def test_any_override_text_parses_or_is_one_line(text):
    try:
        parse_overrides([text])
    except SceneError as exc:
        assert len(exc.lines) == 1 and len(exc.lines[0]) < 400


# ------------------------------------------------------------------ outputs


@pytest.fixture
def rendered(tmp_path_factory):
    out = tmp_path_factory.mktemp("hostile") / "run"
    assert main(["run", "paper-default", "--out", str(out), "--frames", "4", "--workers", "1", "--quiet", *SMALL]) == 0
    return out


@pytest.mark.parametrize(
    "argv",
    [
        ["analytic", "--json", "{f}"],
        ["analytic", "--plot", "{f}"],
        ["simulate", "paper-default", "--runs", "2", "--json", "{f}"],
        ["calibrate", "{run}", "--json", "{f}"],
        ["estimate-row-time", "{run}", "--clock-hz", "8000", "--json", "{f}"],
        ["bench", "render", "--json", "{f}"],
        ["bench", "eventsim", "--json", "{f}"],
        ["bench", "decode", "--json", "{f}"],
        ["bench", "stress", "--json", "{f}"],
        ["bench", "stress", "--markdown", "{f}"],
    ],
    ids=lambda a: " ".join(a[:2]) + (" " + a[-2] if a[-2].startswith("--") else ""),
)
def test_existing_output_files_are_never_replaced_without_force(tmp_path, capsys, monkeypatch, rendered, argv):
    target = tmp_path / "mine.png"
    target.write_text("the user's file")
    argv = [a.replace("{f}", str(target)).replace("{run}", str(rendered)) for a in argv]
    _unchanged_around(tmp_path, capsys, argv, 2, f"{target}: exists; use --force to replace it")
    assert target.read_text() == "the user's file"
    # A directory is no file name, and a plot is a PNG.
    argv = [str(tmp_path) if a == str(target) else a for a in argv]
    _unchanged_around(tmp_path, capsys, argv, 2, f"{tmp_path}: is a directory")


def test_force_replaces_an_output_file_and_checks_come_first(tmp_path, capsys, monkeypatch):
    target = tmp_path / "a.json"
    target.write_text("old")
    _unchanged_around(tmp_path, capsys, ["analytic", "--plot", tmp_path / "out.xyz"], 2, "ending in .png")
    _unchanged_around(tmp_path, capsys, ["analytic", "--p", "inf", "--q", "0"], 2, "--p = inf: must be in [0, 1]")
    _unchanged_around(tmp_path, capsys, ["analytic", "--p-e", "nan"], 2, "--p-e = nan")
    assert main(["analytic", "--json", str(target), "--force"]) == 0
    assert json.loads(target.read_text())["M"] == 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]


def test_out_may_not_be_the_working_directory_nor_hold_the_inputs(tmp_path, capsys, monkeypatch, rendered):
    _unchanged_around(rendered.parent, capsys, ["render", "paper-default", "--out", ".", "--force", "--quiet"], 2,
                      "is the working directory or holds it", cwd=rendered, monkeypatch=monkeypatch)
    scene = tmp_path / "scenes" / "mine.yaml"
    scene.parent.mkdir()
    scene.write_text("name: mine\n")
    monkeypatch.chdir(tmp_path)
    _unchanged_around(tmp_path, capsys, ["render", scene, "--out", scene.parent, "--force", "--quiet"], 2,
                      "holds the input")
    _unchanged_around(tmp_path, capsys, ["run", scene, "--out", scene, "--quiet"], 2, "holds the input")


# ------------------------------------------------- memory, under 1 GiB of address space


def _png_declaring(width: int, height: int, bit_depth: int = 16, colour_type: int = 6) -> bytes:
    """A tiny, well-formed PNG header that declares a huge image."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", width, height, bit_depth, colour_type, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b"")


MEMORY_CASES = {
    "huge message": (["describe", "paper-default", "--set", "link.message_bytes=10000000", "--set", "link.header_bits=32"],
                     2, ["link.message_bytes = 10000000", "needs about", "memory budget"]),
    "huge frame": (["render", "paper-default", "--out", "out", "--frames", "1", "--set", "camera.width_px=20000",
                    "--set", "camera.height_px=20000", "--set", "camera.row_time_us=1"],
                   2, ["camera.width_px x height_px = 20000 x 20000", "needs about"]),
    "billion emissions": (["describe", "paper-default", "--emissions", "1000000000"], 2, ["--emissions = 1000000000"]),
    "alias bomb": (["validate", "bomb.yaml"], 2, ["expands to more than 100000 values"]),
    "PNG bomb": (["decode", "pngs", "--clock-hz", "8000", "--quiet", "--workers", "1"], 0,
                 ["skipped frame 0", "declares 32000x32000 pixels"]),
    "billion runs": (["simulate", "paper-default", "--runs", "1000000000", "--quiet"], 2, ["runs = 1000000000"]),
}


@pytest.mark.parametrize("name", list(MEMORY_CASES))
def test_memory_cases_fail_cleanly_within_5_s_under_1_gib(tmp_path, name):
    argv, code, fragments = MEMORY_CASES[name]
    (tmp_path / "bomb.yaml").write_text(ALIAS_BOMB)
    (tmp_path / "pngs").mkdir()
    (tmp_path / "pngs" / "frame_000000.png").write_bytes(_png_declaring(32000, 32000))
    before = tree_state(tmp_path)
    result = run_rollsim(*argv, cwd=tmp_path, address_space=GIB, timeout=30)
    stderr = "\n".join(line for line in result.err_lines)
    assert "Traceback" not in stderr and "MemoryError" not in stderr
    assert_one_error(result, code, *fragments)
    assert result.seconds < 5.0
    after = tree_state(tmp_path)
    if name == "PNG bomb":  # the decode itself is written into pngs/; the frame is skipped
        assert sorted(after) == sorted([*before, "pngs/decode.json", "pngs/decoded.jsonl"])
        after = {k: v for k, v in after.items() if not k.startswith("pngs")}
        before = {k: v for k, v in before.items() if not k.startswith("pngs")}
    assert after == before


def test_a_billion_slot_cycle_answers_under_1_gib(tmp_path):
    result = run_rollsim("analytic", "--M", "1000000000", "--r-max", "3", cwd=tmp_path, address_space=GIB)
    assert result.returncode == 0 and result.stderr == "" and result.seconds < 5.0
    assert len(result.stdout.splitlines()) == 4


def test_memory_limit_option_and_variable(tmp_path, capsys, monkeypatch):
    args = ["describe", "paper-default", "--set", "link.message_bytes=100000", "--set", "link.header_bits=16"]
    code, err = _main(capsys, "--memory-limit", "1M", *args)
    assert code == 2 and "more than the memory budget of 1 MB" in err
    monkeypatch.setenv("ROLLSIM_MEMORY_LIMIT", "1M")
    code, err = _main(capsys, *args)
    assert code == 2 and "ROLLSIM_MEMORY_LIMIT" in err
    code, err = _main(capsys, "--memory-limit", "1G", *args)
    assert code == 0
    code, err = _main(capsys, "--memory-limit", "lots", *args)
    assert_one_error(err, 2, "--memory-limit = 'lots': expected a size")
