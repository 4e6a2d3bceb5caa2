"""Stripe geometry, exposure shape, footprint and truth against closed forms."""

import math

import numpy as np
import pytest

from rollsim.optics import led_image_size_px
from rollsim.render import RenderPipeline
from rollsim.transmitter import Waveform

from conftest import SingleChip, make_scene


def _led_profile(pipeline, index=0):
    """Mean DN over the central columns of the LED, per row."""
    frame = pipeline.render(index)
    cx = int(pipeline.setup.led_centre_px[0])
    return frame.image[:, cx - 5 : cx + 5].astype(float).mean(axis=1), frame


def _edge_positions(profile, rows):
    seg = profile[rows[0] : rows[1] + 1]
    mid = 0.5 * (seg.max() + seg.min())
    above = seg > mid
    # Sub-row edge positions by linear interpolation across the midpoint.
    idx = np.flatnonzero(above[1:] != above[:-1])
    frac = (mid - seg[idx]) / (seg[idx + 1] - seg[idx])
    return rows[0] + idx + frac


@pytest.mark.parametrize(
    "clock_hz, row_time_us, exposure_us",
    [(8000, 20.0, 50.0), (4000, 30.0, 100.0), (10000, 10.0, 30.0), (2000, 40.0, 400.0), (8000, 20.0, 180.0)],
)
def test_stripe_period_equals_two_chips_over_row_time(clock_hz, row_time_us, exposure_us):
    """Square pattern, no noise: the stripe period in rows is 2·T_chip/t_row.
    Includes exposures longer than a chip (the last two cases)."""
    scene = make_scene(
        camera={"row_time_us": row_time_us, "exposure_us": exposure_us, "height_px": 800, "width_px": 64},
        led={"size_mm": 100.0},
        link={"pattern": "square", "clock_hz": float(clock_hz)},
    )
    pipeline = RenderPipeline(scene)
    profile, _ = _led_profile(pipeline)
    edges = _edge_positions(profile, pipeline.setup.led_rows)
    # Rising and falling edges alternate; one period spans two edges.
    rising, falling = edges[0::2], edges[1::2]
    periods = [np.polyfit(np.arange(len(e)), e, 1)[0] for e in (rising, falling) if len(e) > 3]
    expected = 2.0 / clock_hz / (row_time_us * 1e-6)
    assert periods and all(abs(p - expected) < 0.5 for p in periods)


@pytest.mark.parametrize("exposure_us", [40.0, 125.0, 300.0])
def test_single_chip_profile_is_the_predicted_trapezoid(exposure_us):
    """An isolated chip of length T_c seen with exposure t_exp lights rows over
    (T_c + t_exp)/t_row rows, with a flat top of |T_c − t_exp|/t_row rows,
    and each row's value is the overlap of its window with the chip."""
    import dataclasses

    scene = make_scene(camera={"row_time_us": 10.0, "exposure_us": exposure_us, "height_px": 400, "width_px": 32},
                       led={"size_mm": 100.0})
    pipeline = RenderPipeline(scene)
    clock = 8000.0
    chip_on = 10  # starts at 1.25 ms, row 125
    wave = Waveform(SingleChip(chip_on), clock)
    tx = dataclasses.replace(pipeline.setup.transmitter, waveform=wave)
    pipeline = RenderPipeline.from_setup(dataclasses.replace(pipeline.setup, transmitter=tx))
    state = pipeline.run_stages(0)
    signal = state.led_exposure_s
    t_row, t_exp, T_c = 10e-6, exposure_us * 1e-6, 1 / clock
    starts = np.arange(400) * t_row
    a, b = chip_on * T_c, (chip_on + 1) * T_c
    overlap = np.clip(np.minimum(starts + t_exp, b) - np.maximum(starts, a), 0, None)
    np.testing.assert_allclose(signal, overlap, rtol=1e-12, atol=1e-18)
    lit = np.count_nonzero(signal > 1e-12)
    flat = np.count_nonzero(signal > signal.max() * (1 - 1e-9))
    assert abs(lit - (T_c + t_exp) / t_row) <= 1
    assert abs(flat - abs(T_c - t_exp) / t_row) <= 1


@pytest.mark.parametrize("distance_cm", [5.0, 10.0, 25.0])
def test_covered_rows_match_thin_lens(distance_cm):
    scene = make_scene(camera={"height_px": 1080, "width_px": 800}, led={"size_mm": 10.0}, link={"distance_cm": distance_cm})
    setup = RenderPipeline(scene).setup
    f, d = 3.97e-3, distance_cm * 1e-2
    size_px = 10e-3 * f / (d - f) / 1.4e-6
    assert led_image_size_px(scene) == pytest.approx(size_px)
    # A disk of diameter D centred on row 540: the rows with at least
    # MIN_ROW_COVERAGE_PX of area lie within [540 - D/2, 540 + D/2].
    first, last = setup.led_rows
    assert abs(first - (540 - size_px / 2)) <= 1.5 and abs(last + 1 - (540 + size_px / 2)) <= 1.5
    assert setup.footprint.coverage.sum() == pytest.approx(math.pi * size_px**2 / 4, rel=1e-9)


def test_fully_visible_sdus_lie_inside_the_led_rows_and_match_the_chips():
    scene = make_scene(camera={"height_px": 1080, "width_px": 48, "row_time_us": 25.0, "exposure_us": 60.0,
                               "output": "gray8"}, led={"size_mm": 25.0})
    pipeline = RenderPipeline(scene)
    tx = pipeline.setup.transmitter
    for index in range(3):
        frame = pipeline.render(index)
        truth = frame.truth
        first, last = truth["led_rows"]
        profile = frame.image[:, 20:28].astype(float).mean(axis=1)
        mid = 0.5 * (profile[first:last].max() + profile[first:last].min())
        visible = [s for s in truth["sdus"] if s["fully_visible"]]
        assert visible
        for sdu in visible:
            assert first <= sdu["first_row"] <= sdu["last_row"] <= last
            half = 0.5 * 60.0 / 25.0  # half an exposure, in rows
            assert sdu["first_row_f"] == pytest.approx(sdu["first_row"] - half, abs=1.0)
            # Sample the row centred on each chip's centre; with t_exp < T_c/2
            # that row integrates only that chip.
            chips = tx.sdu_chips[sdu["sequence"]]
            centres = sdu["start_s"] + (np.arange(chips.size) + 0.5) / tx.waveform.clock_hz
            rows = np.rint(pipeline.setup.timing.row_of_time(centres, truth["start_s"])).astype(int)
            np.testing.assert_array_equal((profile[rows] > mid).astype(np.uint8), chips)
            assert sdu["bits"] == "".join(map(str, tx.payloads[sdu["sequence"]]))


def test_geometric_paper_scene_is_tuned_as_documented():
    """paper-geometric's LED size reproduces the paper's measured ROI at 5 cm
    and its luminous intensity puts fully ON rows at 75% of the ADC range; a
    rendered frame's ON stripes are neither black nor clipped."""
    from rollsim.channel.channels import camcomsim_roi as paper_measured_roi  # Fig. 11's table
    from rollsim.render.tuning import effective_led_size_mm, luminous_intensity_for_on_fraction
    from rollsim.scene import load_scene

    scene = load_scene("paper-geometric")
    assert scene.led.size_mm == pytest.approx(effective_led_size_mm(scene, paper_measured_roi(5)), abs=0.05)
    assert scene.led.luminous_intensity_cd == pytest.approx(luminous_intensity_for_on_fraction(scene, 0.75), rel=2e-3)
    small = load_scene("paper-geometric", ["camera.width_px=64", "effects.shot_noise=false", "effects.read_noise=false"])
    pipeline = RenderPipeline(small)
    image = pipeline.render(0).image
    first, last = pipeline.setup.led_rows
    rows = image[first + 20 : last - 20, 28:36].astype(float).mean(axis=1)
    assert 0.6 * 255 < rows.max() < 0.9 * 255 and rows.min() < 0.2 * 255


def test_paper_scenes_share_one_parameter_set():
    """The paper's distance scenes differ from paper-default in the distance
    only (and their name): one emitter model, no per-distance tuning."""
    from rollsim.scene import load_scene, scene_to_dict

    def without(name, *keys):
        d = scene_to_dict(load_scene(name))
        for key in ("name", "description", *keys):
            d.pop(key, None)
        return d

    default = without("paper-default")
    far = without("paper-10cm")
    assert far["link"].pop("distance_cm") == 10 and default["link"].pop("distance_cm") == 5
    assert far == default
    assert load_scene("paper-default").led.size_mm == 5  # the testbed's 5 mm LED (paper sec. 3)
