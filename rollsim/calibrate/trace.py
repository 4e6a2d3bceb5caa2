"""Outcome traces: per emission, success or failure, with its time.

A trace comes from an evaluated render directory (``outcomes.csv``, with
``truth.jsonl`` for the frame start times and ``scene.resolved.yaml`` for
the scene), or from any CSV with a ``success`` column (``true``/``false`` or
``1``/``0``; an ``outcome`` column with ``ok`` meaning success also works)
and, optionally, ``start_s``.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from typing import TYPE_CHECKING
from pathlib import Path

import numpy as np

from rollsim.plumbing.budget import check_file_size
from rollsim.errors import RollsimError
from rollsim.plumbing.validation import missing_path

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

_TRUE = {"1", "true", "True", "TRUE", "yes", "ok"}
_FALSE = {"0", "false", "False", "FALSE", "no"}


@dataclass(frozen=True)
class Trace:
    """A success/failure trace in emission order.

    Attributes
    ----------
    success : ndarray of bool
    start_s : ndarray of float or None
        Emission start times, seconds.
    frame_starts_s : ndarray of float or None
        Start of every frame (rendered data), seconds.
    scene : Scene or None
        The scene that produced the trace, when known.
    source : str
    """

    success: np.ndarray
    start_s: np.ndarray | None = None
    frame_starts_s: np.ndarray | None = None
    scene: Scene | None = None
    source: str = "<trace>"

    @classmethod
    def from_outcomes(cls, outcomes: list[dict], truth, scene: Scene | None = None,
                      source: str = "<trace>") -> "Trace":
        """The trace of an evaluation: its outcomes in tx order and its frames' starts.

        Parameters
        ----------
        outcomes : list of dict
            :attr:`rollsim.stages.evaluate.Evaluation.outcomes` (``success``, ``start_s``).
        truth : iterable
            The frames' truth records, dicts or objects with ``start_s``.
        """
        def start_of(frame):
            return frame["start_s"] if isinstance(frame, dict) else frame.start_s

        return cls(np.array([o["success"] for o in outcomes], dtype=bool),
                   np.array([o["start_s"] for o in outcomes], dtype=np.float64),
                   np.array([start_of(t) for t in truth], dtype=np.float64), scene, source)


def _parse_success(row: dict, path: Path, line: int) -> bool:
    if "success" in row and row["success"] not in (None, ""):
        value = row["success"].strip()
        if value in _TRUE:
            return True
        if value in _FALSE:
            return False
        raise RollsimError(f"{path}: line {line}: success = {value!r}: expected true/false or 1/0")
    if "outcome" in row and row["outcome"]:
        return row["outcome"].strip() == "ok"
    raise RollsimError(f"{path}: line {line}: no success or outcome value")


def read_trace_csv(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """``success`` and (if present) ``start_s`` columns of a trace CSV."""
    path = Path(path)
    # A row becomes a dict of strings: about 20 bytes of memory per byte.
    check_file_size(path, 20)
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            reader = csv.DictReader(handle)
            fields = reader.fieldnames or []
            if "success" not in fields and "outcome" not in fields:
                raise RollsimError(f"{path}: needs a 'success' or 'outcome' column (has: {', '.join(fields) or 'none'})")
            rows = list(reader)
    except (FileNotFoundError, NotADirectoryError):
        raise RollsimError(missing_path(path) or f"{path}: does not exist") from None
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise RollsimError(f"{path}: cannot read as CSV ({exc})") from None
    if not rows:
        raise RollsimError(f"{path}: the trace is empty")
    success = np.array([_parse_success(row, path, i + 2) for i, row in enumerate(rows)], dtype=bool)
    start = None
    if "start_s" in rows[0]:
        try:
            start = np.array([float(row["start_s"]) for row in rows])
        except (TypeError, ValueError):
            raise RollsimError(f"{path}: start_s must be numbers") from None
        if not np.all(np.isfinite(start)) or np.any(np.diff(start) < 0):
            raise RollsimError(f"{path}: start_s must be finite and in emission order")
    return success, start


def load_trace(path, source: str | None = None) -> Trace:
    """A trace from an evaluated render directory or a trace CSV.

    ``source`` names the trace in results (default: ``path``).
    """
    from rollsim.stages.records import read_jsonl
    from rollsim.scene import load_scene

    path = Path(path)
    if path.is_dir():
        outcomes = path / "outcomes.csv"
        if not outcomes.exists():
            raise RollsimError(f"{path}: no outcomes.csv; run `rollsim evaluate {path}` first")
        success, start = read_trace_csv(outcomes)
        truth = path / "truth.jsonl"
        frames = np.array([t["start_s"] for t in read_jsonl(truth)]) if truth.exists() else None
        scene_file = path / "scene.resolved.yaml"
        scene = load_scene(scene_file) if scene_file.exists() else None
        return Trace(success, start, frames, scene, source or str(path))
    success, start = read_trace_csv(path)
    return Trace(success, start, None, None, source or str(path))
