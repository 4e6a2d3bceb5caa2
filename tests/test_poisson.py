"""The exact Poisson sampler: its law against scipy's pmf on every path, its decomposition, its two twins."""

import warnings

import numpy as np
import pytest
from scipy import stats

from rollsim.sensor.chain import ChainKeys, _chain_numpy, run_chain, shot_poisson
from rollsim.sensor.poisson import (
    CLASS_BITS,
    CLASS_MEANS,
    DIRECT_CLASSES,
    GAUSSIAN_ABOVE_E,
    K_MASK,
    SEVERAL_STEPS,
    STRADDLE,
    TABLE_BINS,
    TABLES,
    UNBUILT,
    PoissonTables,
    class_mean,
    class_of_remainder,
    exp_neg,
    poisson,
    poisson_numpy,
    split_class,
)


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


# Below 1 (remainder only), on a class mean (no remainder), between class
# means, one table step, two table steps (>= 256), three (>= 2^16).
@pytest.mark.parametrize("mean", [1e-3, 0.7, 1.0, 4.1, 10.25, 12.1, 33.3, 250.0, 300.7, 9000.0, 70000.5])
def test_constant_mean_follows_the_poisson_law(mean):
    sample = poisson(np.random.default_rng(int(mean * 10) + 1), np.full((300, 400), mean))
    assert sample.dtype == np.float32 and sample.shape == (300, 400)
    assert _chi_square_p(sample.ravel(), mean) > 1e-4


def test_every_pixel_its_own_mean_follows_the_law():
    """Means drawn at random (vignetting, glare, PRNU): the probability integral
    transform of each count is uniform (randomised for the discrete law)."""
    rng = np.random.default_rng(4)
    lam = rng.uniform(0.0, 60.0, size=(400, 500))
    sample = poisson(np.random.default_rng(9), lam).astype(np.float64)
    v = rng.random(lam.shape)
    pit = stats.poisson.cdf(sample - 1, lam) + v * stats.poisson.pmf(sample, lam)
    assert stats.kstest(pit.ravel(), "uniform").pvalue > 1e-4


def test_means_beyond_the_tables_are_gaussian_with_the_poisson_moments():
    lam = np.full((200, 200), 3.0 * GAUSSIAN_ABOVE_E)
    sample = poisson(np.random.default_rng(2), lam).astype(np.float64)
    z = (sample - lam) / np.sqrt(lam)
    assert abs(z.mean()) < 0.02 and abs(z.std() - 1.0) < 0.02


def test_zero_mean_gives_zero():
    assert not poisson(np.random.default_rng(0), np.zeros((50, 60))).any()


def test_the_split_is_exact_and_the_class_means_agree():
    """g <= lambda, lambda - g is exact and below lambda / 2^CLASS_BITS, and the
    kernels' class ids and means (frexp, the class-mean table) are split_class's."""
    lam = np.random.default_rng(1).uniform(1.0, GAUSSIAN_ABOVE_E, 5000)
    lam = np.r_[lam, 1.0, 255.99, 256.0, np.nextafter(GAUSSIAN_ABOVE_E, 0)]
    ids, g = split_class(lam)
    assert (g <= lam).all() and (lam - g < lam / 2**CLASS_BITS).all()
    assert ((lam - g) + g == lam).all()
    assert np.array_equal(CLASS_MEANS[ids], g) and np.array_equal(class_mean(ids), g)
    assert [class_of_remainder(x) for x in lam[:200]] == list(ids[:200])


def test_exp_polynomial_is_e_to_the_minus_r():
    r = np.linspace(0.0, 1.0, 1001)[:-1]
    # The documented budget: truncation after 1/14! is below 1/15! = 7.6e-13, far under the uniforms' 2^-32.
    assert np.max(np.abs(exp_neg(r) - np.exp(-r))) < 1e-12


def test_compiled_kernel_equals_the_numpy_twin():
    """Byte for byte, on every path: below 1, one, two and three table steps, Gaussian, zero."""
    rng = np.random.default_rng(0)
    lam = np.concatenate([np.full(3000, 12.1), rng.uniform(0, 40, 3000), rng.uniform(200, 7e4, 500),
                          [0.0, 0.5, 1.0, 2.0**21, 3e6]])
    key = np.uint64(12345)
    assert np.array_equal(poisson_numpy(lam, key), shot_poisson(key, lam))


def test_tables_are_built_once_and_do_not_change_the_result():
    lam = np.full((20, 30), 17.77)
    key = np.uint64(3)
    first = shot_poisson(key, lam)
    built = int((TABLES.slot >= 0).sum())
    again = shot_poisson(key, lam)
    assert np.array_equal(first, again) and int((TABLES.slot >= 0).sum()) == built


def test_a_bins_one_step_gives_the_count_the_cdf_gives_at_every_word_around_it():
    """The step table: where a guide bin holds one step of the CDF, the count is the bin's below the word
    the table names and one more from it on, exactly as the CDF's inverse at u = w / 2^32 (the words
    either side of the step, and the bin's ends); bins of several steps are named so (searched)."""
    tables = PoissonTables()
    ids = np.array([300, DIRECT_CLASSES + 7, 12 * 256 + 29, 12 * 256 + 30, 15 * 256 + 200])  # λ ≈ 3.2 … 58000
    tables.build(ids)
    shift = 32 - int(np.log2(TABLE_BINS))
    for c in ids:
        cdf = tables.cdf[tables.cdf_start[c]:tables.cdf_start[c] + tables.cdf_size[c]]
        row = slice(tables.slot[c] * TABLE_BINS, (tables.slot[c] + 1) * TABLE_BINS)
        guide, step = tables.guide[row], tables.step[row]
        bins_of = np.floor(cdf[:-1] * TABLE_BINS).astype(np.int64)
        steps_in = np.bincount(bins_of, minlength=TABLE_BINS)[:TABLE_BINS]
        assert np.array_equal(step != SEVERAL_STEPS, steps_in == 1)
        assert np.array_equal((guide & STRADDLE) != 0, steps_in > 0)
        one = np.flatnonzero(steps_in == 1)
        assert one.size > 0
        start = one.astype(np.uint64) << np.uint64(shift)
        last = start + np.uint64((1 << shift) - 1)
        at = start + step[one].astype(np.uint64)
        for words in (start, last, at, np.maximum(at, start + np.uint64(1)) - np.uint64(1)):
            count = (guide[one] & K_MASK).astype(np.int64) + (words - start >= step[one])
            exact = np.searchsorted(cdf, words.astype(np.float64) * 2.0**-32, side="right")
            assert np.array_equal(count, exact), c


def test_direct_rows_hold_each_bins_count_and_flag_and_unbuilt_before():
    """The direct table (classes of means below 256) holds k_lo + the guide's offset, with the same flag."""
    tables = PoissonTables()
    ids = np.array([0, 1, 700, DIRECT_CLASSES - 1, DIRECT_CLASSES, DIRECT_CLASSES + 300])
    tables.build(ids)
    direct = tables.direct.reshape(DIRECT_CLASSES, TABLE_BINS)
    guide = tables.guide.reshape(-1, TABLE_BINS)
    for c in ids[ids < DIRECT_CLASSES]:
        row = guide[tables.slot[c]]
        assert np.array_equal(direct[c] & K_MASK, tables.k_lo[c] + (row & K_MASK))
        assert np.array_equal(direct[c] & STRADDLE, row & STRADDLE)
        assert not np.any(direct[c] == UNBUILT)
    untouched = np.setdiff1d(np.arange(DIRECT_CLASSES), ids)
    assert np.all(direct[untouched] == UNBUILT)
    # The count at a bin's start is the CDF's inverse there (u = bin / 1024): checked on one class.
    c = 700
    cdf = tables.cdf[tables.cdf_start[c]:tables.cdf_start[c] + tables.cdf_size[c]]
    u = np.arange(TABLE_BINS) / TABLE_BINS
    assert np.array_equal(direct[c] & K_MASK, tables.k_lo[c] + np.searchsorted(cdf, u, side="right"))


FRESH_PROCESS = """
import numpy as np
from rollsim.sensor.chain import shot_poisson
from rollsim.sensor.poisson import poisson_numpy
rng = np.random.default_rng(1)
# Every class of means below 256 is met for the first time: the kernel stops, builds and goes on, block after block.
lam = np.concatenate([rng.uniform(1, 256, 20000), np.full(5000, 3.0), rng.uniform(256, 5e3, 2000)])
key = np.uint64(99)
print(np.array_equal(shot_poisson(key, lam), poisson_numpy(lam, key)))
"""


def test_a_fresh_process_builds_the_classes_it_meets_and_draws_the_twins_bytes():
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", FRESH_PROCESS], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "True"


@pytest.mark.parametrize("bad", [np.nan, np.inf, -1.0])
def test_bad_means_are_refused(bad):
    lam = np.full((4, 4), 3.0)
    lam[2, 1] = bad
    with pytest.raises(ValueError, match="finite and non-negative"):
        poisson(np.random.default_rng(0), lam)
    with pytest.raises(ValueError, match="finite and non-negative"):
        run_chain(lam, "gaussian", ChainKeys(shot=np.uint64(1)))


def test_deterministic_and_finite_without_warnings():
    lam = np.full((64, 64), 33.3)
    lam[10:20, 5:40] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        a = poisson(np.random.default_rng(1), lam)
        b = poisson(np.random.default_rng(1), lam)
        c = _chain_numpy(lam.ravel(), "poisson", ChainKeys(shot=np.uint64(7)), None, None, None, None)
    assert np.array_equal(a, b) and np.isfinite(a).all() and np.isfinite(c).all()
    assert not a[10:20, 5:40].any()
