"""decoder.binarize: local envelopes, midpoint threshold, erasures."""

import numpy as np
from synth import profile_from_chips

from decoder.binarize import binarize_profile, confident_on_span, envelopes, hysteresis_levels

RPC = 4.5
WINDOW = 51


def manchester_chips(n_bits, rng):
    bits = rng.integers(0, 2, n_bits)
    return np.stack([1 - bits, bits], axis=1).ravel()


def chip_at_rows(chips, n_rows, rows_per_chip=RPC, exposure_rows=0.8):
    """Chip seen at the centre of each row's exposure window."""
    centre = (np.arange(n_rows) + 0.5 * exposure_rows) / rows_per_chip
    return chips[np.floor(centre).astype(int)]


def test_envelopes_follow_a_varying_gain():
    rng = np.random.default_rng(0)
    chips = manchester_chips(200, rng)
    clean = profile_from_chips(chips, RPC, 0.8)
    gain = np.linspace(0.3, 1.0, clean.size)  # vignetting / chord / blooming
    upper, lower = envelopes(50 * gain * clean + 20, WINDOW)
    assert np.all(upper <= 50 * gain.max() + 20 + 1e-9)
    inner = slice(WINDOW, -WINDOW)
    assert np.allclose(upper[inner], (50 * gain + 20)[inner], rtol=0.06)
    assert np.allclose(lower[inner], 20, atol=1.0)


def test_levels_follow_the_chips_under_gradients():
    rng = np.random.default_rng(1)
    chips = manchester_chips(200, rng)
    clean = profile_from_chips(chips, RPC, 0.8)
    n = clean.size
    # Ambient gradient plus a 3x gain change along the profile.
    values = 30 + 40 * np.linspace(0, 1, n) + 100 * np.linspace(1.0, 0.33, n) * clean
    levels = binarize_profile(values, 0.5, WINDOW, RPC / 6)
    expected = chip_at_rows(chips, n)
    # Rows near an edge are ambiguous; away from them the level is the chip.
    centre_phase = ((np.arange(n) + 0.4) / RPC) % 1.0
    clear = (centre_phase > 0.25) & (centre_phase < 0.75)
    assert np.all(levels.level[clear] == expected[clear])
    assert np.all(np.abs(levels.q[clear]) > 0.5)


def test_flat_and_noise_profiles_are_erasures():
    rng = np.random.default_rng(2)
    flat = np.full(500, 100.0)
    assert np.all(binarize_profile(flat, 0.3, WINDOW).level == -1)
    noise = 100 + rng.normal(0, 1.0, 2000)
    assert np.all(binarize_profile(noise, 1.0, WINDOW, RPC / 6).level == -1)


def test_low_contrast_rows_become_erasures():
    rng = np.random.default_rng(3)
    chips = manchester_chips(200, rng)
    clean = profile_from_chips(chips, RPC, 0.8)
    contrast = np.where(np.arange(clean.size) < clean.size // 2, 100.0, 2.0)
    values = 20 + contrast * clean + rng.normal(0, 1.0, clean.size)
    level = binarize_profile(values, 1.0, WINDOW, RPC / 6).level
    half = clean.size // 2
    assert np.all(level[: half - WINDOW] >= 0)
    assert np.all(level[half + WINDOW :] == -1)


def test_hysteresis_ignores_wobble_near_the_threshold():
    q = np.array([-1, -0.8, 0.1, -0.1, 0.2, -0.2, 0.9, 1.0, 0.1, -0.25, 0.2, -0.9, -1.0])
    valid = np.ones(q.size, bool)
    level = hysteresis_levels(q, valid, 0.3)
    assert level.tolist() == [0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 0, 0]
    valid[7] = False
    level = hysteresis_levels(q, valid, 0.3)
    assert level[7] == -1 and level[8] == -1 and level[11] == 0


def test_background_at_the_midpoint_is_erased_and_outside_the_span():
    rng = np.random.default_rng(4)
    chips = manchester_chips(70, rng)
    stripes = 20 + 100 * profile_from_chips(chips, RPC, 3.6)
    tail = 70 + rng.normal(0, 3.0, 120)  # background about at the midpoint
    values = np.concatenate([stripes, tail])
    levels = binarize_profile(values, 3.0, WINDOW, RPC / 6, min_run_rows=0.5 * RPC)
    n = stripes.size
    assert np.mean(levels.level[n + 5 :] == -1) > 0.9
    first, last = confident_on_span(levels.level, levels.q)
    assert first < 10 and n - 3 * RPC < last < n + 2
