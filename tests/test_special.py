"""rollsim.sensor.special: scipy.special's values, bit for bit, without importing scipy.special."""

import numpy as np
import pytest
from scipy.special import gammaln as scipy_gammaln

from rollsim.sensor.poisson import GAUSSIAN_ABOVE_E
from rollsim.sensor.special import gammaln


def test_gammaln_of_every_integer_the_poisson_tables_reach_is_scipys():
    # The tables evaluate gammaln(k + 1) for k up to a class mean below
    # GAUSSIAN_ABOVE_E plus 12 standard deviations and 12.
    reach = int(GAUSSIAN_ABOVE_E + 12 * GAUSSIAN_ABOVE_E**0.5 + 14)
    k = np.arange(1, 2 * reach, dtype=np.float64)
    assert gammaln(k).tobytes() == scipy_gammaln(k).tobytes()


@pytest.mark.parametrize("x", [[0.5, 2.5, 12.999], [1e8, 1e9, 3.0], [0.0, -1.0, 5.0], [np.nan, 2.0], [1e300],
                               [[3.0, 14.0], [1001.0, 7.0]], []])
def test_gammaln_of_any_argument_is_scipys(x):
    x = np.array(x, dtype=np.float64)
    got, expected = gammaln(x), scipy_gammaln(x)
    assert got.shape == expected.shape and got.dtype == expected.dtype
    assert got.tobytes() == expected.tobytes()
