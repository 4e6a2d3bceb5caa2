"""decoder.region: finding LED footprints cut into bands by stripes."""

import numpy as np
import pytest
from synth import make_transmitter, synth_frame

from decoder.region import block_means, choose_factor, detect_regions, horizontal_noise, otsu_threshold

CLOSE_ROWS = 20.0  # Manchester at 4.5 rows per chip


def regions_of(image, close_rows=CLOSE_ROWS):
    return detect_regions(block_means(image, choose_factor(image.shape[:2])), close_rows)


def bright_rows(frame):
    """First and last LED row that is mostly ON (OFF rows at the footprint's
    ends look like background and cannot be told from it)."""
    first, last = frame.led_rows
    on = first + np.flatnonzero(frame.row_level[first : last + 1] > 0.5)
    return int(on[0]), int(on[-1])


def test_otsu_splits_two_levels_and_rejects_constant():
    values = np.concatenate([np.full(300, 10.0), np.full(100, 200.0)]).astype(np.float32).reshape(20, 20)
    threshold, low, high = otsu_threshold(values)
    assert 10 < threshold < 200
    assert low == pytest.approx(10.0) and high == pytest.approx(200.0)
    assert otsu_threshold(np.full((5, 5), 3.0, np.float32)) is None


def test_horizontal_noise_ignores_stripes():
    rng = np.random.default_rng(1)
    stripes = np.repeat((np.arange(400) // 5 % 2) * 100.0, 300).reshape(400, 300)
    noisy = stripes + rng.normal(0, 3.0, stripes.shape)
    assert horizontal_noise(noisy) == pytest.approx(3.0, rel=0.05)


def test_disk_is_one_region_covering_its_rows():
    frame = synth_frame(make_transmitter(), size=700, noise_dn=5)
    regions = regions_of(frame.image)
    assert len(regions) == 1
    region = regions[0]
    first, last = bright_rows(frame)
    # Block quantisation plus one block of margin on each side.
    assert first - 8 <= region.rows.start <= first
    assert last + 1 <= region.rows.stop <= last + 9
    assert region.weights.shape == (region.rows.stop - region.rows.start, region.block_cols.stop - region.block_cols.start)
    # OFF bands inside the disk are part of the region (closed).
    middle = region.weights[(region.rows.stop - region.rows.start) // 2]
    assert middle.sum() >= 0.9 * 480 / 4  # the disk is wider than the frame


def test_led_filling_the_frame():
    frame = synth_frame(make_transmitter(), shape=(600, 300), kind="square", size=2000, noise_dn=3)
    regions = regions_of(frame.image)
    assert len(regions) == 1
    assert regions[0].rows == slice(0, 600)
    assert regions[0].weights.min() == 1.0


def test_led_partly_outside_the_frame():
    frame = synth_frame(make_transmitter(), centre=(240, 100), size=600, noise_dn=3)
    regions = regions_of(frame.image)
    assert len(regions) == 1
    assert regions[0].rows.start == 0
    # The disk's last rows are slivers: within a block of the last ON row.
    assert regions[0].rows.stop >= bright_rows(frame)[1] - 4


def test_two_leds_are_two_regions():
    left = synth_frame(make_transmitter(), shape=(800, 600), centre=(150, 400), size=250, background_dn=30)
    right = synth_frame(make_transmitter(start_s=1e-3), shape=(800, 600), centre=(450, 400), size=250, background_dn=0)
    image = np.clip(left.image.astype(int) + right.image, 0, 255).astype(np.uint8)
    regions = regions_of(image)
    assert len(regions) == 2
    starts = sorted(r.block_cols.start for r in regions)
    assert starts[0] < 150 // 4 < starts[1]


@pytest.mark.parametrize("kind", ["black", "saturated", "uniform_noise", "gaussian_noise", "noise16"])
def test_no_region_without_led(kind):
    rng = np.random.default_rng(5)
    image = {
        "black": lambda: np.zeros((240, 320), np.uint8),
        "saturated": lambda: np.full((240, 320), 255, np.uint8),
        "uniform_noise": lambda: rng.integers(0, 256, (240, 320)).astype(np.uint8),
        "gaussian_noise": lambda: np.clip(rng.normal(80, 20, (240, 320)), 0, 255).astype(np.uint8),
        "noise16": lambda: rng.integers(0, 65536, (240, 320)).astype(np.uint16),
    }[kind]()
    assert regions_of(image) == []


def test_dim_led_is_found_by_its_mean_level():
    """A rendered dim LED (ON rows at ~14 % of full scale over a dark, noisy
    background): its ON bands do not clear the noise by Otsu's margin, its
    level averaged over a few chips does."""
    from rollsim.render import RenderPipeline
    from rollsim.scene import load_scene

    from decoder.region import bright_mask

    scene = load_scene("paper-default", ["led.luminous_intensity_cd=0.0016", "environment.ambient_lux=20"])
    pipeline = RenderPipeline(scene)
    blocks = block_means(pipeline.render(0).image, 4)
    noise = horizontal_noise(blocks.blocks, row_step=2)
    kernel_rows = 7  # CLOSE_ROWS / 4, odd
    assert bright_mask(blocks.blocks, noise, kernel_rows, 1, 5.0) is None
    regions = detect_regions(blocks, CLOSE_ROWS)
    assert len(regions) == 1
    first, last = pipeline.setup.led_rows
    assert regions[0].rows.start <= first + 8 and regions[0].rows.stop >= last - 8
