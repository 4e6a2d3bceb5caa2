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

    # The geometric footprint of a uniform 17.3 mm disk, without glare.
    scene = load_scene("paper-default", ["led.size_mm=17.3", "effects.glare=false",
                                         "led.luminous_intensity_cd=0.0016", "environment.ambient_lux=20"])
    pipeline = RenderPipeline(scene)
    blocks = block_means(pipeline.render(0).image, 4)
    noise = horizontal_noise(blocks.blocks, row_step=2)
    kernel_rows = 7  # CLOSE_ROWS / 4, odd
    assert bright_mask(blocks.blocks, noise, kernel_rows, 1, 5.0) is None
    regions = detect_regions(blocks, CLOSE_ROWS)
    assert len(regions) == 1
    first, last = pipeline.setup.led_rows
    assert regions[0].rows.start <= first + 8 and regions[0].rows.stop >= last - 8


# ------------------------------------------------- detection by modulation


def _noise_frame(rng, sigma_dn, shape=(1080, 1920)):
    return np.clip(rng.normal(100.0, sigma_dn, shape), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("rows_per_chip", [3.0, 6.6, 20.0])
def test_noise_alone_is_never_modulated(rows_per_chip):
    """Pure noise, quantised to 8 bits as a camera does, from 0.5 to 40 DN:
    no block passes the threshold."""
    from decoder.region import _block_quantisation, modulated_mask

    rng = np.random.default_rng(7)
    kernel_rows = 2 * int(((3 + 1) * rows_per_chip + 8) / 8) + 1
    for sigma in (0.5, 2.0, 10.0, 40.0):
        blocks = block_means(_noise_frame(rng, sigma), 4)
        floor = _block_quantisation(blocks, blocks.blocks)
        assert not modulated_mask(blocks.blocks, rows_per_chip / 4, kernel_rows, floor).any()


def test_noise_power_is_unbiased_and_ignores_stripes():
    from decoder.region import _noise_power

    rng = np.random.default_rng(3)
    stripes = np.repeat((np.arange(300) // 3 % 2) * 50.0, 400).reshape(300, 400)
    noisy = stripes + rng.normal(0, 2.0, stripes.shape)
    power = _noise_power(noisy, 9)
    assert power.shape == noisy.shape
    assert power.mean() == pytest.approx(4.0, rel=0.03)


def _halo_frame(rng, amplitude_dn, rows_per_chip=6.6, shape=(1080, 1920), noise_dn=6.0):
    """A small saturated striped core and, round it, stripes of a Moffat halo
    whose amplitude falls from ``amplitude_dn`` at the core: a mean level far
    too faint for Otsu to split from the background."""
    height, width = shape
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    r2 = ((y - height / 2) ** 2 + (x - width / 2) ** 2) / 200.0**2
    halo = amplitude_dn / (1.0 + r2) ** 2
    on = (np.arange(height) / rows_per_chip).astype(int) % 2 == 0
    core = r2 < (20.0 / 200.0) ** 2
    signal = np.where(on[:, None], halo + np.where(core, 400.0, 0.0), 0.0)
    return np.clip(70.0 + signal + rng.normal(0, noise_dn, shape), 0, 255).astype(np.uint8), halo


def test_faint_halo_stripes_are_one_region_with_the_core():
    """Without the chip pitch only the core is found; with it, the region
    reaches as far as the halo's stripes stand out of the noise, and stays
    one region."""
    rng = np.random.default_rng(5)
    image, halo = _halo_frame(rng, amplitude_dn=12.0)
    blocks = block_means(image, 4)
    by_level = detect_regions(blocks, 35.0)
    by_modulation = detect_regions(blocks, 35.0, rows_per_chip=6.6)
    assert len(by_level) == 1 and by_level[0].rows.stop - by_level[0].rows.start < 80
    assert len(by_modulation) == 1
    rows = by_modulation[0].rows
    assert rows.start < 540 < rows.stop
    # The halo's ON level clears 1 DN (a sixth of the pixel noise) over a
    # block row out to |dy| ≈ 200·sqrt(sqrt(12) − 1) ≈ 314 rows.
    assert rows.stop - rows.start > 400
    assert rows.stop - rows.start < 2 * 320 + 40


def test_modulation_needs_stripes_not_level():
    """The same halo without stripes (a steady glow) is no region at all."""
    rng = np.random.default_rng(6)
    height, width = 1080, 1920
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    glow = 60.0 / (1.0 + ((y - 540) ** 2 + (x - 960) ** 2) / 300.0**2) ** 2
    image = np.clip(70.0 + glow + rng.normal(0, 6.0, (height, width)), 0, 255).astype(np.uint8)
    from decoder.region import _block_quantisation, modulated_mask

    blocks = block_means(image, 4)
    assert not modulated_mask(blocks.blocks, 6.6 / 4, 9, _block_quantisation(blocks, blocks.blocks)).any()
