"""A grey frame's JPEG round trip without the entropy coding: OpenCV's libjpeg to the bit."""

import numpy as np
import pytest

from rollsim.numerics import jit
from rollsim.isp import jpeg_round_trip
from rollsim.isp.jpeg_islow import (LUMINANCE_TABLE, _round_trip_numpy, quantisation_table, round_trip_grey)


def opencv_round_trip(image, quality):
    import cv2

    ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    assert ok
    return cv2.imdecode(encoded, cv2.IMREAD_GRAYSCALE)


def frames(shape, seed):
    """Noise, a smooth scene with a little noise, and hard edges (stripes and a step)."""
    rng = np.random.default_rng(seed)
    noise = rng.integers(0, 256, shape, dtype=np.uint8)
    rows, cols = np.indices(shape)
    smooth = np.clip(128 + 100 * np.sin(cols / 7.0) * np.cos(rows / 11.0) + rng.normal(0, 4, shape), 0, 255)
    stripes = np.where((rows // 3) % 2 == 0, 215, 5) + np.where(cols > shape[1] // 2, 40, 0)
    return [noise, smooth.astype(np.uint8), stripes.astype(np.uint8), np.full(shape, 255, np.uint8)]


QUALITIES = [1, 2, 10, 25, 49, 50, 51, 75, 85, 90, 99, 100]


@pytest.mark.parametrize("shape", [(1, 1), (7, 9), (37, 53), (64, 64), (120, 160)])
@pytest.mark.parametrize("quality", QUALITIES)
def test_the_round_trip_is_opencvs_libjpeg_to_the_bit(shape, quality):
    for image in frames(shape, seed=sum(shape) + quality):
        assert round_trip_grey(image, quality).tobytes() == opencv_round_trip(image, quality).tobytes()


def test_a_rendered_noisy_frame_through_the_effect_is_opencvs():
    from rollsim.render import RenderPipeline
    from rollsim.scene import load_scene

    image = RenderPipeline(load_scene("paper-geometric", ["camera.width_px=320", "camera.height_px=240"])).render(0).image
    assert jpeg_round_trip(image, 85).tobytes() == opencv_round_trip(image, 85).tobytes()


@pytest.mark.parametrize("quality", [1, 50, 85, 100])
def test_the_compiled_kernel_is_the_numpy_twin(quality):
    image = frames((45, 67), seed=quality)[0]
    twin = _round_trip_numpy(image, quantisation_table(quality))
    assert round_trip_grey(image, quality).tobytes() == twin.tobytes()
    with jit.numpy_only():
        assert round_trip_grey(image, quality).tobytes() == twin.tobytes()


def test_the_quantisation_tables_are_annex_ks_scaled_by_the_ijg_rule():
    assert np.array_equal(quantisation_table(50), LUMINANCE_TABLE)  # scale 100 %
    assert np.array_equal(quantisation_table(100), np.ones((8, 8), dtype=np.int64))  # scale 0 %, at least 1
    assert quantisation_table(1).max() == 255 and quantisation_table(1).min() == 255  # baseline's limit
    assert quantisation_table(85)[0, 0] == (16 * 30 + 50) // 100  # scale 200 - 2·85 = 30 %


def test_the_float_quotient_floors_exactly_for_every_coefficient_and_divisor():
    """The kernel's (|v| + d/2) // d in float64: exact for |v| < 2^15 (the islow outputs stay under 2^14)."""
    numerators = np.arange(0, 1 << 15, dtype=np.int64)[:, None]
    divisors = (np.arange(1, 256, dtype=np.int64) * 8)[None, :]
    quotients = (numerators.astype(np.float64) / divisors.astype(np.float64)).astype(np.int64)
    assert np.array_equal(quotients, numerators // divisors)


@pytest.mark.parametrize("image", [np.zeros((4, 4, 3), np.uint8), np.zeros((4, 4), np.float32)])
def test_a_frame_that_is_not_grey_uint8_is_refused(image):
    with pytest.raises(ValueError, match="uint8"):
        round_trip_grey(image, 85)
    if image.ndim == 2:  # not wrapped modulo 256 on its way in either
        with pytest.raises(ValueError, match="uint8"):
            jpeg_round_trip(image, 85)


def test_a_quality_outside_1_to_100_is_refused():
    with pytest.raises(ValueError, match="quality"):
        round_trip_grey(np.zeros((8, 8), np.uint8), 0)
