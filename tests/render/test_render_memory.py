"""The memory estimates behind the budget checks are upper bounds of what a process really uses.

Peak resident memory (VmHWM, reset before the work) is measured in a fresh
process, so that OpenCV's own allocations, which tracemalloc does not see,
count too.
"""

import json
import subprocess
import sys

import pytest

from rollsim.stages.decode import DECODE_BYTES_PER_PIXEL
from rollsim.render.pipeline import render_memory_bytes
from rollsim.scene import load_scene

_MEASURE = r"""
import json, re, sys
from pathlib import Path

def rss(field):
    return int(re.search(field + r":\s+(\d+) kB", Path("/proc/self/status").read_text()).group(1)) * 1024

from rollsim.scene import load_scene
from rollsim.render import RenderPipeline
from rollsim.stages.decode import settings_from_scene
from decoder import decode_frame

scene = load_scene("paper-default", json.loads(sys.argv[1]))
Path("/proc/self/clear_refs").write_text("5")  # reset the high-water mark
base = rss("VmRSS")
pipeline = RenderPipeline(scene)
image = pipeline.render(0).image
image = pipeline.render(1).image
render_peak = rss("VmHWM") - base
settings = settings_from_scene(scene)
Path("/proc/self/clear_refs").write_text("5")
base = rss("VmRSS")
decode_frame(image, settings.phy, settings.clock_hz, settings.row_time_s, 1)
decode_peak = rss("VmHWM") - base
print(json.dumps({"render": render_peak, "decode": decode_peak}))
"""

ALL_EFFECTS = ["effects.blur=null", "effects.vignetting=null", "effects.prnu=null", "effects.dsnu=null",
               "effects.dark_current=null", "effects.flicker=null", "effects.blooming=null", "effects.motion=null",
               "effects.led_rise_time=null", "effects.tone_curve=null",
               "effects.glare=false"]  # motion cannot be combined with glare; the glare case has it
SIZE = ["camera.width_px=1920", "camera.height_px=1080"]
SMALL = ["camera.width_px=192", "camera.height_px=108"]


@pytest.mark.parametrize(
    "overrides",
    [SIZE, [*SIZE, *ALL_EFFECTS], [*SIZE, "effects.bayer=null", "camera.output=rgb8"],
     [*SIZE, "effects.defocus.focus_distance_cm=20"],
     [*SIZE, "effects.glare=null", "effects.led_profile=null", "effects.blur=null"]],
    ids=["default", "every-effect", "bayer-rgb8", "defocus", "glare"],
)
def test_render_and_decode_stay_within_their_estimates(overrides):
    # The kernels compiled first (a small frame of the same scene), as after a machine's first
    # render: numba's compiler, not the render, would set the peak (a cold cache exceeds the
    # every-effect estimate by 1 %), and which test compiles first depends on the test processes' order.
    subprocess.run([sys.executable, "-c", _MEASURE, json.dumps([*overrides, *SMALL])], capture_output=True, check=True)
    done = subprocess.run([sys.executable, "-c", _MEASURE, json.dumps(overrides)], capture_output=True, text=True,
                          check=True)
    peak = json.loads(done.stdout)
    print(overrides[2:], peak)
    scene = load_scene("paper-default", overrides)
    pixels = scene.camera.width_px * scene.camera.height_px
    assert peak["render"] <= render_memory_bytes(scene, workers=1)
    assert peak["decode"] <= DECODE_BYTES_PER_PIXEL * pixels
