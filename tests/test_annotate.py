"""rollsim.report.annotate: a frame drawn with its truth's PHY-SDUs by outcome and the rows a decoder read.

The outcome of each span is checked against the truth by its colour in the
drawn image: one PHY-SDU of each kind (read right, read with a wrong
payload the check passed, read with a failed check, whole but not read,
partly out of the frame), and a decode of nothing.
"""

import numpy as np
import pytest

from rollsim.errors import ApiArgumentError
from rollsim.report.annotate import OUTCOME_COLOURS, LED_COLOUR, MIN_COLUMN_PX, annotate, frame_spans, png_bytes

HEIGHT, WIDTH = 400, 200


def _sdu(first, last, sequence, bits, fully=True):
    return {"tx": sequence, "first_row_f": first, "last_row_f": last, "sequence": sequence, "bits": bits,
            "fully_visible": fully}


TRUTH = {"frame": 3, "led_rows": [20, 380], "sdus": [
    _sdu(-40.0, 20.0, 0, "0000", fully=False),  # partly above the frame: not_visible
    _sdu(20.0, 80.0, 1, "0001"),   # read right: ok
    _sdu(80.0, 140.0, 2, "0010"),  # payload wrong, check passed: undetected_error
    _sdu(140.0, 200.0, 3, "0011"),  # check failed: corrupted
    _sdu(200.0, 260.0, 4, "0100"),  # whole, not read: missed
]}
DECODED = [
    {"frame": 3, "first_row": 21, "last_row": 79, "sequence": 1, "bits": "0001", "check_ok": True},
    {"frame": 3, "first_row": 81, "last_row": 139, "sequence": 2, "bits": "1111", "check_ok": True},
    {"frame": 3, "first_row": 141, "last_row": 199, "sequence": 3, "bits": "0011", "check_ok": False},
    {"frame": 3, "first_row": 300, "last_row": 360, "sequence": 9, "bits": "1001", "check_ok": True},  # nothing there
]
EXPECTED_TRUTH = ["not_visible", "ok", "undetected_error", "corrupted", "missed"]
EXPECTED_READ = ["ok", "undetected_error", "corrupted", "false"]


def test_each_span_gets_its_outcome_against_the_truth():
    truth_spans, read_spans = frame_spans(TRUTH, DECODED)
    assert [s.outcome for s in truth_spans] == EXPECTED_TRUTH
    assert [s.outcome for s in read_spans] == EXPECTED_READ


def test_a_second_decode_of_one_phy_sdu_keeps_its_best_verdict():
    twice = DECODED[:1] + [{**DECODED[0], "bits": "1111", "check_ok": False}]
    truth_spans, read_spans = frame_spans(TRUTH, twice)
    assert truth_spans[1].outcome == "ok"
    assert [s.outcome for s in read_spans] == ["ok", "corrupted"]


@pytest.mark.parametrize("layout", ["grey", "colour", "16-bit"])
def test_the_drawn_colours_are_the_outcomes(layout):
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (HEIGHT, WIDTH), dtype=np.uint8)
    if layout == "colour":
        image = np.repeat(image[:, :, None], 3, axis=2)
    elif layout == "16-bit":
        image = image.astype(np.uint16) * 257
    drawn = annotate(image, TRUTH, DECODED)
    column = max(MIN_COLUMN_PX, WIDTH // 20)
    x_truth = WIDTH + column // 2 + column // 2
    x_read = WIDTH + column // 2 + column + column // 4 + column // 2
    truth_spans, read_spans = frame_spans(TRUTH, DECODED)
    for span in truth_spans:
        row = int(0.5 * (max(span.first_row, 0) + min(span.last_row, HEIGHT - 1)))  # the part in the frame
        assert tuple(drawn[row, x_truth]) == OUTCOME_COLOURS[span.outcome], span
    for span in read_spans:
        row = int(0.5 * (span.first_row + span.last_row))
        assert tuple(drawn[row, x_read]) == OUTCOME_COLOURS[span.outcome], span
    # The LED's rows are bracketed on the frame's left edge, and the frame is kept beside it.
    assert tuple(drawn[200, 0]) == LED_COLOUR and tuple(drawn[5, 0]) != LED_COLOUR
    expected = image if layout != "16-bit" else (image >> 8).astype(np.uint8)
    grey = expected if expected.ndim == 2 else expected[:, :, 0]
    np.testing.assert_array_equal(drawn[:HEIGHT, WIDTH // 2, 0], grey[:, WIDTH // 2])


def test_without_truth_the_rows_read_are_drawn_unjudged():
    _, read_spans = frame_spans(None, DECODED)
    assert {s.outcome for s in read_spans} == {"not_visible"}
    assert png_bytes(annotate(np.zeros((50, 40), np.uint8), None, DECODED)).startswith(b"\x89PNG")


def test_a_frame_of_another_shape_is_refused_in_one_line():
    with pytest.raises(ValueError, match="frame: expected a grey"):
        annotate(np.zeros((10, 10, 4), np.uint8))


# ------------------------------------------------------- rs.show and rollsim inspect

SMALL = {"camera.width_px": 320, "camera.height_px": 240}


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    from rollsim.cli import main

    root = tmp_path_factory.mktemp("inspect")
    sets = [a for k, v in SMALL.items() for a in ("--set", f"{k}={v}")]
    assert main(["render", "paper-geometric", "--out", str(root / "run"), "--frames", "3", "--quiet",
                 "--workers", "1", *sets]) == 0
    assert main(["decode", str(root / "run"), "--quiet", "--workers", "1"]) == 0
    return root / "run"


def _expected(run, frame):
    import json

    truth = next(t for t in map(json.loads, (run / "truth.jsonl").read_text().splitlines()) if t["frame"] == frame)
    decoded = [d for d in map(json.loads, (run / "decoded.jsonl").read_text().splitlines()) if d["frame"] == frame]
    return annotate(cv2_read(run, frame), truth, decoded)


def cv2_read(run, frame):
    import cv2

    return cv2.imread(str(run / "frames" / f"frame_{frame:06d}.png"), cv2.IMREAD_UNCHANGED)


def test_inspect_draws_the_runs_frame_with_its_truth_and_decodes(small_run, tmp_path, capsys):
    import cv2

    from rollsim.cli import main

    out = tmp_path / "a" / "frame1.png"
    assert main(["inspect", str(small_run), "--frame", "1", "--out", str(out)]) == 0
    drawn = cv2.cvtColor(cv2.imread(str(out), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    np.testing.assert_array_equal(drawn, _expected(small_run, 1))
    # Never silently replaced; a frame the run does not hold is named, and nothing is written.
    assert main(["inspect", str(small_run), "--frame", "1", "--out", str(out)]) == 2
    assert main(["inspect", str(small_run), "--frame", "7", "--out", str(tmp_path / "x.png")]) == 2
    assert "no frame 7 (it holds frames 0 to 2)" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_show_draws_the_same_as_inspect(small_run, tmp_path):
    import rollsim as rs

    scene = rs.load_scene(small_run / "scene.resolved.yaml")
    frame = list(rs.render(scene, n_frames=2))[1]
    decoded = rs.decode([frame], scene=scene)
    shown = rs.show(frame, decoded=decoded)
    assert repr(shown) == "<AnnotatedFrame of frame 1: %dx%d px>" % (shown.image.shape[1], shown.image.shape[0])
    assert shown._repr_png_().startswith(b"\x89PNG")
    # The same frame, truth and reading as the run's on disk.
    np.testing.assert_array_equal(shown.image, _expected(small_run, 1))
    path = shown.save(tmp_path / "b" / "shown.png")
    assert path.exists()
    with pytest.raises(ApiArgumentError, match="exists"):
        shown.save(path)
    # An image without truth: its rows read, unjudged.
    bare = rs.show(frame.image, decoded=decoded)
    assert bare.index is None and bare.image.shape == shown.image.shape
