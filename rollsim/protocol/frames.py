"""How frame files are named: the one file convention a render and a decoder share.

A render writes frame k as ``frame_{k:06d}.png``; a decoder and the
evaluation read the index back from the last number in a file's stem, so
frames renamed by other tools (``img_42.png``) keep their order.
"""

from __future__ import annotations

import os
import re

FRAME_NAME = "frame_{:06d}.png"

_TRAILING_NUMBER = re.compile(r"(\d+)\D*$")


def frame_index_from_name(path, default: int) -> int:
    """Frame index from the last number in a file's stem (``frame_000042.png``
    → 42), else ``default``."""
    stem = os.path.splitext(os.path.basename(os.fspath(path)))[0]
    match = _TRAILING_NUMBER.search(stem)
    return int(match.group(1)) if match else default
