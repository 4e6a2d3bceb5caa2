"""Evaluation: a verdict for every emitted PHY-SDU against exact ground truth.

Decoded PHY-SDUs are matched to the truth by frame and rows: a decode matches
the PHY-SDU of that frame whose row span (centre convention,
``first_row_f`` … ``last_row_f``) holds the decode's middle row. Every
emission from the first to the last that the rendered time span covers gets
exactly one outcome, including those sent wholly inside an inter-frame gap,
which no truth record lists:

``ok``
    decoded, the check passed, and sequence number and payload are right;
``undetected_error``
    decoded, the check passed, but the sequence number or payload is wrong;
``corrupted``
    decoded, but the check failed;
``missed``
    fully visible in some frame, not decoded;
``not_visible``
    never fully visible, not decoded.

An emission decoded in two frames keeps its best verdict (ok, then
undetected_error, then corrupted). A decode that matches no emission is a
*false decode*; ``false_decodes_check_passed`` counts those whose check
passed, the only ones that can mislead a receiver (the others are records of
candidates that failed the line code or the check, reported because a
decoder was asked for its failures too).

Rates in the summary:

* ``error_rate``: 1 − ok / fully visible, among the fully visible emissions;
* ``corrupted_rate``: corrupted / fully visible (``fully_visible_counts``
  breaks the fully visible emissions down by outcome; a PHY-SDU only partly
  visible may be decoded too, and then counts in ``counts`` only);
* ``missed_rate``: missed / fully visible;
* ``undetected_error_rate``: undetected errors / decodes whose check passed;
* ``false_decodes_per_1000_frames``.
"""

from __future__ import annotations

import csv
import json
import math
import operator
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rollsim.errors import RollsimError, clip, short_repr
from rollsim.stages.receiver import receive_message
from rollsim.stages.records import read_decoded, read_jsonl, run_identifier
from rollsim.plumbing.validation import missing_path

OUTCOMES = ("ok", "undetected_error", "corrupted", "missed", "not_visible")
OUTCOME_COLUMNS = ("tx", "sequence", "outcome", "success", "frame", "fully_visible", "decodes", "start_s", "end_s")


@dataclass(frozen=True)
class Evaluation:
    """Outcomes, false decodes and their summary.

    Attributes
    ----------
    outcomes : list of dict
        One row per emission, columns :data:`OUTCOME_COLUMNS`, in tx order.
    false_decodes : list of dict
        The decoded records that match no emission.
    summary : dict
    """

    outcomes: list
    false_decodes: list
    summary: dict


def truth_table(truth: list[dict]) -> dict[str, np.ndarray]:
    """The truth records' PHY-SDUs as columns (frame, tx, first and last row, fully visible, sequence, bits)."""
    rows = [(t["frame"], s) for t in truth for s in t["sdus"]]
    return {
        "frame": np.array([f for f, _ in rows], dtype=np.int64),
        "tx": np.array([s["tx"] for _, s in rows], dtype=np.int64),
        "first": np.array([s["first_row_f"] for _, s in rows], dtype=np.float64),
        "last": np.array([s["last_row_f"] for _, s in rows], dtype=np.float64),
        "fully_visible": np.array([s["fully_visible"] for _, s in rows], dtype=bool),
        "sequence": np.array([s["sequence"] for _, s in rows], dtype=np.int64),
        "bits": np.array([s["bits"] for _, s in rows], dtype=object),
    }


def _column(records: list[dict], name: str) -> np.ndarray:
    """One number field of every record, as float64."""
    return np.array(list(map(operator.itemgetter(name), records)), dtype=np.float64)


def match_decodes(truth_rows: dict[str, np.ndarray], decoded: list[dict]) -> np.ndarray:
    """Index into ``truth_rows`` of the PHY-SDU each decode matches, or -1.

    A decode matches the PHY-SDU of its frame whose row span holds the
    decode's middle row (vectorised: one sort and one search).
    """
    if not decoded or truth_rows["frame"].size == 0:
        return np.full(len(decoded), -1, dtype=np.int64)
    frames = np.array(list(map(operator.itemgetter("frame"), decoded)), dtype=np.int64)
    # Halves summed, not the sum halved: the same number, and no overflow for rows near 1e308.
    middle = 0.5 * _column(decoded, "first_row") + 0.5 * _column(decoded, "last_row")
    order = np.lexsort((truth_rows["first"], truth_rows["frame"]))
    t_frame, t_first, t_last = (truth_rows[k][order] for k in ("frame", "first", "last"))
    # PHY-SDUs of one frame are back to back, so their spans are sorted and
    # disjoint: the candidate is the last one starting at or before the middle.
    span = max(1.0, float(np.max(t_last - t_first)))
    key_truth = t_frame * (4.0 * span + 1e6) + t_first
    key_decode = frames * (4.0 * span + 1e6) + middle
    candidate = np.searchsorted(key_truth, key_decode, side="right") - 1
    ok = candidate >= 0
    c = np.where(ok, candidate, 0)
    ok &= (t_frame[c] == frames) & (middle >= t_first[c]) & (middle <= t_last[c])
    return np.where(ok, order[c], -1)


def decode_verdicts(decodes: list[dict], sequences: list, bits: list) -> np.ndarray:
    """:data:`OUTCOMES` index of each decode against the PHY-SDU it matched (its sequence number and bits).

    ``corrupted`` if the check failed, else ``ok`` if sequence number and
    payload are right, else ``undetected_error``. One pass in C over Python
    comparisons: a million decodes take a fraction of a second.
    """
    ok, undetected, corrupted = (OUTCOMES.index(name) for name in ("ok", "undetected_error", "corrupted"))
    return np.fromiter(
        ((ok if d.get("sequence") == s and d.get("bits") == b else undetected) if d.get("check_ok", False)
         else corrupted for d, s, b in zip(decodes, sequences, bits)),
        dtype=np.int64, count=len(decodes))


def evaluate(truth: list[dict], decoded: list[dict], transmitter) -> Evaluation:
    """Give every emission of the rendered span its outcome.

    Parameters
    ----------
    truth : list of dict
        Records of ``truth.jsonl``.
    decoded : list of dict
        Records of ``decoded.jsonl`` (``frame``, ``first_row``, ``last_row``,
        ``sequence``, ``bits``, ``check_ok``).
    transmitter : Transmitter
        The scene's transmitter, for the times of emissions no frame saw.
    """
    rows = truth_table(truth)
    matched = match_decodes(rows, decoded)
    false_decodes = [d for d, m in zip(decoded, matched.tolist()) if m < 0]
    outcomes: list[dict] = []
    if rows["tx"].size:
        first_tx = int(rows["tx"].min())
        all_tx = np.arange(first_tx, int(rows["tx"].max()) + 1)
        outcome, frame, fully = _visibility(rows, first_tx, all_tx.size)
        decodes = _apply_decodes(rows, decoded, matched, first_tx, outcome, frame)
        outcomes = _outcome_records(transmitter, all_tx, outcome, frame, fully, decodes)
    summary = summarise(outcomes, false_decodes, len(truth))
    summary["message"] = receive_message(decoded, truth, transmitter).as_dict()
    return Evaluation(outcomes, false_decodes, summary)


def _visibility(rows: dict, first_tx: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per emission: ``missed`` where some frame saw it whole (else ``not_visible``), that frame, and whether."""
    outcome = np.full(n, OUTCOMES.index("not_visible"), dtype=np.int64)
    frame = np.full(n, -1, dtype=np.int64)
    fully = np.zeros(n, dtype=bool)
    visible = np.flatnonzero(rows["fully_visible"])
    visible = visible[np.lexsort((rows["frame"][visible], rows["tx"][visible]))]
    tx_visible, first_seen = np.unique(rows["tx"][visible], return_index=True)  # earliest frame per tx
    fully[tx_visible - first_tx] = True
    frame[tx_visible - first_tx] = rows["frame"][visible[first_seen]]
    outcome[fully] = OUTCOMES.index("missed")
    return outcome, frame, fully


def _apply_decodes(rows: dict, decoded: list[dict], matched: np.ndarray, first_tx: int, outcome: np.ndarray,
                   frame: np.ndarray) -> np.ndarray:
    """Set each decoded emission's best verdict and its frame in place; return the decodes per emission."""
    hits = np.flatnonzero(matched >= 0)
    decode_tx = rows["tx"][matched[hits]] - first_tx
    decodes = np.bincount(decode_tx, minlength=outcome.size)
    truth_index = matched[hits]
    verdicts = decode_verdicts([decoded[i] for i in hits.tolist()], rows["sequence"][truth_index].tolist(),
                         rows["bits"][truth_index].tolist())
    # Best verdict per emission (lowest OUTCOMES index), then its earliest frame.
    decode_frame = rows["frame"][matched[hits]]
    order = np.lexsort((decode_frame, verdicts, decode_tx))
    tx_decoded, best = np.unique(decode_tx[order], return_index=True)
    outcome[tx_decoded] = verdicts[order][best]
    frame[tx_decoded] = decode_frame[order][best]
    return decodes


def _outcome_records(transmitter, all_tx: np.ndarray, outcome: np.ndarray, frame: np.ndarray, fully: np.ndarray,
                     decodes: np.ndarray) -> list[dict]:
    """One outcome record per emission (the rows of ``outcomes.csv``)."""
    starts = transmitter.emission_start_s(all_tx)
    sequence = transmitter.schedule.sequence_numbers(all_tx)
    return [
        {
            "tx": int(all_tx[i]),
            "sequence": int(sequence[i]),
            "outcome": OUTCOMES[outcome[i]],
            "success": bool(outcome[i] == 0),
            "frame": int(frame[i]),
            "fully_visible": bool(fully[i]),
            "decodes": int(decodes[i]),
            "start_s": float(starts[i]),
            "end_s": float(starts[i] + transmitter.sdu_duration_s),
        }
        for i in range(all_tx.size)
    ]


def summarise(outcomes: list[dict], false_decodes: list, n_frames: int) -> dict:
    """Counts and rates of an evaluation (see the module docstring)."""
    counts = {name: 0 for name in OUTCOMES}
    for row in outcomes:
        counts[row["outcome"]] += 1
    visible_counts = {name: 0 for name in OUTCOMES[:4]}
    for row in outcomes:
        if row["fully_visible"]:
            visible_counts[row["outcome"]] += 1
    fully = sum(visible_counts.values())
    passed = counts["ok"] + counts["undetected_error"]
    return {
        "frames": n_frames,
        "emissions": len(outcomes),
        "fully_visible": fully,
        "counts": counts,
        "fully_visible_counts": visible_counts,
        "false_decodes": len(false_decodes),
        "false_decodes_check_passed": sum(1 for d in false_decodes if d.get("check_ok")),
        "error_rate": (1.0 - visible_counts["ok"] / fully) if fully else None,
        "corrupted_rate": (visible_counts["corrupted"] / fully) if fully else None,
        "missed_rate": (counts["missed"] / fully) if fully else None,
        "undetected_error_rate": (counts["undetected_error"] / passed) if passed else None,
        "false_decodes_per_1000_frames": (1000.0 * len(false_decodes) / n_frames) if n_frames else None,
    }


def evaluate_directory(run_dir: Path, force: bool = False, decoded_file: Path | None = None,
                       against: Path | None = None, allow_foreign: bool = False) -> Evaluation:
    """Evaluate a decoded render directory; write ``outcomes.csv`` and ``evaluation.json``.

    Reads ``truth.jsonl``, ``decoded.jsonl``, ``scene.resolved.yaml`` and the
    frame files (and ``decode.json``, when present, for the frames that
    could not be read). They must describe the same frames
    (:func:`check_consistency`); frames the decoder could not read are
    scored as it saw them, with a warning and ``consistent: false``.

    Parameters
    ----------
    run_dir : Path
    force : bool
        Replace existing outputs; without it they are never overwritten.
    decoded_file : Path, optional
        The decoded PHY-SDUs to score, default ``run_dir/decoded.jsonl``:
        any decoder's, checked line by line against the schema
        (:mod:`rollsim.stages.records`).
    against : Path, optional
        A second decoder's ``decoded.jsonl``, scored on the same frames and
        compared outcome by outcome (:func:`rollsim.stages.compare.compare_evaluations`)
        into ``run_dir/comparison.json``, committed with the others.
    allow_foreign : bool
        Score records of another render too (their ``run`` differs from
        this directory's: :func:`rollsim.stages.records.run_identifier`), with a
        warning; without it they are refused.

    Raises
    ------
    RollsimError
        A missing, malformed or inconsistent input file (named, with the
        line), or an existing output without ``force``.
    """
    from rollsim.stages.compare import compare_evaluations
    from rollsim.plumbing.outputs import check_file_targets, staged_files

    run_dir = Path(run_dir)
    targets = [run_dir / "outcomes.csv", run_dir / "evaluation.json"]
    if against is not None:
        targets.append(run_dir / "comparison.json")
    if run_dir.is_dir():
        check_file_targets(targets, force)
    result, unreadable = score_directory(run_dir, decoded_file, allow_foreign)
    report = {"summary": result.summary, "false_decodes": result.false_decodes, "unreadable": unreadable}
    comparison = None
    if against is not None:
        names = (str(decoded_file or run_dir / "decoded.jsonl"), str(against))
        comparison = compare_evaluations(result, score_directory(run_dir, Path(against), allow_foreign)[0], names)
    with staged_files(targets, force) as files:
        files.write(targets[0], outcomes_csv(result.outcomes))
        files.write(targets[1], json.dumps(report, indent=2, allow_nan=False) + "\n")
        if comparison is not None:
            files.write(targets[2], json.dumps(comparison, indent=2, allow_nan=False) + "\n")
    return result


def score_directory(run_dir: Path, decoded_file: Path | None = None,
                    allow_foreign: bool = False) -> tuple[Evaluation, list]:
    """Read and check a render directory and a decoded file, and evaluate them (writing nothing).

    Decoded records of another render (a ``run`` other than this
    directory's) are refused, or with ``allow_foreign`` scored with a
    warning; records without ``run`` (another decoder's) are scored.

    Returns
    -------
    (Evaluation, list of dict)
        The evaluation (its summary with ``frames_unreadable``,
        ``consistent`` and ``warnings``) and the frames the decoder could
        not read (from ``decode.json``, for the run's own decode).
    """
    from rollsim.scene import load_scene
    from rollsim.transmitter import transmitter_from_scene

    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise RollsimError(missing_path(run_dir) or f"{run_dir}: not a directory")
    scene_file = run_dir / "scene.resolved.yaml"
    if not scene_file.exists():
        raise RollsimError(f"{scene_file}: not found; evaluate needs a directory written by `rollsim render`")
    own_decode = decoded_file is None
    decoded_file = run_dir / "decoded.jsonl" if decoded_file is None else Path(decoded_file)
    if not decoded_file.exists():
        hint = f"; run `rollsim decode {run_dir}` first" if own_decode else ""
        raise RollsimError(f"{decoded_file}: not found{hint}")
    scene = load_scene(scene_file)
    truth_file = run_dir / "truth.jsonl"
    truth = read_jsonl(truth_file)
    check_records(truth, truth_file, TRUTH_FIELDS)
    for record in truth:
        check_records(record["sdus"], truth_file, TRUTH_SDU_FIELDS, f"frame {record['frame']}: PHY-SDU")
    run = run_identifier(run_dir)
    decoded = read_decoded(decoded_file, None if allow_foreign else run)
    # decode.json describes the run's own decode, not another decoder's file.
    decode_info = _decode_info(run_dir / "decode.json") if own_decode else {}
    warnings = check_consistency(run_dir, truth, decoded, decode_info, scene.link.payload_bits, decoded_file)
    if allow_foreign:  # else read_decoded refused them
        warnings += foreign_warnings(decoded, run, decoded_file)
    result = evaluate(truth, decoded, transmitter_from_scene(scene))
    unreadable = decode_info.get("unreadable", [])
    result.summary["frames_unreadable"] = len(unreadable)
    result.summary["consistent"] = not warnings
    result.summary["warnings"] = warnings
    return result, unreadable


_BITS = re.compile(r"^[01]*$")
_INT64_END = 2**63


def check_consistency(run_dir: Path, truth: list[dict], decoded: list[dict], decode_info: dict,
                      payload_bits: int, decoded_file: Path | None = None) -> list[str]:
    """Check that frames, truth and decoded records describe the same frames.

    Errors (one line naming the file and line): an empty truth, truth
    frames out of order, a frame file the truth lists but the directory
    lacks, frame files the truth does not list (an unfinished render), a
    ``decode.json`` that counted other frames, decoded records of frames the
    truth does not list, sequence numbers beyond 64 bits, and payload bits
    that are not ``payload_bits`` zeros and ones.

    Returns
    -------
    list of str
        Warnings: frames the decoder could not read. Their PHY-SDUs are
        scored as missed, so the figures are not those of the whole render.
    """
    from rollsim.protocol.frames import frame_index_from_name

    truth_file = run_dir / "truth.jsonl"
    decoded_file = run_dir / "decoded.jsonl" if decoded_file is None else decoded_file
    if not truth:
        raise RollsimError(f"{truth_file}: empty; the render wrote no frame (re-render the directory)")
    frames = [record["frame"] for record in truth]
    for line, (before, frame) in enumerate(zip(frames, frames[1:]), start=2):
        if frame <= before:
            raise RollsimError(f"{truth_file}: line {line}: frame {frame} after frame {before}; frames must increase")
    frame_dir = run_dir / "frames"
    if not frame_dir.is_dir():
        from rollsim.video.write import rendered_video

        video = rendered_video(run_dir)
        if video is None:
            raise RollsimError(f"{frame_dir}: not found; evaluate checks the truth against the rendered frames")
        _check_video_frames(video, truth_file, len(frames))
        return _decode_checks(run_dir, truth_file, frames, decoded, decoded_file, decode_info, payload_bits)
    on_disk = {}
    for path in frame_dir.iterdir():
        if path.suffix.lower() == ".png" and not path.name.startswith("."):
            on_disk[frame_index_from_name(path.name, -1)] = path
    for line, frame in enumerate(frames, start=1):
        if frame not in on_disk:
            raise RollsimError(f"{frame_dir}: no file for frame {frame} ({truth_file.name} line {line}); "
                               "a frame was deleted or the directory was not written by one render")
    extra = sorted(set(on_disk) - set(frames))
    if extra:
        raise RollsimError(f"{truth_file}: lists {len(frames)} frames but {frame_dir.name}/ holds {len(on_disk)} "
                           f"({on_disk[extra[0]].name} has no truth line); the render did not finish")
    return _decode_checks(run_dir, truth_file, frames, decoded, decoded_file, decode_info, payload_bits)


def _check_video_frames(video: Path, truth_file: Path, n_truth: int) -> None:
    """Refuse a rendered video whose frame count disagrees with the truth's lines."""
    from rollsim.video.read import count_video_frames

    held = count_video_frames(video)
    if held != n_truth:
        raise RollsimError(f"{video}: holds {held} frames but {truth_file.name} lists {n_truth}; the video and the "
                           "truth are not of one render")


def _decode_checks(run_dir: Path, truth_file: Path, frames: list, decoded: list[dict], decoded_file: Path,
                   decode_info: dict, payload_bits: int) -> list[str]:
    counted = decode_info.get("frames")
    if isinstance(counted, int) and counted != len(frames):
        raise RollsimError(f"{run_dir / 'decode.json'}: the decode read {counted} frames but {truth_file.name} lists "
                           f"{len(frames)}; decode again with --force")
    known = set(frames)
    for line, record in enumerate([] if _columns_fine(decoded, known, payload_bits) else decoded, start=1):
        if record["frame"] not in known:
            raise RollsimError(f"{decoded_file}: line {line}: frame {record['frame']} is not in {truth_file.name} "
                               "(decoded from other frames?)")
        if not record["sequence"] < _INT64_END:  # the schema has it >= 0; numpy holds it in 64 bits
            raise RollsimError(f"{decoded_file}: line {line}: sequence = {short_repr(record['sequence'])}: "
                               "expected less than 2**63")
        bits = record["bits"]
        if len(bits) != payload_bits or not _BITS.match(bits):
            raise RollsimError(f"{decoded_file}: line {line}: bits = {clip(repr(bits), 40)}: expected {payload_bits} "
                               "characters 0 or 1 (the payload bits)")
    unreadable = decode_info.get("unreadable", [])
    if unreadable:
        return [f"{len(unreadable)} of {len(frames)} frames could not be read by the decoder (see decode.json); "
                "their PHY-SDUs count as missed, so these figures are not those of the whole render"]
    return []


def _columns_fine(decoded: list[dict], known: set, payload_bits: int) -> bool:
    """Whether every decoded record passes :func:`check_consistency`'s checks, taken column by column in C.

    Frames and bits are checked once per distinct value; when this says no,
    the records are gone through one by one to name the first bad one.
    """
    if not decoded:
        return True
    frames = set(map(operator.itemgetter("frame"), decoded))
    bits = set(map(operator.itemgetter("bits"), decoded))
    return (frames <= known and max(map(operator.itemgetter("sequence"), decoded)) < _INT64_END
            and all(len(b) == payload_bits and _BITS.match(b) for b in bits))


def foreign_warnings(decoded: list[dict], run: str | None, decoded_file: Path) -> list[str]:
    """A warning if some records carry another render's ``run`` (scored only when allowed)."""
    foreign = sum(1 for record in decoded if record.get("run", run) != run)
    if not foreign:
        return []
    other = next(record["run"] for record in decoded if record.get("run", run) != run)
    return [f"{foreign} of {len(decoded)} records of {decoded_file} are of another render (run {short_repr(other)}, "
            f"this directory's is {run!r}); scored as asked, so these figures may not be this render's"]


# Fields matching needs, with their JSON types ("number": finite int or float).
TRUTH_FIELDS = {"frame": "int", "start_s": "number", "sdus": "list"}
TRUTH_SDU_FIELDS = {"tx": "int", "sequence": "int", "bits": "str", "first_row_f": "number", "last_row_f": "number",
                    "fully_visible": "bool"}


def _has_type(value, kind: str) -> bool:
    if kind == "number":
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if kind == "int":
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, {"str": str, "bool": bool, "list": list}[kind])


def check_records(records: list, path: Path, fields: dict, what: str = "record") -> None:
    """One-line error naming the file, the record and the field, for records
    that lack a field evaluation needs or hold a value of the wrong type."""
    for number, record in enumerate(records, start=1):
        if not isinstance(record, dict):
            raise RollsimError(f"{path}: {what} {number}: not a JSON object")
        for name, kind in fields.items():
            if name not in record:
                raise RollsimError(f"{path}: {what} {number}: missing {name}")
            if not _has_type(record[name], kind):
                raise RollsimError(f"{path}: {what} {number}: {name} = {short_repr(record[name])}: expected {kind}")


def _decode_info(path: Path) -> dict:
    """``decode.json`` (empty when absent: a decoder of the user's own wrote only ``decoded.jsonl``)."""
    if not path.exists():
        return {}
    try:
        info = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise RollsimError(f"{path}: cannot read as JSON ({exc})") from None
    if not isinstance(info, dict):
        raise RollsimError(f"{path}: expected a JSON object")
    if not isinstance(info.get("unreadable", []), list):
        raise RollsimError(f"{path}: unreadable: expected a list of frames")
    return info


def outcomes_csv(outcomes: list[dict]) -> str:
    """The outcome table as CSV text (columns :data:`OUTCOME_COLUMNS`)."""
    import io

    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=OUTCOME_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in outcomes:
        writer.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in row.items()})
    return buffer.getvalue()


def format_summary(summary: dict) -> str:
    """A short table of an evaluation summary."""
    from rollsim.plumbing.text_tables import format_percent

    unreadable = summary.get("frames_unreadable")
    lines = [
        f"frames {summary['frames']}" + (f" ({unreadable} unreadable)" if unreadable else "")
        + f", emissions {summary['emissions']}, fully visible {summary['fully_visible']}"
    ]
    lines += [f"  {name:<17} {count}" for name, count in summary["counts"].items()]
    lines += [
        f"  {'false decodes':<17} {summary['false_decodes']}"
        + (f" ({summary['false_decodes_check_passed']} with the check passed)" if summary["false_decodes"] else ""),
        f"error rate (fully visible)      {format_percent(summary['error_rate'])}",
        f"missed rate (fully visible)     {format_percent(summary['missed_rate'])}",
        f"undetected-error rate (passed)  {format_percent(summary['undetected_error_rate'])}",
        "false decodes per 1000 frames   "
        + ("n/a" if summary["false_decodes_per_1000_frames"] is None else f"{summary['false_decodes_per_1000_frames']:.2f}"),
    ]
    message = summary.get("message")
    if message is not None:
        lines.append(_message_line(message))
    return "\n".join(lines)


def _message_line(message: dict) -> str:
    """What the receiver made of the message (:mod:`rollsim.stages.receiver`)."""
    if not message["decodable"]:
        return f"message                         not decodable from the {message['receptions']} PHY-SDUs read"
    exact = "bit-exact" if message["message_ok"] else "WRONG (an undetected error was used)"
    return (f"message                         decodable in frame {message['frame']} after {message['receptions']} "
            f"PHY-SDUs, {exact}; goodput {message['goodput_bps']:.4g} bit/s")

