"""Named random streams derived from one scene seed.

Every random stream of a run (message content, noise, PRNU map, ...) comes
from the scene's ``seed`` and a fixed stream name, never from the clock. Two
streams with different names are statistically independent, and adding a new
stream does not change the numbers an existing one produces.
"""

from __future__ import annotations

import zlib

import numpy as np


def stream_key(name: str) -> int:
    """Stable integer key of a stream name (CRC-32 of its UTF-8 bytes)."""
    return zlib.crc32(name.encode("utf-8"))


def seed_sequence(seed: int, name: str, *extra: int) -> np.random.SeedSequence:
    """The :class:`numpy.random.SeedSequence` of stream ``name``.

    Parameters
    ----------
    seed : int
        The scene seed, a non-negative integer.
    name : str
        Stream name, e.g. ``"message"`` or ``"shot_noise"``.
    *extra : int
        Further non-negative keys, e.g. a frame index, so that frame k's noise
        does not depend on how many frames were rendered before it.
    """
    if seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed}")
    return np.random.SeedSequence(seed, spawn_key=(stream_key(name), *extra))


def rng(seed: int, name: str, *extra: int) -> np.random.Generator:
    """A PCG64 generator for stream ``name`` (see :func:`seed_sequence`)."""
    return np.random.Generator(np.random.PCG64(seed_sequence(seed, name, *extra)))
