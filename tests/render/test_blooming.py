"""blooming: charge above full well spills along columns, conserved."""

import numpy as np
import pytest

from rollsim.numerics.jit import numpy_only
from rollsim.render import RenderPipeline
from rollsim.sensor.blooming import _bloom_kernel, bloom

from conftest import make_scene

C = 100.0


def test_single_over_full_pixel_spreads_its_excess_exactly():
    """Excess 730 e⁻: 365 up and 365 down, each filling three pixels and a
    remainder of 65; the other columns do not change."""
    frame = np.full((100, 3), 7.0)
    frame[:, 1] = 0.0
    frame[50, 1] = C + 730.0
    before = frame.copy()
    assert bloom(frame, C) == 0.0
    expected = np.zeros(100)
    expected[47:54] = C
    expected[46] = expected[54] = 65.0
    np.testing.assert_array_equal(frame[:, 1], expected)
    np.testing.assert_array_equal(frame[:, [0, 2]], before[:, [0, 2]])


def test_a_drain_takes_the_rest_of_the_excess():
    column = np.zeros((40, 1))
    column[20, 0] = C + 400.0
    assert bloom(column, C, spill_fraction=0.25) == 0.0  # 50 up, 50 down; 300 drain
    expected = np.zeros(40)
    expected[20], expected[19], expected[21] = C, 50.0, 50.0
    np.testing.assert_array_equal(column[:, 0], expected)


def test_two_sources_share_the_room_between_them():
    """Rows 10 and 14 each hold 4C over full well; the 3C of room between
    them fills first from above (the downward flow), the rest goes on."""
    column = np.zeros((30, 1))
    column[[10, 14], 0] = 5 * C
    bloom(column, C)
    expected = np.zeros(30)
    expected[7:17] = C  # 8 C of excess: rows 11-13, then 3 rows above, 2 below
    np.testing.assert_allclose(column[:, 0], expected, atol=1e-9)


def test_charge_leaving_the_frame_is_reported():
    column = np.zeros((10, 1))
    column[1, 0] = C + 500.0  # 250 up: row 0 takes 100, 150 leave; 250 down: rows 2, 3, half of 4
    assert bloom(column, C) == pytest.approx(150.0)
    np.testing.assert_allclose(column[:, 0], [C, C, C, C, 50, 0, 0, 0, 0, 0])


def test_total_charge_is_conserved_when_nothing_leaves():
    rng = np.random.default_rng(4)
    frame = rng.uniform(0, 0.6 * C, size=(400, 300)).astype(np.float32)
    frame[rng.integers(50, 350, 40), rng.integers(0, 300, 40)] = rng.uniform(2 * C, 20 * C, 40)
    frame[100:110, 7] = 3 * C
    total = frame.astype(np.float64).sum()
    assert bloom(frame, C) == 0.0
    assert frame.max() <= C
    assert frame.astype(np.float64).sum() == pytest.approx(total, rel=1e-6)  # float32 storage
    wide = frame.astype(np.float64)
    wide[0, 0] = 50 * C
    total = wide.sum()
    lost = bloom(wide, C)
    assert wide.sum() + lost == pytest.approx(total, rel=1e-13)


@pytest.mark.parametrize("layout", ["region", "everywhere", "two far apart", "columns between"])
@pytest.mark.parametrize("spill_fraction", [1.0, 0.3])
def test_compiled_pass_equals_the_numpy_twin_byte_for_byte(layout, spill_fraction):
    """The kernel takes the span of columns between the first and last over-full ones; the twin only those."""
    if _bloom_kernel.compiled is None:
        pytest.skip("numba is not used here")
    rng = np.random.default_rng(11)
    frame = rng.gamma(2.0, 0.3 * C, size=(300, 400)).astype(np.float32)
    if layout == "region":
        frame = np.minimum(frame, np.float32(0.9 * C))
        frame[100:180, 150:260] *= np.float32(3.0)
    elif layout == "two far apart":
        frame = np.minimum(frame, np.float32(0.9 * C))
        frame[5, 390], frame[290, 2] = 40 * C, 3 * C
    elif layout == "columns between":  # the compiled pass takes columns 100 … 110, the twin three of them
        frame = np.minimum(frame, np.float32(0.9 * C))
        frame[50, 100], frame[200, 110], frame[10, 104] = 5 * C, 3 * C, 2 * C
    compiled, twin = frame.copy(), frame.copy()
    lost = bloom(compiled, C, spill_fraction)
    with numpy_only():
        lost_twin = bloom(twin, C, spill_fraction)
    assert compiled.tobytes() == twin.tobytes()
    assert lost == lost_twin
    assert not np.array_equal(compiled, frame)


def test_blooming_in_the_pipeline_fills_off_stripes_next_to_over_full_on_stripes():
    sections = dict(camera={"height_px": 300, "width_px": 40, "iso": 100.0, "exposure_us": 100.0},
                    led={"size_mm": 100.0, "luminous_intensity_cd": 400.0}, link={"pattern": "square"})
    plain = RenderPipeline(make_scene(**sections))
    blooming = RenderPipeline(make_scene(effects=("blooming",), **sections))
    assert "blooming" in blooming.stage_names and "blooming" not in plain.stage_names
    a, b = plain.run_stages(0), blooming.run_stages(0)
    full_well = blooming.setup.scene.camera.full_well_e
    # The mean charge before the full-well clip, per row.
    unclipped = blooming.setup.led_e_per_s * a.led_exposure_s
    assert unclipped.max() > 1.5 * full_well
    # Columns are uniform here, so whatever does not leave the frame stays.
    assert b.electrons[:, 20].sum() <= unclipped.sum() + 1e-6
    assert b.electrons[:, 20].sum() > a.electrons[:, 20].sum()
    assert b.electrons.max() <= full_well
