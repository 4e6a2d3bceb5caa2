"""The sample frame's plot shows the frame reduced by block means to the plot's resolution."""

import numpy as np

from rollsim.report.plots import display_image


def test_a_frame_wider_than_the_plot_is_reduced_by_the_smallest_integer_block_mean():
    image = np.arange(1080 * 1920, dtype=np.int64).reshape(1080, 1920) % 251
    image = image.astype(np.uint8)
    shown, k = display_image(image, max_width_px=800)
    # 1920 / 800 → k = 3: 360 × 640 blocks, each the rounded mean of its 3 × 3 pixels.
    assert k == 3 and shown.shape == (360, 640) and shown.dtype == np.uint8
    assert shown[7, 11] == np.rint(image[21:24, 33:36].mean())
    assert abs(float(shown.mean()) - float(image.mean())) < 0.5


def test_rgb_keeps_its_channels_and_a_narrow_frame_is_shown_as_it_is():
    rgb = np.random.default_rng(0).integers(0, 256, (100, 1700, 3), dtype=np.uint8)
    shown, k = display_image(rgb, max_width_px=800)
    assert k == 3 and shown.shape == (33, 566, 3) and shown.dtype == np.uint8
    narrow = np.zeros((50, 640), dtype=np.uint16)
    kept, k = display_image(narrow, max_width_px=800)
    assert kept is narrow and k == 1
