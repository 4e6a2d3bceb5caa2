"""Render benchmarks: skipped by default, run with ``pytest -m benchmark``."""

import resource

import pytest

from rollsim.bench.render import bench_render, format_render
from rollsim.render import iter_frames

from conftest import make_scene


@pytest.mark.benchmark
def test_bench_render_reports_every_figure():
    """Every part at 1080p with few frames (a minute or two); the speed targets are printed, not asserted."""
    result = bench_render(frames=3, e2e_frames=8, rss_frames=(10, 40), workers=2, effect_frames=2, decode_frames=4,
                          decode_repeats=1, e2e_repeats=1, startup_runs=1)
    print(format_render(result))
    assert result["resolution"] == "1920x1080"
    assert set(result["in_memory_ms_per_frame"]) == {
        "core only (no effects)",
        "default effects, Poisson shot noise",
        "default effects, Gaussian shot noise",
    }
    assert result["stage_profile"]["total_ms_per_frame"] > 0
    assert result["end_to_end_frames_per_s"] > 0 and result["png_floor_frames_per_s"] > 0
    assert all(c["ms_added"] is not None for c in result["effects_cost"])  # every effect renders at 1080p
    assert result["in_memory_decode"]["frames_per_s_workers"] > 0
    assert all(figure["median_s"] > 0 for figure in result["startup"].values())
    small, large = result["peak_rss_mb"].values()
    assert large < small * 1.2 + 20  # flat: memory does not grow with frames
    assert result["memory_flat"]


@pytest.mark.benchmark
def test_100000_frames_stream_in_constant_memory():
    """100,000 frames of a small scene, streamed: memory after the run is
    what it was after the first thousand frames."""
    scene = make_scene(effects=("ambient", "shot_noise", "read_noise"), camera={"height_px": 64, "width_px": 48})
    frames = iter_frames(scene, 100_000)
    for k, frame in enumerate(frames):
        if k == 1000:
            early = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        assert frame.image.shape == (64, 48)
    late = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    assert k == 99_999 and late < early * 1.1 + 10_000
