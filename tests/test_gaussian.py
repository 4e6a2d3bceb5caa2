"""Standard normal deviates: the table method against the normal law."""

import numpy as np
import pytest
from scipy import stats

from rollsim.numerics.gaussian import standard_normal


@pytest.mark.parametrize("method", ["exact", "table"])
def test_moments_and_kolmogorov_distance(method):
    z = standard_normal(np.random.default_rng(3), 2_000_000, method)
    assert z.dtype == np.float32
    assert abs(z.mean()) < 0.003 and abs(z.std() - 1) < 0.003
    assert stats.kstest(z, "norm").pvalue > 1e-3


def test_table_reaches_the_tails_exactly():
    z = standard_normal(np.random.default_rng(4), 4_000_000, "table")
    tail = np.abs(z) > 4.17
    # Beyond the outermost bin medians only the exact tail draws remain:
    # P(|Z| > 4.17) = 3.05e-5, and their law is the normal's tail.
    assert tail.sum() == pytest.approx(4_000_000 * 2 * stats.norm.sf(4.17), rel=0.1)
    assert stats.kstest(np.abs(z[tail]), lambda x: 1 - stats.norm.sf(x) / stats.norm.sf(4.17)).pvalue > 1e-3


def test_unknown_method():
    with pytest.raises(ValueError, match="unknown method"):
        standard_normal(np.random.default_rng(0), 3, "ziggurat")


def _all_words_of_bins(bins: np.ndarray, fine: np.ndarray) -> np.ndarray:
    return (bins.astype(np.uint64) << np.uint64(16)) | fine.astype(np.uint64)


def test_word_table_follows_the_normal_law():
    from rollsim.numerics.gaussian import normal_from_words, normal_tables

    words = np.random.default_rng(5).integers(0, 2**32, size=2_000_000, dtype=np.uint64)
    z = normal_from_words(words, *normal_tables())
    assert z.dtype == np.float32
    assert abs(z.mean()) < 0.003 and abs(z.std() - 1) < 0.003
    assert stats.kstest(z, "norm").pvalue > 1e-3


def test_word_table_tails_are_the_quantiles_of_the_word_centres():
    """Every word of the two outermost bins maps to the normal quantile at its centre (w + 1/2)/2^32,
    so the tails reach +-6.34 sigma and mirror each other exactly."""
    from rollsim.numerics.gaussian import normal_from_word, normal_from_words, normal_tables

    tables = normal_tables()
    fine = np.arange(65536)
    low = normal_from_words(_all_words_of_bins(np.zeros(65536), fine), *tables)
    high = normal_from_words(_all_words_of_bins(np.full(65536, 65535), fine), *tables)
    centres = (fine + 0.5) / 2.0**32
    assert np.allclose(low, stats.norm.ppf(centres), rtol=1e-6)
    assert np.array_equal(high, -low[::-1])
    assert low.min() == pytest.approx(-6.34, abs=0.01) and np.all(np.diff(low) > 0)
    # The scalar (kernel) form agrees with the array form.
    for word in (0, 1, 65535, 65536, 2**31, 2**32 - 1):
        assert normal_from_word(np.uint64(word), *tables) == normal_from_words(np.array([word], np.uint64), *tables)[0]


def test_tables_are_scipys_quantiles_to_the_bit():
    """AS241 (no scipy.special import at start-up) gives, as float32, the very
    tables scipy.special.ndtri gives: every entry of all three."""
    from scipy.special import ndtri

    from rollsim.numerics.gaussian import normal_tables

    body, low, high = normal_tables()
    bins = np.arange(65536, dtype=np.float64)
    assert body.tobytes() == ndtri((bins + 0.5) / 65536).astype(np.float32).tobytes()
    assert low.tobytes() == ndtri((bins + 0.5) / 2.0**32).astype(np.float32).tobytes()
    assert high.tobytes() == (-ndtri((bins + 0.5) / 2.0**32).astype(np.float32))[::-1].tobytes()


def test_normal_quantile_is_ndtri_to_a_few_ulps():
    from scipy.special import ndtri

    from rollsim.numerics.gaussian import normal_quantile

    rng = np.random.default_rng(7)
    # Every branch of AS241: the body (|p - 1/2| <= 0.425), the near and the far tails, and their edges.
    p = np.concatenate([rng.random(200_000), 10.0 ** -rng.uniform(0, 300, 20_000),
                        [0.5, 0.075, 0.925, 0.0749999, 0.9250001, np.exp(-25.0), 1e-300, 1 - 2**-53, 2**-1074]])
    np.testing.assert_allclose(normal_quantile(p), ndtri(p), rtol=5e-15, atol=0)
