"""A JPEG's quality read back from its decoded frames (rollsim.fit.compression)."""

import numpy as np
import pytest

from rollsim.fit.compression import MAX_CHANGED, changed_share, jpeg_quality, mosaic, unclipped_blocks
from rollsim.isp import jpeg_round_trip


def _frames(seed: int, colour: bool, quality: int | None, n: int = 3, shape=(240, 320)) -> list[np.ndarray]:
    """Noisy frames of stripes (levels 100 and 160), saved as JPEG of ``quality`` (None: not compressed)."""
    rng = np.random.default_rng(seed)
    rows = np.arange(shape[0])[:, None]
    out = []
    for f in range(n):
        grey = 100.0 + 60.0 * (np.mod(rows + 3.3 + 5.1 * f, 17.3) < 8.6) + rng.normal(0, 3, shape)
        image = np.stack([grey, 0.6 * grey, 0.3 * grey], axis=-1) if colour else grey
        image = np.clip(np.rint(image), 0, 255).astype(np.uint8)
        out.append(jpeg_round_trip(image, quality) if quality is not None else image)
    return out


@pytest.mark.parametrize("colour", [False, True])
@pytest.mark.parametrize("quality", [20, 50, 60, 69, 75, 85, 92])
def test_the_quality_a_frame_was_saved_at_is_read_back(quality, colour):
    assert jpeg_quality(_frames(quality, colour, quality)) == quality


@pytest.mark.parametrize("colour", [False, True])
def test_frames_never_compressed_show_no_quality(colour):
    assert jpeg_quality(_frames(3, colour, None)) is None


def test_a_round_trip_is_idempotent_at_its_own_quality_only():
    # The known answer behind the reading: a decoded JPEG encoded again with
    # its own tables comes back (nearly) unchanged; coarser tables change it.
    blocks = unclipped_blocks(_frames(4, False, 60))
    image = mosaic(blocks)
    assert changed_share(image, 60) <= MAX_CHANGED
    assert changed_share(image, 59) > 10 * MAX_CHANGED
    assert changed_share(image, 40) > 10 * MAX_CHANGED


def test_clipped_blocks_and_a_cut_grid_are_left_out():
    frames = _frames(5, False, 60)
    # All clipped: nothing to read.
    assert jpeg_quality([np.full((64, 64), 255, np.uint8)] * 2) is None
    assert unclipped_blocks([np.full((64, 64), 0, np.uint8)]).shape == (0, 8, 8)
    # A crop 3 rows into the JPEG's grid: the blocks read are not the codec's.
    assert jpeg_quality([f[3:] for f in frames]) is None


@pytest.mark.parametrize("quality", [50, 64, 75])
def test_low_contrast_frames_read_within_two_qualities(quality):
    # Stripes of 10 levels with noise of 1: most coefficients are one or two
    # steps, which a neighbouring quality's tables requantise alike.
    rng = np.random.default_rng(quality)
    rows = np.arange(240)[:, None]
    frames = [jpeg_round_trip(np.clip(np.rint(100.0 + 10.0 * (np.mod(rows + 5.1 * f, 17.3) < 8.6)
                                              + rng.normal(0, 1, (240, 320))), 0, 255).astype(np.uint8), quality)
              for f in range(3)]
    assert abs(jpeg_quality(frames) - quality) <= 2


def test_nearly_lossless_qualities_are_not_read():
    assert jpeg_quality(_frames(6, False, 97)) is None


def test_flat_blocks_tell_no_quality():
    # A black background lifted to one level (seed 1 camera 21 of `rollsim
    # bench fit-camera`): every unclipped block is flat, and comes back flat
    # under most tables (read with them, they give quality 1).
    frames = [np.full((240, 320), 1, np.uint8)] * 3
    assert unclipped_blocks(frames).shape == (0, 8, 8)
    assert jpeg_quality(frames) is None
    # Lone spikes a level deep: every quality's round trip smooths some
    # away (no quality changes 2 % or less of the pixels).
    rng = np.random.default_rng(8)
    shallow = [(1 + (rng.random((240, 320)) < 0.02)).astype(np.uint8) for _ in range(3)]
    assert jpeg_quality(shallow) is None
