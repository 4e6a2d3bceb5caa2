"""rollsim.sensor.special: scipy.special's algorithm, without importing scipy.special, the same bits on every CPU."""

import math

import numpy as np
import pytest
from scipy.special import gammaln as scipy_gammaln

from rollsim.sensor import special
from rollsim.sensor.poisson import GAUSSIAN_ABOVE_E
from rollsim.sensor.special import gammaln

# The tables evaluate gammaln(k + 1) for k up to a class mean below
# GAUSSIAN_ABOVE_E plus 12 standard deviations and 12.
REACH = int(GAUSSIAN_ABOVE_E + 12 * GAUSSIAN_ABOVE_E**0.5 + 14)
TABLE_INTEGERS = np.arange(1, 2 * REACH, dtype=np.float64)


def c_library_log(x):
    """The C library's log, element by element: what scipy's cephes calls."""
    x = np.asarray(x, dtype=np.float64)
    return np.fromiter(map(math.log, x.ravel().tolist()), dtype=np.float64, count=x.size).reshape(x.shape)


def test_gammaln_is_cephes_lgam_to_the_bit_given_the_c_librarys_log(monkeypatch):
    # The port of cephes' lgam, checked apart from the logarithm it is given:
    # with the C library's (scipy's own), every integer the tables reach
    # gives scipy's bits.
    monkeypatch.setattr(special, "log", c_library_log)
    monkeypatch.setattr(special, "_SMALL", special._log_factorials())
    assert gammaln(TABLE_INTEGERS).tobytes() == scipy_gammaln(TABLE_INTEGERS).tobytes()


def test_gammaln_of_every_integer_the_poisson_tables_reach_is_within_2_ulp_of_scipys():
    # With the portable logarithm (the same bits on every CPU; scipy's, the C
    # library's, differs from numpy's in the last bit on some CPUs).
    got, expected = gammaln(TABLE_INTEGERS), scipy_gammaln(TABLE_INTEGERS)
    nonzero = expected != 0.0
    assert np.array_equal(got[~nonzero], expected[~nonzero])
    assert np.max(np.abs(got - expected)[nonzero] / np.spacing(expected[nonzero])) <= 2.0


@pytest.mark.parametrize("x", [[0.5, 2.5, 12.999], [1e8, 1e9, 3.0], [0.0, -1.0, 5.0], [np.nan, 2.0], [1e300], []])
def test_gammaln_of_arguments_the_tables_never_pass_is_scipys(x):
    x = np.array(x, dtype=np.float64)
    got, expected = gammaln(x), scipy_gammaln(x)
    assert got.shape == expected.shape and got.dtype == expected.dtype
    assert got.tobytes() == expected.tobytes()


def test_gammaln_keeps_the_shape_of_an_array_of_integers():
    x = np.array([[3.0, 14.0], [1001.0, 7.0]])
    got = gammaln(x)
    assert got.shape == x.shape and got.dtype == np.float64
    np.testing.assert_allclose(got, scipy_gammaln(x), rtol=4.5e-16, atol=0)
