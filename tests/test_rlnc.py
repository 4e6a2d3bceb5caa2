"""Random linear coding over GF(2): elimination, coefficient draws and the full-rank distribution."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rollsim.protocol.gf2 import eliminate, first_full_rank, gf2_matmul, pack_rows, rank, unpack_rows
from rollsim.protocol.rlnc import (
    combinations,
    encode,
    expected_receptions_to_full_rank,
    rank_step_probabilities,
    receptions_to_full_rank_pmf,
)


@given(st.integers(1, 5), st.integers(1, 150), st.integers(0, 2**32 - 1))
@settings(max_examples=60, deadline=None)
def test_packing_round_trips(n, m, seed):
    bits = np.random.default_rng(seed).random((n, m)) < 0.5
    np.testing.assert_array_equal(unpack_rows(pack_rows(bits), m), bits)


@given(st.integers(1, 70), st.integers(1, 40), st.integers(0, 2**32 - 1))
@settings(max_examples=60, deadline=None)
def test_any_full_rank_subset_recovers_the_message(k, p, seed):
    rng = np.random.default_rng(seed)
    message = rng.random((k, p)) < 0.5
    seeds = rng.integers(0, 2**63, size=k + 12, dtype=np.uint64)
    coded = encode(message, seeds)
    coefficients = combinations(seeds, k)
    # Any subset: drop a random third of the coded packets, shuffle the rest.
    keep = rng.permutation(seeds.size)[: max(k, (2 * seeds.size) // 3)]
    found = eliminate(coefficients[keep], coded[keep])
    assert found.rank == rank(coefficients[keep])
    if found.rank == k:
        np.testing.assert_array_equal(found.solution, message)
    else:
        assert found.solution is None and not found.decodable


@given(st.integers(2, 40), st.integers(0, 2**32 - 1))
@settings(max_examples=40, deadline=None)
def test_below_full_rank_fails_cleanly(k, seed):
    rng = np.random.default_rng(seed)
    message = rng.random((k, 8)) < 0.5
    seeds = rng.integers(0, 2**63, size=k - 1, dtype=np.uint64)
    found = eliminate(combinations(seeds, k), encode(message, seeds))
    assert found.rank <= k - 1 and found.solution is None


def test_elimination_knows_the_identity_and_dependent_rows():
    eye = np.eye(4, dtype=bool)
    payload = np.arange(16).reshape(4, 4) % 2 == 1
    np.testing.assert_array_equal(eliminate(eye[::-1], payload[::-1]).solution, payload)
    dependent = np.array([[1, 1, 0], [0, 1, 1], [1, 0, 1]], dtype=bool)  # row 3 = row 1 ^ row 2
    assert rank(dependent) == 2 and eliminate(dependent, np.zeros((3, 1), bool)).solution is None
    assert first_full_rank(np.array([[1, 1], [1, 1], [0, 1], [1, 0]], dtype=bool)) == 3
    assert first_full_rank(np.array([[1, 1], [1, 1]], dtype=bool)) is None
    with pytest.raises(ValueError, match="one row per coded packet"):
        eliminate(np.zeros((2, 3), bool), np.zeros((3, 1), bool))


def test_gf2_product_is_xor_of_rows():
    a = np.array([[1, 0, 1], [1, 1, 1]], dtype=bool)
    b = np.array([[1, 0], [1, 1], [1, 1]], dtype=bool)
    np.testing.assert_array_equal(gf2_matmul(a, b), [[b[0][0] ^ b[2][0], b[0][1] ^ b[2][1]], [True, False]])


def test_combinations_are_deterministic_non_empty_and_uniform():
    seeds = np.arange(60000, dtype=np.uint64)
    rows = combinations(seeds, 3)
    np.testing.assert_array_equal(rows, combinations(seeds, 3))
    assert rows.any(axis=1).all()
    # Uniform over the 7 non-empty subsets of 3: Pearson chi-square, 6 degrees
    # of freedom; 22.46 is its 0.999 quantile.
    index = rows @ np.array([1, 2, 4])
    counts = np.bincount(index, minlength=8)[1:]
    expected = seeds.size / 7
    assert float(np.sum((counts - expected) ** 2 / expected)) < 22.46
    assert combinations([5], 200).shape == (1, 200)
    with pytest.raises(ValueError, match="k must be"):
        combinations([1], 0)


@pytest.mark.parametrize("k", [1, 2, 3, 10, 50])
def test_the_full_rank_distribution_sums_to_one_with_the_closed_form_mean(k):
    n_max = k + 80
    pmf = receptions_to_full_rank_pmf(k, n_max)
    assert pmf[:k].sum() == 0.0 and math.isclose(pmf.sum(), 1.0, abs_tol=1e-12)
    mean = float(np.sum(np.arange(n_max + 1) * pmf))
    assert mean == pytest.approx(expected_receptions_to_full_rank(k), rel=1e-9)


def test_rank_steps_are_exact_for_small_k_and_finite_for_large():
    np.testing.assert_allclose(rank_step_probabilities(3), [1.0, 6 / 7, 4 / 7], rtol=1e-15)
    p = rank_step_probabilities(5000)
    assert np.all(np.isfinite(p)) and p[0] == 1.0 and p[-1] == pytest.approx(0.5)
    # K + E extra receptions on average for large K: E = Σ 1/(2^j − 1), the
    # Erdős–Borwein constant 1.606695…
    assert expected_receptions_to_full_rank(5000) - 5000 == pytest.approx(1.606695152, abs=1e-6)


@pytest.mark.parametrize("k", [4, 20])
def test_the_full_rank_distribution_equals_simulation(k):
    """Receptions to full rank of coded packets drawn by seed, against the chain, within a 99.9 % band."""
    runs, extra = 3000, 30
    rng = np.random.default_rng(k)
    seeds = rng.integers(0, 2**63, size=(runs, k + extra), dtype=np.uint64)
    found = np.array([first_full_rank(combinations(row, k)) for row in seeds])
    assert np.all(found != None)  # noqa: E711  (k + 30 random rows: full rank but for 2^-30)
    pmf = receptions_to_full_rank_pmf(k, k + extra)
    for n in range(k, k + 4):
        observed = np.mean(found == n)
        sigma = math.sqrt(pmf[n] * (1 - pmf[n]) / runs)
        assert abs(observed - pmf[n]) < 3.3 * sigma + 1e-12, (n, observed, pmf[n])
    mean_sigma = float(np.std(found)) / math.sqrt(runs)
    assert abs(found.mean() - expected_receptions_to_full_rank(k)) < 3.3 * mean_sigma


@pytest.mark.parametrize("n, m, k, density, seed", [(30, 422 + 19, 422, 0.5, 0), (500, 150, 120, 0.02, 1),
                                                     (64, 64, 64, 0.5, 2), (10, 200, 190, 0.3, 3), (1, 5, 5, 1.0, 4)])
def test_compiled_and_numpy_elimination_give_the_same_words(n, m, k, density, seed):
    """The compiled kernel makes the numpy twin's choices: the same reduced words and rank."""
    from rollsim.numerics.jit import numpy_only
    from rollsim.protocol.gf2 import _reduce

    bits = np.random.default_rng(seed).random((n, m)) < density
    compiled_words, compiled_rank = _reduce(pack_rows(bits), k)
    with numpy_only():
        plain_words, plain_rank = _reduce(pack_rows(bits), k)
    assert compiled_rank == plain_rank
    np.testing.assert_array_equal(compiled_words, plain_words)
