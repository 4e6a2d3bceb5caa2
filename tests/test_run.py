"""rollsim run: render, decode, evaluate, calibrate and report, end to end."""

import json
import re
from pathlib import Path

import cv2
import pytest

from rollsim.cli import main
from rollsim.report.run import STAGES

FAST = ["--set", "camera.width_px=480", "--workers", "1"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    # The geometric LED: 480 columns hold its whole disk (a halo would be cropped).
    out = tmp_path_factory.mktemp("run") / "paper-geometric"
    assert main(["run", "paper-geometric", "--out", str(out), "--frames", "16", *FAST]) == 0
    return out


def test_run_writes_every_stage_output(run_dir):
    for name in ("truth.jsonl", "scene.resolved.yaml", "decoded.jsonl", "decode.json", "outcomes.csv",
                 "evaluation.json", "calibration.json", "report.md"):
        assert (run_dir / name).is_file(), name
    assert len(list((run_dir / "frames").glob("*.png"))) == 16
    calibration = json.loads((run_dir / "calibration.json").read_text())
    assert calibration["source"] == str(run_dir)
    assert set(calibration) >= {"mmbp", "ge", "prediction", "goodput_rp", "message", "run_lengths"}


def test_report_defines_its_terms_and_names_where_the_docs_say_more(run_dir):
    from rollsim.report import TERMS

    report = (run_dir / "report.md").read_text()
    assert "## Terms" in report
    body = report[:report.index("## Terms")]
    for outcome in ("ok", "undetected_error", "corrupted", "missed", "not_visible"):
        assert f"| {outcome} |" in body  # the evaluation table uses it ...
        assert f"| `{outcome}` |" in report  # ... and the terms define it
    docs = Path(__file__).resolve().parents[1] / "docs"
    for term, _meaning, where in TERMS:
        page, section = where.split(", ", 1)
        text = (docs.parent / page).read_text(encoding="utf-8")
        assert f"# {section}" in text or f"`{section.split('.')[-1]}`" in text, (term, where)


def test_report_links_six_readable_plots(run_dir):
    report = (run_dir / "report.md").read_text()
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", report)
    assert [link.split("/")[-1] for link in links] == [
        "sample_frame.png", "row_profile.png", "outcome_timeline.png", "run_lengths.png",
        "message_curves.png", "goodput.png",
    ]
    for link in links:
        image = cv2.imread(str(run_dir / link))
        assert image is not None and image.shape[0] > 100 and image.shape[1] > 100
    for heading in ("## Time per stage", "## Evaluation against the ground truth", "## Calibration"):
        assert heading in report
    assert "the fit agrees" in report


def test_run_prints_progress_per_stage_and_a_summary(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", "paper-default", "--out", str(out), "--frames", "3", *FAST]) == 0
    captured = capsys.readouterr()
    for number, stage in enumerate(STAGES, start=1):
        assert f"[{number}/{len(STAGES)}] {stage}" in captured.err
    assert "MMBP fit: M =" in captured.out and str(out / "report.md") in captured.out


def test_run_refuses_a_non_empty_directory_and_leaves_nothing_on_failure(tmp_path, capsys):
    taken = tmp_path / "taken"
    taken.mkdir()
    (taken / "keep.txt").write_text("mine")
    assert main(["run", "paper-default", "--out", str(taken), "--frames", "2", *FAST]) == 2
    assert "not empty" in capsys.readouterr().err
    assert [p.name for p in taken.iterdir()] == ["keep.txt"]
    # A bad override: a one-line error, and no output directory (nor a
    # partial one) left behind.
    bad = tmp_path / "bad"
    assert main(["run", "paper-default", "--out", str(bad), "--frames", "2", *FAST, "--set", "camera.exposure_us=-5"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]


def test_a_dark_scene_still_reports_what_the_decoder_saw(tmp_path, capsys):
    out = tmp_path / "dark"
    assert main(["run", "paper-default", "--out", str(out), "--frames", "3", "--quiet", *FAST,
                 "--set", "link.pattern=off"]) == 0
    assert "calibration not possible: " in capsys.readouterr().out
    report = (out / "report.md").read_text()
    assert "## Calibration\n\nNot possible: " in report and str(out) in report and ".partial-" not in report
    assert not (out / "calibration.json").exists() and (out / "plots" / "sample_frame.png").is_file()


def _decoded_again(run_dir: Path, tmp_path: Path, workers: str) -> Path:
    """``rollsim decode`` of a copy of ``run_dir``: its PNGs read back."""
    import shutil

    copy = tmp_path / f"again-{workers}"
    shutil.copytree(run_dir, copy)
    assert main(["decode", str(copy), "--force", "--quiet", "--workers", workers]) == 0
    return copy


def test_the_runs_decode_in_the_render_workers_is_rollsim_decode_of_its_pngs(run_dir, tmp_path):
    """The run decodes each frame as it is rendered, before its PNG is read back: the records (with the
    render's identifier) and the summary are those ``rollsim decode`` writes from the PNGs."""
    again = _decoded_again(run_dir, tmp_path, "2")
    for name in ("decoded.jsonl", "decode.json"):
        assert (again / name).read_bytes() == (run_dir / name).read_bytes(), name
    assert (run_dir / "decoded.jsonl").read_text().count('"run":') > 0


def test_an_rgb_run_decodes_what_its_pngs_hold(tmp_path):
    """An RGB frame (Bayer, demosaiced): the PNG holds BGR on disk, read back as RGB, as rendered."""
    out = tmp_path / "bayer"
    assert main(["run", "effect-bayer", "--out", str(out), "--frames", "3", "--quiet", *FAST]) == 0
    again = _decoded_again(out, tmp_path, "1")
    assert (again / "decoded.jsonl").read_bytes() == (out / "decoded.jsonl").read_bytes()
    assert json.loads((out / "decode.json").read_text())["sdus"] > 0


def _without_times(report: str) -> str:
    """``report.md`` without its table of seconds per stage (the one part that varies between runs)."""
    start = report.index("## Time per stage")
    return report[:start] + report[report.index("## Evaluation", start):]


def test_two_workers_give_the_one_worker_run_byte_for_byte(run_dir, tmp_path):
    """With workers, the calibration's modules load while they render, and a second process draws
    half the plots beside the calibration: every file is the one-process run's (but the times)."""
    out = tmp_path / "two"
    assert main(["run", "paper-geometric", "--out", str(out), "--frames", "16", "--quiet",
                 "--set", "camera.width_px=480", "--workers", "2"]) == 0
    names = sorted(p.relative_to(run_dir) for p in run_dir.rglob("*") if p.is_file())
    assert names == sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    assert len([n for n in names if n.parts[0] == "plots"]) == 6
    for name in names:
        if name.name in ("report.md", "calibration.json", ".rollsim-output.json"):
            continue  # the times; the run's directory name
        assert (out / name).read_bytes() == (run_dir / name).read_bytes(), name
    assert _without_times((out / "report.md").read_text()) == _without_times((run_dir / "report.md").read_text())
    ours, theirs = (json.loads((d / "calibration.json").read_text()) for d in (out, run_dir))
    assert {**ours, "source": ""} == {**theirs, "source": ""}
