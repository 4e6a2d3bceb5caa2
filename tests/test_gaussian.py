"""Standard normal deviates: the table method against the normal law."""

import numpy as np
import pytest
from scipy import stats

from rollsim.gaussian import standard_normal


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
