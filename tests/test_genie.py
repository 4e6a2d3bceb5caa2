"""The genie-aided reference receiver (rollsim.stages.genie): forward model, ML detection, rendered frames."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.stats import binom

from rollsim.api import load_scene
from rollsim.bench.variants import NOISE_EFFECTS
from rollsim.stages.evaluate import evaluate
from rollsim.stages.genie import (
    detect_chips,
    exposure_weights,
    flip_costs,
    frame_weights,
    genie_decode,
    grid_weights,
    memory_chips,
    row_response,
)
from rollsim.render.pipeline import RenderPipeline

CHIP_US = 125.0  # paper-default's 8 kHz clock
PAPER_ROW_TIME_US = 1e6 * 0.9 / 30 / 1080  # the Nexus 5 at 1080p30, IFG 0.1


def _chip_source(n: int, seed: int, margin: int = 64):
    """A random chip sequence and a ``chip_values`` over it (chip c is ``chips[c + margin]``)."""
    chips = np.random.default_rng(seed).integers(0, 2, n + 2 * margin).astype(np.uint8)
    return chips, (lambda c: chips[np.asarray(c) + margin])


# ------------------------------------------------------------ forward model


@pytest.mark.parametrize("rows_per_chip, exposure_chips", [(1, 0.05), (4.5, 0.8), (20, 4.0), (1.3, 3.0), (7, 1.0)])
def test_each_row_weights_sum_to_one_and_match_a_fine_box_integral(rows_per_chip, exposure_chips):
    w = grid_weights(50, rows_per_chip, exposure_chips, first_start_chips=0.37)
    np.testing.assert_allclose(w.weights.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    assert np.all(w.weights >= 0)
    # Against a midpoint sum of the box over 20,000 sub-intervals per row.
    dense = w.dense(-1, 100)
    start = 0.37 + np.arange(50) / rows_per_chip
    t = start[:, None] + exposure_chips * (np.arange(20000) + 0.5) / 20000
    chip = np.floor(t).astype(int) + 1
    sampled = np.stack([np.bincount(c, minlength=100) / t.shape[1] for c in chip])
    np.testing.assert_allclose(dense, sampled, atol=2e-4)


def test_constant_on_gives_level_one_and_a_chip_inside_the_window_its_share():
    w = grid_weights(40, 3.0, 3.4, first_start_chips=0.2)
    np.testing.assert_allclose(w.levels(lambda c: np.ones(np.shape(c))), 1.0, atol=1e-12)
    # A row whose window [0.2, 3.6] holds chip 1 whole: weight T/t_exp = 1/3.4.
    single = w.levels(lambda c: (np.asarray(c) == 1).astype(float))
    assert single[0] == pytest.approx(1 / 3.4, abs=1e-12)
    # A window ending on a chip edge touches no later chip.
    edge = exposure_weights([0], [0.0], 2.0)
    assert edge.last_chip[0] == 1 and edge.first_touched[0] == 0


def test_frame_weights_reproduce_the_transmitters_exact_exposure_integral():
    scene = load_scene("paper-default", {"camera.width_px": 64, "camera.height_px": 300,
                                         "camera.row_time_us": PAPER_ROW_TIME_US, "camera.exposure_us": 310.0})
    pipeline = RenderPipeline(scene)
    truth = pipeline.render(3).truth
    rows = np.arange(300)
    waveform = pipeline.setup.transmitter.waveform
    s = frame_weights(pipeline.setup, truth, rows).levels(waveform.chips.values)
    start = truth["start_s"] + rows * truth["row_time_s"]
    exact = waveform.exposure(start, start + truth["exposure_s"]) / truth["exposure_s"]
    np.testing.assert_allclose(s, exact, atol=1e-9)
    assert s.min() < 0.25 and s.max() > 0.75  # a frame of stripes, not a constant


def test_row_response_is_the_clipped_pixel_sum():
    rng = np.random.default_rng(5)
    weights = rng.random((30, 40))
    weights /= weights.sum(axis=1, keepdims=True)
    gap, headroom = rng.uniform(0, 50, (30, 40)), rng.uniform(0, 60, (30, 40))
    gap[:, :3], headroom[:, 3:6] = 0.0, 0.0  # no light; clipped even when OFF
    response = row_response(weights, gap, headroom)
    s = rng.random((30, 7))
    expected = np.einsum("rj,rkj->rk", weights, np.minimum(gap[:, None, :] * s[:, :, None], headroom[:, None, :]))
    np.testing.assert_allclose(response(np.arange(30)[:, None], s), expected, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("call, field", [
    (lambda: grid_weights(10, 2.0, 0.0), "exposure_chips"),
    (lambda: grid_weights(10, 2.0, -1.0), "exposure_chips"),
    (lambda: grid_weights(10, 0.0, 1.0), "rows_per_chip"),
    (lambda: grid_weights(10, -3.0, 1.0), "rows_per_chip"),
    (lambda: exposure_weights([0], [0.5], float("nan")), "exposure_chips"),
    (lambda: memory_chips(40.0), "exposure_chips"),
    (lambda: detect_chips(np.zeros(4), 0.0, 1.0, 0.0, grid_weights(4, 1.0, 0.5), [0], 2, np.zeros_like), "sigma"),
])
def test_bad_inputs_raise_naming_the_field(call, field):
    with pytest.raises(ValueError, match=field):
        call()


@pytest.mark.parametrize("field", ["exposure_s", "row_time_s"])
def test_a_truth_record_with_a_bad_time_is_refused(field):
    scene = load_scene("paper-default", {"camera.width_px": 32, "camera.height_px": 40, "camera.row_time_us": 200})
    pipeline = RenderPipeline(scene)
    truth = {**pipeline.render(0).truth, field: 0.0}
    with pytest.raises(ValueError, match=field):
        frame_weights(pipeline.setup, truth, np.arange(40))


# ---------------------------------------------------------------- detection


@pytest.mark.parametrize("rows_per_chip, exposure_chips", [(1, 0.05), (20, 0.05), (1, 4.0), (20, 4.0), (4.5, 0.8),
                                                           (1.3, 2.5), (3, 3.0)])
def test_noiseless_profiles_are_read_exactly_for_every_exposure_and_row_density(rows_per_chip, exposure_chips):
    n_sdus, n_chips = 6, 56
    _, values_of = _chip_source(n_sdus * n_chips + 40, seed=2)
    w = grid_weights(int((n_sdus * n_chips + 20) * rows_per_chip), rows_per_chip, exposure_chips, 0.31)
    y = 12.0 + 80.0 * w.levels(values_of)
    first = 5 + n_chips * np.arange(n_sdus)
    decided = detect_chips(y, 12.0, 80.0, 1.0, w, first, n_chips, values_of)
    np.testing.assert_array_equal(decided.chips, values_of(first[:, None] + np.arange(n_chips)))


def _brute_force_ml(y, sigma, w, first, n_chips, values_of, off, gap):
    """The minimum metric and its chips over all 2^n_chips sequences, the chips around them known."""
    rows = (w.last_chip >= first) & (w.first_touched < first + n_chips)
    lo = first - w.memory
    dense = w.dense(lo, n_chips + 2 * w.memory)[rows]
    context = values_of(lo + np.arange(n_chips + 2 * w.memory)).astype(float)
    candidates = np.array(list(itertools.product([0, 1], repeat=n_chips)), dtype=float)
    chips = np.broadcast_to(context, (candidates.shape[0], context.size)).copy()
    chips[:, first - lo: first - lo + n_chips] = candidates
    metric = np.sum(((y[rows] - off - gap * chips @ dense.T) / sigma[rows]) ** 2, axis=1)
    best = int(np.argmin(metric))
    return metric[best], candidates[best], int(np.sum(metric <= metric[best] * (1 + 1e-12)))


def _noisy_blocks(n_chips, n_sdus, known_between, rows_per_chip, exposure_chips, noise, seed):
    """Blocks of ``n_chips`` unknown chips (``known_between`` known ones between) seen as noisy rows, off 3, gap 2.

    Returns y, sigma (per row, 0.5 to 1.5 units), the weights, each block's first chip and ``chip_values``.
    """
    period = n_chips + known_between
    _, values_of = _chip_source(n_sdus * period + 40, seed=seed)
    n_rows = int((n_sdus * period + 30) * rows_per_chip)
    w = grid_weights(n_rows, rows_per_chip, exposure_chips, 0.13)
    rng = np.random.default_rng(seed + 1)
    sigma = rng.uniform(0.5, 1.5, n_rows)
    y = 3.0 + 2.0 * w.levels(values_of) + sigma * rng.normal(0, noise, n_rows)
    return y, sigma, w, 8 + period * np.arange(n_sdus), values_of


@pytest.mark.parametrize("rows_per_chip, exposure_chips, noise", [(2.5, 1.7, 0.8), (1.0, 3.2, 0.8), (6.0, 0.3, 2.5)])
def test_the_viterbi_finds_the_maximum_likelihood_sequence(rows_per_chip, exposure_chips, noise):
    # Brute force over all 2^10 sequences of short blocks with inter-chip interference and strong noise.
    n_chips = 10
    y, sigma, w, first, values_of = _noisy_blocks(n_chips, 8, 2, rows_per_chip, exposure_chips, noise, seed=3)
    decided = detect_chips(y, 3.0, 2.0, sigma, w, first, n_chips, values_of)
    for i, c0 in enumerate(first):
        metric, chips, optima = _brute_force_ml(y, sigma, w, c0, n_chips, values_of, 3.0, 2.0)
        assert decided.metric[i] == pytest.approx(metric, rel=1e-9)
        if optima == 1:  # a unique optimum: the chips must be it
            np.testing.assert_array_equal(decided.chips[i], chips)
    assert np.any(decided.chips != values_of(first[:, None] + np.arange(n_chips)))  # the noise did bite


@pytest.mark.parametrize("rows_per_chip, exposure_chips", [(2.5, 1.7), (4.5, 0.8), (1.0, 3.2)])
def test_flip_costs_are_what_flipping_each_chip_adds_to_the_metric(rows_per_chip, exposure_chips):
    # Brute force: the metric of every single-chip flip of the decided sequence.
    n_chips = 12
    y, sigma, w, first, values_of = _noisy_blocks(n_chips, 5, 2, rows_per_chip, exposure_chips, 0.7, seed=5)
    decided = detect_chips(y, 3.0, 2.0, sigma, w, first, n_chips, values_of)
    costs = flip_costs(y, 3.0, 2.0, sigma, w, first, decided.chips, values_of)
    assert np.all(costs >= 0)
    for i, c0 in enumerate(first):
        rows = (w.last_chip >= c0) & (w.first_touched < c0 + n_chips)
        dense = w.dense(c0 - w.memory, n_chips + 2 * w.memory)[rows]
        context = values_of(c0 - w.memory + np.arange(n_chips + 2 * w.memory)).astype(float)
        context[w.memory: w.memory + n_chips] = decided.chips[i]
        flipped = np.tile(context, (n_chips, 1))
        flipped[np.arange(n_chips), w.memory + np.arange(n_chips)] = 1 - decided.chips[i]
        metric = np.sum(((y[rows] - 3.0 - 2.0 * np.vstack([context, flipped]) @ dense.T) / sigma[rows]) ** 2, axis=1)
        np.testing.assert_allclose(costs[i], metric[1:] - metric[0], rtol=1e-9, atol=1e-9)
        assert metric[0] == pytest.approx(decided.metric[i], rel=1e-9)


@pytest.mark.parametrize("snr", [1.0, 1.5, 2.0])
def test_chip_error_rate_matches_the_closed_form(snr):
    # Rows wholly inside one chip (exposure 0.05 chips, 4 rows per chip): independent
    # chips, ML = threshold the mean of k rows at the midpoint, P = Q(sqrt(k)·gap/(2σ)).
    k, gap, n_sdus, n_chips = 4, 1.0, 200, 100
    sigma = math.sqrt(k) * gap / (2 * snr)
    total = n_sdus * n_chips
    _, values_of = _chip_source(total + 10, seed=11)
    w = grid_weights(k * (total + 2), k, 0.05, first_start_chips=0.1)
    np.testing.assert_allclose(w.weights.max(axis=1), 1.0, atol=1e-12)  # each row sees one chip only
    noise = np.random.default_rng(12).normal(0.0, sigma, w.last_chip.size)
    y = gap * w.levels(values_of) + noise
    first = 1 + n_chips * np.arange(n_sdus)
    decided = detect_chips(y, 0.0, gap, sigma, w, first, n_chips, values_of)
    sent = values_of(first[:, None] + np.arange(n_chips))
    # ML here is the midpoint threshold of each chip's row mean, decision for decision.
    row_means = np.bincount(w.last_chip, weights=y) / np.bincount(w.last_chip)
    np.testing.assert_array_equal(decided.chips, row_means[first[:, None] + np.arange(n_chips)] > gap / 2)
    errors = int(np.sum(decided.chips != sent))
    p = 0.5 * math.erfc(snr / math.sqrt(2))
    low, high = binom.interval(0.99, total, p)
    assert low <= errors <= high, (errors, total * p, low, high)


# ---------------------------------------------------------- rendered frames


@pytest.mark.parametrize("exposure_chips", [0.5, 1, 2, 3, 4])
def test_the_genie_reads_every_fully_visible_phy_sdu_of_noiseless_frames(exposure_chips):
    exposure_us = exposure_chips * CHIP_US
    overrides = {
        # A 640 x 600 crop of the 1080p frame at the paper's row time.
        "camera.width_px": 640, "camera.height_px": 600, "camera.row_time_us": PAPER_ROW_TIME_US,
        "camera.exposure_us": exposure_us,
        # The paper's brightness (ISO 10000 at 100 us) at every exposure: at 4 chips
        # and ISO 10000 even OFF rows clip and the frame is white, for any receiver.
        "camera.iso": 10000.0 * 100.0 / exposure_us,
        **{f"effects.{name}": False for name in NOISE_EFFECTS},
    }
    pipeline = RenderPipeline(load_scene("paper-default", overrides))
    frames = [pipeline.render(k) for k in range(3)]
    decoded = [d for f in frames for d in genie_decode(f.image, f.truth, pipeline.setup)]
    summary = evaluate([f.truth for f in frames], decoded, pipeline.setup.transmitter).summary
    assert summary["fully_visible"] >= 3
    assert summary["fully_visible_counts"]["ok"] == summary["fully_visible"], summary["fully_visible_counts"]
    assert summary["false_decodes"] == 0
    assert len(decoded) == sum(s["fully_visible"] for f in frames for s in f.truth["sdus"])
    assert {tuple(sorted(d)) for d in decoded} == {("bits", "check_ok", "confidence", "first_row", "first_row_f", "frame",
                                                    "last_row", "last_row_f", "region", "sequence", "status")}


def test_a_frame_without_a_fully_visible_phy_sdu_gives_no_record():
    pipeline = RenderPipeline(load_scene("paper-default", {"camera.width_px": 32, "camera.height_px": 40,
                                                           "camera.row_time_us": 20}))
    frame = pipeline.render(0)
    assert not any(s["fully_visible"] for s in frame.truth["sdus"])
    assert genie_decode(frame.image, frame.truth, pipeline.setup) == []
