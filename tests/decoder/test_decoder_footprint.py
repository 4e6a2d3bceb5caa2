"""decoder.footprint: the LED's columns of a striped band, told by their level."""

import warnings

import numpy as np
import pytest
from scipy.ndimage import uniform_filter1d
from synth import footprint_coverage

from decoder.footprint import (FOOTPRINT_LEVEL_SIGMA, FOOTPRINT_TOLD_FRACTION, background_levels,
                               block_column_levels, footprint_weights, nearest_told)
from decoder.profile import stripe_band_weights, stripe_weighted_profile
from decoder.region import Region, band_means, block_means


def test_block_column_levels_are_block_means_and_their_running_mean():
    rng = np.random.default_rng(0)
    crop = rng.normal(40.0, 8.0, (200, 130)).astype(np.float32)
    means, levels = block_column_levels(crop, 4, 32, level_rows=9)
    expected = crop[:, :128].reshape(200, 32, 4).mean(axis=2, dtype=np.float64)
    assert means.shape == levels.shape == (200, 32)
    assert np.allclose(means, expected, atol=1e-4)
    assert np.allclose(levels, uniform_filter1d(expected, 9, axis=0, mode="nearest"), atol=1e-4)


def test_background_levels_are_the_median_of_the_weightless_bands():
    band_levels = np.array([[1.0, 5.0, 3.0, 9.0], [1.0, 5.0, 3.0, 9.0], [1.0, 5.0, 3.0, 9.0], [2.0, 2.0, 2.0, 2.0]])
    weightless = np.array([[True, True, True, False], [True, False, True, True], [False, False, False, False],
                           [False, True, False, False]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        found = background_levels(band_levels, weightless)
    assert found[0] == 3.0                     # median of 1, 5, 3
    assert found[1] == 3.0                     # median of 1, 3, 9
    assert np.isnan(found[2])                  # no weightless band
    assert found[3] == 2.0
    assert background_levels(band_levels[:, :2], np.array([[True, True]] * 4))[0] == 3.0   # even count: the mean of two


def _levels_row(led_columns, led_dn, background_dn=60.0, n_columns=16):
    row = np.full(n_columns, background_dn)
    row[led_columns] = led_dn
    return row


@pytest.mark.parametrize("led_dn", [25.0, 90.0])
def test_the_columns_at_the_led_level_weigh_alike(led_dn):
    # Four bands of four block columns. The LED covers band 2 and the right
    # half of band 1; the stripes' weights (smoothed over many rows) also
    # put a little on band 3, wholly background. The LED's six columns take
    # 1/6 each, whether its face is darker or brighter than the background.
    band_weights = np.array([[0.0, 0.3, 0.6, 0.1]])
    levels = _levels_row(slice(6, 12), led_dn)[None, :]
    weights = footprint_weights(band_weights, levels, level_noise=1.0, fill_rows=0)
    expected = np.zeros(16)
    expected[6:12] = 1.0 / 6.0
    assert np.allclose(weights[0], expected)


def test_rows_the_level_cannot_tell_keep_the_bands_weights():
    band_weights = np.array([[0.0, 0.3, 0.7, 0.0],     # LED level within the noise of the background's
                             [0.1, 0.2, 0.6, 0.1],     # no weightless band: no background level
                             [0.0, 0.0, 0.0, 0.0]])    # no stripes
    close = 60.0 + 0.9 * FOOTPRINT_LEVEL_SIGMA
    levels = np.stack([_levels_row(slice(6, 12), close), _levels_row(slice(6, 12), 25.0), _levels_row(slice(6, 12), 25.0)])
    weights = footprint_weights(band_weights, levels, level_noise=1.0, fill_rows=0)
    assert np.allclose(weights[:2], np.repeat(band_weights[:2] / 4.0, 4, axis=1))
    assert np.all(weights[2] == 0.0)
    assert np.all(np.isfinite(weights))


def test_nearest_told_row_within_reach():
    told = np.array([False, False, True, False, False, False, False, True, False, False, False, False])
    assert nearest_told(told, 2).tolist() == [2, 2, 2, 2, 2, 7, 7, 7, 7, 7, -1, -1]
    assert nearest_told(np.zeros(4, dtype=bool), 3).tolist() == [-1, -1, -1, -1]


def test_the_led_columns_are_found_off_the_heaviest_band_and_carried_to_rows_not_told():
    # Ten rows of four bands. The stripes' weights (smoothed over many rows)
    # put most on band 3, wholly background; the LED covers band 1. Row 4's
    # LED is as bright as the wall (an ON chip): it is not told, and takes
    # its neighbours' columns rather than the bands' weights.
    band_weights = np.tile([0.0, 0.3, 0.2, 0.5], (10, 1))
    levels = np.tile(_levels_row(slice(4, 8), 25.0), (10, 1))
    levels[4, 4:8] = 60.0
    weights = footprint_weights(band_weights, levels, level_noise=1.0, fill_rows=2)
    expected = np.zeros(16)
    expected[4:8] = 0.25
    assert np.allclose(weights, expected[None, :])


def test_a_profile_told_in_too_few_rows_keeps_the_bands_weights():
    # The level tells the LED's columns in fewer than FOOTPRINT_TOLD_FRACTION
    # of the rows with stripes: a switch inside the LED would step the
    # level, so no row switches.
    n_rows = 20
    band_weights = np.tile([0.0, 0.5, 0.5, 0.0], (n_rows, 1))
    levels = np.tile(_levels_row(slice(4, 12), 60.0), (n_rows, 1))
    told_rows = int(np.ceil(FOOTPRINT_TOLD_FRACTION * n_rows)) - 1
    levels[:told_rows, 6:12] = 25.0                 # the right half of band 1, all of band 2
    weights = footprint_weights(band_weights, levels, level_noise=1.0, fill_rows=0)
    assert np.allclose(weights, np.repeat(band_weights / 4.0, 4, axis=1))
    levels[: told_rows + 1, 6:12] = 25.0
    assert not np.allclose(footprint_weights(band_weights, levels, level_noise=1.0, fill_rows=0)[0],
                           np.repeat(band_weights[0] / 4.0, 4))


def test_a_disks_ends_are_read_as_the_matched_filter_reads_them():
    # A uniform disk (a face at 25 DN on a 60 DN wall, as paper-geometric's)
    # with weak stripes and 8 DN of pixel noise. Near its top and bottom the
    # chord is a few 32-pixel bands wide and its edges cross them. Against
    # the matched filter (the exact mean over the disk's pixels: 11.0 and
    # 12.3 dB of stripe SNR over the top and bottom 85 rows), the bands'
    # weights alone read -3.6 and -6.6 dB (their weights move along the
    # rows between bands of the face and of the wall, and the level with
    # them); with the footprint's level the profile reads 11.1 and 12.0 dB.
    rng = np.random.default_rng(3)
    n_rows, n_cols, rows_per_chip = 1080, 1920, 4.5
    chips = rng.integers(0, 2, int(n_rows / rows_per_chip) + 2)
    stripes = chips[(np.arange(n_rows) / rows_per_chip).astype(int)].astype(float)
    disk = footprint_coverage((n_rows, n_cols), (960.0, 540.0), 1066.0, "disk")
    frame = 60.0 + disk * (-35.0 + 1.5 * stripes[:, None]) + rng.normal(0.0, 8.0, (n_rows, n_cols))
    frame = frame.astype(np.float32)
    image = block_means(frame, 4)
    region = Region(slice(0, n_rows), slice(0, n_cols // 4), np.ones((n_rows, n_cols // 4), np.float32), n_rows * n_cols // 4)
    weighted = stripe_weighted_profile(image, region, rows_per_chip)
    bands = band_means(frame, 32)
    band_only = np.sum(stripe_band_weights(bands, rows_per_chip, 1e-6) * bands, axis=1)
    covered = disk.sum(axis=1)
    matched = np.divide((frame * disk).sum(axis=1), covered, out=np.zeros(n_rows), where=covered > 0)

    def snr_db(values, rows):
        fit = np.polyfit(stripes[rows], values[rows], 1)
        return 20 * np.log10(fit[0] / np.std(values[rows] - np.polyval(fit, stripes[rows])))

    for rows in (slice(15, 100), slice(980, 1065)):
        assert snr_db(weighted.values, rows) > snr_db(matched, rows) - 0.5
        assert snr_db(band_only, rows) < snr_db(matched, rows) - 1.5


def test_paper_geometric_reads_phy_sdus_at_a_dim_disks_ends():
    # The SNR map's cell at 10.3 dB of stripe SNR (16 frames: 50 of 52
    # read, 43 with the bands' weights alone, 52 by the genie): frame 5's
    # PHY-SDUs over rows 48 … 296 and 804 … 1052 lie where the chord is
    # narrow; the bands' weights alone read neither, now both are read.
    from rollsim.stages.decode import settings_from_scene
    from rollsim.render import RenderPipeline
    from rollsim.scene import load_scene

    from decoder import decode_frame

    scene = load_scene("paper-geometric", ["led.luminous_intensity_cd=0.000340353", "seed=3702625670267878614", "frames=6"])
    pipeline = RenderPipeline(scene)
    settings = settings_from_scene(scene)
    frame = pipeline.render(5)
    found = decode_frame(frame.image, settings.phy, settings.clock_hz, settings.row_time_s, 5, exposure_s=settings.exposure_s)
    read = {int(round(sdu.first_row_f)) for sdu in found if sdu.check_ok}
    visible = [sdu["first_row"] for sdu in frame.truth["sdus"] if sdu["fully_visible"]]
    assert visible == [48, 300, 552, 804]
    assert all(any(abs(first - r) <= 2 for r in read) for first in visible)
