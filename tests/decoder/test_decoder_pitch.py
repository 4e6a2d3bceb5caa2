"""The chip pitch of frames whose row time is not known (decoder.pitch)."""

import numpy as np
import pytest
from synth import core_saturated, profile_from_chips

from decoder.pipeline import _region_profiles, decode_frame, frame_rows_per_chip, profile_rows_per_chip
from decoder.pitch import GridFit, choose_grid, edge_grid_fit, peak_period_rows, pitch_candidates
from decoder.profile import RowProfile
from decoder.timing import Runs
from rollsim.protocol import PhyFormat

PHY = PhyFormat(5, 19)
PHY_4B6B = PhyFormat(5, 19, "parity2", "4b6b")


def manchester_chips(n_bits, rng):
    bits = rng.integers(0, 2, n_bits)
    return np.stack([1 - bits, bits], axis=1).ravel()


def runs_of_chips(chips, pitch, bias_rows=0.0, jitter_rows=0.0, rng=None):
    """Runs of a chip stream with exact edges; ON runs ``bias_rows`` longer."""
    change = np.flatnonzero(np.diff(chips)) + 1
    edges = change * pitch + np.where(chips[change] == 1, -0.5, 0.5) * bias_rows
    if jitter_rows:
        edges = edges + rng.normal(0.0, jitter_rows, edges.size)
    bounds = np.concatenate([[-0.5], edges, [chips.size * pitch]])
    values = np.concatenate([chips[:1], chips[change]]).astype(np.int8)
    return Runs(bounds, values)


# --------------------------------------------------------------- primitives


def test_the_spectral_peak_of_a_cosine_is_its_period():
    rows = np.arange(600)
    assert peak_period_rows(np.cos(2 * np.pi * rows / 7.3), 2.0, 100.0) == pytest.approx(7.3, rel=2e-3)
    assert peak_period_rows(np.zeros(3), 2.0, 100.0) is None


def test_candidates_are_the_pitches_with_a_harmonic_at_the_line():
    # A line at 6 rows is harmonic k of a 2-chip symbol of pitch k·3 rows.
    assert pitch_candidates(6.0, 2, 20.0) == [18.0, 15.0, 12.0, 9.0, 6.0, 3.0]
    assert pitch_candidates(6.0, 6, 3.0) == [3.0, 2.0]


@pytest.mark.parametrize("pitch", [2.3, 4.5, 11.7])
@pytest.mark.parametrize("bias", [0.0, 0.45])
def test_the_grid_fit_recovers_the_pitch_whatever_the_edge_bias(pitch, bias):
    rng = np.random.default_rng(3)
    runs = runs_of_chips(manchester_chips(150, rng), pitch, bias * pitch, 0.05 * pitch, rng)
    fit = edge_grid_fit(runs, pitch * 1.04)  # a guess 4 % off
    assert fit.rows_per_chip == pytest.approx(pitch, rel=1e-3)
    assert fit.residual < 0.05


def test_a_stray_edge_costs_only_itself():
    rng = np.random.default_rng(4)
    runs = runs_of_chips(manchester_chips(100, rng), 6.0)
    # The last run cut half a chip short (a footprint's edge).
    bounds = runs.bounds.copy()
    bounds[-2] -= 3.0
    fit = edge_grid_fit(Runs(bounds, runs.values), 6.0)
    assert fit.rows_per_chip == pytest.approx(6.0, rel=1e-9)
    assert fit.spread_rows < 1e-9


def test_twice_the_pitch_is_rejected_and_half_of_it_is_not_taken():
    rng = np.random.default_rng(5)
    pitch = 4.5
    runs = runs_of_chips(manchester_chips(150, rng), pitch, 0.4 * pitch, 0.1, rng)
    fits = [(g, edge_grid_fit(runs, g)) for g in (3 * pitch, 2 * pitch, pitch, pitch / 2)]
    assert choose_grid(fits).rows_per_chip == pytest.approx(pitch, rel=1e-3)
    assert choose_grid([]) is None
    assert choose_grid([(9.0, None), (4.5, GridFit(4.5, 0.0, 0.6, 2.0, 10))]) is None


def test_a_grid_fit_needs_edges():
    assert edge_grid_fit(Runs(np.array([-0.5, 10.0, 20.0]), np.array([1, 0], np.int8)), 5.0) is None
    assert edge_grid_fit(Runs(np.array([-0.5, 99.5]), np.array([-1], np.int8)), 5.0) is None


# ------------------------------------------------------------ whole profiles


@pytest.mark.parametrize("rows_per_chip", [2.7, 4.5, 9.3, 17.0])
@pytest.mark.parametrize("exposure_chips, ceiling", [(0.3, 1.0), (1.0, 1.0), (0.5, 0.25)])
def test_a_profile_gives_its_pitch(rows_per_chip, exposure_chips, ceiling):
    """Manchester data through the exact rolling-shutter box, clipped at
    ``ceiling`` (saturation widens the ON runs), with noise."""
    rng = np.random.default_rng(int(rows_per_chip * 10))
    chips = manchester_chips(int(1200 / rows_per_chip / 2), rng)
    values = profile_from_chips(chips, rows_per_chip, exposure_chips * rows_per_chip)
    values = 10.0 + 200.0 * np.minimum(values, ceiling) / ceiling + rng.normal(0.0, 2.0, values.size)
    profile = RowProfile(0, values, np.full(values.size, 2.0))
    assert profile_rows_per_chip(profile, PHY) == pytest.approx(rows_per_chip, rel=0.002)


@pytest.mark.parametrize("rows_per_chip", [3.3, 4.5, 9.3])
def test_a_profile_saturated_in_its_core_gives_its_pitch(rows_per_chip):
    """Saturation that varies along the profile moves the rising and the
    falling edges apart by a varying amount: each polarity stays on the chip
    grid, but in one edge-energy sequence their lines interfere."""
    rng = np.random.default_rng(int(rows_per_chip * 10) + 1)
    chips = manchester_chips(int(1080 / rows_per_chip / 2), rng)
    level = core_saturated(profile_from_chips(chips, rows_per_chip, 0.8 * rows_per_chip))
    values = 40.0 + 210.0 * level + rng.normal(0.0, 1.0, level.size)
    profile = RowProfile(0, values, np.full(values.size, 1.0))
    assert profile_rows_per_chip(profile, PHY) == pytest.approx(rows_per_chip, rel=0.002)


@pytest.mark.parametrize("rows_per_chip", [3.3, 8.0])
def test_a_4b6b_profile_gives_its_pitch(rows_per_chip):
    from rollsim.protocol.linecode import encode

    rng = np.random.default_rng(7)
    chips = encode(rng.integers(0, 2, (1, 4 * int(1100 / rows_per_chip / 6))).astype(np.uint8), "4b6b").ravel()
    values = 10.0 + 200.0 * profile_from_chips(chips, rows_per_chip, 0.6 * rows_per_chip)
    profile = RowProfile(0, values + rng.normal(0.0, 2.0, values.size), np.full(values.size, 2.0))
    assert profile_rows_per_chip(profile, PHY_4B6B) == pytest.approx(rows_per_chip, rel=0.002)


def test_a_flat_profile_has_no_pitch():
    rng = np.random.default_rng(8)
    values = 100.0 + rng.normal(0.0, 1.0, 500)
    assert profile_rows_per_chip(RowProfile(0, values, np.ones(500)), PHY) is None
    assert profile_rows_per_chip(RowProfile(0, values[:6], np.ones(6)), PHY) is None


# ------------------------------------------------------------ rendered frames

# A phone's ISP (sRGB, vertical smoothing, sharpening, JPEG) and a small
# sensor with row and column noise and an sRGB JPEG: the frames on which the
# chip pitch must land within 2 % without a row time.
ISP_CAMERA = ["camera.width_px=480", "camera.height_px=360", "camera.row_time_us=31.7", "camera.exposure_us=140",
              "camera.iso=4000", "camera.read_noise_e=3", "led.size_mm=9", "led.luminous_intensity_cd=0.002",
              "effects.row_noise.std_e=1", "effects.column_fpn.std_e=1", "effects.tone_curve.curve=srgb",
              "effects.isp_smoothing.sigma_rows_px=1.2", "effects.sharpening.amount=0.3", "effects.jpeg.quality=90"]


@pytest.mark.parametrize("scene_name, overrides", [
    ("effect-isp", ["link.clock_hz=8000"]),
    ("effect-isp", ["link.clock_hz=4000"]),
    ("paper-default", ["link.clock_hz=8000"]),
    ("stress-saturation", ["link.clock_hz=3000"]),
    ("paper-geometric", [*ISP_CAMERA, "link.clock_hz=4000"]),
], ids=["isp-4.5rows", "isp-9rows", "paper-default", "saturated-12rows", "isp-camera-7.9rows"])
def test_rendered_frames_give_their_pitch_and_decode_as_with_it(scene_name, overrides):
    from rollsim.stages.decode import settings_from_scene
    from rollsim.render import iter_frames
    from rollsim.scene import load_scene

    scene = load_scene(scene_name, overrides)
    settings = settings_from_scene(scene)
    true = 1.0 / (settings.clock_hz * settings.row_time_s)
    for frame in iter_frames(scene, 2):
        profiles = [read.profile for read in _region_profiles(frame.image, settings.phy, None, None, 16, 4)]
        assert frame_rows_per_chip(profiles, settings.phy) == pytest.approx(true, rel=0.02)
        known = decode_frame(frame.image, settings.phy, clock_hz=settings.clock_hz, row_time_s=settings.row_time_s)
        unknown = decode_frame(frame.image, settings.phy)
        assert [(r.first_row, r.bits) for r in unknown if r.check_ok] == [(r.first_row, r.bits) for r in known if r.check_ok]
