"""Counter-based random words: word i of a stream is a hash of (key, i).

The per-pixel noise of a frame needs one or two 32-bit uniforms per pixel,
drawn in one pass together with the rest of the sensor chain. A counter-based
generator gives pixel i its words from the stream's key and i alone, so a
compiled kernel and its numpy twin compute the very same words (the kernel
in its loop, numpy as whole-array integer arithmetic), in any order.

The hash is SplitMix64 (Steele, Lea and Flood, "Fast splittable
pseudorandom number generators", OOPSLA 2014): word i is
``mix(key + (i + 1)·γ)``, which is exactly the SplitMix64 sequence started at
``key``, a generator that passes BigCrush. The key comes from the frame's
named numpy stream (:func:`stream_key`), so streams stay independent and
seeded from the scene seed, never from the clock.
"""

from __future__ import annotations

import numpy as np

GAMMA = np.uint64(0x9E3779B97F4A7C15)
MIX1 = np.uint64(0xBF58476D1CE4E5B9)
MIX2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S32 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(32)
LOW32 = np.uint64(0xFFFFFFFF)
# A word's 32-bit halves as uniforms on [0, 1): u = w · 2^-32, exact in float64.
WORD_SCALE = 2.0**-32


def stream_key(rng: np.random.Generator) -> np.uint64:
    """A 64-bit key drawn from a named stream's generator (one draw)."""
    return rng.integers(0, 2**64, dtype=np.uint64, endpoint=False)


def mix64(z):
    """SplitMix64's output function on uint64 arrays (the compiled chain writes the same steps inline).

    numpy's uint64 arithmetic wraps modulo 2^64, as the hash needs.
    """
    z = (z ^ (z >> _S30)) * MIX1
    z = (z ^ (z >> _S27)) * MIX2
    return z ^ (z >> _S31)


def words(key: np.uint64, counters: np.ndarray) -> np.ndarray:
    """64-bit words ``mix(key + (counter + 1)·γ)`` of the given counters (uint64 array)."""
    with np.errstate(over="ignore"):
        z = counters.astype(np.uint64) + np.uint64(1)
        z *= GAMMA
        z += np.uint64(key)
        return mix64(z)
