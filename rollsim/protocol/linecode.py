"""Line codes: bits to LED chips (1 = ON, 0 = OFF) and back.

manchester
    IEEE 802.3 polarity: bit 1 is sent as chips ``0 1`` (OFF then ON, a rising
    edge mid-bit), bit 0 as ``1 0``. Two chips per bit, DC-balanced, runs of
    one or two equal chips only. A pair of equal chips cannot come from any
    bit, so it decodes as an error, never as a guess.

4b6b
    Each 4-bit group (MSB first) is sent as a 6-chip codeword with exactly
    three ON chips (the table of IEEE 802.15.7 VLC PHY II), so every
    codeword is DC-balanced. Runs are at most 4 chips long across codeword
    boundaries. Data whose length is not a multiple of 4 is padded with zero
    bits; the pad is stripped on decoding. The 48 six-chip patterns that are
    not codewords decode as errors.
"""

from __future__ import annotations

import numpy as np

LINE_CODES = ("manchester", "4b6b")

# Data nibble (value 0..15, MSB first) -> 6-chip codeword.
FOUR_B_SIX_B_TABLE = (
    "001110", "001101", "010011", "010110",
    "010101", "100011", "100110", "100101",
    "011001", "011010", "011100", "110001",
    "110010", "101001", "101010", "101100",
)

_4B6B_CHIPS = np.array([[int(c) for c in word] for word in FOUR_B_SIX_B_TABLE], dtype=np.uint8)
_6B_WEIGHTS = 1 << np.arange(5, -1, -1)
_4B_WEIGHTS = 1 << np.arange(3, -1, -1)
_6B_TO_NIBBLE = np.full(64, -1, dtype=np.int16)
_6B_TO_NIBBLE[_4B6B_CHIPS @ _6B_WEIGHTS] = np.arange(16)
_NIBBLE_BITS = ((np.arange(16)[:, None] >> np.arange(3, -1, -1)) & 1).astype(np.uint8)


def _check_code(code: str) -> None:
    if code not in LINE_CODES:
        raise ValueError(f"unknown line code {code!r}; expected one of {list(LINE_CODES)}")


def _as_rows(bits) -> np.ndarray:
    arr = np.asarray(bits, dtype=np.uint8)
    return arr[np.newaxis, :] if arr.ndim == 1 else arr


def padded_bits(n_bits: int, code: str) -> int:
    """Number of bits after padding for ``code`` (a multiple of 4 for 4B6B)."""
    _check_code(code)
    return n_bits if code == "manchester" else -(-n_bits // 4) * 4


def coded_chips(n_bits: int, code: str) -> int:
    """Number of chips that ``n_bits`` data bits take in line code ``code``."""
    n = padded_bits(n_bits, code)
    return 2 * n if code == "manchester" else 6 * (n // 4)


def chips_per_symbol(code: str) -> tuple[int, int]:
    """``(chips, bits)`` of one code symbol: (2, 1) Manchester, (6, 4) 4B6B."""
    _check_code(code)
    return (2, 1) if code == "manchester" else (6, 4)


def max_run_length(code: str) -> int:
    """Longest run of equal chips that back-to-back coded data can contain."""
    _check_code(code)
    if code == "manchester":
        return 2
    words = ["".join(map(str, w)) for w in _4B6B_CHIPS]
    # A run can span at most two codewords, since no codeword is constant.
    longest = 0
    for a in words:
        for b in words:
            s = a + b
            run = 1
            for x, y in zip(s, s[1:]):
                run = run + 1 if x == y else 1
                longest = max(longest, run)
    return longest


def encode(bits, code: str) -> np.ndarray:
    """Line-code each row of ``bits``.

    Parameters
    ----------
    bits : array_like of {0, 1}, shape (n_packets, n_bits) or (n_bits,)
    code : {"manchester", "4b6b"}

    Returns
    -------
    ndarray of uint8, shape (n_packets, coded_chips(n_bits, code))
    """
    _check_code(code)
    rows = _as_rows(bits)
    if code == "manchester":
        chips = np.empty((rows.shape[0], 2 * rows.shape[1]), dtype=np.uint8)
        chips[:, 0::2] = 1 - rows
        chips[:, 1::2] = rows
        return chips
    n_pad = padded_bits(rows.shape[1], code) - rows.shape[1]
    if n_pad:
        rows = np.concatenate([rows, np.zeros((rows.shape[0], n_pad), np.uint8)], axis=1)
    nibbles = rows.reshape(rows.shape[0], -1, 4) @ _4B_WEIGHTS
    return _4B6B_CHIPS[nibbles].reshape(rows.shape[0], -1)


def decode(chips, code: str, n_bits: int) -> tuple[np.ndarray, np.ndarray]:
    """Decode each row of ``chips`` back to ``n_bits`` bits.

    Parameters
    ----------
    chips : array_like of {0, 1}, shape (n_packets, coded_chips(n_bits, code))
    code : {"manchester", "4b6b"}
    n_bits : int
        Number of data bits before padding.

    Returns
    -------
    bits : ndarray of uint8, shape (n_packets, n_bits)
        Decoded bits; 0 where the symbol was invalid.
    valid : ndarray of bool, shape (n_packets,)
        False where any symbol was not a valid code symbol (an equal
        Manchester pair, a non-codeword 4B6B pattern).
    """
    _check_code(code)
    rows = _as_rows(chips)
    expected = coded_chips(n_bits, code)
    if rows.shape[1] != expected:
        raise ValueError(f"expected {expected} chips for {n_bits} bits in {code}, got {rows.shape[1]}")
    symbols = _symbol_index(rows.reshape(rows.shape[0], -1, chips_per_symbol(code)[0]), code)
    valid = np.all(symbols >= 0, axis=1)
    if code == "manchester":
        return np.maximum(symbols, 0).astype(np.uint8), valid
    bits = _NIBBLE_BITS[np.maximum(symbols, 0)].reshape(rows.shape[0], -1)
    return bits[:, :n_bits], valid


def _symbol_index(symbols: np.ndarray, code: str) -> np.ndarray:
    """Which codeword of :func:`_codewords` each symbol (chips on the last axis) is; -1 if none.

    The index is the symbol's value: the bit of a Manchester pair, the
    nibble of a 4B6B word.
    """
    if code == "manchester":
        return np.where(symbols[..., 0] != symbols[..., 1], symbols[..., 1].astype(np.int16), -1)
    return _6B_TO_NIBBLE[symbols @ _6B_WEIGHTS]


def _codewords(code: str) -> np.ndarray:
    """Every valid symbol of ``code`` as chips, shape (n_symbols, chips per symbol), in the order of their values."""
    # Manchester: bit 0 is 10, bit 1 is 01 (IEEE 802.3 polarity).
    return np.array([[1, 0], [0, 1]], dtype=np.uint8) if code == "manchester" else _4B6B_CHIPS


def repair(chips, reliability, code: str, max_symbols: int = 1, min_margin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Invalid symbols replaced by the most likely valid one, in rows with at most ``max_symbols`` of them.

    Each chip's reliability is what flipping it would cost (a log-likelihood
    ratio, or anything proportional to one within a symbol). The most likely
    valid symbol flips the chips of least total reliability:
    it maximises Σ_k (2c_k − 1)·r_k·(2w_k − 1) over the codewords w. For
    Manchester this is the differential decision: an equal pair keeps its
    more reliable chip. A row with more invalid symbols keeps them (its
    noise is not one unlucky chip), and so does a symbol whose best
    replacement does not beat the next best by more than ``min_margin`` of
    the reliability of the chips where the two differ (a tie: nothing says
    which chip is wrong). For one chip of reliability b to flip against
    another of a, that is 2(a − b)/(a + b), in either code.

    Repairing weakens the code as an error detector: a random symbol row
    may now pass when at most ``max_symbols`` of its S symbols are invalid
    (those whose repair the margin lets through). With one symbol, at most
    (S + 1)·2^-S for Manchester instead of 2^-S (26 bits: a factor 27, 4.8
    bits of the line code's protection) and (1 + 3S)·4^-S for 4B6B instead
    of 4^-S.

    Parameters
    ----------
    chips : array_like of {0, 1}, shape (n_packets, n_chips) or (n_chips,)
        Coded chips, a whole number of symbols per row.
    reliability : array_like of float, same shape
        Non-negative reliability of each chip's decision.
    code : {"manchester", "4b6b"}
    max_symbols : int
        Most invalid symbols a row may have to be repaired (>= 0).
    min_margin : float
        Least lead of the best replacement's score over the next best, as a
        fraction of the summed reliability of the chips where the two
        differ (>= 0).

    Returns
    -------
    chips : ndarray of uint8, shape (n_packets, n_chips)
        A copy, repaired.
    repaired : ndarray of int64, shape (n_packets,)
        Symbols replaced in each row.

    Raises
    ------
    ValueError
        Shapes that differ or are not whole symbols, a negative or
        non-finite reliability, or a negative ``max_symbols``.
    """
    _check_code(code)
    rows = _as_rows(chips).copy()
    weights = np.asarray(reliability, dtype=np.float64)
    weights = weights[np.newaxis, :] if weights.ndim == 1 else weights
    per_symbol = chips_per_symbol(code)[0]
    if weights.shape != rows.shape or rows.shape[1] % per_symbol:
        raise ValueError(f"chips {rows.shape} and reliability {weights.shape} must match, in whole {per_symbol}-chip symbols")
    if not np.all(np.isfinite(weights) & (weights >= 0)):
        raise ValueError("reliability must be finite and >= 0")
    if max_symbols < 0 or not min_margin >= 0:
        raise ValueError(f"max_symbols and min_margin must be >= 0, got {max_symbols} and {min_margin}")
    words = _codewords(code)
    shape = (rows.shape[0], rows.shape[1] // per_symbol, per_symbol)
    symbols, weights = rows.reshape(shape), weights.reshape(shape)
    invalid = _symbol_index(symbols, code) < 0
    count = invalid.sum(axis=1)
    scores = ((2.0 * symbols - 1.0) * weights) @ (2.0 * words - 1.0).T
    order = np.argsort(scores, axis=2)
    best, runner_up = order[:, :, -1], order[:, :, -2]
    lead = np.take_along_axis(scores, best[:, :, None], 2)[:, :, 0] - np.take_along_axis(scores, runner_up[:, :, None], 2)[:, :, 0]
    contested = np.sum(weights * (words[best] != words[runner_up]), axis=2)
    clear = (lead > 0) & (lead > min_margin * contested)
    replace = invalid & clear & (count <= max_symbols)[:, None]
    symbols[replace] = words[best[replace]]
    return rows, replace.sum(axis=1)
