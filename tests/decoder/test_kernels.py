"""The compiled block means give OpenCV's INTER_AREA numbers bit for bit."""

import cv2
import numpy as np
import pytest

from decoder import kernels
from decoder.kernels import block_means_u8, column_means_u8, frame_words
from decoder.profile import region_columns
from decoder.region import BlockImage, Region, block_means

pytestmark = pytest.mark.skipif(kernels._kernels() is None, reason="numba is not installed or ROLLSIM_JIT=0")


def _frame(height, width, seed=0):
    rng = np.random.default_rng(seed)
    frame = rng.integers(0, 256, (height, width), dtype=np.uint8)
    # Saturated and black patches. Random pixels give many exact ties of the
    # rounding (a block sum ≡ 8 mod 16, a column sum ≡ 2 mod 4); this block's
    # mean is 0.5, which rounds to the even 0.
    frame[: height // 4, : width // 4] = 255
    frame[-8:, -8:] = 0
    frame[4:8, 0:4] = 0
    frame[4, 3] = 8
    return frame


@pytest.mark.parametrize("shape", [(1080, 1920), (64, 64), (480, 644), (36, 100)])
def test_block_means_are_opencvs(shape):
    frame = _frame(*shape)
    expected = cv2.resize(frame, (shape[1] // 4, shape[0] // 4), interpolation=cv2.INTER_AREA).astype(np.float32)
    words = frame_words(frame, 4)
    assert words is not None
    assert np.array_equal(block_means_u8(words), expected)
    assert np.array_equal(block_means(frame, 4).blocks, expected)


@pytest.mark.parametrize(("rows", "block_cols"), [(slice(0, 1080), slice(0, 480)), (slice(3, 17), slice(7, 9)),
                                                   (slice(1079, 1080), slice(479, 480)), (slice(500, 900), slice(100, 300))])
def test_column_means_are_opencvs(rows, block_cols):
    frame = _frame(1080, 1920, seed=1)
    crop = frame[rows, 4 * block_cols.start : 4 * block_cols.stop]
    n_blocks = block_cols.stop - block_cols.start
    expected = cv2.resize(crop, (n_blocks, crop.shape[0]), interpolation=cv2.INTER_AREA).astype(np.float32)
    assert np.array_equal(column_means_u8(frame_words(frame, 4), rows, block_cols), expected)


def test_region_columns_take_the_same_numbers_either_way(monkeypatch):
    frame = _frame(1080, 1920, seed=2)
    region = Region(slice(100, 700), slice(20, 300), np.ones((600, 280), np.float32), 150 * 280)
    fast = region_columns(block_means(frame, 4), region)
    monkeypatch.setenv("ROLLSIM_JIT", "0")
    assert frame_words(frame, 4) is None
    slow_image = block_means(frame, 4)
    assert np.array_equal(region_columns(slow_image, region), fast)
    assert np.array_equal(slow_image.blocks, block_means(frame, 4).blocks)


@pytest.mark.parametrize("frame", [
    np.zeros((1080, 1918), np.uint8),          # width not a multiple of 4
    np.zeros((1082, 1920), np.uint8),          # height not a multiple of 4
    np.zeros((1080, 1920), np.uint16),         # 16 bits
    np.zeros((1080, 1920, 3), np.uint8),       # colour
    np.zeros((1080, 3840), np.uint8)[:, ::2],  # not contiguous
])
def test_other_frames_take_opencvs_path(frame):
    assert frame_words(frame, 4) is None
    assert frame_words(np.zeros((64, 64), np.uint8), 2) is None


def test_the_fast_path_changes_no_block_image_field():
    frame = _frame(64, 64, seed=5)
    image = block_means(frame, 4)
    assert isinstance(image, BlockImage) and image.frame is frame and image.factor == 4
    assert image.blocks.dtype == np.float32 and image.blocks.shape == (16, 16)


@pytest.mark.parametrize(("shape", "lag"), [((270, 480), 9), ((40, 19), 9), ((5, 3), 1), ((270, 480), 1)])
def test_noise_power_is_numpys(monkeypatch, shape, lag):
    from decoder.region import _noise_power

    rng = np.random.default_rng(6)
    values = (rng.normal(0.0, 3.0, shape) + np.arange(shape[0])[:, None] % 7).astype(np.float32)
    values[: shape[0] // 2, : shape[1] // 3] = 0.0  # flat patches: exact zeros
    compiled = _noise_power(values, lag)
    monkeypatch.setenv("ROLLSIM_JIT", "0")
    twin = _noise_power(values, lag)
    assert compiled.dtype == twin.dtype == np.float32
    assert np.array_equal(compiled, twin)



@pytest.mark.parametrize("memory", [1, 2, 3, 5])
def test_compiled_viterbi_is_numpys_to_the_bit(memory):
    from decoder.equalise import _viterbi_numpy, viterbi

    rng = np.random.default_rng(memory)
    # Random metrics, and small integers, whose sums tie often (ties keep the first state).
    for metrics in (rng.random((5, 61, 2**memory)) * 1e3, rng.integers(0, 3, (3, 40, 2**memory)).astype(np.float64),
                    np.zeros((2, 9, 2**memory))):
        chips, cost = viterbi(metrics)
        twin_chips, twin_cost = _viterbi_numpy(metrics)
        assert chips.dtype == twin_chips.dtype == np.int8
        assert np.array_equal(chips, twin_chips)
        assert np.array_equal(cost, twin_cost)
