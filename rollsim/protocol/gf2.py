"""Linear algebra over GF(2): Gaussian elimination on bit matrices.

A receiver of a random linear code over GF(2) holds one row per coded
PHY-SDU received: the K coefficients of its combination, then its payload
bits. The message is recovered when the coefficient rows reach rank K, by
Gauss-Jordan elimination of the augmented matrix. Rows are packed into
64-bit words (:func:`pack_rows`) so that one XOR updates 64 columns. The
elimination is a compiled kernel (:mod:`rollsim.numerics.jit`): a 1 kB
message has K = 422 pivot columns, and a loop over them in Python, each
step vectorised over the rows, took 10 ms an elimination (the event
simulator's rlnc runs need a dozen each). Its numpy twin makes the same
choices (the first row holding the pivot, the same row XORs), so the two
give the same words.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rollsim.numerics.jit import kernel

WORD_BITS = 64


def pack_rows(bits) -> np.ndarray:
    """Pack a (n, m) 0/1 matrix into (n, ceil(m / 64)) uint64 words, column 0 in bit 0 of word 0."""
    bits = np.asarray(bits, dtype=bool)
    if bits.ndim != 2:
        raise ValueError(f"expected a 2-D bit matrix, got shape {bits.shape}")
    n, m = bits.shape
    words = -(-m // WORD_BITS)
    padded = np.zeros((n, words * WORD_BITS), dtype=bool)
    padded[:, :m] = bits
    as_bytes = np.packbits(padded.reshape(n, words * 8, 8), axis=2, bitorder="little").reshape(n, words * 8)
    return np.ascontiguousarray(as_bytes).view("<u8").reshape(n, words)


def unpack_rows(words: np.ndarray, m: int) -> np.ndarray:
    """Inverse of :func:`pack_rows`: the first ``m`` columns as a bool matrix."""
    words = np.ascontiguousarray(np.asarray(words, dtype="<u8"))
    n = words.shape[0]
    bits = np.unpackbits(words.view(np.uint8).reshape(n, -1), axis=1, bitorder="little")
    return bits[:, :m].astype(bool)


def gf2_matmul(a, b) -> np.ndarray:
    """The product of two 0/1 matrices over GF(2) (bool (n, m)).

    Integer products of at most 2^31 terms cannot overflow int64; larger
    inner dimensions are summed in blocks.
    """
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    block = 1 << 30
    total = np.zeros((a.shape[0], b.shape[1]), dtype=np.int64)
    for start in range(0, a.shape[1], block):
        total ^= (a[:, start : start + block] @ b[start : start + block]) & 1
    return total.astype(bool)


@dataclass(frozen=True)
class Elimination:
    """What Gaussian elimination of ``[coefficients | payloads]`` found.

    Attributes
    ----------
    rank : int
        Rank of the coefficient rows.
    solution : ndarray of bool, shape (K, P), or None
        The K source packets, when ``rank`` is K; None below full rank.
    """

    rank: int
    solution: np.ndarray | None

    @property
    def decodable(self) -> bool:
        return self.solution is not None


def _bit(words: np.ndarray, column: int) -> np.ndarray:
    """Column ``column`` of packed rows, as bool."""
    return ((words[:, column // WORD_BITS] >> np.uint64(column % WORD_BITS)) & np.uint64(1)).astype(bool)


def _reduce(words: np.ndarray, k: int) -> tuple[np.ndarray, int]:
    """Gauss-Jordan elimination over the first ``k`` columns of packed rows (in place).

    Returns the rows (the first ``rank`` of them the reduced pivot rows, in
    column order) and the rank.
    """
    compiled = _reduce_words.compiled
    if compiled is not None:
        return words, int(compiled(words, k))
    return _reduce_numpy(words, k)


@kernel
def _reduce_words(words, k):  # pragma: no cover - compiled by numba
    n, width = words.shape
    one = np.uint64(1)
    rank = 0
    for column in range(k):
        if rank == n:
            break
        word = column // 64
        shift = np.uint64(column % 64)
        pivot = -1
        for r in range(rank, n):
            if (words[r, word] >> shift) & one:
                pivot = r
                break
        if pivot < 0:
            continue
        if pivot != rank:
            for j in range(width):
                held = words[rank, j]
                words[rank, j] = words[pivot, j]
                words[pivot, j] = held
        # Clear this column in every other row.
        for r in range(n):
            if r != rank and (words[r, word] >> shift) & one:
                for j in range(width):
                    words[r, j] ^= words[rank, j]
        rank += 1
    return rank


def _reduce_numpy(words: np.ndarray, k: int) -> tuple[np.ndarray, int]:
    """:data:`_reduce_words` in numpy: the same pivots and row operations, each step vectorised over the rows."""
    rank = 0
    for column in range(k):
        if rank == words.shape[0]:
            break
        has = _bit(words[rank:], column)
        if not has.any():
            continue
        pivot = rank + int(np.argmax(has))
        if pivot != rank:
            words[[rank, pivot]] = words[[pivot, rank]]
        # Clear this column in every other row: one XOR of whole rows.
        others = _bit(words, column)
        others[rank] = False
        words[others] ^= words[rank]
        rank += 1
    return words, rank


def eliminate(coefficients, payloads) -> Elimination:
    """Recover K source packets from n coded ones, when their coefficients have rank K.

    Parameters
    ----------
    coefficients : array_like of bool, shape (n, K)
        Row i: which source packets coded packet i is the XOR of.
    payloads : array_like of bool, shape (n, P)
        The coded packets' bits.

    Returns
    -------
    Elimination
        The rank, and the source packets (K, P) when it is K.
    """
    c = np.asarray(coefficients, dtype=bool)
    d = np.asarray(payloads, dtype=bool)
    if c.ndim != 2 or d.ndim != 2 or c.shape[0] != d.shape[0]:
        raise ValueError(f"coefficients {c.shape} and payloads {d.shape} must be 2-D with one row per coded packet")
    k, p = c.shape[1], d.shape[1]
    if c.shape[0] == 0:
        return Elimination(0, None if k else np.zeros((0, p), dtype=bool))
    words, rank = _reduce(pack_rows(np.concatenate([c, d], axis=1)), k)
    if rank < k:
        return Elimination(rank, None)
    # Reduced rows 0..K-1 hold the identity in the coefficient columns.
    return Elimination(rank, unpack_rows(words[:k], k + p)[:, k:])


def rank(coefficients) -> int:
    """Rank over GF(2) of a 0/1 matrix."""
    c = np.asarray(coefficients, dtype=bool)
    if c.size == 0:
        return 0
    return _reduce(pack_rows(c), c.shape[1])[1]


def row_basis(coefficients) -> np.ndarray:
    """A basis of the row space: the reduced independent rows (bool, shape (rank, K))."""
    c = np.asarray(coefficients, dtype=bool)
    if c.shape[0] == 0:
        return np.zeros((0, c.shape[1]), dtype=bool)
    words, found = _reduce(pack_rows(c), c.shape[1])
    return unpack_rows(words[:found], c.shape[1])


def first_full_rank(coefficients) -> int | None:
    """The least n for which the first n rows have rank K (the number of columns), or None.

    Rank grows with the rows, so a binary search over the prefixes needs
    log2(n) eliminations.
    """
    c = np.asarray(coefficients, dtype=bool)
    k = c.shape[1]
    if rank(c) < k:
        return None
    low, high = k, c.shape[0]  # rank(c[:high]) == k; fewer than k rows cannot reach it
    while low < high:
        middle = (low + high) // 2
        if rank(c[:middle]) == k:
            high = middle
        else:
            low = middle + 1
    return low
