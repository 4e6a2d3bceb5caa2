"""The decoder on the paper's scenes, rendered in memory and evaluated against the truth.

The acceptance figures (300 frames per scene, full 1920 x 1080 frames) are
slow tests: ``python -m pytest -m slow tests/test_decode_paper_scenes.py``.
The default run checks the same on fewer, narrower frames.
"""

import pytest

from rollsim.bench.stress import scene_outcomes
from rollsim.scene import load_scene

SCENES = ["paper-default", "paper-10cm"]


def check_paper_outcomes(summary: dict) -> None:
    assert summary["fully_visible"] > 0
    assert 1.0 - summary["error_rate"] >= 0.995
    assert summary["false_decodes"] == 0
    assert summary["counts"]["undetected_error"] == 0


@pytest.mark.parametrize("check", ["parity2", "crc8"])
@pytest.mark.parametrize("name", SCENES)
def test_paper_scenes_few_frames(name, check):
    # 480 columns: the disk fills the width, every row is as in the full frame.
    scene = load_scene(name, ["camera.width_px=480", f"link.check={check}"])
    check_paper_outcomes(scene_outcomes(scene, 24))


@pytest.mark.slow
@pytest.mark.parametrize("check", ["parity2", "crc8"])
@pytest.mark.parametrize("name", SCENES)
def test_paper_scenes_300_frames(name, check):
    summary = scene_outcomes(load_scene(name, [f"link.check={check}"]), 300)
    print(name, check, summary["counts"], summary["fully_visible"])
    check_paper_outcomes(summary)
