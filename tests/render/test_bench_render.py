"""Render benchmarks: skipped by default, run with ``pytest -m benchmark``."""

import resource

import pytest

from rollsim.bench.render import bench_render, format_render
from rollsim.render import iter_frames

from conftest import make_scene


@pytest.mark.benchmark
def test_bench_render_reports_every_figure():
    result = bench_render(frames=3, e2e_frames=8, rss_frames=(10, 40), workers=2)
    print(format_render(result))
    assert set(result["in_memory_ms_per_frame"]) == {
        "core only (no effects)",
        "default effects, Poisson shot noise",
        "default effects, Gaussian shot noise",
    }
    assert result["end_to_end_frames_per_s"] > 0
    small, large = result["peak_rss_mb"].values()
    assert large < small * 1.2 + 20  # flat: memory does not grow with frames


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
