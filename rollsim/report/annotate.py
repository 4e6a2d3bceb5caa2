"""One frame annotated with its truth and a decoder's reading: what a decoder author looks at first.

:func:`frame_spans` gives each PHY-SDU of a frame its outcome in that frame
(the truth's spans) and each decoded record its verdict (the decoder's
spans); :func:`annotate` draws them beside the frame:

- the frame, grey or colour, with the LED's rows (the truth's ``led_rows``)
  bracketed in cyan on its left edge;
- a column of the truth's PHY-SDU spans, each filled with its outcome's
  colour (:data:`OUTCOME_COLOURS`): ``ok``, ``undetected_error``,
  ``corrupted``, ``missed`` (fully visible in the frame, not read) or
  ``not_visible`` (only partly in the frame, not read);
- a column of the decoded records' spans (the rows read), each filled with
  its verdict's colour, ``false`` for a record that matches no PHY-SDU.

The verdicts are :func:`rollsim.stages.evaluate.evaluate`'s, taken within the one
frame: a decode matches the PHY-SDU whose row span holds its middle row.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Optional, Sequence

import cv2
import numpy as np

from rollsim.stages.decode import frame_files
from rollsim.errors import RollsimError
from rollsim.stages.evaluate import OUTCOMES, truth_table, decode_verdicts, match_decodes
from rollsim.protocol.frames import frame_index_from_name
from rollsim.stages.records import iter_jsonl, read_decoded

# RGB. Green for ok, red for a wrong payload the check passed, orange for a
# failed check, blue for missed, grey for never whole in the frame, magenta
# for a decode of nothing.
OUTCOME_COLOURS = {
    "ok": (40, 190, 60),
    "undetected_error": (220, 30, 30),
    "corrupted": (250, 150, 20),
    "missed": (50, 110, 240),
    "not_visible": (150, 150, 150),
    "false": (220, 40, 220),
}
LED_COLOUR = (0, 220, 230)
# Width of each span column and of the gaps, px (at least; they grow with wide frames).
MIN_COLUMN_PX = 24
LEGEND_ROW_PX = 16


@dataclass(frozen=True)
class Span:
    """Rows ``first_row`` … ``last_row`` of a frame, and what happened to them (a key of :data:`OUTCOME_COLOURS`)."""

    first_row: float
    last_row: float
    outcome: str
    sequence: int | None


def frame_spans(truth: Mapping | None, decoded: Sequence[Mapping] = ()) -> tuple[list[Span], list[Span]]:
    """The truth's PHY-SDU spans with their outcome in this frame, and the decoded records' spans with their verdict.

    Parameters
    ----------
    truth : mapping or None
        The frame's ``truth.jsonl`` record (``frame``, ``sdus`` with
        ``first_row_f``, ``last_row_f``, ``fully_visible``, ``sequence``,
        ``bits``); None: no truth, every decode's verdict is unknown
        (``not_visible``'s grey).
    decoded : sequence of mapping
        ``decoded.jsonl`` records of this frame (their ``frame`` is not checked).

    Returns
    -------
    (truth_spans, decoded_spans) : lists of :class:`Span`
    """
    decoded = list(decoded)
    if truth is None:
        return [], [Span(float(d["first_row"]), float(d["last_row"]), "not_visible", d.get("sequence"))
                    for d in decoded]
    rows = truth_table([{"frame": 0, "sdus": list(truth["sdus"])}])
    records = [{**d, "frame": 0} for d in decoded]
    matched = match_decodes(rows, records)
    hits = np.flatnonzero(matched >= 0)
    verdicts = decode_verdicts([records[i] for i in hits.tolist()], rows["sequence"][matched[hits]].tolist(),
                         rows["bits"][matched[hits]].tolist())
    decoded_outcome = ["false"] * len(records)
    best: dict[int, int] = {}
    for i, v in zip(hits.tolist(), verdicts.tolist()):
        decoded_outcome[i] = OUTCOMES[v]
        best[int(matched[i])] = min(best.get(int(matched[i]), v), v)  # the best verdict, as evaluate keeps
    truth_spans = []
    for k, sdu in enumerate(truth["sdus"]):
        if k in best:
            outcome = OUTCOMES[best[k]]
        else:
            outcome = "missed" if sdu["fully_visible"] else "not_visible"
        truth_spans.append(Span(float(sdu["first_row_f"]), float(sdu["last_row_f"]), outcome, int(sdu["sequence"])))
    decoded_spans = [Span(float(d["first_row"]), float(d["last_row"]), o, d.get("sequence"))
                     for d, o in zip(records, decoded_outcome)]
    return truth_spans, decoded_spans


def _as_rgb8(image: np.ndarray) -> np.ndarray:
    """An 8-bit RGB copy of a grey or RGB frame (16-bit frames scaled down)."""
    image = np.asarray(image)
    if image.dtype == np.uint16:
        image = (image >> 8).astype(np.uint8)
    elif image.dtype != np.uint8:
        image = np.clip(np.rint(image), 0, 255).astype(np.uint8)
    if image.ndim == 2:
        return np.repeat(image[:, :, None], 3, axis=2)
    if image.ndim == 3 and image.shape[2] == 3:
        return image.copy()
    raise ValueError(f"frame: expected a grey (H, W) or RGB (H, W, 3) image, got shape {image.shape}")


def _fill_spans(canvas: np.ndarray, spans: Sequence[Span], x0: int, x1: int) -> None:
    """Each span as a filled bar in columns ``x0`` … ``x1 − 1``, a dark line between neighbours."""
    height = canvas.shape[0]
    for span in spans:
        top = int(np.clip(np.floor(span.first_row), 0, height))
        bottom = int(np.clip(np.ceil(span.last_row) + 1, 0, height))
        if bottom <= top:
            continue
        canvas[top:bottom, x0:x1] = OUTCOME_COLOURS[span.outcome]
        canvas[top, x0:x1] = 30


def annotate(image: np.ndarray, truth: Mapping | None = None, decoded: Sequence[Mapping] = ()) -> np.ndarray:
    """The frame with its LED's rows, the truth's PHY-SDUs by outcome and the rows read, drawn beside it.

    Parameters
    ----------
    image : ndarray
        The frame: grey (H, W) or RGB (H, W, 3), 8- or 16-bit.
    truth : mapping, optional
        The frame's ``truth.jsonl`` record.
    decoded : sequence of mapping
        The ``decoded.jsonl`` records of this frame.

    Returns
    -------
    ndarray, uint8, shape (H + legend, W + 3 columns, 3)
        RGB: the frame, a gap, the truth's column, the decoder's column,
        and a legend of the colours below.
    """
    frame = _as_rgb8(image)
    height, width = frame.shape[:2]
    column = max(MIN_COLUMN_PX, width // 20)
    truth_spans, decoded_spans = frame_spans(truth, decoded)
    canvas = np.full((height + 2 * LEGEND_ROW_PX, width + 3 * column, 3), 255, dtype=np.uint8)
    canvas[:height, :width] = frame
    if truth is not None and truth.get("led_rows"):
        first, last = (int(v) for v in truth["led_rows"])
        first, last = max(0, first), min(height - 1, last)
        bar = max(2, column // 6)
        canvas[first:last + 1, :bar] = LED_COLOUR
    x_truth = width + column // 2
    _fill_spans(canvas, truth_spans, x_truth, x_truth + column)
    _fill_spans(canvas, decoded_spans, x_truth + column + column // 4, x_truth + 2 * column + column // 4)
    _draw_legend(canvas, height)
    return canvas


def _draw_legend(canvas: np.ndarray, top: int) -> None:
    """The colours' names in a row under the frame, and what the two columns are."""
    x = 4
    scale = 0.35
    names = [("LED rows", LED_COLOUR), *OUTCOME_COLOURS.items(), ("columns: truth, rows read", None)]
    for name, colour in names:
        if colour is None:
            cv2.putText(canvas, name, (x, top + 13), cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 1, cv2.LINE_AA)
            break
        cv2.rectangle(canvas, (x, top + 4), (x + 10, top + 14), colour, thickness=-1)
        cv2.putText(canvas, name, (x + 13, top + 13), cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 1, cv2.LINE_AA)
        x += 13 + cv2.getTextSize(name, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)[0][0] + 10
        if x > canvas.shape[1] - 40:  # a narrow frame: the rest on the second row
            x, top = 4, top + LEGEND_ROW_PX


def png_bytes(rgb: np.ndarray) -> bytes:
    """An RGB image as PNG bytes."""
    ok, data = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    if not ok:
        raise ValueError("the annotated frame could not be encoded as PNG")
    return data.tobytes()


def frame_truth(truth_path: Path, frame: int) -> Optional[dict]:
    """The ``truth.jsonl`` record of one frame (read until it is found), or None."""
    for _, record in iter_jsonl(truth_path):
        if isinstance(record, dict) and record.get("frame") == frame:
            return record
    return None


def inspect_run(run_dir: Path, frame: int, decoded_file: Optional[Path] = None) -> np.ndarray:
    """Frame ``frame`` of a render (or decode) directory, annotated as :func:`annotate` draws it.

    The frame is the PNG whose name's last number is ``frame``; its truth is
    read from ``DIR/truth.jsonl`` and its decoded records from
    ``decoded_file`` (default ``DIR/decoded.jsonl``), where they exist.

    Raises
    ------
    RollsimError
        No such directory, no PNG frames, no frame of that number (the
        range held is named), or a frame, truth or decoded file that cannot
        be read.
    """
    from decoder import FrameError, read_frame

    run_dir = Path(run_dir)
    files = frame_files(run_dir)
    by_index = {frame_index_from_name(path, i): path for i, path in enumerate(files)}
    if frame not in by_index:
        raise RollsimError(f"{run_dir}: no frame {frame} (it holds frames {min(by_index)} to {max(by_index)})")
    try:
        image = read_frame(by_index[frame])
    except FrameError as exc:
        raise RollsimError(str(exc)) from None
    truth_path = run_dir / "truth.jsonl"
    truth = frame_truth(truth_path, frame) if truth_path.exists() else None
    decoded_path = Path(decoded_file) if decoded_file is not None else run_dir / "decoded.jsonl"
    if decoded_file is not None or decoded_path.exists():
        decoded = [d for d in read_decoded(decoded_path) if d["frame"] == frame]
    else:
        decoded = []
    return annotate(image, truth, decoded)
