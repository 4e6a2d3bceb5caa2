"""rollsim.fit.measure.find_led_region checked by where the stripes move.

The brightest frame alone misplaces the LED where something else is as
bright: a bright background lights the frame's border as an LED filling the
frame would, and a brighter static lamp draws the disk. The stripes, which
move between frames, say where the LED is; the frames' swing (brightest less
darkest) around them gives its disk.
"""

import numpy as np
import pytest

from rollsim.fit.measure import LedDisk, clear_background_block, disk_from_swing, find_led_region, halo_free, \
    lit_border_fraction
from rollsim.fit.refine import moving_stripes

PERIOD_ROWS = 16.0


def _frames(shape, centre, radius, background, amplitude, seed=1, lamp=None, count=6, noise=3.0, face=None):
    """8-bit frames of a striped LED disk on a flat background (each frame its own stripe phase),
    its face at ``face`` when OFF (default the background's level), with an optional static
    lamp (centre, radius, level) brighter than the LED."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    inside = np.hypot(xx + 0.5 - centre[0], yy + 0.5 - centre[1]) <= radius
    frames = []
    for phase in rng.uniform(0, PERIOD_ROWS, count):
        on = ((yy + phase) % PERIOD_ROWS) < PERIOD_ROWS / 2
        image = np.where(inside, float(background if face is None else face), float(background))
        image += amplitude * (inside & on)
        if lamp is not None:
            (lx, ly), lr, level = lamp
            image[np.hypot(xx + 0.5 - lx, yy + 0.5 - ly) <= lr] = level
        image += rng.normal(0.0, noise, shape)
        frames.append(np.clip(np.rint(image), 0, 255).astype(np.uint8))
    return frames


def _region(frames, stripes):
    return find_led_region(np.asarray(frames, dtype=np.float64), 1.8, PERIOD_ROWS, stripes)


def test_a_bright_background_is_not_an_led_filling_the_frame():
    # An LED whose face is dark when OFF, on a background brighter than half its ON level.
    frames = _frames((300, 400), (84.0, 200.0), 40.0, background=150, amplitude=180, face=20, noise=5.0)
    assert _region(frames, None).disk is None  # the lit border alone reads as an LED filling the frame
    disk = _region(frames, moving_stripes(frames)).disk
    assert disk is not None
    assert disk.centre_x_px == pytest.approx(84.0, abs=3.0)
    assert disk.centre_y_px == pytest.approx(200.0, abs=3.0)
    assert disk.radius_px == pytest.approx(40.0, rel=0.1)


@pytest.mark.parametrize("noise", [3.0, 10.0, 20.0])
def test_pixel_noise_does_not_light_the_border(noise):
    # A faint LED (stripes of 25 levels) on a background as bright as its face: the
    # maximum of six frames' noise stands ~1.3 sigma above the background and the
    # minimum as far below it, as far as the stripes reach at sigma 10 (seed 6
    # camera 2 of the benchmark: 8-bit noise of ~10 levels, an LED 0.39 full scale).
    frames = _frames((300, 400), (200.0, 150.0), 110.0, background=140, amplitude=25, noise=noise)
    stack = np.asarray(frames, dtype=np.float64)
    assert lit_border_fraction(stack, stack.max(axis=0), stack.min(axis=0), PERIOD_ROWS) < 0.05
    disk = _region(frames, None).disk
    assert disk is not None
    assert disk.centre_x_px == pytest.approx(200.0, abs=5.0) and disk.centre_y_px == pytest.approx(150.0, abs=5.0)


def test_the_border_envelope_is_the_whole_frames_box_average():
    # Computed on strips along the edges, it equals the whole frame's box average, maximum over
    # frames and over a stripe period of rows, read on the border.
    from scipy.ndimage import maximum_filter1d, uniform_filter

    from rollsim.fit.measure import BORDER_BOX_COLUMNS, BORDER_BOX_ROWS, _border_envelope

    rng = np.random.default_rng(5)
    for stack, period in [(rng.uniform(0, 255, (4, 90, 70)), p) for p in (3.0, 16.0, 40.0, 400.0)] + \
            [(rng.uniform(0, 255, (3, 200, 6)), 16.0)]:  # a crop narrower than the box
        box = (1, max(1, int(BORDER_BOX_ROWS * period)) | 1, BORDER_BOX_COLUMNS)
        whole = uniform_filter(stack, box, mode="nearest").max(axis=0)
        whole = maximum_filter1d(whole, size=max(1, int(np.ceil(period))) | 1, axis=0, mode="nearest")
        border = np.concatenate([whole[0], whole[-1], whole[1:-1, 0], whole[1:-1, -1]])
        np.testing.assert_allclose(_border_envelope(stack, period), border, rtol=1e-12)


def test_a_brighter_lamp_does_not_draw_the_disk():
    frames = _frames((300, 400), (300.0, 150.0), 45.0, background=20, amplitude=60, lamp=((80.0, 80.0), 30.0, 250))
    lamp_disk = _region(frames, None).disk
    assert lamp_disk is not None and abs(lamp_disk.centre_x_px - 80.0) < 45.0  # drawn on the lamp
    disk = _region(frames, moving_stripes(frames)).disk
    assert disk.centre_x_px == pytest.approx(300.0, abs=3.0)
    assert disk.centre_y_px == pytest.approx(150.0, abs=3.0)
    assert disk.radius_px == pytest.approx(45.0, rel=0.1)


def test_a_crop_the_led_fills_across_keeps_its_rows_and_background():
    frames = _frames((600, 30), (15.0, 250.0), 160.0, background=60, amplitude=80)
    region = _region(frames, moving_stripes(frames))
    disk = region.disk
    assert disk.centre_x_px == pytest.approx(15.0)
    assert disk.centre_y_px == pytest.approx(250.0, abs=3.0)
    assert disk.radius_px == pytest.approx(160.0, rel=0.05)
    assert region.block is not None and region.block[0].start >= 250 + 160  # the rows below the LED


def test_an_led_filling_the_frame_has_no_disk():
    frames = _frames((200, 300), (150.0, 100.0), 400.0, background=30, amplitude=90)
    stripes = moving_stripes(frames)
    stack = np.asarray(frames, dtype=np.float64)
    assert disk_from_swing(stack.max(axis=0), stack.min(axis=0), stripes, PERIOD_ROWS) is None
    assert _region(frames, stripes).disk is None


def test_a_crop_the_led_fills_across_is_placed_by_its_lit_rows_where_the_stripes_hide():
    # Benchmark seed 2 camera 17: a 22-column crop, the LED's rows 52-394 of 410, its
    # stripes faint against the pixel noise (the frames' swing is flat, no stripes found):
    # the background above and below it is darker.
    frames = _frames((410, 22), (11.0, 223.0), 171.0, background=20, amplitude=12, face=30, noise=8.0)
    region = _region(frames, None)
    assert region.disk is not None
    assert region.disk.centre_x_px == pytest.approx(11.0)
    assert region.disk.centre_y_px == pytest.approx(223.0, abs=3.0)
    assert region.disk.radius_px == pytest.approx(171.0, rel=0.03)
    assert region.block is not None and region.block[0].stop <= 223 - 171  # the rows above the LED


def test_an_led_spanning_the_rows_of_a_wide_frame_is_placed_by_its_lit_columns():
    # A disk of radius 195 px cut by the top and bottom of a 120-row frame lights over half
    # of its border, as an LED filling the frame would; its lit columns are its diameter.
    frames = _frames((120, 600), (200.0, 60.0), 195.0, background=20, amplitude=80, face=30)
    region = _region(frames, None)
    assert region.disk is not None
    assert region.disk.centre_x_px == pytest.approx(200.0, abs=2.0)
    assert region.disk.centre_y_px == pytest.approx(60.0)
    assert region.disk.radius_px == pytest.approx(195.0, rel=0.02)


@pytest.mark.parametrize("seed", range(4))
def test_a_noisy_crop_the_led_fills_keeps_a_band_inside_it(seed):
    # The LED fills a 22-column crop: the swing across its columns is noise, whose
    # half-height run can draw a disk centred beyond the crop's edge, which leaves no band
    # to read (benchmark seed 2 camera 17 cropped to the LED's rows). Such a disk is not taken.
    frames = _frames((334, 22), (11.0, 167.0), 400.0, background=20, amplitude=12, face=30, noise=8.0, seed=seed)
    stripes = moving_stripes(frames) or (slice(100, 250), 11.0)
    region = _region(frames, stripes)
    disk = region.disk
    assert disk is None or (0 <= disk.centre_x_px <= 22 and 0 <= disk.centre_y_px <= 334)
    rows, cols = region.band
    assert 0 <= rows.start < rows.stop <= 334 and 0 <= cols.start < cols.stop <= 22


def test_a_disk_whose_band_lies_outside_the_frame_is_refused_in_words():
    """A disk found wrongly (its centre beyond the frame's edge) leaves no band to read:
    a ValueError naming it, not the means of an empty slice."""
    from rollsim.fit.measure import LedDisk, central_band

    assert central_band(LedDisk(50.0, 40.0, 20.0, 10), (100, 120)) == (slice(23, 57), slice(44, 56))
    for disk in (LedDisk(130.0, 40.0, 20.0, 10), LedDisk(50.0, -30.0, 20.0, 10)):
        with pytest.raises(ValueError, match="no band of rows inside the 120x100 px frame"):
            central_band(disk, (100, 120))


def test_a_large_led_takes_its_background_nearer_where_no_halo_shows():
    # A disk of radius 120 px centred in a 300 x 400 frame: nothing lies beyond 1.8 radii, but
    # the columns beyond 1.5 radii (x < 20 and x >= 380) are background.
    shape, disk = (300, 400), LedDisk(200.0, 150.0, 120.0, 200)
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    distance = np.hypot(xx + 0.5 - 200.0, yy + 0.5 - 150.0)
    flat = np.where(distance <= 120.0, 200.0, 40.0)
    block = clear_background_block(flat, disk, 1.8)
    assert block is not None and block[0] == slice(0, 300)
    assert block[1].stop <= 200 - 1.5 * 120 + 1 or block[1].start >= 200 + 1.5 * 120 - 1
    assert halo_free(flat, block, disk)
    noisy = flat + np.random.default_rng(3).normal(0.0, 2.0, shape)  # a mean frame's noise
    assert halo_free(noisy, block, disk) and clear_background_block(noisy, disk, 1.8) == block
    # A glare halo falling with the distance from the LED: its wing lies in every nearer block.
    halo = flat + np.where(distance > 120.0, 2000.0 / np.maximum(distance - 100.0, 1.0), 0.0)
    assert not halo_free(halo, block, disk)
    assert clear_background_block(halo, disk, 1.8) is None


def test_a_band_shorter_than_two_stripe_periods_is_refused_in_words():
    # A region found wrongly (seed 6 camera 29's green plane: 8 rows of a
    # 16.7-row period) cannot be fitted; a ValueError, by which a colour
    # plane so read is passed over (rollsim.fit.refine.measured_planes).
    from rollsim.fit.camera import MIN_BAND_PERIODS, measure
    from rollsim.fit.measure import LedRegion

    rows = np.arange(200)[:, None]
    frames = [100.0 + 60.0 * (np.mod(rows + 3.0 * f, 20.0) < 10.0) + np.zeros((200, 40)) for f in range(3)]
    row_time = (1.0 / (4000 * 10.0), 0.0)  # a period of 20 rows at 4 kHz
    short = LedRegion(None, (slice(100, 139), slice(10, 30)), None)
    assert 39 < MIN_BAND_PERIODS * 20.0
    with pytest.raises(ValueError, match=r"the LED's rows hold 1\.9 stripe periods \(< 2\)"):
        measure(frames, 4000.0, row_time, region=short)
