"""decoder.order_stats returns numpy's medians and percentiles bit for bit."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from decoder.order_stats import median, percentile, percentiles

finite64 = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
finite32 = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False, width=32)


@settings(max_examples=300, deadline=None)
@given(arrays(np.float64, st.integers(1, 300), elements=finite64),
       st.lists(st.floats(0.0, 100.0, allow_nan=False), min_size=1, max_size=4))
def test_percentiles_match_numpy_bit_for_bit(values, q):
    assert np.array_equal(percentiles(values, q), np.percentile(values, q))


@settings(max_examples=300, deadline=None)
@given(arrays(np.float64, st.integers(1, 300), elements=st.integers(-5, 5).map(float)))
def test_percentiles_with_ties_and_the_ends(values):
    q = [0.0, 5.0, 10.0, 50.0, 95.0, 100.0]
    assert np.array_equal(percentiles(values, q), np.percentile(values, q))
    assert percentile(values, 10.0) == np.percentile(values, 10.0)


@settings(max_examples=300, deadline=None)
@given(st.one_of(arrays(np.float64, st.integers(1, 300), elements=finite64),
                 arrays(np.float32, st.integers(1, 300), elements=finite32),
                 arrays(np.int64, st.integers(1, 300), elements=st.integers(-1000, 1000))))
def test_median_matches_numpy_bit_for_bit(values):
    assert median(values) == float(np.median(values))


def test_median_of_a_two_dimensional_view():
    values = np.random.default_rng(3).random((270, 480)).astype(np.float32)
    sub = values[::4, ::7]
    assert median(sub) == float(np.median(sub))


@pytest.mark.parametrize("dtype", [np.float32, np.int64])
def test_percentiles_of_other_types_are_numpys(dtype):
    values = (np.random.default_rng(4).random(101) * 100).astype(dtype)
    assert np.array_equal(percentiles(values, [5.0, 95.0]), np.percentile(values, [5.0, 95.0]))
