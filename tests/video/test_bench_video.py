"""``rollsim bench video``: its figures are measured and tabled against the targets (a small run)."""

from __future__ import annotations

from rollsim.bench.video import ENCODINGS, TARGET_FRAMES_PER_S, TARGET_READ_MS, bench_video, format_video

SMALL = ["camera.width_px=160", "camera.height_px=120", "camera.row_time_us=200"]


def test_the_video_bench_times_each_encoding_against_the_png_render():
    encodings = (ENCODINGS[0], ("ultrafast", {"preset": "ultrafast"}))
    result = bench_video(frames=4, encodings=encodings, workers=1, overrides=SMALL)
    assert result["resolution"] == "160x120" and result["png_frames_per_s"] > 0
    assert [r["encoding"] for r in result["encodings"]] == [ENCODINGS[0][0], "ultrafast"]
    assert [r["default"] for r in result["encodings"]] == [True, False]
    assert "preset superfast tune none b-frames 0" in result["encodings"][0]["settings"]
    assert "preset ultrafast" in result["encodings"][1]["settings"]
    for row in result["encodings"]:
        assert row["render_frames_per_s"] > 0 and row["steady_frames_per_s"] > 0 and row["read_ms_per_frame"] > 0
    assert result["targets"] == {"render_frames_per_s": TARGET_FRAMES_PER_S, "read_ms_per_frame": TARGET_READ_MS}
    text = format_video(result)
    assert ENCODINGS[0][0] in text and "frames/s" in text


def test_the_default_row_is_rollsims_default_encoding():
    from rollsim.video.settings import VideoSettings

    assert VideoSettings(**ENCODINGS[0][1]) == VideoSettings()
