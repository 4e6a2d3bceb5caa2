"""rollsim paper: the paper's settings, the comparison rows and paper.json's schema."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from rollsim.cli import main
from rollsim.paper.compare import FIELDS, analytic_rows, comparison_row, deviation
from rollsim.paper.experiments import DISTANCES_CM, ROI_MEASURED, Claim, claims, header_bits_for, settings, split_for
from rollsim.paper.layers import load
from rollsim.protocol import n_packets

RESULTS = Path(__file__).parents[1] / "rollsim" / "bench" / "results" / "paper-quick"


def test_distance_settings_differ_from_paper_default_only_in_distance():
    """One parameter set: the distance experiments change link.distance_cm and nothing else."""
    found = settings()
    for d in DISTANCES_CM:
        assert found[f"d{d}"].overrides == (f"link.distance_cm={d}",)
    assert ROI_MEASURED == {5: 0.985, 10: 0.724, 15: 0.528, 20: 0.425, 25: 0.312, 30: 0.256, 35: 0.162, 40: 0.058}


@pytest.mark.parametrize(("message_bytes", "length"), [(50, 16), (50, 24), (50, 64), (1000, 24), (1, 4)])
def test_header_bits_are_just_enough(message_bytes, length):
    header = header_bits_for(message_bytes, length)
    assert 2**header >= n_packets(message_bytes, length - header)
    assert header == 1 or 2 ** (header - 1) < n_packets(message_bytes, length - header + 1)
    assert split_for(message_bytes, length)[:2] == [f"link.header_bits={header}",
                                                   f"link.payload_bits={length - header}"]


def test_default_split_is_the_papers():
    assert split_for(50, 24)[:2] == ["link.header_bits=5", "link.payload_bits=19"]


def test_every_setting_is_a_valid_scene():
    for setting in settings().values():
        load(setting.overrides)


def test_deviation_uses_the_most_physical_layer():
    assert deviation(100.0, {"analytic": 90.0, "event": 95.0, "pixel": 110.0}) == (pytest.approx(0.1), "pixel")
    assert deviation(100.0, {"analytic": 90.0, "event": None, "pixel": None}) == (pytest.approx(-0.1), "analytic")
    assert deviation(None, {"pixel": 3.0}) == (None, None)
    row = comparison_row(Claim("Fig. X", "goodput", "s", 200.0, "bit/s"), {"analytic": 100.0, "event": None})
    assert tuple(row) == FIELDS and row["deviation"] == -0.5 and row["deviation_layer"] == "analytic"


def test_claims_cover_every_figure_the_issue_lists():
    figures = {claim.figure for claim, _ in claims()} | {row["figure"] for row in analytic_rows()}
    assert {"Fig. 9", "Fig. 11", "Fig. 12", "Fig. 14", "Fig. 15", "Fig. 16", "Fig. 17", "Fig. 18", "Eq. 7"} <= figures
    numbers = {(claim.figure, claim.setting, claim.paper, claim.source) for claim, _ in claims()}
    assert ("Fig. 14", "d = 5 cm, G = 50 B, r = 1", 1700.0, "testbed") in numbers
    assert ("Fig. 18", "d = 10 cm, 1 kB log, r = 4", 540.0, "camcomsim") in numbers


def test_errata_rows_show_what_the_paper_got_wrong():
    rows = {row["figure"]: row for row in analytic_rows()}
    assert rows["Fig. 12"]["rollsim_analytic"] == pytest.approx(5 / 7, rel=1e-3)  # M/(M+N), not N/(M+N)
    assert rows["Eq. 7"]["paper"] > rows["Eq. 7"]["rollsim_analytic"]  # Eq. 7 overestimates p0 for r >= N + 2


def check_paper_json(rows: list) -> None:
    """paper.json's schema: a list of comparison rows with every field, finite numbers, consistent deviations."""
    assert isinstance(rows, list) and rows
    for row in rows:
        assert tuple(row) == FIELDS
        for name in ("paper", "rollsim_analytic", "rollsim_event", "rollsim_pixel", "deviation"):
            assert row[name] is None or (isinstance(row[name], (int, float)) and math.isfinite(row[name]))
        if row["deviation"] is not None:
            value = row[f"rollsim_{row['deviation_layer']}"]
            assert row["deviation"] == pytest.approx((value - row["paper"]) / row["paper"])
        assert isinstance(row["notes"], list)


@pytest.mark.slow
def test_paper_quick_writes_its_report(tmp_path, capsys):
    out = tmp_path / "paper"
    assert main(["paper", "--out", str(out), "--quick", "--quiet", "--workers", "2"]) == 0
    rows = json.loads((out / "paper.json").read_text())
    check_paper_json(rows)
    assert {"report.md", "roi_distance.png", "goodput_distance.png", "paper.json"} <= {p.name for p in out.iterdir()}
    assert "### Fig. 11" in (out / "report.md").read_text()
    assert main(["paper", "--out", str(out), "--quick", "--quiet"]) == 2  # never replaced without --force


def test_tiny_paper_run_matches_the_schema(tmp_path):
    """The whole command with 2 frames and 5 runs per setting, on a real local Dask cluster."""
    out = tmp_path / "paper"
    assert main(["paper", "--out", str(out), "--quick", "--frames", "2", "--runs", "5", "--quiet", "--workers", "2"]) == 0
    rows = json.loads((out / "paper.json").read_text())
    check_paper_json(rows)
    roi = {row["setting"]: row for row in rows if row["figure"] == "Fig. 11"}
    assert [roi[f"d = {d} cm"]["paper"] for d in DISTANCES_CM] == list(ROI_MEASURED.values())
    assert all(roi[f"d = {d} cm"]["rollsim_pixel"] is not None for d in DISTANCES_CM)
    p_e = [row for row in rows if row["quantity"] == "p_e"]
    assert len(p_e) == len(DISTANCES_CM)
    for row in p_e:  # an interval, or the one-sided bound, never a bare 0
        assert row["rollsim_pixel"] is None or any("95 %" in note for note in row["notes"])


def test_committed_results_match_the_schema():
    check_paper_json(json.loads((RESULTS / "paper.json").read_text()))


def test_fig16_bound_note_states_the_papers_own_limit():
    # 0.724 of a 30 ms readout holds 21.72/6.5 - 1 = 2.342 whole 6.5 ms
    # PHY-SDUs per frame: 24 bits x 30 frames/s x 2.342 = 1686 bit/s.
    from rollsim.paper.experiments import throughput_bound_note

    note = throughput_bound_note(10, 1940.0)
    assert "1686 bit/s" in note and "6.5 ms" in note and "ROI >= 0.80" in note
    assert "1514 bit/s" in note and "7.0 ms" in note and "ROI >= 0.86" in note
    fig16 = [c for c, key in claims() if c.figure == "Fig. 16" and c.quantity == "throughput" and c.paper == 1940.0]
    assert len(fig16) == 1 and fig16[0].notes == (note,)


def test_the_mmbp_cycle_note_matches_a_direct_count_of_the_cycle():
    # The 1 kB log at 5 cm: 8 ms PHY-SDUs, C = round(33.3 / 8) = 4 slots, M = 3,
    # N = 1. Replaying RP r = 1 over the noiseless cycle from each of its 4
    # phases and every start packet counts the rounds directly.
    from rollsim.paper.experiments import _log, mmbp_cycle_note

    note = mmbp_cycle_note(5)
    assert "cycle is 4 slots" in note and "422 packets are 2 mod 4" in note and "N = 1" in note
    n, on = 422, np.array([True, True, True, False])
    emissions = []
    for phase in range(4):
        received = np.zeros(n, dtype=bool)
        e = 0
        while not received.all():
            received[e % n] |= on[(phase + e) % 4]
            e += 1
        emissions.append(e)
    assert f"completes in {np.mean(emissions) / n:.2f} rounds" in note
    scene = load(_log(5, 1))
    assert scene.link.header_bits == 9


def _paper_scenes():
    wanted = sorted({key for _, key in claims()})
    return {key: load(settings()[key].overrides) for key in wanted}


@pytest.mark.parametrize("quick", [True, False])
def test_settings_that_resolve_to_one_scene_share_its_computations(quick):
    from rollsim.paper import PaperOptions, cluster_tasks
    from rollsim.scene import scene_to_yaml

    scenes = _paper_scenes()
    tasks = cluster_tasks(PaperOptions.make(quick=quick), scenes)
    served = [(key, task.layer) for task in tasks for key in task.keys]
    # Every claimed setting gets its event figures once, and no task is run twice.
    assert len(served) == len(set(served))
    assert {key for key, layer in served if layer == "event"} == set(scenes)
    by_layer: dict[str, list] = {}
    for task in tasks:
        texts = {scene_to_yaml(scenes[key]) for key in task.keys}
        assert len(texts) == 1, task.keys  # only one scene behind a shared task
        by_layer.setdefault(task.layer, []).append(texts.pop())
    for layer, texts in by_layer.items():
        assert len(texts) == len(set(texts)), layer  # and each scene once per layer
    # The 1 kB message at 5 cm with one repeat is Fig. 15's setting and Fig. 18's.
    assert any({"g1000", "log_d5_r1"} <= set(task.keys) for task in tasks if task.layer == "event")


def test_pixel_tasks_measure_the_roi_exactly_where_a_claim_needs_it():
    from rollsim.paper import ROI_QUANTITIES, PaperOptions, cluster_tasks

    needs = {key for claim, key in claims() if claim.quantity in ROI_QUANTITIES}
    assert {f"d{d}" for d in DISTANCES_CM} <= needs
    for task in cluster_tasks(PaperOptions.make(quick=False), _paper_scenes()):
        if task.layer == "pixel":
            assert task.args[-1] == any(key in needs for key in task.keys), task.keys


def test_pixel_figures_without_the_roi_are_the_same_figures():
    """decode_frame and inspect_frame read the same PHY-SDUs: only the ROI and its bound go."""
    from rollsim.paper.layers import pixel_figures

    overrides = ("camera.width_px=320", "camera.height_px=240")
    measured = pixel_figures(overrides, 6)
    unmeasured = pixel_figures(overrides, 6, measure_roi=False)
    assert measured["roi_ratio"] is not None and measured["throughput_bound_bps"] is not None
    assert unmeasured["roi_ratio"] is None and unmeasured["throughput_bound_bps"] is None
    same = {"roi_ratio", "throughput_bound_bps", "seconds"}
    assert measured["ok"] > 0
    assert {k: v for k, v in measured.items() if k not in same} == {k: v for k, v in unmeasured.items() if k not in same}
