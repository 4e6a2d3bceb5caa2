"""PNG encoding of rendered frames, at the speed of the compressor.

A rendered frame carries sensor noise in every pixel, so it barely
compresses (a noisy 1080p gray8 frame keeps about 90 % of its bytes
whatever the effort): the encoder's job is to be fast. This module writes
the PNG container itself (ISO/IEC 15948: signature, ``IHDR``, the frame's
``tEXt`` chunks, one ``IDAT``, ``IEND``) around scanlines filtered with
PNG's SUB filter in one numpy pass, and compresses them with ISA-L's
deflate (:mod:`isal.isal_zlib`, level 1): about 4 ms per 1080p frame on
this machine, where OpenCV's encoder, even storing the data uncompressed,
took 23–29 ms in libpng's per-row machinery.

Without ISA-L (a platform with no wheel of ``isal``), the standard
library's zlib compresses instead, with Huffman coding only: the same
pixels, other compressed bytes, about 30 ms per frame. Either way a frame's
bytes depend only on its pixels and text, so renders stay byte-identical
for any number of workers.
"""

from __future__ import annotations

import struct
import zlib
from typing import Any, Mapping, Optional

import numpy as np

from rollsim.protocol.png_text import PNG_SIGNATURE, png_chunk, text_chunks

_isal_zlib: Any
try:  # ISA-L's deflate, about 8x faster than zlib's fastest setting on noisy frames
    from isal import isal_zlib as _isal_zlib
except ImportError:  # pragma: no cover - exercised where isal has no wheel
    _isal_zlib = None

# PNG colour types (ISO/IEC 15948, 11.2.2): gray and truecolour (RGB).
_GRAY, _RGB = 0, 2
_SUB_FILTER = 1


def compressor_name() -> str:
    """Which deflate implementation encodes frames: ``"isal"`` or ``"zlib"``."""
    return "zlib" if _isal_zlib is None else "isal"


def _deflate(data: memoryview, use_isal: bool) -> bytes:
    """``data`` as a zlib stream: ISA-L level 1, or zlib with Huffman coding only."""
    if use_isal and _isal_zlib is not None:
        return _isal_zlib.compress(data, 1)
    packer = zlib.compressobj(1, zlib.DEFLATED, 15, 9, zlib.Z_HUFFMAN_ONLY)
    return packer.compress(data) + packer.flush()


def sub_filtered_scanlines(image: np.ndarray) -> np.ndarray:
    """The image's scanlines as PNG stores them with the SUB filter on every row.

    Each row starts with the filter type byte (1); every byte after the
    first pixel is stored minus the byte one pixel to its left, modulo 256
    (ISO/IEC 15948, 9.2). 16-bit samples are big-endian.

    Parameters
    ----------
    image : ndarray of uint8 or uint16, shape (H, W) or (H, W, 3)
        Gray or RGB samples.

    Returns
    -------
    ndarray of uint8, shape (H, 1 + W · channels · bytes per sample)
    """
    height = image.shape[0]
    big_endian = np.ascontiguousarray(image, dtype=image.dtype.newbyteorder(">"))
    rows = big_endian.view(np.uint8).reshape(height, -1)
    pixel_bytes = image.itemsize * (image.shape[2] if image.ndim == 3 else 1)
    lines = np.empty((height, rows.shape[1] + 1), dtype=np.uint8)
    lines[:, 0] = _SUB_FILTER
    lines[:, 1:1 + pixel_bytes] = rows[:, :pixel_bytes]
    np.subtract(rows[:, pixel_bytes:], rows[:, :-pixel_bytes], out=lines[:, 1 + pixel_bytes:])
    return lines


def _check_image(image: np.ndarray) -> None:
    if image.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"a PNG frame holds uint8 or uint16 samples, got {image.dtype}")
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
        raise ValueError(f"a PNG frame is gray (H, W) or RGB (H, W, 3), got shape {image.shape}")
    if min(image.shape[:2]) < 1 or max(image.shape[:2]) > 2**31 - 1:
        raise ValueError(f"a PNG frame's width and height are 1 to 2^31 - 1 pixels, got {image.shape[:2]}")


def encode_png(image: np.ndarray, text: Optional[Mapping[str, str]] = None, *, use_isal: bool = True) -> bytes:
    """PNG bytes of an 8- or 16-bit image, with ``text`` as ``tEXt`` chunks.

    Parameters
    ----------
    image : ndarray of uint8 or uint16, shape (H, W) or (H, W, 3)
        Gray, or RGB in that order (what the render's colour outputs hold).
    text : mapping of str to str, optional
        Metadata entries (:mod:`rollsim.protocol.png_text`), written after
        the image header, where image readers skip them.
    use_isal : bool
        Compress with ISA-L where it is installed (the default); False
        takes zlib's Huffman-only coding (the fallback's bytes).

    Returns
    -------
    bytes
        A complete PNG file.

    Raises
    ------
    ValueError
        Samples that are not uint8 or uint16, a shape that is not gray or
        RGB, or a keyword or text that is not Latin-1.
    """
    _check_image(image)
    height, width = image.shape[:2]
    colour = _RGB if image.ndim == 3 else _GRAY
    header = struct.pack(">IIBBBBB", width, height, 8 * image.itemsize, colour, 0, 0, 0)
    data = _deflate(sub_filtered_scanlines(image).data, use_isal)
    return b"".join([PNG_SIGNATURE, png_chunk(b"IHDR", header), text_chunks(text or {}),
                     png_chunk(b"IDAT", data), png_chunk(b"IEND", b"")])


__all__ = ["compressor_name", "encode_png", "sub_filtered_scanlines"]
