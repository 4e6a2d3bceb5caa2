"""The message a scene broadcasts."""

from __future__ import annotations

import numpy as np

from rollsim.numerics.seeds import rng


def message_from_seed(seed: int, message_bytes: int) -> bytes:
    """``message_bytes`` pseudo-random bytes from the scene seed.

    Like CamComSim's arbitrary payload data, but reproducible: the bytes come
    from the named stream ``"message"`` of the seed.
    """
    if message_bytes < 1:
        raise ValueError(f"message_bytes must be >= 1, got {message_bytes}")
    return rng(seed, "message").integers(0, 256, size=message_bytes, dtype=np.uint8).tobytes()
