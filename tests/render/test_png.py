"""rollsim's PNG encoder: any reader decodes the exact samples, with ISA-L or zlib."""

import io
import zlib

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from PIL import Image

from rollsim.protocol.png_text import read_png_text
from rollsim.render.png import compressor_name, encode_png, sub_filtered_scanlines


def _read_cv2(png: bytes) -> np.ndarray:
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    return image[:, :, ::-1] if image.ndim == 3 else image  # OpenCV gives BGR


def _read_pillow(png: bytes) -> np.ndarray:
    # Pillow checks every chunk's CRC as it reads.
    with Image.open(io.BytesIO(png)) as image:
        return np.asarray(image)


shapes = st.one_of(st.tuples(st.integers(1, 9), st.integers(1, 9)),
                   st.tuples(st.integers(1, 9), st.integers(1, 9), st.just(3)))


@settings(max_examples=60, deadline=None)
@given(arrays(st.sampled_from([np.uint8, np.uint16]), shapes), st.booleans())
def test_readers_decode_the_exact_samples(image, use_isal):
    png = encode_png(image, {"frame": "3"}, use_isal=use_isal)
    assert np.array_equal(_read_cv2(png), image)
    assert read_png_text(png) == {"frame": "3"}
    if image.dtype == np.uint8 or image.ndim == 2:  # Pillow reads no 48-bit RGB
        assert np.array_equal(_read_pillow(png).astype(image.dtype), image)


def test_a_noisy_1080p_frame_round_trips_through_both_compressors():
    rng = np.random.default_rng(3)
    frame = rng.normal(40, 6, (1080, 1920)).clip(0, 255).astype(np.uint8)
    for use_isal in (True, False):
        png = encode_png(frame, use_isal=use_isal)
        assert np.array_equal(_read_cv2(png), frame)
        assert len(png) < frame.size  # the SUB filter and Huffman codes still save bytes on noise


def test_sub_filter_is_the_difference_to_the_pixel_on_the_left_modulo_256():
    image = np.array([[10, 5, 250, 3]], dtype=np.uint8)
    assert sub_filtered_scanlines(image).tolist() == [[1, 10, (5 - 10) % 256, (250 - 5) % 256, (3 - 250) % 256]]
    sixteen = np.array([[0x0102, 0x0304]], dtype=np.uint16)  # big-endian bytes 01 02 03 04; the left pixel is 2 bytes back
    assert sub_filtered_scanlines(sixteen).tolist() == [[1, 0x01, 0x02, 0x02, 0x02]]
    rgb = np.array([[[1, 2, 3], [4, 6, 8]]], dtype=np.uint8)  # the left pixel is 3 bytes back
    assert sub_filtered_scanlines(rgb).tolist() == [[1, 1, 2, 3, 3, 4, 5]]


def test_the_container_is_well_formed():
    png = encode_png(np.zeros((2, 3), np.uint16), {"a": "1"})
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and png[12:16] == b"IHDR"
    width, height, depth, colour = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big"), png[24], png[25]
    assert (width, height, depth, colour) == (3, 2, 16, 0)
    assert png.endswith(b"IEND" + zlib.crc32(b"IEND").to_bytes(4, "big"))


def test_the_same_frame_gives_the_same_bytes():
    frame = np.random.default_rng(4).integers(0, 256, (64, 80), dtype=np.uint8)
    assert encode_png(frame, {"a": "1"}) == encode_png(frame.copy(), {"a": "1"})


@pytest.mark.parametrize("image, match", [
    (np.zeros((4, 4), np.float32), "uint8 or uint16"),
    (np.zeros((4, 4, 4), np.uint8), "gray .* or RGB"),
    (np.zeros((0, 4), np.uint8), "width and height"),
])
def test_what_png_cannot_hold_is_refused(image, match):
    with pytest.raises(ValueError, match=match):
        encode_png(image)


def test_isal_is_installed_with_rollsim():
    assert compressor_name() == "isal"
