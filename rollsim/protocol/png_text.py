"""Frame metadata as PNG text chunks: what a camera's EXIF would say.

A rendered frame carries its exposure, ISO, row time, black level, gain,
index, start time, seeds and the rollsim version as ``tEXt`` chunks
(keyword, a zero byte, Latin-1 text), placed after the image header, where
image readers (OpenCV, Pillow) skip them. A decoder reads them back with
:func:`read_png_text`; like the file names (:mod:`rollsim.protocol.frames`),
they are part of the frame-file convention a render and a decoder share.

PNG chunk layout (ISO/IEC 15948): a 4-byte big-endian data length, a
4-byte type, the data, and the CRC-32 of type and data.
"""

from __future__ import annotations

import struct
import zlib
from typing import Mapping

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_HEADER_END = len(PNG_SIGNATURE) + 8 + 13 + 4  # signature, IHDR (length, type, 13 bytes of data, CRC)
MAX_KEYWORD_BYTES = 79


def png_chunk(kind: bytes, data: bytes) -> bytes:
    """One PNG chunk: length, type, data and the CRC-32 of type and data."""
    crc = zlib.crc32(data, zlib.crc32(kind))  # no copy of a frame's data to join it to its type
    return b"".join([struct.pack(">I", len(data)), kind, data, struct.pack(">I", crc)])


def _text_data(keyword: str, text: str) -> bytes:
    key = keyword.encode("latin-1")
    if not 1 <= len(key) <= MAX_KEYWORD_BYTES or key != key.strip() or b"\x00" in key:
        raise ValueError(f"PNG text keyword {keyword!r}: 1 to 79 Latin-1 characters, no leading or trailing space")
    return key + b"\x00" + text.encode("latin-1")


def text_chunks(entries: Mapping[str, str]) -> bytes:
    """A ``tEXt`` chunk per entry, in order.

    Raises
    ------
    ValueError
        A keyword or text that is not Latin-1, or a keyword that is empty,
        longer than 79 bytes or padded with spaces.
    """
    return b"".join(png_chunk(b"tEXt", _text_data(key, str(value))) for key, value in entries.items())


def add_png_text(png: bytes, entries: Mapping[str, str]) -> bytes:
    """``png`` with a ``tEXt`` chunk per entry after its image header.

    Raises
    ------
    ValueError
        ``png`` does not start with a PNG signature and image header, or a
        keyword or text is not Latin-1.
    """
    if png[: len(PNG_SIGNATURE)] != PNG_SIGNATURE or png[12:16] != b"IHDR":
        raise ValueError("not a PNG: no signature and image header")
    return png[:_HEADER_END] + text_chunks(entries) + png[_HEADER_END:]


def read_png_text(png: bytes) -> dict[str, str]:
    """The ``tEXt`` entries of a PNG file's bytes, ``{keyword: text}``.

    Stops at the image data: the text a render writes comes before it.
    A chunk that runs past the end of the bytes ends the reading.

    Raises
    ------
    ValueError
        Not a PNG.
    """
    if png[: len(PNG_SIGNATURE)] != PNG_SIGNATURE:
        raise ValueError("not a PNG: no signature")
    entries: dict[str, str] = {}
    position = len(PNG_SIGNATURE)
    while position + 8 <= len(png):
        (length,) = struct.unpack(">I", png[position: position + 4])
        kind = png[position + 4: position + 8]
        data = png[position + 8: position + 8 + length]
        if len(data) < length or kind in (b"IDAT", b"IEND"):
            break
        if kind == b"tEXt" and b"\x00" in data:
            key, _, text = data.partition(b"\x00")
            entries[key.decode("latin-1")] = text.decode("latin-1")
        position += 12 + length
    return entries
