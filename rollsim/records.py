"""JSON-lines record files: read with line numbers, and decoded PHY-SDUs checked against their schema.

:func:`read_jsonl` reads any JSON-lines file (``truth.jsonl``,
``decoded.jsonl``) with one-line errors naming the file and line.

The versioned schema of decoded PHY-SDUs is what any decoder writes for
``rollsim evaluate``: ``decoded.jsonl`` holds one JSON object per PHY-SDU found; the schema
(``rollsim/schemas/decoded-phy-sdu.schema.json``, JSON Schema 2020-12,
version :data:`SCHEMA_VERSION`) names the fields evaluation needs and their
types. :func:`read_decoded` reads a file and checks it line by line with the
``jsonschema`` validator, stopping at the first bad line with one line that
names the file, the line and the field.
"""

from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Iterator

from rollsim.budget import check_file_size
from rollsim.errors import RollsimError, short_repr

SCHEMA_VERSION = 1
SCHEMA_FILE = "decoded-phy-sdu.schema.json"

# Clearer words than the validator's for the checks a decoder fails most.
_EXPLAIN = {"pattern": "expected a string of 0s and 1s", "required": "missing", "minimum": "expected >= 0"}


@lru_cache(maxsize=1)
def schema() -> dict:
    """The JSON Schema of a decoded PHY-SDU (a dict)."""
    return json.loads(resources.files("rollsim").joinpath("schemas", SCHEMA_FILE).read_text(encoding="utf-8"))


@lru_cache(maxsize=1)
def _validator():
    from jsonschema import Draft202012Validator

    return Draft202012Validator(schema())


def record_error(record) -> str | None:
    """Why ``record`` is not a decoded PHY-SDU (``field = value: reason``), or None if it is one."""
    from jsonschema.exceptions import best_match

    error = best_match(_validator().iter_errors(record))
    if error is None:
        return None
    if error.validator == "required":
        missing = [name for name in error.validator_value if name not in error.instance]
        return f"{missing[0]}: missing"
    if not error.absolute_path:
        return "not a JSON object" if error.validator == "type" else error.message
    field = ".".join(str(part) for part in error.absolute_path)
    reason = _EXPLAIN.get(str(error.validator), error.message)
    if error.validator == "type":
        reason = f"expected {error.validator_value}"
    return f"{field} = {short_repr(error.instance)}: {reason}"


def as_decoded_record(found, frame_index: int) -> dict:
    """A decoder's find as a ``decoded.jsonl`` record, numbered with its frame's index.

    ``found`` is a :class:`decoder.DecodedPhySdu` (anything with
    ``to_record()``) or a mapping. A decoder sees one image and cannot know
    its index, so any ``frame`` it gives is replaced.

    Raises
    ------
    RollsimError
        If the record does not follow the schema (naming the field).
    """
    record = found.to_record() if hasattr(found, "to_record") else found
    if not isinstance(record, dict):
        raise RollsimError(f"frame {frame_index}: a decoded record must be a dict, got {short_repr(record)}")
    record = {"frame": int(frame_index), **{k: v for k, v in record.items() if k != "frame"}}
    problem = record_error(record)
    if problem is not None:
        raise RollsimError(f"frame {frame_index}: decoded record: {problem}")
    return record


def iter_jsonl(path: Path) -> Iterator[tuple[int, object]]:
    """``(line number, record)`` of each non-blank line of a JSON-lines file.

    Raises
    ------
    RollsimError
        The file missing, unreadable, too large for memory, or a line that is
        not JSON (naming the file and line).
    """
    path = Path(path)
    check_file_size(path, 10)  # parsed JSON takes about ten times its text's bytes
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except FileNotFoundError:
        raise RollsimError(f"{path}: not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise RollsimError(f"{path}: cannot read ({exc})") from None
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            yield number, json.loads(line)
        except json.JSONDecodeError as exc:
            raise RollsimError(f"{path}: line {number}: not valid JSON ({exc.msg})") from None


def read_jsonl(path: Path) -> list:
    """Records of a JSON-lines file, with one-line errors naming file and line."""
    return [record for _, record in iter_jsonl(path)]


def read_decoded(path: Path) -> list[dict]:
    """The records of a ``decoded.jsonl`` file, each checked against the schema.

    Raises
    ------
    RollsimError
        ``FILE: line N: FIELD = VALUE: reason`` for the first bad line (or
        the file's own problem: missing, unreadable, not JSON).
    """
    records: list[dict] = []
    for number, record in iter_jsonl(path):
        problem = record_error(record)
        if problem is not None or not isinstance(record, dict):
            raise RollsimError(f"{path}: line {number}: {problem or 'not a JSON object'}")
        records.append(record)
    return records
