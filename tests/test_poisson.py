"""The exact Poisson sampler: its law, against scipy's pmf, on every path."""

import warnings

import numpy as np
import pytest
from scipy import stats

from rollsim.sensor.poisson import MAX_TABLE_MEAN, MIN_RUN, poisson


def _chi_square_p(sample: np.ndarray, mean: float) -> float:
    k = np.arange(int(mean + 10 * np.sqrt(mean) + 12))
    observed = np.bincount(sample.astype(np.int64), minlength=k.size)[: k.size]
    expected = stats.poisson.pmf(k, mean) * sample.size
    keep = expected > 5
    # Pool the rest of the mass into one cell so that nothing is ignored.
    obs = np.r_[observed[keep], sample.size - observed[keep].sum()]
    exp = np.r_[expected[keep], sample.size - expected[keep].sum()]
    keep2 = exp > 0
    chi = ((obs[keep2] - exp[keep2]) ** 2 / exp[keep2]).sum()
    return stats.chi2.sf(chi, max(1, keep2.sum() - 1))


@pytest.mark.parametrize("mean", [1e-3, 0.7, 4.1, 12.1, 33.3, 250.0, 9000.0, 2 * MAX_TABLE_MEAN])
def test_constant_mean_follows_the_poisson_law(mean):
    sample = poisson(np.random.default_rng(int(mean * 10) + 1), np.full((300, 400), mean))
    assert _chi_square_p(sample.ravel(), mean) > 1e-4


def test_zero_mean_gives_zero():
    assert not poisson(np.random.default_rng(0), np.zeros((50, 60))).any()


def test_row_constant_means_use_tables_and_follow_the_law():
    """Rows of different means (the LED interior), short runs (edges) and a
    background: each group follows its own Poisson law."""
    rng = np.random.default_rng(4)
    means = np.linspace(2.0, 40.0, 200)
    lam = np.repeat(means[:, None], 300, axis=1)
    lam[:, :5] = rng.uniform(1, 5, size=(200, 5))  # short runs -> numpy path
    lam[:, -50:] = 12.1  # a background run
    sample = poisson(np.random.default_rng(9), lam)
    # Standardised residuals of each table row are N(0, 1) overall.
    body = sample[:, 5:-50]
    z = (body - means[:, None]) / np.sqrt(means[:, None])
    assert abs(z.mean()) < 0.01 and abs(z.std() - 1) < 0.01
    assert _chi_square_p(sample[:, -50:].ravel(), 12.1) > 1e-4
    assert (sample[:, :5] >= 0).all() and float(sample[:, :5].mean()) == pytest.approx(lam[:, :5].mean(), rel=0.1)


def test_short_runs_only_fall_back_to_numpy():
    lam = np.random.default_rng(3).uniform(1, 20, size=(100, MIN_RUN - 1))
    sample = poisson(np.random.default_rng(5), lam)
    z = (sample - lam) / np.sqrt(lam)
    assert abs(z.mean()) < 0.05 and abs(z.std() - 1) < 0.05


def test_deterministic_and_finite_without_warnings():
    lam = np.full((64, 64), 33.3)
    lam[10:20, 5:40] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        a = poisson(np.random.default_rng(1), lam)
        b = poisson(np.random.default_rng(1), lam)
    assert np.array_equal(a, b) and np.isfinite(a).all()
    assert not a[10:20, 5:40].any()
