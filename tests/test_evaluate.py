"""Evaluation against ground truth, on rendered truth and hand-made decodes."""

import pytest

from rollsim.stages.evaluate import OUTCOMES, evaluate, format_summary, match_decodes, outcomes_csv, truth_table
from rollsim.render import RenderPipeline
from rollsim.scene import scene_from_dict


@pytest.fixture(scope="module")
def rendered():
    scene = scene_from_dict(
        {"camera": {"preset": "nexus5", "width_px": 32}, "led": {"size_mm": 17.3}, "effects": []}
    )
    pipeline = RenderPipeline(scene)
    truth = [pipeline.render(k).truth for k in range(6)]
    return truth, pipeline.setup.transmitter


def _decode_of(sdu, frame, **changes):
    record = {
        "frame": frame,
        "first_row": sdu["first_row_f"] + 0.7,
        "last_row": sdu["last_row_f"] - 0.4,
        "sequence": sdu["sequence"],
        "bits": sdu["bits"],
        "check_ok": True,
        "confidence": 0.9,
    }
    record.update(changes)
    return record


def _fully_visible(truth):
    return [(t["frame"], s) for t in truth for s in t["sdus"] if s["fully_visible"]]


def test_every_emission_gets_exactly_one_outcome_including_the_gaps(rendered):
    truth, tx = rendered
    result = evaluate(truth, [], tx)
    txs = [row["tx"] for row in result.outcomes]
    assert txs == list(range(txs[0], txs[-1] + 1))  # no gaps, no repeats
    assert all(row["outcome"] in OUTCOMES for row in result.outcomes)
    seen = {s["tx"] for t in truth for s in t["sdus"]}
    assert set(txs) >= seen
    # Emissions no frame saw exist and are not visible.
    assert set(txs) - seen <= {r["tx"] for r in result.outcomes if r["outcome"] == "not_visible"}
    n_visible = len({s["tx"] for _, s in _fully_visible(truth)})
    assert result.summary["counts"]["missed"] == n_visible == result.summary["fully_visible"]
    assert result.summary["error_rate"] == 1.0


def test_verdicts_ok_corrupted_undetected_and_false_decodes(rendered):
    truth, tx = rendered
    visible = _fully_visible(truth)
    (f0, s0), (f1, s1), (f2, s2) = visible[:3]
    flipped = s2["bits"][:-1] + ("1" if s2["bits"][-1] == "0" else "0")
    decoded = [
        _decode_of(s0, f0),
        _decode_of(s1, f1, check_ok=False),
        _decode_of(s2, f2, bits=flipped),
        {"frame": 0, "first_row": 5000.0, "last_row": 5100.0, "sequence": 1, "bits": "0", "check_ok": True},
        {"frame": 1, "first_row": 5000.0, "last_row": 5100.0, "sequence": 2, "bits": "1", "check_ok": False},
    ]
    result = evaluate(truth, decoded, tx)
    by_tx = {row["tx"]: row for row in result.outcomes}
    assert by_tx[s0["tx"]]["outcome"] == "ok" and by_tx[s0["tx"]]["success"]
    assert by_tx[s1["tx"]]["outcome"] == "corrupted"
    assert by_tx[s2["tx"]]["outcome"] == "undetected_error"
    assert len(result.false_decodes) == 2
    summary = result.summary
    assert summary["counts"]["ok"] == 1 and summary["undetected_error_rate"] == 0.5
    # Only the false decode whose check passed could mislead a receiver.
    assert summary["false_decodes_check_passed"] == 1
    assert summary["false_decodes_per_1000_frames"] == pytest.approx(2000 / 6)
    assert "(1 with the check passed)" in format_summary(summary)


def test_best_verdict_wins_when_decoded_twice(rendered):
    truth, tx = rendered
    f0, s0 = _fully_visible(truth)[0]
    decoded = [_decode_of(s0, f0, check_ok=False), _decode_of(s0, f0)]
    row = next(r for r in evaluate(truth, decoded, tx).outcomes if r["tx"] == s0["tx"])
    assert row["outcome"] == "ok" and row["decodes"] == 2


def test_matching_uses_frame_and_rows(rendered):
    truth, _ = rendered
    rows = truth_table(truth)
    f0, s0 = _fully_visible(truth)[0]
    decoded = [_decode_of(s0, f0), _decode_of(s0, f0 + 1)]
    matched = match_decodes(rows, decoded)
    assert rows["tx"][matched[0]] == s0["tx"]
    # The same rows one frame later hold another emission.
    assert matched[1] == -1 or rows["tx"][matched[1]] != s0["tx"]


def test_outcomes_csv_has_the_calibration_columns(rendered):
    truth, tx = rendered
    text = outcomes_csv(evaluate(truth, [], tx).outcomes)
    header = text.splitlines()[0].split(",")
    assert {"tx", "sequence", "frame", "start_s", "end_s", "outcome", "success"} <= set(header)
