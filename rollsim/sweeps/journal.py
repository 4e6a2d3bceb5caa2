"""A sweep's output directory: it fills up cell by cell, so that it can resume.

``DIR/sweep.yaml``
    The resolved sweep, written first. ``--resume`` continues only a sweep
    whose ``sweep.yaml`` matches (same scene content, grid, stage, options
    and seed).
``DIR/cells.jsonl``
    The journal: one JSON line per finished cell, appended by the main
    process as results arrive (one ``write`` per line, flushed; synced to
    disk at least every second). A line cut short by a kill is ignored when
    the journal is read back, so a killed sweep loses only the cells in
    flight.
``DIR/results.parquet``, ``DIR/results.csv``, ``DIR/report.md``, ``DIR/plots/``
    Written when every cell is done, together (:mod:`rollsim.plumbing.outputs`).
``DIR/frames/cell-…/``
    With ``--keep-frames``: each cell's frames as a render directory.

Without ``--resume`` or ``--force`` an existing, non-empty ``DIR`` is refused;
``--force`` replaces only a previous rollsim result.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from pathlib import Path
from typing import Iterable

import yaml

from rollsim.errors import OutputError, RollsimError
from rollsim.plumbing.outputs import check_directory_target, create_directory, foreign_entries, os_failures, read_manifest, \
    write_file

SPEC_NAME = "sweep.yaml"
JOURNAL_NAME = "cells.jsonl"
# What the journal owns whatever its content (it grows as cells finish).
PATTERNS = (JOURNAL_NAME, "frames", "frames/*", "plots")
_SYNC_EVERY_S = 1.0


def scene_digest(base: dict) -> str:
    """SHA-256 of the base scene's data, so that a resumed sweep is the same sweep."""
    return hashlib.sha256(json.dumps(base, sort_keys=True, default=str).encode()).hexdigest()


class SweepDirectory:
    """An open sweep directory: what is committed, and the journal to append to.

    Use :meth:`open`.
    """

    def __init__(self, path: Path, shown: Path):
        self.path = path
        self.shown = shown
        self._journal: int | None = None
        self._last_sync = 0.0

    @staticmethod
    def check(target: Path, record: dict, *, resume: bool, force: bool, inputs: Iterable = ()) -> bool:
        """Refuse an unusable ``target`` before any work; True when the sweep there will be resumed.

        Raises
        ------
        RollsimError
            ``target`` holds another sweep (``--resume``), or is not empty
            (neither option), or is not rollsim's (``--force``).
        """
        target = Path(target)
        if resume and (target / SPEC_NAME).is_file():
            _check_same_sweep(target, record)
            real = Path(os.path.realpath(target))
            foreign = foreign_entries(real)
            if read_manifest(real) is None or foreign:
                raise OutputError(f"{target}: holds files a sweep did not write ({', '.join(foreign[:3])}); "
                                  "--resume continues only rollsim's own sweep directory")
            return True
        check_directory_target(target, force, inputs)
        return False

    @classmethod
    def open(cls, target: Path, record: dict, *, resume: bool, force: bool, inputs: Iterable = ()) -> "SweepDirectory":
        """Start a sweep in ``target``, or (``resume``) continue the one there (see :meth:`check`)."""
        target = Path(target)
        if cls.check(target, record, resume=resume, force=force, inputs=inputs):
            return cls(Path(os.path.realpath(target)), target)
        real = create_directory(target, force, inputs, PATTERNS)
        write_file(real / SPEC_NAME, yaml.safe_dump(record, sort_keys=False), force=True)
        return cls(real, target)

    def committed(self) -> dict[str, dict]:
        """``{cell_id: row}`` of the cells in the journal (the last line of a cell wins)."""
        rows: dict[str, dict] = {}
        path = self.path / JOURNAL_NAME
        if not path.exists():
            return rows
        with open(path, "rb") as handle:
            for line in handle:
                if not line.endswith(b"\n"):
                    break  # cut short by a kill: the cell was not committed
                try:
                    row = json.loads(line)
                except ValueError:
                    continue
                if isinstance(row, dict) and isinstance(row.get("cell_id"), str):
                    rows[row["cell_id"]] = row
        return rows

    def append(self, rows: list[dict]) -> None:
        """Commit finished cells: one line each, written whole."""
        with os_failures(target=self.shown):
            journal = self._journal
            if journal is None:
                journal = self._journal = os.open(self.path / JOURNAL_NAME, os.O_WRONLY | os.O_APPEND | os.O_CREAT,
                                                  0o666)
                _drop_torn_line(self.path / JOURNAL_NAME, journal)
            for row in rows:
                os.write(journal, (json.dumps(row, separators=(",", ":"), allow_nan=False) + "\n").encode())
            now = time.monotonic()
            if now - self._last_sync >= _SYNC_EVERY_S:
                os.fsync(journal)
                self._last_sync = now

    def close(self) -> None:
        if self._journal is not None:
            try:
                os.fsync(self._journal)
            finally:
                os.close(self._journal)
                self._journal = None


def _drop_torn_line(path: Path, fd: int) -> None:
    """Cut a last line a kill left unfinished, so that the next line starts clean."""
    size = os.fstat(fd).st_size
    if size == 0:
        return
    with open(path, "rb") as handle:
        handle.seek(max(0, size - 65536))
        tail = handle.read()
    if not tail.endswith(b"\n"):
        cut = tail.rfind(b"\n")
        os.ftruncate(fd, size - len(tail) + cut + 1 if cut >= 0 else (0 if size <= 65536 else size))


def _check_same_sweep(target: Path, record: dict) -> None:
    from rollsim.scene import read_yaml

    try:
        previous = read_yaml(target / SPEC_NAME)
    except RollsimError as exc:
        raise RollsimError(f"{target}: cannot resume: {exc}") from None
    keys = [key for key in record if key != "rollsim"]
    changed = [key for key in keys if previous.get(key) != record[key]]
    if changed:
        raise RollsimError(f"{target}: holds another sweep ({', '.join(changed)} differ); --resume continues the same "
                           "sweep only: give another --out, or --force to start afresh")


def describe_progress(done: int, total: int, where: Path) -> str:
    """What an interrupted sweep leaves, for the message of its exit."""
    return f"{done} of {total} cells are committed in {where}; the same command with --resume continues"
