"""The Gilbert-Elliott likelihood kernel: its numpy twin's bits, matrix powers and extreme parameters."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rollsim.calibrate.ge import GeTrace, ge_loglik
from rollsim.numerics.ge_likelihood import _ge_loglik_kernel, _ge_loglik_numpy, scaled_powers

needs_numba = pytest.mark.skipif(_ge_loglik_kernel.compiled is None, reason="numba not used here")


def _arguments(trace: GeTrace, p: float, q: float, p_e: float) -> tuple:
    return (p, q, p_e, trace.exponents.astype(np.int64), trace.counts.astype(np.int64), trace._head,
            trace.lengths.size, trace.closing > 0, trace.none > 0)


def _traces(rng: np.random.Generator):
    """Traces of every shape the likelihood distinguishes: no success, success first or last, long gaps."""
    yield np.zeros(7, dtype=bool)
    yield np.ones(5, dtype=bool)
    yield np.array([True, False, False, True])
    yield np.array([False, False, True, False])
    long_gaps = np.zeros(300_000, dtype=bool)
    long_gaps[[5, 100_005, 100_006, 299_000]] = True
    yield long_gaps
    for _ in range(20):
        yield rng.random(int(rng.integers(2, 3000))) < rng.uniform(0.02, 0.98)


@needs_numba
def test_the_kernel_and_its_numpy_twin_give_the_same_bits():
    rng = np.random.default_rng(5)
    edges = [1e-9, 1e-6, 0.5, 1 - 1e-6, 1 - 1e-9]
    for success in _traces(rng):
        trace = GeTrace(success)
        for p, q, p_e in [tuple(rng.uniform(0, 1, 3)) for _ in range(5)] + [tuple(rng.choice(edges, 3)) for _ in range(5)]:
            args = _arguments(trace, float(p), float(q), float(p_e))
            compiled = _ge_loglik_kernel.compiled(*args)
            twin = _ge_loglik_numpy(*args)
            assert np.float64(compiled).tobytes() == np.float64(twin).tobytes(), (success.size, p, q, p_e)


def test_scaled_powers_equal_the_matrix_powers():
    rng = np.random.default_rng(2)
    for _ in range(50):
        a = rng.uniform(0, 1, (2, 2))
        exponents = np.array([0, 1, 2, 3, 7, 8, 31, 100], dtype=np.int64)
        (m00, m01, m10, m11), scale = scaled_powers((a[0, 0], a[0, 1], a[1, 0], a[1, 1]), exponents)
        for i, power in enumerate(exponents):
            exact = np.linalg.matrix_power(a, int(power))
            got = np.array([[m00[i], m01[i]], [m10[i], m11[i]]]) * 2.0 ** scale[i]
            np.testing.assert_allclose(got, exact, rtol=1e-12, atol=0)
            # The scaled matrix's largest entry lies in [1/2, 1): no drift of the scale into the entries.
            assert 0.5 <= max(m00[i], m01[i], m10[i], m11[i]) < 1.0 or power == 0


def test_powers_far_beyond_floats_range_keep_their_scale():
    # A = diag(1/2, 1/4): A^L = diag(2^-L, 2^-2L), exactly, for L past float64's 2^-1074.
    (m00, m01, m10, m11), scale = scaled_powers((0.5, 0.0, 0.0, 0.25), np.array([5000], dtype=np.int64))
    assert (m00[0], m01[0], m10[0]) == (0.5, 0.0, 0.0) and scale[0] == -4999
    assert m11[0] == 0.0  # 2^-10000 / 2^-5000 underflows: the smaller entry is lost against the larger


@settings(max_examples=200, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=60),
       st.floats(1e-9, 1 - 1e-9), st.floats(1e-9, 1 - 1e-9), st.floats(0.0, 1.0))
def test_the_likelihood_is_a_log_probability_without_warnings(success, p, q, p_e):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        value = ge_loglik(np.array(success), p, q, p_e)
    assert not math.isnan(value) and value <= 1e-12
    impossible = (p_e == 0.0 and not all(success)) or (p_e == 1.0 and any(success))
    if not impossible:
        assert math.isfinite(value)


def test_a_trace_of_a_million_emissions_has_the_sum_of_its_halves_likelihoods():
    # Cut right after a success, the trace's likelihood factorises (a success pins the chain to S1),
    # except for the second half's stationary start: compare against that start's closed form.
    rng = np.random.default_rng(9)
    success = rng.random(1_000_000) < 0.3
    success[499_999] = success[500_000] = True
    p, q, p_e = 0.2, 0.1, 0.05
    whole = ge_loglik(success, p, q, p_e)
    first = ge_loglik(success[:500_000], p, q, p_e)
    # The second half opens with a success, in S1: from a stationary start that has probability
    # π₁ (1 − p_e), after the first half's closing success in S1 it has (1 − q)(1 − p_e).
    second_stationary = ge_loglik(success[500_000:], p, q, p_e)
    second = second_stationary - math.log(p / (p + q)) + math.log(1 - q)
    assert whole == pytest.approx(first + second, rel=1e-12)
