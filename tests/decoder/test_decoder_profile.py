"""decoder.profile: row means of a region, noise, colour channel choice."""

import numpy as np
import pytest
from synth import make_transmitter, synth_frame

from decoder.profile import row_profile, stripe_contrast
from decoder.region import block_means, detect_regions


def profile_of(image):
    blocks = block_means(image, 4)
    regions = detect_regions(blocks, 20.0)
    assert len(regions) == 1
    return row_profile(blocks, regions[0])


def test_square_led_profile_is_the_row_level():
    frame = synth_frame(make_transmitter(), shape=(600, 320), kind="square", size=160, on_dn=200, off_dn=20, dtype=np.float32)
    profile = profile_of(frame.image)
    rows = np.arange(profile.first_row, profile.first_row + len(profile))
    inside = (rows >= 222) & (rows <= 378)  # clear of the square's top and bottom edges
    expected = 20 + 180 * frame.row_level[rows[inside]]
    assert profile.channel is None
    assert np.allclose(profile.values[inside], expected, atol=1e-3)


def test_disk_chord_does_not_change_the_level():
    frame = synth_frame(make_transmitter(pattern="on"), shape=(800, 800), size=600, on_dn=180, background_dn=60)
    profile = profile_of(frame.image)
    core = profile.values[40:-40]
    # The mean over the footprint, not the sum: flat although chords vary
    # from ~300 to 600 pixels (edge blocks mix in a little background).
    assert core.max() - core.min() < 0.1 * 180


def test_noise_of_row_means():
    rng = np.random.default_rng(2)
    frame = synth_frame(make_transmitter(), shape=(600, 400), kind="square", size=400, noise_dn=8.0, dtype=np.float32, rng=rng)
    profile = profile_of(frame.image)
    rows = np.arange(profile.first_row, profile.first_row + len(profile))
    inside = (rows > 210) & (rows < 390)
    residual = profile.values[inside] - (20 + 180 * frame.row_level[rows[inside]])
    # 400 columns averaged: sigma 8 / sqrt(400) = 0.4 DN.
    assert np.std(residual) == pytest.approx(0.4, rel=0.2)
    assert np.median(profile.noise[inside]) == pytest.approx(0.4, rel=0.2)


def test_stripe_contrast_ranks_signal_over_noise():
    rng = np.random.default_rng(0)
    stripes = (np.arange(500) // 4 % 2) * 10.0
    assert stripe_contrast(stripes + rng.normal(0, 1, 500), np.ones(500)) > 8
    assert stripe_contrast(rng.normal(0, 1, 500), np.ones(500)) < 4


@pytest.mark.parametrize(
    "gains, best",
    [
        ((0.1, 1.0, 0.2), 1),  # green LED
        ((1.0, 0.05, 0.05), 0),  # red LED
        ((3.0, 0.6, 0.0), 1),  # red saturates and loses its stripes; green keeps them
    ],
)
def test_colour_uses_the_channel_with_best_contrast(gains, best):
    rng = np.random.default_rng(4)
    frame = synth_frame(
        make_transmitter(), shape=(600, 400), size=400, on_dn=200, off_dn=120, background_dn=40,
        channel_gains=gains, noise_dn=3, rng=rng,
    )
    profile = profile_of(frame.image)
    assert profile.channel == best
