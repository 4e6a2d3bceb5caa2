"""rollsim bench envelope: the Wilson interval, the 95 %-ok boundary, the envelope stage and the command."""

import csv
import json
import math

import pytest

from rollsim.bench.envelope import MAP_NAMES, MAPS, auto_iso, format_regions, maps_by_name, ok_regions
from rollsim.calibrate import wilson_interval
from rollsim.cli import main
from rollsim.errors import RollsimError
from rollsim.scene import read_yaml, scene_from_dict
from rollsim.scene.bundled import resolve_scene_path
from rollsim.sweeps.stages import ENVELOPE_COLUMNS, STAGE_COLUMNS, envelope_row
from rollsim.sweeps.table import columns_of

# ------------------------------------------------------------------ Wilson


@pytest.mark.parametrize("k, n, low, high", [
    (8, 10, 0.4901625, 0.9433178),   # p̂ = 0.8, z = 1.959964
    (0, 10, 0.0, 0.2775328),         # z²/(n + z²)
    (10, 10, 0.7224672, 1.0),
    (50, 100, 0.4038315, 0.5961685),
])
def test_wilson_interval_matches_known_values(k, n, low, high):
    got = wilson_interval(k, n)
    assert got == pytest.approx((low, high), abs=1e-6)


def test_wilson_interval_is_symmetric_and_holds_the_estimate():
    for n in (1, 7, 40):
        for k in range(n + 1):
            low, high = wilson_interval(k, n)
            assert 0.0 <= low <= k / n <= high <= 1.0
            mirrored = wilson_interval(n - k, n)
            assert (low, high) == pytest.approx((1.0 - mirrored[1], 1.0 - mirrored[0]), abs=1e-12)


@pytest.mark.parametrize("k, n", [(1, 0), (-1, 5), (6, 5)])
def test_wilson_interval_refuses_impossible_counts(k, n):
    with pytest.raises(ValueError, match="must be"):
        wilson_interval(k, n)


# ------------------------------------------------------------------ boundary


def test_boundary_interpolates_the_crossing_linearly():
    # 1.0 at x = 2, 0.9 at x = 3: 0.95 is halfway.
    assert ok_regions([1, 2, 3, 4], [1.0, 1.0, 0.9, 0.5]) == [pytest.approx((1.0, 2.5))]


def test_boundary_of_a_curve_that_fails_at_both_ends():
    regions = ok_regions([3, 0, 1, 2], [0.5, 0.5, 1.0, 1.0])  # unsorted input
    assert regions == [pytest.approx((0.9, 2.1))]


def test_boundary_on_a_log_axis_interpolates_in_log_x():
    assert ok_regions([1, 100], [1.0, 0.9], log_x=True) == [pytest.approx((1.0, 10.0))]


def test_boundary_finds_every_stretch_and_none_below():
    assert ok_regions([0, 1, 2, 3, 4], [1.0, 0.0, 1.0, 0.0, 1.0]) == [
        pytest.approx((0.0, 0.05)), pytest.approx((1.95, 2.05)), pytest.approx((3.95, 4.0))]
    assert ok_regions([0, 1, 2], [0.9, 0.94, 0.5]) == []
    assert format_regions([], 0, 4) == "none"
    assert format_regions([(0.0, 2.5)], 0.0, 4.0) == "≤ 2.5"
    assert format_regions([(0.9, 4.0)], 0.0, 4.0) == "≥ 0.9"
    assert format_regions([(0.0, 4.0)], 0.0, 4.0).startswith("whole grid")


# ------------------------------------------------------------------ maps


def test_maps_are_named_and_selectable():
    assert [m.name for m in maps_by_name("snr,exposure")] == ["exposure", "snr"]  # MAPS order
    assert len(maps_by_name(None)) == len(MAPS) == len(MAP_NAMES)
    with pytest.raises(RollsimError, match="unknown map nope"):
        maps_by_name("exposure,nope")


def test_exposure_map_scales_iso_like_auto_exposure():
    points = next(m for m in MAPS if m.name == "exposure").points(False)
    exposure, iso = points["camera.exposure_us"], points["camera.iso"]
    assert exposure[0] == pytest.approx(12.5) and exposure[-1] == pytest.approx(500.0)
    assert all(e * i == pytest.approx(100.0 * 10000.0, rel=1e-5) for e, i in zip(exposure, iso))
    assert auto_iso(100.0) == 10000.0


def test_shake_map_is_every_rows_per_chip_with_every_tremor_in_the_hands_proportions():
    from rollsim.bench.envelope import DRIFT_PER_TREMOR, SHAKE_ROWS_PER_CHIP

    shake = next(m for m in MAPS if m.name == "shake")
    points = shake.points(False)
    n = len(points["effects.motion.tremor_deg"])
    assert all(len(values) == n for values in points.values())
    tremors = sorted(set(points["effects.motion.tremor_deg"]))
    assert n == len(tremors) * len(SHAKE_ROWS_PER_CHIP)
    # Each (clock, tremor) pair once: the product of the two axes.
    assert len(set(zip(points["link.clock_hz"], points["effects.motion.tremor_deg"]))) == n
    for k in range(n):
        tremor, drift = points["effects.motion.tremor_deg"][k], points["effects.motion.drift_deg"][k]
        assert drift == pytest.approx(DRIFT_PER_TREMOR * tremor)
        assert points["effects.motion.roll_tremor_deg"][k] == tremor
        assert points["effects.motion.roll_drift_deg"][k] == drift
        assert points["effects.motion.mode"][k] == "handheld"
    row_time_s = 1.0 / 30.0 * 0.9 / 1080
    rows = sorted({round(1.0 / (c * row_time_s), 3) for c in points["link.clock_hz"]})
    assert rows == pytest.approx(sorted(SHAKE_ROWS_PER_CHIP), rel=1e-4)


def test_compression_map_is_every_rows_per_chip_with_every_bitrate_from_half_to_fifty_mbps():
    from rollsim.bench.envelope import SHAKE_ROWS_PER_CHIP

    compression = next(m for m in MAPS if m.name == "compression")
    points = compression.points(False)
    bitrates = points["effects.video_codec.bitrate_bps"]
    assert all(len(values) == len(bitrates) for values in points.values())
    assert min(bitrates) == 5e5 and max(bitrates) == 5e7
    assert len(set(zip(points["link.clock_hz"], bitrates))) == len(set(bitrates)) * len(SHAKE_ROWS_PER_CHIP)
    # The scene takes every point: the codec's keys are scene keys like any other.
    from rollsim.scene import load_scene

    for k in (0, len(bitrates) - 1):
        scene = load_scene(compression.scene, [f"{key}={values[k]}" for key, values in points.items()])
        assert scene.effects.video_codec.bitrate_bps == bitrates[k]


def _cell(series, x, ok, genie_ok, status="ok"):
    return {"status": status, "rows_per_chip": series, "effects.motion.tremor_deg": x, "ok_fraction": ok,
            "ok_ci_low": ok, "ok_ci_high": ok, "genie_ok_fraction": genie_ok, "genie_ok_ci_low": genie_ok,
            "genie_ok_ci_high": genie_ok}


def test_a_series_map_has_a_boundary_and_a_table_row_per_curve():
    from rollsim.bench.envelope import boundaries, curves_of, table_rows

    shake = next(m for m in MAPS if m.name == "shake")
    rows = [_cell(4.5, 0.1, 1.0, 1.0), _cell(2.0, 0.1, 1.0, 1.0), _cell(4.5, 0.4, 0.5, 1.0), _cell(2.0, 0.4, 0.9, 1.0),
            {"status": "error", "rows_per_chip": None}]
    assert [v for v, _ in curves_of(shake, rows)] == [2.0, 4.5]
    entries = boundaries(shake, rows)
    assert [e["series_value"] for e in entries] == [2.0, 4.5]
    # 2 rows per chip: 1.0 at 0.1, 0.9 at 0.4: the crossing at (0.05/0.1) of the way in log x.
    low, high = entries[0]["decoder"][0]
    assert low == pytest.approx(0.1) and high == pytest.approx(math.exp(math.log(0.1) + 0.5 * math.log(4.0)))
    assert entries[1]["genie"] == [[0.1, 0.4]]
    # The failed cell has no series value: it is counted once, with the first curve.
    assert [e["failed"] for e in entries] == [1, 0]
    names = [row[0] for row in table_rows({"boundaries": entries})]
    assert names == ["shake (2 rows/chip)", "shake (4.5 rows/chip)"]
    exposure = next(m for m in MAPS if m.name == "exposure")
    assert [v for v, _ in curves_of(exposure, rows)] == [None]


# ------------------------------------------------------------------ stage


def test_envelope_stage_has_both_receivers_columns():
    for name in ("fully_visible", "ok", "ok_fraction", "ok_ci_low", "ok_ci_high", "false_decodes",
                 "false_decodes_passed", "genie_ok", "genie_ok_fraction", "genie_ok_ci_low", "genie_ok_ci_high",
                 "genie_false_decodes", "genie_false_decodes_passed", "stripe_snr_db", "exposure_chips",
                 "rows_per_chip", "led_to_background", "on_full_wells"):
        assert name in ENVELOPE_COLUMNS
    assert STAGE_COLUMNS["envelope"] == ENVELOPE_COLUMNS
    assert columns_of("envelope", ["camera.iso"])[:2] == ["cell", "camera.iso"]


def _noiseless_scene():
    base = read_yaml(resolve_scene_path("paper-geometric"))
    base["effects"] = {"ambient": {}}  # no shot noise, no read noise
    return scene_from_dict(base, "paper-geometric", ["camera.width_px=640"], {"frames": 2, "seed": 5})


def test_a_noiseless_easy_cell_is_read_entirely_by_the_genie():
    row = envelope_row(_noiseless_scene(), {"frames": 2})
    assert set(row) == set(ENVELOPE_COLUMNS)
    assert row["fully_visible"] > 0
    assert row["genie_ok"] == row["fully_visible"] and row["genie_ok_fraction"] == 1.0
    assert row["genie_ok_ci_high"] == 1.0 and 0.0 < row["genie_ok_ci_low"] < 1.0
    assert row["genie_false_decodes"] == 0
    assert row["exposure_chips"] == pytest.approx(0.8) and row["rows_per_chip"] == pytest.approx(4.5)
    assert row["stripe_snr_db"] > 40.0  # quantisation alone
    assert row["led_to_background"] > 0.0 and 0.0 < row["on_full_wells"] < 1.0


# ------------------------------------------------------------------ command


def test_quick_command_writes_csv_png_and_boundaries(tmp_path, capsys):
    out = tmp_path / "envelope"
    assert main(["bench", "envelope", "--quick", "--maps", "exposure", "--workers", "1", "--quiet",
                 "--out", str(out)]) == 0
    assert "exposure" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == ["envelope.json", "envelope.md", "exposure.csv", "exposure.png"]
    rows = list(csv.DictReader((out / "exposure.csv").read_text().splitlines()))
    assert len(rows) == 2 and all(r["status"] == "ok" for r in rows)
    assert [float(r["exposure_chips"]) for r in rows] == pytest.approx([0.5, 2.0])
    for row in rows:
        fraction = float(row["genie_ok_fraction"])
        assert float(row["genie_ok_ci_low"]) <= fraction <= float(row["genie_ok_ci_high"])
        assert math.isclose(fraction, int(row["genie_ok"]) / int(row["fully_visible"]))
    assert (out / "exposure.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    result = json.loads((out / "envelope.json").read_text())
    assert result["boundaries"][0]["map"] == "exposure" and "genie" in result["boundaries"][0]
    assert "| exposure |" in (out / "envelope.md").read_text()
    # The results are never silently replaced: refused before any work.
    assert main(["bench", "envelope", "--quick", "--maps", "exposure", "--out", str(out)]) != 0
    assert "exists" in capsys.readouterr().err
