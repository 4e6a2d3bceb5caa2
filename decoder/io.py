"""Reading and checking frames.

A frame file is a PNG (8- or 16-bit) or a JPEG (8-bit, a phone's or a
camera's still), told apart by its first bytes. A JPEG is read as it is
stored, without turning it by its EXIF orientation: its rows are the
sensor's, the rows the rolling shutter reads one after another.

A frame reaching the decoder is one of

- gray: ``(H, W)`` uint8 (gray8, black level removed) or uint16 (raw16 DN,
  black level present), or float;
- colour: ``(H, W, 3)``, RGB channel order (:func:`read_frame` converts
  OpenCV's BGR).

A 4-channel image (RGBA, or grey + alpha that OpenCV expands to 4 channels)
loses its alpha channel. Anything else (a 2-channel array, 5 channels, an
image too small to hold a stripe, an empty or non-finite array) is rejected
with a :class:`FrameError`, never guessed at.
"""

from __future__ import annotations

import os
import stat

import cv2
import numpy as np

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# Every complete PNG ends with an empty IEND chunk (length 0, type, CRC).
PNG_IEND = b"\x00\x00\x00\x00IEND\xaeB`\x82"
# A frame must have room for at least a few stripes; smaller is not a frame.
MIN_ROWS = 4
MIN_COLS = 2
# The largest frame read by default: 2**28 pixels (16384 x 16384), more than
# any camera sensor. A file that declares more is refused from its header,
# before a byte of image memory is allocated.
MAX_FRAME_PIXELS = 2**28
JPEG_SIGNATURE = b"\xff\xd8\xff"  # SOI, then the first marker's 0xFF
# JPEG markers that carry no length: TEM, RST0-7, SOI.
_STANDALONE = {0x01, *range(0xD0, 0xD8), 0xD8}
# Start-of-frame markers (baseline, extended, progressive, lossless; Huffman or arithmetic), whose
# segment gives the image's size; C4 (DHT), C8 (JPG) and CC (DAC) are not frames.
_START_OF_FRAME = {*range(0xC0, 0xD0)} - {0xC4, 0xC8, 0xCC}
# Bytes of a decoded PNG per pixel, by IHDR colour type (OpenCV expands a
# palette to RGB and grey + alpha to four channels), before the bit depth.
_CHANNELS = {0: 1, 2: 3, 3: 3, 4: 4, 6: 4}


class FrameError(ValueError):
    """A frame that cannot be decoded: wrong shape, channels or dtype."""


class FrameReadError(FrameError):
    """A frame file that cannot be read.

    Attributes
    ----------
    path : str
        The file name, as given.
    reason : str
        What is wrong with it.
    """

    def __init__(self, path, reason: str):
        self.path = str(path)
        self.reason = reason
        super().__init__(f"{self.path}: {reason}")


def as_frame_array(image) -> np.ndarray:
    """Check an in-memory frame and bring it to a decodable layout.

    Parameters
    ----------
    image : array_like
        ``(H, W)``, ``(H, W, 1)``, ``(H, W, 3)`` or ``(H, W, 4)`` (alpha
        dropped). uint8, uint16 and float32 pass unchanged; other integer
        and float types become float32, bool becomes uint8.

    Returns
    -------
    ndarray
        ``(H, W)`` or ``(H, W, 3)``, C-contiguous.

    Raises
    ------
    FrameError
        Wrong number of dimensions or channels, fewer than
        :data:`MIN_ROWS` rows or :data:`MIN_COLS` columns, a non-numeric
        dtype, or NaN/inf values.
    """
    arr = np.asarray(image)
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.ndim == 3:
        channels = arr.shape[2]
        if channels == 4:
            arr = arr[:, :, :3]
        elif channels != 3:
            raise FrameError(f"a frame needs 1, 3 or 4 channels, got {channels}")
    elif arr.ndim != 2:
        raise FrameError(f"a frame must be a 2-D (gray) or 3-D (colour) array, got {arr.ndim} dimensions")
    height, width = arr.shape[:2]
    if height < MIN_ROWS or width < MIN_COLS:
        raise FrameError(f"a frame needs at least {MIN_ROWS}x{MIN_COLS} pixels, got {height}x{width}")
    if arr.dtype == np.bool_:
        arr = arr.astype(np.uint8)
    elif arr.dtype.kind not in "uif":
        raise FrameError(f"a frame must hold numbers, got dtype {arr.dtype}")
    elif arr.dtype not in (np.uint8, np.uint16, np.float32):
        arr = arr.astype(np.float32)
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise FrameError("a frame must not contain NaN or inf")
    return np.ascontiguousarray(arr)


def png_header(data: bytes) -> tuple[int, int, int]:
    """Width, height and decoded bytes per pixel that a PNG's IHDR chunk declares.

    Raises
    ------
    ValueError
        No IHDR chunk where the PNG format puts it, or impossible values.
    """
    if len(data) < 33 or data[12:16] != b"IHDR":
        raise ValueError("no IHDR chunk after the signature")
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    depth, colour = data[24], data[25]
    if width < 1 or height < 1 or colour not in _CHANNELS or depth not in (1, 2, 4, 8, 16):
        raise ValueError(f"impossible header (size {width}x{height}, bit depth {depth}, colour type {colour})")
    return width, height, _CHANNELS[colour] * (2 if depth == 16 else 1)


def jpeg_header(data: bytes) -> tuple[int, int, int, int]:
    """Width, height and components that a JPEG's frame header declares, and where the header ends.

    The markers are walked from the start of the file to the first
    start-of-frame segment (past APPn, EXIF and its thumbnail, the tables).

    Raises
    ------
    ValueError
        No frame header before the image data or the end, a segment cut
        short, or samples other than 8 bits.
    """
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            raise ValueError(f"no marker at byte {i}")
        marker = data[i + 1]
        if marker == 0xFF:  # a fill byte before a marker
            i += 1
            continue
        if marker in _STANDALONE:
            i += 2
            continue
        if marker in (0xD9, 0xDA):
            raise ValueError("no frame header before the image data")
        length = int.from_bytes(data[i + 2:i + 4], "big")
        if length < 2 or i + 2 + length > len(data):
            raise ValueError(f"a segment at byte {i} cut short")
        if marker in _START_OF_FRAME:
            segment = data[i + 4:i + 2 + length]
            if len(segment) < 6:
                raise ValueError("a frame header cut short")
            precision, components = segment[0], segment[5]
            height, width = int.from_bytes(segment[1:3], "big"), int.from_bytes(segment[3:5], "big")
            if precision != 8:
                raise ValueError(f"{precision}-bit samples (8-bit JPEGs only)")
            if width < 1 or height < 1 or components not in (1, 3, 4):
                raise ValueError(f"impossible frame header (size {width}x{height}, {components} components)")
            return width, height, components, i + 2 + length
        i += 2 + length
    raise ValueError("no frame header")


def _check_jpeg(name: str, data: bytes, max_pixels: int) -> None:
    """Refuse a JPEG that is corrupt in its header, cut short or larger than ``max_pixels``."""
    try:
        width, height, _, end = jpeg_header(data)
    except ValueError as exc:
        raise FrameReadError(name, f"corrupt JPEG ({exc})") from None
    if width * height > max_pixels:
        raise FrameReadError(name, f"declares {width}x{height} pixels, more than the {max_pixels} allowed "
                                   "(a frame this large would not fit in memory)")
    # libjpeg decodes a file cut short with grey in place of the missing rows
    # and a warning on stderr: refused here instead. Entropy-coded data never
    # holds 0xFF 0xD9 (a coded 0xFF is followed by 0x00), so the image ends at
    # the first EOI after its first scan; what a phone appends after it (a
    # second picture) is not read.
    scan = data.find(b"\xff\xda", end)
    if scan < 0 or data.find(b"\xff\xd9", scan) < 0:
        raise FrameReadError(name, "truncated JPEG (no end of image after its data)")


def _check_declared_size(name: str, data: bytes, max_pixels: int) -> None:
    """Refuse a PNG whose header declares more pixels than ``max_pixels``."""
    try:
        width, height, _ = png_header(data)
    except ValueError as exc:
        raise FrameReadError(name, f"corrupt PNG ({exc})") from None
    if width * height > max_pixels:
        raise FrameReadError(name, f"declares {width}x{height} pixels, more than the {max_pixels} allowed "
                                   "(a frame this large would not fit in memory)")


def _read_bounded(name: str, max_pixels: int) -> bytes:
    """The file's bytes, refusing one larger than any PNG (or JPEG) of ``max_pixels`` could be."""
    # Deflate never grows data by more than a few bytes per 16 kB block:
    # 8 bytes per pixel (RGBA16) plus filter bytes and chunk overhead bound
    # every valid PNG of that many pixels, and a JPEG's at most 3 coded bytes
    # of 8-bit samples a pixel, with its metadata, too.
    limit = 8 * max_pixels + (1 << 20) + max_pixels // 8
    # Opened without blocking and checked before reading: a pipe given as a
    # frame would otherwise wait for a writer for ever, a device never end.
    fd = os.open(name, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    with open(fd, "rb", closefd=True) as handle:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise FrameReadError(name, "not a regular file (a pipe, device or socket is no frame file)")
        data = handle.read(limit + 1)
    if len(data) > limit:
        raise FrameReadError(name, f"larger than any frame file of at most {max_pixels} pixels")
    return data


def read_frame(path, max_pixels: int = MAX_FRAME_PIXELS) -> np.ndarray:
    """Read a PNG or JPEG frame, unchanged in bit depth (a JPEG as stored: not turned by its EXIF orientation).

    Parameters
    ----------
    path : str or os.PathLike
        A PNG file (8- or 16-bit, gray or colour) or a JPEG file (8-bit).
    max_pixels : int, optional
        The largest frame to read; a file whose header declares more is
        refused before its image is allocated.

    Returns
    -------
    ndarray
        ``(H, W)`` uint8/uint16, or ``(H, W, 3)`` in RGB order (alpha
        dropped).

    Raises
    ------
    FrameReadError
        Missing or unreadable file, neither PNG nor JPEG, truncated, undecodable,
        larger than ``max_pixels``, or of a shape :func:`as_frame_array`
        rejects. The message names the file.
    """
    name = os.fspath(path)
    try:
        data = _read_bounded(name, max_pixels)
    except FileNotFoundError:
        raise FrameReadError(name, "no such file") from None
    except IsADirectoryError:
        raise FrameReadError(name, "is a directory, not a frame file") from None
    except OSError as exc:
        raise FrameReadError(name, f"cannot read: {exc.strerror or exc}") from None
    if data.startswith(JPEG_SIGNATURE):
        kind = "JPEG"
        _check_jpeg(name, data, max_pixels)
    elif data.startswith(PNG_SIGNATURE):
        kind = "PNG"
        # Checked here because libpng's own message for a cut file is vague and
        # goes to stderr.
        if PNG_IEND not in data[-4096:]:
            raise FrameReadError(name, "truncated PNG (no IEND chunk)")
        _check_declared_size(name, data, max_pixels)
    else:
        raise FrameReadError(name, "not a PNG or JPEG file (bad signature)")
    # IMREAD_UNCHANGED: a PNG's bit depth kept, and a JPEG not turned by its EXIF orientation.
    image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None or image.size == 0:
        raise FrameReadError(name, f"corrupt {kind} (cannot be decoded)")
    if image.ndim == 3 and image.shape[2] >= 3:
        image = image[:, :, 2::-1]  # BGR(A) -> RGB, alpha dropped
    try:
        return as_frame_array(image)
    except FrameError as exc:
        raise FrameReadError(name, str(exc)) from None
