"""rollsim bench decode and bench stress: the decoder's speed and outcome tables."""

import json

import pytest

from rollsim.bench.decode import bench_decode, format_decode
from rollsim.bench.stress import HEADER, default_scenes, format_markdown
from rollsim.sweeps.stream import scene_outcomes
from rollsim.cli import main
from rollsim.scene import load_scene


def test_stress_set_is_bundled():
    names = default_scenes()
    for kind in ("low-light", "high-iso", "long-exposure", "small-far", "strong-ambient", "saturation", "partly-out"):
        assert f"stress-{kind}" in names
    assert {"paper-default", "paper-10cm"} <= set(names)


def test_scene_outcomes_counts_every_emission():
    scene = load_scene("stress-saturation", ["camera.width_px=320"])
    summary = scene_outcomes(scene, 4)
    counts = summary["counts"]
    assert sum(counts.values()) == summary["emissions"] > 0
    assert counts["ok"] >= summary["fully_visible"] - 1 > 0
    assert summary["false_decodes"] == 0
    assert summary["render_ms_per_frame"] > 0 and summary["decode_ms_per_frame"] > 0


def test_bench_stress_cli_writes_the_table(tmp_path, capsys):
    table, data = tmp_path / "stress.md", tmp_path / "stress.json"
    args = ["bench", "stress", "stress-partly-out", "--frames", "2", "--workers", "1", "--markdown", str(table)]
    assert main(args + ["--json", str(data)]) == 0
    assert "stress-partly-out" in capsys.readouterr().out
    text = table.read_text()
    assert text.startswith("| " + " | ".join(HEADER) + " |")
    result = json.loads(data.read_text())
    assert result["frames"] == 2 and result["scenes"][0]["scene"] == "stress-partly-out"
    assert format_markdown(result) + "\n" == text


def test_bench_stress_refuses_a_bad_scene_before_work(capsys):
    assert main(["bench", "stress", "no-such-scene", "--frames", "1"]) == 2
    assert "no-such-scene" in capsys.readouterr().err


@pytest.mark.benchmark
def test_bench_decode_reports_both_figures():
    result = bench_decode(frames=3, scenes=("paper-default",))
    print(format_decode(result))
    figures = result["scenes"]["paper-default"]
    assert figures["decode_ms_per_frame"] > 0 and figures["png_read_ms_per_frame"] > 0
