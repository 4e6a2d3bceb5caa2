"""Message bytes to packets and back.

A message of G bytes is read as 8·G bits, MSB first, and cut into
``N_p = ceil(8·G / P)`` payloads of P bits. The last payload is padded with
zero bits; how many of its bits are real follows from G, which sender and
receiver both know (:func:`last_payload_bits`). Each packet's header is its
sequence number 0..N_p-1 in H bits, MSB first.
"""

from __future__ import annotations

import math

import numpy as np


def n_packets(message_bytes: int, payload_bits: int) -> int:
    """Number of packets N_p = ceil(8·G / P) of a G-byte message."""
    if message_bytes < 1:
        raise ValueError(f"message_bytes must be >= 1, got {message_bytes}")
    if payload_bits < 1:
        raise ValueError(f"payload_bits must be >= 1, got {payload_bits}")
    return -(-8 * message_bytes // payload_bits)


def last_payload_bits(message_bytes: int, payload_bits: int) -> int:
    """Number of real (unpadded) bits in the last packet's payload."""
    return 8 * message_bytes - (n_packets(message_bytes, payload_bits) - 1) * payload_bits


def min_header_bits(packets: int) -> int:
    """Fewest header bits that give ``packets`` distinct sequence numbers."""
    if packets < 1:
        raise ValueError(f"packets must be >= 1, got {packets}")
    return math.ceil(math.log2(packets)) if packets > 1 else 0


def int_to_bits(values, n_bits: int) -> np.ndarray:
    """Non-negative integers to rows of ``n_bits`` bits, MSB first."""
    values = np.asarray(values, dtype=np.int64).reshape(-1)
    if n_bits == 0:
        return np.zeros((values.size, 0), dtype=np.uint8)
    if np.any(values < 0) or np.any(values >= (1 << n_bits)):
        raise ValueError(f"values do not fit in {n_bits} bits")
    shifts = np.arange(n_bits - 1, -1, -1, dtype=np.int64)
    return ((values[:, None] >> shifts) & 1).astype(np.uint8)


def bits_to_int(bits) -> np.ndarray:
    """Rows of bits, MSB first, to integers."""
    rows = np.asarray(bits, dtype=np.int64)
    rows = rows[np.newaxis, :] if rows.ndim == 1 else rows
    weights = np.left_shift(1, np.arange(rows.shape[1] - 1, -1, -1, dtype=np.int64))
    return rows @ weights


def packetize(message: bytes, payload_bits: int) -> np.ndarray:
    """Cut ``message`` into zero-padded payloads.

    Parameters
    ----------
    message : bytes
        The message, at least one byte.
    payload_bits : int
        Payload size P in bits.

    Returns
    -------
    ndarray of uint8, shape (N_p, payload_bits)
        Payload bits of packet k in row k.
    """
    count = n_packets(len(message), payload_bits)
    bits = np.unpackbits(np.frombuffer(bytes(message), dtype=np.uint8))
    padded = np.zeros(count * payload_bits, dtype=np.uint8)
    padded[: bits.size] = bits
    return padded.reshape(count, payload_bits)


def depacketize(payloads, message_bytes: int) -> bytes:
    """Inverse of :func:`packetize`: join payloads in order and drop the pad."""
    rows = np.asarray(payloads, dtype=np.uint8)
    bits = rows.reshape(-1)[: 8 * message_bytes]
    if bits.size != 8 * message_bytes:
        raise ValueError(f"{rows.size} payload bits cannot hold a {message_bytes}-byte message")
    return np.packbits(bits).tobytes()

