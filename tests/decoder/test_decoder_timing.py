"""decoder.timing: edges, glitches, chip pitch and clock recovery."""

import numpy as np
import pytest
from synth import profile_from_chips

from decoder.binarize import binarize_profile
from decoder.timing import (
    Runs,
    correct_edge_bias,
    edge_bias_chips,
    estimate_rows_per_chip,
    find_runs,
    merge_glitches,
    nominal_rows_per_chip,
    runs_to_chips,
)

RPC = 4.5


def random_chips(n, rng, code="manchester"):
    if code == "manchester":
        bits = rng.integers(0, 2, n // 2)
        return np.stack([1 - bits, bits], axis=1).ravel()
    return rng.integers(0, 2, n)


def levels_of(chips, rpc=RPC, exposure_rows=3.6, phase=0.0, noise=0.0, rng=None):
    values = profile_from_chips(chips, rpc, exposure_rows, phase, on=100.0, off=10.0, noise=noise, rng=rng)
    levels = binarize_profile(values, max(noise, 0.1), 2 * int(11 * rpc / 2) + 1, rpc / 6)
    return levels


def test_nominal_rows_per_chip():
    assert nominal_rows_per_chip(8000.0, 27.8e-6) == pytest.approx(4.496, abs=1e-3)
    with pytest.raises(ValueError):
        nominal_rows_per_chip(0.0, 1e-5)


def test_edges_sit_on_chip_boundaries():
    rng = np.random.default_rng(0)
    chips = random_chips(300, rng)
    phase, exposure = 0.3, 3.6
    levels = levels_of(chips, phase=phase, exposure_rows=exposure)
    runs = find_runs(levels.level, levels.q)
    inner = runs.bounds[1:-1]
    # A chip boundary at chip position c shows at row (c - phase)·rpc - exposure/2.
    boundaries = np.flatnonzero(np.diff(chips)) + 1
    rows = (boundaries - phase) * RPC - exposure / 2
    rows = rows[(rows > 0) & (rows < levels.level.size - 1)]
    assert inner.size == rows.size
    assert np.max(np.abs(inner - rows)) < 0.15


def test_recovered_chips_with_row_time_errors():
    rng = np.random.default_rng(1)
    chips = random_chips(400, rng)
    levels = levels_of(chips, phase=0.5, noise=2.0, rng=rng)
    runs = merge_glitches(find_runs(levels.level, levels.q), RPC)
    for error in (-0.03, -0.015, 0.0, 0.015, 0.03):
        stream = runs_to_chips(runs, RPC * (1 + error), levels.q)
        got = stream.values
        # The stream starts inside chip 0 (cut) or at chip 1.
        offset = 1 if got.size < chips.size - 1 else 0
        n = min(got.size, chips.size - offset - 1)
        assert np.array_equal(got[1:n], chips[offset + 1 : offset + n])


def test_chip_positions_and_confidence():
    chips = np.array([1, 0, 1, 1, 0, 0, 1, 0, 1, 1, 1, 0, 1, 0] * 3)
    levels = levels_of(chips, exposure_rows=0.5)
    runs = find_runs(levels.level, levels.q)
    stream = runs_to_chips(runs, RPC, levels.q)
    assert np.array_equal(stream.values, chips[: stream.values.size])
    starts = np.arange(stream.values.size) * RPC - 0.25
    # An exposure of half a row makes sharp steps: edges are known to +-0.5 row.
    assert np.allclose(stream.start[1:-1], starts[1:-1], atol=0.55)
    assert np.all(stream.confidence[1:-1] > 0.8)
    assert np.all(stream.exact[1:-1])


def test_cut_runs_are_laid_from_their_real_edge():
    # A 3-chip ON run cut to 2.6 chips by the region's start: 3 chips laid back
    # from its real (falling) edge; the first reaches 0.4 chip past the cut.
    runs = Runs(np.array([-0.5, 2.6 * RPC - 0.5, 3.6 * RPC - 0.5, 5.6 * RPC - 0.5]), np.array([1, 0, 1], np.int8))
    stream = runs_to_chips(runs, RPC)
    assert stream.values.tolist() == [1, 1, 1, 0, 1, 1]
    assert stream.start[0] == pytest.approx(-0.5 - 0.4 * RPC)
    assert stream.exact.tolist() == [False, True, True, True, True, True]


def test_erasures_cost_chips_and_cut_runs():
    runs = Runs(np.array([-0.5, 9.0, 13.5, 31.5, 40.5]), np.array([0, 1, -1, 0], np.int8))
    stream = runs_to_chips(runs, RPC)
    assert stream.values.tolist() == [0, 0, 1, -1, -1, -1, -1, 0, 0]
    assert stream.confidence[3] == 0.0


def test_glitches_merge_into_their_neighbours():
    runs = Runs(np.array([-0.5, 9.0, 10.0, 18.0, 22.5, 23.0, 31.5]), np.array([1, 0, 1, 0, 1, 0], np.int8))
    merged = merge_glitches(runs, RPC)
    assert merged.values.tolist() == [1, 0]
    assert merged.bounds.tolist() == [-0.5, 18.0, 31.5]


@pytest.mark.parametrize("code", ["manchester", "random"])
@pytest.mark.parametrize("rpc", [2.2, 4.5, 11.3])
def test_rows_per_chip_estimate(code, rpc):
    rng = np.random.default_rng(int(rpc * 10))
    chips = random_chips(600, rng, code)
    levels = levels_of(chips, rpc=rpc, exposure_rows=0.4 * rpc, noise=1.0, rng=rng)
    estimate = estimate_rows_per_chip(find_runs(levels.level, levels.q))
    assert estimate == pytest.approx(rpc, rel=0.005)


def test_rows_per_chip_needs_runs():
    assert estimate_rows_per_chip(Runs(np.array([-0.5, 99.5]), np.array([-1], np.int8))) is None


def biased_runs(chips, beta, rpc=RPC, jitter=0.0, rng=None):
    """Runs of a chip sequence whose ON runs are ``beta`` chips too long."""
    starts = np.concatenate([[0], np.flatnonzero(np.diff(chips)) + 1])
    values = chips[starts].astype(np.int8)
    bounds = np.concatenate([starts, [chips.size]]).astype(float) * rpc - 0.5
    inner = bounds[1:-1]
    rising = values[1:] == 1
    inner += np.where(rising, -0.5, 0.5) * beta * rpc
    if jitter:
        inner += rng.normal(0, jitter, inner.size)
    return Runs(bounds, values), bounds.copy()


@pytest.mark.parametrize("beta", [0.0, 0.3, 0.68, 0.85, -0.2])
def test_edge_bias_is_measured_and_removed(beta):
    rng = np.random.default_rng(4)
    chips = random_chips(400, rng)
    exact, _ = biased_runs(chips, 0.0)
    runs, _ = biased_runs(chips, beta, jitter=0.15, rng=rng)
    measured = edge_bias_chips(runs, RPC)
    assert measured == pytest.approx(np.full(measured.size, beta), abs=0.06)
    corrected = correct_edge_bias(runs, measured, RPC)
    # Every run is back to a whole number of chips, the right one.
    assert np.array_equal(np.rint(corrected.lengths / RPC), np.rint(exact.lengths / RPC))
    assert np.max(np.abs(corrected.bounds - exact.bounds)) < 0.8


def test_edge_bias_follows_a_drift_and_needs_runs():
    rng = np.random.default_rng(5)
    chips = random_chips(600, rng)
    runs, _ = biased_runs(chips, 0.0)
    # β rising from 0.45 to 0.8 along the profile, as saturation grows
    # towards a disk's middle.
    starts = np.concatenate([[0], np.flatnonzero(np.diff(chips)) + 1])
    beta_of_edge = np.interp(starts[1:], [0, chips.size], [0.45, 0.8])
    bounds = runs.bounds.copy()
    bounds[1:-1] += np.where(runs.values[1:] == 1, -0.5, 0.5) * beta_of_edge * RPC
    drifting = Runs(bounds, runs.values)
    corrected = correct_edge_bias(drifting, edge_bias_chips(drifting, RPC), RPC)
    assert np.array_equal(np.rint(corrected.lengths / RPC), np.rint(runs.lengths / RPC))
    few = Runs(runs.bounds[:5], runs.values[:4])
    assert not np.any(edge_bias_chips(few, RPC))


def test_edge_bias_is_found_in_a_saturated_core_between_unsaturated_rows():
    # A footprint saturated only in its middle third: there ON runs look 0.6
    # chip longer than they are and single OFF chips 0.4 long, while the
    # rows above and below carry no bias. No one β fits the whole profile
    # (its circular mean leaves the core's OFF runs or the rims' ON runs
    # holding no chip); the windows must each take their own.
    rng = np.random.default_rng(6)
    chips = random_chips(600, rng)
    runs, _ = biased_runs(chips, 0.0)
    starts = np.concatenate([[0], np.flatnonzero(np.diff(chips)) + 1])
    core = (starts[1:] > chips.size / 3) & (starts[1:] < 2 * chips.size / 3)
    bounds = runs.bounds.copy()
    bounds[1:-1] += np.where(runs.values[1:] == 1, -0.5, 0.5) * np.where(core, 0.6, 0.0) * RPC
    saturated = Runs(bounds, runs.values)
    measured = edge_bias_chips(saturated, RPC)
    middle = (runs.bounds[:-1] > 0.4 * chips.size * RPC) & (runs.bounds[1:] < 0.6 * chips.size * RPC)
    rims = (runs.bounds[1:] < 0.25 * chips.size * RPC) | (runs.bounds[:-1] > 0.75 * chips.size * RPC)
    rims[[0, -1]] = False  # cut by the profile's ends: the whole profile's β stands in
    assert measured[middle] == pytest.approx(np.full(middle.sum(), 0.6), abs=0.05)
    assert measured[rims] == pytest.approx(np.zeros(rims.sum()), abs=0.05)
    corrected = correct_edge_bias(saturated, measured, RPC)
    wrong = np.rint(corrected.lengths / RPC) != np.rint(runs.lengths / RPC)
    # Only runs in a window straddling the core's ends may be miscounted.
    assert np.count_nonzero(wrong) <= 4


def test_edge_bias_of_runs_that_fit_no_bias_is_zero():
    # Noise runs of every length: their fractional lengths scatter, so
    # (but for the odd window whose 15 runs line up by chance) nothing is
    # corrected.
    rng = np.random.default_rng(7)
    lengths = rng.uniform(0.2, 2.0, 300) * RPC
    bounds = np.concatenate([[-0.5], np.cumsum(lengths) - 0.5])
    values = (np.arange(300) % 2).astype(np.int8)
    assert np.count_nonzero(edge_bias_chips(Runs(bounds, values), RPC)) <= 6


def test_a_uniform_bias_with_jittered_edges_is_removed_everywhere():
    # β 0.68 throughout, each edge jittered by half a row (0.11 chip): a
    # window's 15 runs may scatter too much to tell their own β, and must
    # then take a neighbour's, not none (which miscounted about 34 runs of
    # every 300 here).
    wrong = 0
    for seed in range(5):
        rng = np.random.default_rng(seed)
        chips = random_chips(600, rng)
        runs, _ = biased_runs(chips, 0.68, jitter=0.5, rng=rng)
        truth = np.rint(biased_runs(chips, 0.0)[0].lengths / RPC)
        corrected = correct_edge_bias(runs, edge_bias_chips(runs, RPC), RPC)
        wrong += np.count_nonzero(np.rint(corrected.lengths / RPC) != truth)
    assert wrong <= 8
