"""decoder.bloom: blooming's spill, in proportion to each ON run's length, taken out of the runs."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from synth import profile_from_chips

from rollsim.protocol import PhyFormat
from rollsim.sensor.blooming import bloom

from decoder.bloom import FINE_SPILL_STEP, spill_fraction, split_at_dips, without_spill
from decoder.pipeline import decode_profile
from decoder.profile import RowProfile
from decoder.timing import Runs

PHY = PhyFormat(5, 19, "parity2")
PITCH = 4.5
EXPOSURE_ROWS = 3.6


def payloads(n_sdus: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 2, (n_sdus, PHY.payload_bits), dtype=np.uint8)


def manchester_chips(n_sdus: int = 4, seed: int = 2) -> np.ndarray:
    """Chips of PHY-SDUs 0 … n_sdus − 1 carrying :func:`payloads`."""
    return PHY.encode(np.arange(n_sdus), payloads(n_sdus, seed)).reshape(-1)


def runs_of(chips: np.ndarray, full_wells: float, rows_per_chip: float = PITCH) -> Runs:
    """The runs of a chip sequence as the spill model reads them: ON runs f·L chips, OFF runs shorter by (f − 1)·(L₁ + L₂)/2."""
    change = np.flatnonzero(np.diff(chips)) + 1
    starts = np.concatenate([[0], change])
    lengths = np.diff(np.concatenate([starts, [chips.size]])).astype(float)
    values = chips[starts].astype(np.int8)
    on = values == 1
    stretch = (full_wells - 1.0) * lengths * on
    # Each ON run's spill, half into the OFF run on either side.
    read = lengths + stretch
    read[1:] -= 0.5 * stretch[:-1] * ~on[1:]
    read[:-1] -= 0.5 * stretch[1:] * ~on[:-1]
    bounds = np.concatenate([[-0.5], -0.5 + np.cumsum(read * rows_per_chip)])
    return Runs(bounds, values)


@pytest.mark.parametrize("full_wells", [1.2, 1.25, 1.35, 1.45])
def test_the_spill_model_is_measured_and_taken_out(full_wells):
    chips = manchester_chips()
    runs = runs_of(chips, full_wells)
    spilled = spill_fraction(runs, PITCH)
    assert spilled == pytest.approx(1.0 - 1.0 / full_wells, abs=FINE_SPILL_STEP)
    mended = without_spill(runs, spilled)
    # The end runs are cut: only the inner ones are whole.
    assert np.allclose(mended.lengths[1:-1] / PITCH, runs_of(chips, 1.0).lengths[1:-1] / PITCH, atol=0.05)


def test_a_spill_saturations_constant_bias_nearly_explains_is_left_to_it():
    # At 1.1 full wells the runs agree to 0.95 unshrunk, 1.0 shrunk: less
    # than MIN_SPILL_GAIN better; the constant bias corrects such runs.
    assert spill_fraction(runs_of(manchester_chips(), 1.1), PITCH) == 0.0


def test_no_spill_is_found_in_runs_without_one_nor_in_a_pitch_a_few_percent_off():
    chips = manchester_chips()
    rng = np.random.default_rng(3)
    exact = runs_of(chips, 1.0)
    jitter = Runs(exact.bounds + np.concatenate([[0.0], rng.normal(0.0, 0.3, exact.bounds.size - 2), [0.0]]),
                  exact.values)
    assert spill_fraction(jitter, PITCH) == 0.0
    # Every run 10 % long reads as ON runs spilled by 0.09 alone; the OFF
    # runs, as long, tell it apart.
    assert spill_fraction(exact, PITCH / 1.1) == 0.0


def test_one_length_of_on_run_cannot_tell_a_spill():
    chips = np.tile([1, 0, 0], 40)
    assert spill_fraction(runs_of(chips, 1.3), PITCH) == 0.0


def test_without_spill_moves_only_level_edges():
    runs = Runs(np.array([-0.5, 9.5, 18.5, 27.5, 36.5]), np.array([-1, 1, 0, 1], dtype=np.int8))
    mended = without_spill(runs, 0.2)
    # The erasure's edge stays; the ON runs' level edges move in by 0.9 row.
    assert np.allclose(mended.bounds, [-0.5, 9.5, 17.6, 28.4, 36.5])
    assert without_spill(runs, 0.0) is runs


def test_a_dip_inside_an_on_run_gets_an_empty_off_run_at_its_centroid():
    q = np.array([-1, -1, 1, 1, 1, 0.4, 0.2, 0.4, 1, 1, 1, -1, -1], dtype=float)
    runs = Runs(np.array([-0.5, 1.5, 10.5, 12.5]), np.array([0, 1, 0], dtype=np.int8))
    split = split_at_dips(runs, np.where(q > 0, 1, 0), q, np.full(q.size, 0.01), PITCH)
    assert np.array_equal(split.values, [0, 1, 0, 1, 0])
    assert np.allclose(split.bounds, [-0.5, 1.5, 6.0, 6.0, 10.5, 12.5])


@pytest.mark.parametrize("q, noise_q", [
    # A shallow dip.
    ([-1, 1, 1, 0.8, 1, 1, -1], 0.01),
    # A dip within 6 sigmas of the noise.
    ([-1, 1, 1, 0.4, 1, 1, -1], 0.2),
    # A ramp at the run's start: OFF rows before it.
    ([-1, 0.2, 0.5, 1, 1, 1, -1], 0.01),
    # Wider than a chip: not one flooded chip.
    ([-1, 1, 0.3, 0.3, 0.3, 0.3, 0.3, 1, -1], 0.01),
])
def test_no_dip_without_a_narrow_deep_stretch_inside_an_on_run(q, noise_q):
    q = np.asarray(q, dtype=float)
    runs = Runs(np.array([-0.5, 0.5, q.size - 1.5, q.size - 0.5]), np.array([0, 1, 0], dtype=np.int8))
    assert split_at_dips(runs, np.where(q > 0, 1, 0), q, np.full(q.size, noise_q), PITCH) is runs


def bloomed_profile(full_wells: float, seed: int = 0) -> RowProfile:
    """A column of the uniform disk, bloomed by the simulator's own model (no drain), in 8-bit DN with shot noise."""
    full_well_e = 4359.0
    level = profile_from_chips(manchester_chips(6, seed), PITCH, EXPOSURE_ROWS)
    electrons = np.repeat((full_wells * full_well_e * level)[:, None], 3, axis=1).astype(np.float32)
    bloom(electrons, full_well_e, 1.0)
    rng = np.random.default_rng(seed)
    # 400 pixels a row: the row mean's shot noise.
    charge = electrons[:, 1] + rng.normal(0.0, 1.0, level.size) * np.sqrt(electrons[:, 1] / 400.0)
    values = np.round(np.clip(charge, 0.0, full_well_e) * 255.0 / full_well_e)
    return RowProfile(0, values, np.full(values.size, 0.3))


@pytest.mark.parametrize("full_wells", [1.3, 1.35])
def test_phy_sdus_are_read_through_the_simulators_blooming(full_wells):
    # Without the spill taken out, 1.3 and 1.35 full wells read 46 and 14
    # of 52 on effect-blooming's link (16 frames), now 52 and 52.
    for seed in range(3):
        read = {sdu.sequence: sdu.bits for sdu in decode_profile(bloomed_profile(full_wells, seed), PHY, PITCH)
                if sdu.check_ok}
        sent = {sequence: "".join(map(str, bits)) for sequence, bits in enumerate(payloads(6, seed))}
        # The first and last lie at the profile's ends, cut or not.
        assert {1, 2, 3, 4} <= set(read)
        assert all(bits == sent[sequence] for sequence, bits in read.items())


@pytest.mark.parametrize("full_wells", [1.3, 1.35])
def test_effect_blooming_reads_every_fully_visible_phy_sdu_past_a_full_well(full_wells):
    from rollsim.sweeps.stream import scene_outcomes
    from rollsim.scene import load_scene

    scene = load_scene("effect-blooming", [f"led.luminous_intensity_cd={5.0 * full_wells / 1.05}", "camera.width_px=480"])
    summary = scene_outcomes(scene, 6)
    assert summary["fully_visible"] > 0
    assert summary["counts"]["missed"] == summary["counts"]["corrupted"] == 0
    assert summary["counts"]["undetected_error"] == 0 and summary["false_decodes"] == 0


@settings(max_examples=200, deadline=None)
@given(lengths=st.lists(st.floats(0.0, 30.0), min_size=1, max_size=40),
       values=st.lists(st.sampled_from([-1, 0, 1]), min_size=40, max_size=40),
       spilled=st.floats(0.0, 0.4))
def test_without_spill_keeps_the_profiles_ends_and_the_edges_order(lengths, values, spilled):
    bounds = -0.5 + np.concatenate([[0.0], np.cumsum(lengths)])
    runs = Runs(bounds, np.array(values[: len(lengths)], dtype=np.int8))
    mended = without_spill(runs, spilled)
    assert mended.bounds[0] == bounds[0] and mended.bounds[-1] == bounds[-1]
    assert np.all(np.diff(mended.bounds) >= 0.0)
    # ON runs never grow; OFF runs never shrink.
    on, off = runs.values == 1, runs.values == 0
    assert np.all(mended.lengths[on] <= runs.lengths[on] + 1e-9)
    assert np.all(mended.lengths[off] >= runs.lengths[off] - 1e-9)
