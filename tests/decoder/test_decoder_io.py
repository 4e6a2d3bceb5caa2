"""decoder.io: reading PNG and JPEG frames and checking arrays."""

import struct
import zlib

import cv2
import numpy as np
import pytest

from decoder.io import FrameError, FrameReadError, as_frame_array, read_frame


def _png_bytes(image) -> bytes:
    ok, buf = cv2.imencode(".png", image)
    assert ok
    return buf.tobytes()


def _gray_alpha_png(width=8, height=6) -> bytes:
    """A valid 8-bit grey + alpha PNG (colour type 4), which cv2 cannot write."""

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + bytes([10 * y, 255] * width) for y in range(height))
    header = struct.pack(">IIBBBBB", width, height, 8, 4, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


def test_gray8_and_raw16_round_trip(tmp_path):
    gray = np.arange(40 * 30, dtype=np.uint8).reshape(40, 30)
    raw = (np.arange(40 * 30, dtype=np.uint16).reshape(40, 30) * 50 + 64).astype(np.uint16)
    (tmp_path / "g.png").write_bytes(_png_bytes(gray))
    (tmp_path / "r.png").write_bytes(_png_bytes(raw))
    assert np.array_equal(read_frame(tmp_path / "g.png"), gray)
    out = read_frame(str(tmp_path / "r.png"))
    assert out.dtype == np.uint16 and np.array_equal(out, raw)


def test_colour_is_rgb_and_alpha_is_dropped(tmp_path):
    rgb = np.zeros((10, 12, 3), np.uint8)
    rgb[..., 0] = 200  # red
    (tmp_path / "c.png").write_bytes(_png_bytes(np.ascontiguousarray(rgb[..., ::-1])))  # cv2 writes BGR
    assert np.array_equal(read_frame(tmp_path / "c.png"), rgb)
    bgra = np.dstack([rgb[..., ::-1], np.full((10, 12), 7, np.uint8)])
    (tmp_path / "a.png").write_bytes(_png_bytes(bgra))
    out = read_frame(tmp_path / "a.png")
    assert out.shape == (10, 12, 3) and np.array_equal(out, rgb)


def test_gray_plus_alpha_png_reads_as_three_channels(tmp_path):
    (tmp_path / "ga.png").write_bytes(_gray_alpha_png())
    out = read_frame(tmp_path / "ga.png")
    assert out.shape == (6, 8, 3)
    assert np.all(out[2] == 20)


@pytest.mark.parametrize(
    "name, content, reason",
    [
        ("missing.png", None, "no such file"),
        ("text.png", b"this is not an image", "not a PNG"),
        ("jpeg.png", b"\xff\xd8\xff\xe0" + b"\x00" * 100, "corrupt JPEG"),
        ("empty.png", b"", "not a PNG"),
    ],
)
def test_bad_files_name_the_file(tmp_path, name, content, reason):
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(FrameReadError, match=reason) as info:
        read_frame(path)
    assert info.value.path == str(path)
    assert name in str(info.value)


def test_truncated_and_corrupt_png(tmp_path):
    rng = np.random.default_rng(0)
    data = _png_bytes(rng.integers(0, 255, (64, 64), dtype=np.uint8))
    (tmp_path / "cut.png").write_bytes(data[: len(data) // 2])
    with pytest.raises(FrameReadError, match="truncated"):
        read_frame(tmp_path / "cut.png")
    # Signature and IEND intact, image data garbled.
    garbled = data[:60] + bytes(len(data) - 72) + data[-12:]
    (tmp_path / "garbled.png").write_bytes(garbled)
    with pytest.raises(FrameReadError, match="garbled.png"):
        read_frame(tmp_path / "garbled.png")


def _jpeg_bytes(image, quality=90) -> bytes:
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    assert ok
    return buf.tobytes()


def test_jpeg_stills_read_as_libjpeg_decodes_them_grey_and_colour_in_rgb(tmp_path):
    rng = np.random.default_rng(1)
    gray = rng.integers(0, 255, (48, 64), dtype=np.uint8)
    bgr = rng.integers(0, 255, (48, 64, 3), dtype=np.uint8)
    for name, image in (("g.jpg", gray), ("c.JPEG", bgr)):
        data = _jpeg_bytes(image)
        (tmp_path / name).write_bytes(data)
        expected = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
        got = read_frame(tmp_path / name)
        assert got.dtype == np.uint8
        assert np.array_equal(got, expected if expected.ndim == 2 else expected[..., ::-1])


def test_a_jpeg_is_read_as_stored_not_turned_by_its_exif_orientation(tmp_path):
    # A phone held upright tags its landscape sensor's image "turn 90 degrees": the rows stay the sensor's.
    from PIL import Image

    exif = Image.Exif()
    exif[0x0112] = 6
    image = np.tile(np.arange(64, dtype=np.uint8) * 4, (48, 1))
    Image.fromarray(image).save(tmp_path / "upright.jpg", quality=95, exif=exif)
    assert read_frame(tmp_path / "upright.jpg").shape == (48, 64)


def test_bad_jpegs_are_refused_naming_the_file_and_what_is_wrong(tmp_path):
    data = _jpeg_bytes(np.random.default_rng(2).integers(0, 255, (64, 64), dtype=np.uint8))
    (tmp_path / "cut.jpg").write_bytes(data[: len(data) // 2])
    with pytest.raises(FrameReadError, match="cut.jpg: truncated JPEG"):
        read_frame(tmp_path / "cut.jpg")
    sof = data.index(b"\xff\xc0")
    huge = bytearray(data)
    huge[sof + 5:sof + 9] = (30000).to_bytes(2, "big") + (30000).to_bytes(2, "big")
    (tmp_path / "huge.jpg").write_bytes(bytes(huge))
    with pytest.raises(FrameReadError, match="declares 30000x30000 pixels"):
        read_frame(tmp_path / "huge.jpg", max_pixels=10**8)
    twelve = bytearray(data)
    twelve[sof + 4] = 12
    (tmp_path / "twelve.jpg").write_bytes(bytes(twelve))
    with pytest.raises(FrameReadError, match="12-bit samples"):
        read_frame(tmp_path / "twelve.jpg")
    (tmp_path / "headless.jpg").write_bytes(data[:2] + data[sof + 2 + int.from_bytes(data[sof + 2:sof + 4], "big"):])
    with pytest.raises(FrameReadError, match="headless.jpg: corrupt JPEG \\(no frame header"):
        read_frame(tmp_path / "headless.jpg")


def test_directory_and_tiny_image(tmp_path):
    with pytest.raises(FrameReadError, match="directory"):
        read_frame(tmp_path)
    (tmp_path / "one.png").write_bytes(_png_bytes(np.zeros((1, 1), np.uint8)))
    with pytest.raises(FrameReadError, match="at least"):
        read_frame(tmp_path / "one.png")


def test_as_frame_array_layouts():
    assert as_frame_array(np.zeros((8, 5, 1), np.uint8)).shape == (8, 5)
    assert as_frame_array(np.zeros((8, 5, 4), np.uint16)).shape == (8, 5, 3)
    assert as_frame_array(np.zeros((8, 5), bool)).dtype == np.uint8
    assert as_frame_array(np.zeros((8, 5), np.int32)).dtype == np.float32
    assert as_frame_array(np.zeros((8, 5), np.float64)).dtype == np.float32
    view = np.zeros((20, 20), np.uint8)[::2, ::2]
    assert as_frame_array(view).flags["C_CONTIGUOUS"]


@pytest.mark.parametrize(
    "array, message",
    [
        (np.zeros((8, 5, 2), np.uint8), "channels"),
        (np.zeros((8, 5, 5), np.uint8), "channels"),
        (np.zeros((1, 1), np.uint8), "at least"),
        (np.zeros(10, np.uint8), "dimensions"),
        (np.zeros((2, 8, 5, 3), np.uint8), "dimensions"),
        (np.full((8, 5), np.nan), "NaN"),
        (np.full((8, 5), "a"), "numbers"),
    ],
)
def test_as_frame_array_rejects(array, message):
    with pytest.raises(FrameError, match=message):
        as_frame_array(array)


def test_a_pipe_named_as_a_frame_is_refused_without_waiting_for_a_writer(tmp_path):
    import os

    from decoder import FrameReadError, read_frame

    fifo = tmp_path / "frame_000000.png"
    os.mkfifo(fifo)
    with pytest.raises(FrameReadError, match="not a regular file"):
        read_frame(fifo)  # would block for ever if it opened the pipe for a plain read
