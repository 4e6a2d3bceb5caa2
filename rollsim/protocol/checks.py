"""Check bits of a PHY-SDU: the paper's two parity bits, or CRC-8.

Both checks are computed over the data bits (sequence-number header followed
by payload) of many packets at once: ``data`` is an ``(n_packets, n_bits)``
array of 0/1 values, most significant bit first.

parity2
    Two interleaved even-parity bits, appended at codeword positions ``n`` and
    ``n + 1`` (``n`` data bits). The bit at position ``q`` makes the parity of
    every codeword position of the same parity class (``q mod 2``) even. So
    parity2 detects every error pattern that flips an odd number of bits in the
    even positions or an odd number in the odd positions of the codeword: all
    single errors, all bursts of length 2, all patterns of odd weight. It misses
    patterns with an even (non-zero) number of flips in each class, e.g. two
    bits two positions apart.

crc8
    CRC-8 with generator x^8 + x^2 + x + 1 (0x07), initial value 0, no
    reflection, no final XOR, over the data bits MSB first. Its generator
    polynomial is (x + 1) times a primitive polynomial of degree 7, so it
    detects every error of odd weight and every double error in codewords of
    up to 127 bits, i.e. up to :data:`CRC8_MAX_DATA_BITS` = 119 data bits.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

CHECK_BITS = {"parity2": 2, "crc8": 8}
CRC8_POLY = 0x07
CRC8_MAX_DATA_BITS = 119


def _as_bit_matrix(data) -> np.ndarray:
    bits = np.asarray(data, dtype=np.uint8)
    if bits.ndim == 1:
        bits = bits[np.newaxis, :]
    if bits.ndim != 2:
        raise ValueError("data must be a 1-D or 2-D array of bits")
    return bits


def parity2(data) -> np.ndarray:
    """The two interleaved parity bits of each row of ``data``.

    Parameters
    ----------
    data : array_like of {0, 1}, shape (n_packets, n_bits) or (n_bits,)
        Data bits, MSB first.

    Returns
    -------
    ndarray of uint8, shape (n_packets, 2)
        Bit 0 sits at codeword position ``n_bits`` and covers the data
        positions of the same parity as ``n_bits``; bit 1 covers the others.
    """
    bits = _as_bit_matrix(data)
    n = bits.shape[1]
    even = np.bitwise_xor.reduce(bits[:, 0::2], axis=1) if n > 0 else np.zeros(len(bits), np.uint8)
    odd = np.bitwise_xor.reduce(bits[:, 1::2], axis=1) if n > 1 else np.zeros(len(bits), np.uint8)
    first, second = (even, odd) if n % 2 == 0 else (odd, even)
    return np.stack([first, second], axis=1).astype(np.uint8)


@lru_cache(maxsize=64)
def _crc8_matrix(n_bits: int) -> np.ndarray:
    """Generator matrix G with crc(d) = d·G mod 2 (the CRC is linear)."""
    rows = np.zeros((n_bits, 8), dtype=np.int32)
    for i in range(n_bits):
        reg = 0
        for j in range(n_bits):
            feedback = ((reg >> 7) & 1) ^ (1 if j == i else 0)
            reg = (reg << 1) & 0xFF
            if feedback:
                reg ^= CRC8_POLY
        rows[i] = [(reg >> (7 - k)) & 1 for k in range(8)]
    rows.setflags(write=False)
    return rows


def crc8(data) -> np.ndarray:
    """CRC-8 (poly 0x07) of each row of ``data``, as 8 bits MSB first.

    Parameters
    ----------
    data : array_like of {0, 1}, shape (n_packets, n_bits) or (n_bits,)

    Returns
    -------
    ndarray of uint8, shape (n_packets, 8)
    """
    bits = _as_bit_matrix(data)
    matrix = _crc8_matrix(bits.shape[1])
    return ((bits.astype(np.int32) @ matrix) & 1).astype(np.uint8)


def check_bits(data, kind: str) -> np.ndarray:
    """Check bits of kind ``"parity2"`` or ``"crc8"`` for each row of ``data``."""
    if kind == "parity2":
        return parity2(data)
    if kind == "crc8":
        return crc8(data)
    raise ValueError(f"unknown check kind {kind!r}; expected one of {sorted(CHECK_BITS)}")


def verify(codewords, kind: str) -> np.ndarray:
    """Whether each codeword (data bits followed by check bits) passes its check.

    Parameters
    ----------
    codewords : array_like of {0, 1}, shape (n_packets, n_bits + n_check)
    kind : {"parity2", "crc8"}

    Returns
    -------
    ndarray of bool, shape (n_packets,)
    """
    words = _as_bit_matrix(codewords)
    n_check = CHECK_BITS[kind]
    data, received = words[:, :-n_check], words[:, -n_check:]
    return np.all(check_bits(data, kind) == received, axis=1)
