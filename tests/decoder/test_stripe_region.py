"""decoder.stripe_region: the stripes found as what moves between frames, alike along rows."""

import numpy as np
import pytest
from synth import make_transmitter, synth_frame

from decoder import RowTimeError, estimate_row_time
from decoder.stripe_region import region_profile, stripe_region

CLOCK_HZ = 4000.0
ROW_TIME_S = 25e-6  # a 20-row stripe period


def small_led_frames(n=6, seed=0, centre=(1100.0, 700.0), size=120.0, on_dn=70.0, background_dn=110.0,
                     noise_dn=3.0, channel_gains=None, exposure_s=300e-6, start_step_s=None):
    """A faint LED, a small disk in a large frame on a brighter background, its phase moving frame to frame."""
    rng = np.random.default_rng(seed)
    frames = []
    for i in range(n):
        start = rng.uniform(0, 1e-3) if start_step_s is None else i * start_step_s
        tx = make_transmitter(pattern="square", clock_hz=CLOCK_HZ, start_s=start)
        frame = synth_frame(tx, shape=(1000, 1400), row_time_s=ROW_TIME_S, exposure_s=exposure_s, size=size,
                            centre=centre, on_dn=on_dn, off_dn=0.0, background_dn=background_dn,
                            noise_dn=noise_dn, channel_gains=channel_gains, rng=rng)
        frames.append(frame.image)
    return frames


def test_region_covers_the_led_and_leaves_the_background_out():
    centre, size = (1100.0, 700.0), 120.0
    region = stripe_region(small_led_frames(centre=centre, size=size))
    assert region is not None
    # The rows: the disk's, to a block of 16 rows either side.
    assert centre[1] - size / 2 - 16 <= region.rows.start <= centre[1] - size / 2 + 16
    assert centre[1] + size / 2 - 16 <= region.rows.stop <= centre[1] + size / 2 + 16
    weighted = np.flatnonzero(region.column_weights > 0)
    assert weighted.min() >= centre[0] - size / 2 - 16 and weighted.max() <= centre[0] + size / 2 + 16
    assert weighted.size >= 0.5 * size
    assert region.channel is None


def test_nothing_moving_gives_no_region():
    # Frame period a whole number of stripe periods: every frame shows the same phase.
    frames = small_led_frames(start_step_s=2.0 / CLOCK_HZ * 7)
    assert stripe_region(frames) is None
    assert stripe_region(frames[:1]) is None


def test_colour_region_takes_the_channel_that_carries_the_stripes():
    region = stripe_region(small_led_frames(channel_gains=(0.1, 1.0, 0.2)))
    assert region is not None and region.channel == 1


def test_profile_noise_is_the_column_means():
    """White noise of σ per pixel: a mean of m equally weighted columns has σ / √m (closed form)."""
    noise_dn = 4.0
    frames = small_led_frames(noise_dn=noise_dn, size=300.0, on_dn=90.0, background_dn=60.0)
    region = stripe_region(frames)
    profile = region_profile(frames[0], region)
    w = region.column_weights
    expected = noise_dn * np.sqrt(np.sum(w**2)) / w.sum()
    assert profile.noise[0] == pytest.approx(expected, rel=0.25)


def test_row_time_from_a_faint_small_led_on_a_bright_background():
    """The LED covers 1.5 % of the frame and is darker than the background: the brightest region is not the LED."""
    row_time_s, sigma_s = estimate_row_time(small_led_frames(size=160.0), CLOCK_HZ)
    assert row_time_s == pytest.approx(ROW_TIME_S, rel=0.005)
    assert abs(row_time_s - ROW_TIME_S) < 4 * sigma_s + 1e-4 * ROW_TIME_S


def test_noise_alone_is_refused():
    rng = np.random.default_rng(3)
    frames = [rng.normal(100, 5, (400, 300)).clip(0, 255).astype(np.uint8) for _ in range(4)]
    assert stripe_region(frames) is None
    with pytest.raises(RowTimeError):
        estimate_row_time(frames, CLOCK_HZ)



@pytest.mark.parametrize("seed", [0, 1])
def test_noise_in_large_colour_frames_finds_no_region(seed):
    """24,000 blocks tested: the threshold (4.9 standard errors) is such that noise alone passes one in a hundred frame sets."""
    rng = np.random.default_rng(seed)
    frames = [rng.normal(100, 6, (1080, 1920, 3)).clip(0, 255).astype(np.uint8) for _ in range(3)]
    assert stripe_region(frames) is None

