"""rollsim bench render: every figure present, derived figures consistent, the text shows them.

On a tiny frame and a frame or two per figure; no figure is compared with a
time (the targets live in the benchmark, see tests/render/test_bench_render.py).
The fresh-process figures (start-up, peak memory) are stubbed here.
"""

import json
import re

import pytest

from rollsim.bench import render as bench
from rollsim.cli import main
from rollsim.effects import REGISTRY
from rollsim.render import RenderPipeline
from rollsim.scene import load_scene

TINY = ["camera.width_px=96", "camera.height_px=64"]
WORKERS = 2


@pytest.fixture(scope="module")
def result():
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(bench, "startup_seconds", lambda args, runs, out_arg=False: [0.5 + 0.1 * i for i in range(runs)])
        patch.setattr(bench, "peak_rss_mb", lambda scene, overrides, frames, workers: 100.0 + frames / 100)
        return bench.bench_render(frames=2, e2e_frames=4, rss_frames=(3, 30), workers=WORKERS, effect_frames=1,
                                  decode_frames=2, decode_repeats=3, e2e_repeats=3, startup_runs=3,
                                  overrides=TINY)


@pytest.fixture(scope="module")
def text(result):
    return bench.format_render(result)


def test_every_stage_of_the_pipeline_is_profiled(result, text):
    # The stages as they run, whatever their names (fused or not).
    names = [stage.name for stage in RenderPipeline(load_scene(bench.SCENE, TINY)).stages]
    profile = result["stage_profile"]
    assert [s["stage"] for s in profile["stages"]] == list(names)
    assert profile["effects"] == ["ambient", "shot_noise", "read_noise"] and profile["frames"] == 2
    total = profile["total_ms_per_frame"]
    assert total > 0
    table = text[text.index("1. stages"):text.index("render (the stages")]
    for stage in profile["stages"]:
        assert stage["ms_per_frame"] >= 0
        assert stage["share_pct"] == pytest.approx(100 * stage["ms_per_frame"] / total)
        assert re.search(rf"^{re.escape(stage['stage'])} +.* {stage['ms_per_frame']:.2f} ", table, re.M)
    assert re.search(rf"^total \(the stages of one frame\) +{total:.2f} +<= 15 ms/frame", table, re.M)


def test_png_floor_and_end_to_end_ratio_derive_from_the_figures(result, text):
    png_ms, floor = result["png_encode_ms_per_frame"], result["png_floor_frames_per_s"]
    assert png_ms > 0 and floor == pytest.approx(WORKERS * 1000 / png_ms)
    runs = result["end_to_end_frames_per_s_runs"]
    assert len(runs) == 3 and runs == sorted(runs) and result["end_to_end_frames_per_s"] == runs[1]
    ratio = result["end_to_end_vs_png_floor"]
    assert ratio == pytest.approx(result["end_to_end_frames_per_s"] / floor)
    assert f"{png_ms:.1f} ms/frame -> floor {floor:.1f} frames/s on {WORKERS} workers" in text
    assert f"median {result['end_to_end_frames_per_s']:.1f} frames/s" in text
    assert f"= {ratio:.2f}x the PNG floor" in text


def test_every_registered_effect_is_costed_and_the_heavy_ones_marked(result, text):
    costs = result["effects_cost"]
    table = text[text.index("3. each effect"):text.index("4. in memory")]
    assert [c["effect"] for c in costs] == [effect.name for effect in REGISTRY]
    limit = bench.TARGETS["effect_ms_added"][1]
    for c in costs:
        assert c["heavy"] == (c["effect"] in ("motion", "defocus", "video_codec"))
        if c["ms_added"] is None:
            assert c["note"].startswith("not measured") and c["met"] is None
            continue
        assert c["ms_added"] == pytest.approx(c["ms_with"] - c["ms_without"])
        if c["heavy"]:
            assert c["target_ms"] is None and c["met"] is None
            assert f"{c['effect']} (heavy)" in table
        else:
            assert c["target_ms"] == limit and c["met"] == (c["ms_added"] <= limit)
        added = re.escape(f"{c['ms_added']:+.1f}")
        assert re.search(rf"^{re.escape(c['effect'])}\b.* {added} ", table, re.M)
    by_name = {c["effect"]: c for c in costs}
    assert by_name["shot_noise"]["listed"] and by_name["shot_noise"]["parameters_from"] == "paper-geometric"
    assert by_name["blur"]["parameters_from"] == "effect-blur"
    assert by_name["blur"]["parameters"]["sigma_px"] == load_scene("effect-blur").effects.blur.sigma_px


def test_in_memory_and_fresh_process_figures(result, text):
    decode = result["in_memory_decode"]
    assert decode["workers"] == WORKERS and decode["frames"] == 2
    runs = decode["frames_per_s_workers_runs"]
    assert decode["frames_per_s"] > 0 and len(runs) == 3 and runs == sorted(runs) and min(runs) > 0
    assert decode["frames_per_s_workers"] == runs[1]
    assert decode["render_ms_per_frame"] > 0 and decode["decode_ms_per_frame"] > 0
    assert f"{WORKERS} workers: median {decode['frames_per_s_workers']:.1f} frames/s" in text
    render, describe = result["startup"]["render"], result["startup"]["describe"]
    assert render["runs_s"] == pytest.approx([0.5, 0.6, 0.7]) and render["median_s"] == pytest.approx(0.6)
    assert render["command"].startswith("rollsim render paper-geometric --frames 1 --set=camera.width_px=96")
    assert describe["command"] == "rollsim describe paper-default"
    assert result["peak_rss_mb"] == pytest.approx({"3": 100.03, "30": 100.3}) and result["memory_flat"] is True


def test_summary_has_one_row_per_target_met_as_measured(result, text):
    rows = {row["key"]: row for row in result["summary"]}
    assert set(rows) == set(bench.TARGETS) | {"memory_flat"}
    assert rows["default_effects_ms_per_frame"]["measured"] == result["in_memory_ms_per_frame"][bench.DEFAULT_VARIANT]
    assert rows["end_to_end_frames_per_s"]["measured"] == result["end_to_end_frames_per_s"]
    assert rows["in_memory_decode_frames_per_s"]["measured"] == result["in_memory_decode"]["frames_per_s_workers"]
    assert rows["render_one_frame_s"]["measured"] == result["startup"]["render"]["median_s"]
    worst = max((c for c in result["effects_cost"] if not c["heavy"] and c["ms_added"] is not None),
                key=lambda c: c["ms_added"])
    assert rows["effect_ms_added"]["measured"] == worst["ms_added"] and worst["effect"] in rows["effect_ms_added"]["detail"]
    for key, (comparison, value, unit) in bench.TARGETS.items():
        row = rows[key]
        assert row["unit"] == unit and row["target"] == f"{comparison} {value:g} {unit}"
        assert row["met"] == (row["measured"] <= value if comparison == "<=" else row["measured"] >= value)
        assert row["target"] in text
    assert text.index("targets") < text.index("1. stages")


def test_result_is_strict_json_and_says_how_busy_the_machine_was(result, text):
    again = json.loads(json.dumps(result, allow_nan=False))
    assert again["counts"]["rss_frames"] == [3, 30] and again["resolution"] == "96x64"
    parts = {"stages", "png", "effects", "in_memory", "startup", "memory"}
    assert set(again["part_seconds"]) == set(again["load_average_1min"]["after_part"]) == parts
    assert f"took {result['seconds']:.0f} s: stages" in text


def test_bundled_parameters_prefer_the_effects_own_scene():
    found = bench.bundled_effect_parameters()
    assert found["motion"][0] == "effect-motion" and found["dark_current"][0] == "effect-row_noise"
    assert "defocus" not in found  # its focus distance is relative to the scene's


def test_quick_counts_give_way_to_explicit_options():
    class Args:
        quick, frames, effect_frames, decode_frames, decode_repeats, e2e_frames, e2e_repeats = True, 7, *[None] * 5
        startup_runs = None
        rss_frames = [10, 20]

    counts = bench.counts_from_args(Args())
    assert counts == {**bench.QUICK_COUNTS, "frames": 7, "rss_frames": (10, 20)}
    Args.quick = False
    assert bench.counts_from_args(Args())["e2e_frames"] == bench.DEFAULT_COUNTS["e2e_frames"]


def test_cli_refuses_bad_options_before_any_work(capsys):
    assert main(["bench", "render", "--effects", "no_such_effect"]) == 2
    assert "vignetting" in capsys.readouterr().err
    assert main(["bench", "render", "--rss-frames", "50", "20"]) == 2
    assert "--rss-frames 50 20" in capsys.readouterr().err
    assert main(["bench", "render", "--set", "camera.width_px=-3"]) == 2
    assert "camera.width_px" in capsys.readouterr().err
