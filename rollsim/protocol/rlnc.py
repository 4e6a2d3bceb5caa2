"""Random linear network coding over GF(2): the coded PHY-SDUs of a rateless broadcast.

A message of K source packets is sent as coded packets, each the XOR of a
random subset of the sources. The subset is drawn from a seed that the
coded PHY-SDU carries in its header, so transmitter and receiver draw the
same one (:func:`combinations`). A receiver that holds any coded packets
whose subsets span GF(2)^K recovers the message
(:func:`rollsim.protocol.gf2.eliminate`); which packets it missed does not
matter, only how many it holds.

Subsets are uniform over the 2^K − 1 non-empty ones. From rank r, a new
one raises the rank with probability p_r = (2^K − 2^r) / (2^K − 1), so the
number of receptions to full rank is a sum of independent geometric
variables (:func:`receptions_to_full_rank_pmf`, :func:`expected_receptions_to_full_rank`).
"""

from __future__ import annotations

import numpy as np

from rollsim.numerics.counter_rng import GAMMA, mix64
from rollsim.protocol.gf2 import gf2_matmul

def _splitmix64(x: np.ndarray) -> np.ndarray:
    """SplitMix64's next output from state ``x`` (uint64, wrapping arithmetic): a counter-based hash."""
    with np.errstate(over="ignore"):
        return mix64(x + GAMMA)


def _draw(seeds: np.ndarray, k: int, attempt: int) -> np.ndarray:
    """K bits per seed from hashes of (seed, attempt, word): bool (n, K)."""
    words = -(-k // 64)
    with np.errstate(over="ignore"):
        base = _splitmix64(seeds.astype(np.uint64) ^ _splitmix64(np.full(seeds.shape, attempt, dtype=np.uint64)))
        counters = base[:, None] + np.arange(1, words + 1, dtype=np.uint64)[None, :]
    hashed = np.ascontiguousarray(_splitmix64(counters)).astype("<u8")
    bits = np.unpackbits(hashed.view(np.uint8).reshape(seeds.size, -1), axis=1, bitorder="little")
    return bits[:, :k].astype(bool)


def combinations(seeds, k: int) -> np.ndarray:
    """The source subset of each coded packet: uniform over the non-empty subsets of K.

    Parameters
    ----------
    seeds : array_like of int
        One per coded packet, 0 … 2^64 − 1 (what its header carries).
    k : int
        Source packets, ≥ 1.

    Returns
    -------
    ndarray of bool, shape (n, K)
        Row i: the sources XORed into coded packet i. The same seeds give
        the same rows on every machine (a hash, not a generator's state).
    """
    if k < 1:
        raise ValueError(f"k must be >= 1, got {k}")
    seeds = np.atleast_1d(np.asarray(seeds, dtype=np.uint64))
    rows = _draw(seeds, k, 0)
    # An empty subset carries nothing: draw again (attempt 1, 2, ...), which
    # keeps the rows uniform over the non-empty subsets.
    attempt = 1
    empty = ~rows.any(axis=1)
    while empty.any():
        rows[empty] = _draw(seeds[empty], k, attempt)
        empty = ~rows.any(axis=1)
        attempt += 1
    return rows


def encode(packets, seeds) -> np.ndarray:
    """Coded packets: for each seed, the XOR of its subset of the source packets.

    Parameters
    ----------
    packets : array_like of bool, shape (K, P)
        The message's source packets.
    seeds : array_like of int
        One per coded packet.

    Returns
    -------
    ndarray of bool, shape (n, P)
    """
    packets = np.asarray(packets, dtype=bool)
    return gf2_matmul(combinations(seeds, packets.shape[0]), packets)


def _is_prime(n: int) -> bool:
    if n < 2:
        return False
    if n % 2 == 0:
        return n == 2
    return all(n % d for d in range(3, int(n**0.5) + 1, 2))


def seed_space(header_bits: int) -> int:
    """Seeds a coded PHY-SDU's header cycles through: the largest prime ≤ 2^header_bits.

    The transmitter sends seed i mod S at emission i. Were S a power of two,
    a camera whose cycle C (M + N slots) divides it (C = 4 at 5 cm on
    paper-default) would see the same residues of i mod C in its OFF slots
    for ever, and miss those seeds every time: with 9 header bits and a
    1 kB message, 384 visible seeds cannot reach rank 422. A prime S shares
    no factor with any cycle shorter than itself, so every seed comes round
    to an ON slot.
    """
    if header_bits < 1:
        raise ValueError(f"header_bits must be >= 1, got {header_bits}")
    n = 1 << header_bits
    while not _is_prime(n):
        n -= 1
    return n


def rank_step_probabilities(k: int) -> np.ndarray:
    """p_r, r = 0 … K−1: the chance that a uniform non-empty subset raises rank r to r + 1.

    p_r = 1 − (2^r − 1) / (2^K − 1), computed as powers of two below one so
    that K in the thousands neither overflows nor loses p_r's distance from 1.
    """
    if k < 1:
        raise ValueError(f"k must be >= 1, got {k}")
    r = np.arange(k, dtype=np.float64)
    # (2^r − 1) / (2^K − 1) = 2^(r−K) (1 − 2^−r) / (1 − 2^−K)
    ratio = np.exp2(r - k) * (-np.expm1(-r * np.log(2.0))) / (-np.expm1(-k * np.log(2.0)))
    return 1.0 - ratio


def expected_receptions_to_full_rank(k: int) -> float:
    """E[receptions until the coefficients reach rank K] = Σ 1 / p_r."""
    return float(np.sum(1.0 / rank_step_probabilities(k)))


def receptions_to_full_rank_pmf(k: int, n_max: int) -> np.ndarray:
    """P(rank K is first reached at reception n), n = 0 … n_max.

    The rank is a Markov chain that moves from r to r + 1 with probability
    p_r; the distribution is propagated reception by reception (the mass
    past ``n_max`` is 1 − the sum).
    """
    if n_max < 0:
        raise ValueError(f"n_max must be >= 0, got {n_max}")
    p = rank_step_probabilities(k)
    state = np.zeros(k + 1)
    state[0] = 1.0
    pmf = np.zeros(n_max + 1)
    for n in range(1, n_max + 1):
        moved = state[:k] * p
        state[:k] -= moved
        state[1:] += moved
        pmf[n] = state[k]
        state[k] = 0.0
    return pmf
