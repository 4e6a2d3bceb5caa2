"""Binned readout (camera.binning_rows): timing, identical row groups, the mean kept,
the temporal variance divided by k, and the truth's rows on group boundaries."""

import numpy as np
import pytest

from rollsim.render import render_frames
from rollsim.render.truth import frame_truth
from rollsim.scene import load_scene
from rollsim.sensor import RowTiming

SMALL = ["camera.width_px=96", "camera.height_px=240", "led.size_mm=80", "led.luminous_intensity_cd=3",
         "camera.iso=800", "link.pattern=square", "link.clock_hz=2000"]


def _scene(k, extra=()):
    return load_scene("paper-geometric", [*SMALL, f"camera.binning_rows={k}", *extra])


def test_rows_of_a_group_start_together_and_groups_every_k_row_times():
    timing = RowTiming(frame_period_s=1 / 30, row_time_s=10e-6, exposure_s=50e-6, height_px=12, binning_rows=3)
    start, end = timing.row_windows(1.0)
    np.testing.assert_allclose(start - 1.0, np.repeat([0, 30e-6, 60e-6, 90e-6], 3), atol=1e-15)
    np.testing.assert_allclose(end - start, 50e-6)
    # The average rate is unchanged: the last group starts (H − k)·t_row after the first.
    assert timing.rows_span_s(4, 11, 1.0) == pytest.approx((1.0 + 30e-6, 1.0 + 90e-6 + 50e-6))


@pytest.mark.parametrize("k", [2, 3])
def test_the_output_rows_come_in_identical_groups(k):
    image = np.asarray(render_frames(_scene(k), 1)[0][0])
    groups = image.reshape(image.shape[0] // k, k, -1)
    assert np.all(groups == groups[:, :1])


def test_without_noise_a_binned_row_is_the_unbinned_row_that_starts_its_group():
    # Every row of a group is exposed over the same window; with the LED
    # covering them all, the k rows' means agree and their average is the
    # unbinned frame's first row of the group (exposure conservation).
    quiet = ["effects.shot_noise=false", "effects.read_noise=false", "camera.output=raw16", "camera.prnu_percent=0",
             "camera.dsnu_e=0", "camera.dark_current_e_per_s=0"]
    one = np.asarray(render_frames(_scene(1, quiet), 1)[0][0]).astype(float)
    two = np.asarray(render_frames(_scene(2, quiet), 1)[0][0]).astype(float)
    rows = slice(60, 180)  # inside the LED
    np.testing.assert_allclose(two[rows][0::2], one[rows][0::2], atol=0.51)


def test_the_mean_is_kept_and_the_temporal_variance_falls_k_fold():
    # A flat, bright field (the LED covers the frame, its square wave
    # averaged by a whole-period exposure): frame differences cancel the
    # fixed patterns and leave twice the temporal variance.
    flat = ["camera.output=raw16", "camera.exposure_us=1000", "camera.width_px=300", "camera.height_px=200",
            "led.size_mm=200"]
    stats = {}
    for k in (1, 2):
        a, b = (np.asarray(f).astype(float) for f in render_frames(_scene(k, flat), 2)[0])
        diff = (a - b)[20:180:k, 20:280]  # one row of each group: the groups' values
        stats[k] = (a[20:180, 20:280].mean(), diff.var() / 2)
    assert stats[2][0] == pytest.approx(stats[1][0], rel=0.01)
    # Shot and read noise of two independent rows averaged: half the
    # variance (the DN rounding of the mean adds 1/12 DN², small here).
    assert stats[2][1] / stats[1][1] == pytest.approx(0.5, rel=0.08)


def test_the_truth_rows_of_a_phy_sdu_sit_on_group_boundaries():
    from rollsim.render import RenderPipeline

    scene = load_scene("paper-geometric", ["camera.binning_rows=4"])
    setup = RenderPipeline(scene).setup
    sdus = frame_truth(setup, 0, 0.0)["sdus"]  # the data pattern: PHY-SDUs in every frame
    assert sdus
    for sdu in sdus:
        assert sdu["first_row"] % 4 == 0 and sdu["last_row"] % 4 == 3


def test_binning_must_divide_the_height():
    from rollsim.errors import SceneError

    with pytest.raises(SceneError, match="camera.binning_rows = 7: must divide camera.height_px = 1080"):
        load_scene("paper-geometric", ["camera.binning_rows=7"])
