"""``rollsim bench video``: its figures are measured and tabled against the targets (a small run)."""

from __future__ import annotations

from rollsim.bench.video import TARGET_FRAMES_PER_S, TARGET_READ_MS, bench_video, format_video

SMALL = ["camera.width_px=160", "camera.height_px=120", "camera.row_time_us=200"]


def test_the_video_bench_times_each_preset_against_the_png_render():
    result = bench_video(frames=4, presets=("superfast", "ultrafast"), workers=1, overrides=SMALL)
    assert result["resolution"] == "160x120" and result["png_frames_per_s"] > 0
    assert [r["preset"] for r in result["presets"]] == ["superfast", "ultrafast"]
    assert [r["default"] for r in result["presets"]] == [True, False]
    for row in result["presets"]:
        assert row["render_frames_per_s"] > 0 and row["read_ms_per_frame"] > 0
    assert result["targets"] == {"render_frames_per_s": TARGET_FRAMES_PER_S, "read_ms_per_frame": TARGET_READ_MS}
    text = format_video(result)
    assert "superfast (default)" in text and "frames/s" in text
