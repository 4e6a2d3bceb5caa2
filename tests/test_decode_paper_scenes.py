"""The decoder on the paper's scenes, rendered in memory and evaluated against the truth.

The acceptance figures (300 frames per scene, full 1920 x 1080 frames) are
slow tests: ``python -m pytest -m slow tests/test_decode_paper_scenes.py``.
The default run checks the same on fewer frames.

Two kinds of scene:

* ``paper-geometric``: a uniform LED disk with sharp edges. Every fully
  visible PHY-SDU must be read (99.5 %).
* ``paper-default`` and ``paper-10cm``: the testbed's LED with its glare
  (one parameter set). The truth counts a PHY-SDU as fully visible in the
  rows an ideal receiver reads (:mod:`rollsim.effects.readable`), which reach
  further into the halo than the decoder's (0.78 of the frame against 0.71
  at 10 cm), so the decoder misses PHY-SDUs there. At 5 cm the centre
  saturates (10.7 full scales at its peak); thresholding reads it with a
  local edge-bias correction, and where it leaves PHY-SDUs unread the
  decoder, told the exposure, reads them by sequence detection
  (``decoder.equalise``). The floors below are under what 300 frames
  measured (97.9 % and 98.7 % at 5 cm, 0 corrupted; 81.9 % and 80.7 % at
  10 cm, parity2 and CRC-8), to catch a regression; nothing may be decoded
  falsely or pass its check wrongly.
"""

import pytest

from rollsim.sweeps.stream import scene_outcomes
from rollsim.scene import load_scene

FLOORS = {"paper-geometric": 0.995, "paper-default": 0.93, "paper-10cm": 0.65}


def check_paper_outcomes(name: str, summary: dict) -> None:
    assert summary["fully_visible"] > 0
    assert 1.0 - summary["error_rate"] >= FLOORS[name]
    assert summary["false_decodes"] == 0
    assert summary["counts"]["undetected_error"] == 0


@pytest.mark.parametrize("check", ["parity2", "crc8"])
def test_geometric_scene_few_frames(check):
    # 480 columns: the disk fills the width, every row is as in the full frame.
    scene = load_scene("paper-geometric", ["camera.width_px=480", f"link.check={check}"])
    check_paper_outcomes("paper-geometric", scene_outcomes(scene, 24))


@pytest.mark.parametrize("name", ["paper-default", "paper-10cm"])
def test_paper_scenes_few_frames(name):
    # Full frames: a narrower one would crop the halo (a different scene).
    check_paper_outcomes(name, scene_outcomes(load_scene(name), 10))


@pytest.mark.slow
@pytest.mark.parametrize("check", ["parity2", "crc8"])
@pytest.mark.parametrize("name", ["paper-geometric", "paper-default", "paper-10cm"])
def test_paper_scenes_300_frames(name, check):
    summary = scene_outcomes(load_scene(name, [f"link.check={check}"]), 300)
    print(name, check, summary["counts"], summary["fully_visible"])
    check_paper_outcomes(name, summary)
