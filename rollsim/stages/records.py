"""JSON-lines record files: read with line numbers, and decoded PHY-SDUs checked against their schema.

:func:`iter_jsonl` streams any JSON-lines file (``truth.jsonl``,
``decoded.jsonl``) line by line, with one-line errors naming the file and
line: a bad line is reported as soon as it is read, however long the file.

The versioned schema of decoded PHY-SDUs is what any decoder writes for
``rollsim evaluate``: ``decoded.jsonl`` holds one JSON object per PHY-SDU found; the schema
(``rollsim/schemas/decoded-phy-sdu.schema.json``, JSON Schema 2020-12,
version :data:`SCHEMA_VERSION`) names the fields evaluation needs and their
types. A record is a decoded PHY-SDU (:func:`record_error`) when it follows
the schema and every value in it is a plain JSON value: finite numbers (no
NaN or infinity, and no integer beyond a 64-bit float's range), strings,
booleans, null, lists and objects with string keys, nested at most
:data:`MAX_DEPTH` levels and :data:`MAX_VALUES` values in all.

:func:`is_decoded_record` gives the same answer quickly, from checks
derived from the schema; the jsonschema validator only words the error of a
record it refuses. :func:`read_decoded` reads a file that way, stopping at
the first bad line with one line that names the file, the line and the
field.

Every record rollsim's ``decode`` writes carries ``run``
(:func:`run_identifier`): which render its frames came from.
"""

from __future__ import annotations

import hashlib
import json
import math
import operator
import re
import stat
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Callable, Iterator, NamedTuple, Optional

from rollsim.plumbing.budget import check_file_size
from rollsim.errors import RollsimError, clip, short_repr

SCHEMA_VERSION = 1
SCHEMA_FILE = "decoded-phy-sdu.schema.json"
# The limits of a scene file (rollsim.scene.loader), for the same reason: a
# record of any size costs bounded time to check, even one that holds itself.
MAX_DEPTH = 64
MAX_VALUES = 100_000
# The file rollsim renders every frame from: its digest names the render.
SCENE_NAME = "scene.resolved.yaml"
_FRAME_COUNT = re.compile(rb"^frames:[^\n]*\n", re.MULTILINE)

# Clearer words than the validator's for the checks a decoder fails most.
_EXPLAIN = {"pattern": "expected a string of 0s and 1s", "required": "missing", "minimum": "expected >= 0"}
# Integers inside +-2**53 are exact floats; beyond, float() says whether one is finite.
_EXACT = 2**53


@lru_cache(maxsize=1)
def schema() -> dict:
    """The JSON Schema of a decoded PHY-SDU (a dict)."""
    return json.loads(resources.files("rollsim").joinpath("schemas", SCHEMA_FILE).read_text(encoding="utf-8"))


@lru_cache(maxsize=1)
def _validator():
    from jsonschema import Draft202012Validator

    return Draft202012Validator(schema())


def record_error(record) -> str | None:
    """Why ``record`` is not a decoded PHY-SDU (``field = value: reason``), or None if it is one.

    The values' verdict first (:func:`value_error`: NaN, an infinity, or
    anything JSON cannot hold, which the validator may not even compare),
    then the schema's (worded from jsonschema's best match).
    """
    from jsonschema.exceptions import best_match

    problem = value_error(record)
    if problem is not None:
        return problem
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


# ------------------------------------------------------------------ values


def _finite_int(value: int) -> bool:
    if -_EXACT < value < _EXACT:
        return True
    try:
        float(value)
    except OverflowError:
        return False
    return True


def _scalar_problem(value) -> str | None:
    """What is wrong with a value that holds no other (None if it is a JSON scalar)."""
    if value is None or isinstance(value, (str, bool)):
        return None
    if isinstance(value, int):
        return None if _finite_int(value) else "not a finite number (beyond a 64-bit float)"
    if isinstance(value, float):
        return None if math.isfinite(value) else "not a finite number"
    return f"not a JSON value ({type(value).__name__})"


def value_error(record) -> str | None:
    """The first value of ``record`` that JSON cannot hold (``path = value: reason``), or None.

    Walks every value, nested ones too, without recursion (a record from a
    plug-in may hold itself): NaN or an infinity, an integer beyond a
    64-bit float's range, an object key that is not a string, anything but
    JSON's types (a numpy scalar, a set), deeper than :data:`MAX_DEPTH`
    levels or more than :data:`MAX_VALUES` values.
    """
    stack: list[tuple[object, tuple, int]] = [(record, (), 0)]
    seen = 0
    while stack:
        value, path, depth = stack.pop()
        seen += 1
        if seen > MAX_VALUES:
            return f"the record: more than {MAX_VALUES} values"
        if isinstance(value, (dict, list, tuple)):
            if seen + len(value) > MAX_VALUES:
                return f"the record: more than {MAX_VALUES} values"
            if depth > MAX_DEPTH:
                return f"{_where(path)}: nested deeper than {MAX_DEPTH} levels"
            if isinstance(value, dict):
                for key in value:
                    if not isinstance(key, str):
                        return f"{_where((*path, short_repr(key)))}: an object key must be a string"
                items = list(value.items())
            else:
                items = list(enumerate(value))
            stack.extend((item, (*path, key), depth + 1) for key, item in reversed(items))
            continue
        problem = _scalar_problem(value)
        if problem is not None:
            return f"{_where(path)} = {short_repr(value)}: {problem}"
    return None


def _where(path: tuple) -> str:
    """A value's place in a record, as the schema's errors name it (``diag.3.x``), cut short."""
    return clip(".".join(str(part) for part in path))


# ---------------------------------------------------------- the fast check

# The Python types of JSON values each schema type takes without further
# thought. Anything else (an integral float for "integer", an int subclass, a
# numpy scalar) is left to the full check, which words the error anyway.
_PLAIN_TYPES: dict[str, tuple[type, ...]] = {"integer": (int,), "number": (int, float), "string": (str,),
                                             "boolean": (bool,)}
_ANNOTATIONS = {"description", "title", "$comment"}


@dataclass(frozen=True)
class _Rules:
    """The schema as the fast check reads it: names required and known, names barred per type, limits."""

    required: frozenset
    properties: frozenset
    barred: dict
    minimums: dict
    patterns: dict


def _rules(document: dict) -> _Rules:
    """:class:`_Rules` of a schema.

    Raises
    ------
    RuntimeError
        The schema uses a keyword the fast check does not know: it fails at
        once rather than check otherwise than the schema says.
    """
    known_top = {"$schema", "$id", "type", "required", "properties"} | _ANNOTATIONS
    known_property = {"type", "minimum", "pattern"} | _ANNOTATIONS
    properties = document["properties"]
    unknown = set(document) - known_top
    unknown |= {f"{name}.{key}" for name, rules in properties.items() for key in set(rules) - known_property}
    unknown |= {f"{name}.type" for name, rules in properties.items() if rules.get("type") not in _PLAIN_TYPES}
    if unknown or document.get("type") != "object" or not set(document["required"]) <= set(properties):
        raise RuntimeError(f"{SCHEMA_FILE}: the fast check does not know {sorted(unknown)}")
    barred = {kind: frozenset(name for name, rules in properties.items() if kind not in _PLAIN_TYPES[rules["type"]])
              for kind in (int, float, str, bool, type(None))}
    return _Rules(frozenset(document["required"]), frozenset(properties), barred,
                  {name: rules["minimum"] for name, rules in properties.items() if "minimum" in rules},
                  # re.search, as jsonschema matches patterns ("$" matches before a final newline too)
                  {name: re.compile(rules["pattern"]).search for name, rules in properties.items() if "pattern" in rules})


def _picker(positions: list[int]) -> Optional[Callable[[tuple], tuple]]:
    """The values at ``positions`` of a tuple, as a tuple (None for no position)."""
    if not positions:
        return None
    if len(positions) == 1:
        (position,) = positions
        return lambda values: (values[position],)
    return operator.itemgetter(*positions)


class _Shape(NamedTuple):
    """What remains to check of a record of one shape (its keys in order, its values' types)."""

    floats: Optional[Callable[[tuple], tuple]]
    ints: Optional[Callable[[tuple], tuple]]
    minimums: tuple
    patterns: tuple
    nested: bool


def _shape(rules: _Rules, keys: tuple, kinds: tuple) -> Optional[_Shape]:
    """The checks a record of this shape still needs, or None if its shape alone leaves a doubt.

    Plain shapes: string keys, the required ones among them, fewer than
    :data:`MAX_VALUES`; each value a JSON scalar of a type its property
    takes (any, for a field the schema does not name); lists and objects
    only outside the schema's properties.
    """
    if not rules.required <= set(keys) or len(keys) >= MAX_VALUES:
        return None
    floats, ints, nested = [], [], False
    minimums: dict = {}
    patterns = []
    for position, (name, kind) in enumerate(zip(keys, kinds)):
        if type(name) is not str:
            return None
        barred = rules.barred.get(kind)
        if barred is None:  # a container, or no plain JSON type
            if (kind is list or kind is dict) and name not in rules.properties:
                nested = True
                continue
            return None
        if name in barred:
            return None
        if kind is float:
            floats.append(position)
        elif kind is int:
            ints.append(position)
        if name in rules.minimums:
            minimums.setdefault(rules.minimums[name], []).append(position)
        if name in rules.patterns:
            patterns.append((position, rules.patterns[name]))
    return _Shape(_picker(floats), _picker(ints), tuple((_picker(p), m) for m, p in minimums.items()),
                  tuple(patterns), nested)


# Shapes remembered at once: a decoder writes a handful; a hostile file of
# ever new shapes only costs the planning of each.
_MAX_SHAPES = 256
_UNSEEN = object()


@lru_cache(maxsize=1)
def _fast_check() -> Callable[[object], bool]:
    """:func:`is_decoded_record`, built once from the schema.

    A record's shape (keys in order, value types) is planned once
    (:func:`_shape`); each record of that shape then needs only what its
    types leave open, a few calls in C: floats finite (their sum is finite),
    integers within ``2**53``, minimums, patterns, and nested values walked
    (:func:`value_error`). Any doubt goes to :func:`record_error`, so the
    two never disagree.
    """
    rules = _rules(schema())
    shapes: dict = {}

    def full(record) -> bool:
        return record_error(record) is None

    def check(record) -> bool:
        if type(record) is not dict:
            return full(record)
        values = tuple(record.values())
        key = (tuple(record), tuple(map(type, values)))
        plan = shapes.get(key, _UNSEEN)
        if plan is _UNSEEN:
            if len(shapes) >= _MAX_SHAPES:
                shapes.clear()
            plan = shapes[key] = _shape(rules, *key)
        if plan is None:
            return full(record)
        floats, ints, minimums, patterns, nested = plan
        if floats is not None:
            total = sum(floats(values))
            if total - total != 0.0:  # a NaN or an infinity (or an overflow, which the full check clears)
                return full(record)
        if ints is not None:
            picked = ints(values)
            if not (-_EXACT < min(picked) and max(picked) < _EXACT):
                return full(record)
        for pick, minimum in minimums:
            if min(pick(values)) < minimum:
                return full(record)
        for position, search in patterns:
            if search(values[position]) is None:
                return full(record)
        return not nested or value_error(record) is None

    return check


def is_decoded_record(record) -> bool:
    """Whether ``record`` is a decoded PHY-SDU: ``record_error(record) is None``, many times faster.

    The two are the same check (``tests/test_records_fast.py`` compares
    them on generated records, valid and not); use :func:`record_error` to
    say what is wrong.
    """
    return _fast_check()(record)


def decoded_record_error(record) -> str | None:
    """:func:`record_error`, asked only of a record the fast check does not accept."""
    return None if is_decoded_record(record) else record_error(record)


def as_decoded_record(found, frame_index: int, run: Optional[str] = None) -> dict:
    """A decoder's find as a ``decoded.jsonl`` record, numbered with its frame's index.

    ``found`` is a :class:`decoder.DecodedPhySdu` (anything with
    ``to_record()``) or a mapping. A decoder sees one image and cannot know
    its index nor its render, so any ``frame`` or ``run`` it gives is
    replaced (``run`` by ``run``, or dropped when None).

    Raises
    ------
    RollsimError
        If the record does not follow the schema (naming the field).
    """
    record = found.to_record() if hasattr(found, "to_record") else found
    if not isinstance(record, dict):
        raise RollsimError(f"frame {frame_index}: a decoded record must be a dict, got {short_repr(record)}")
    record = {"frame": int(frame_index), **{k: v for k, v in record.items() if k not in ("frame", "run")}}
    if run is not None:
        record["run"] = run
    problem = decoded_record_error(record)
    if problem is not None:
        raise RollsimError(f"frame {frame_index}: decoded record: {problem}")
    return record


# -------------------------------------------------------------------- files


# The decoder's own scanner: json.loads without its two regular-expression
# passes for surrounding whitespace, a third of the time of a short record.
_SCAN: Callable[[str, int], tuple] = json.JSONDecoder().scan_once  # type: ignore[attr-defined]
_JSON_SPACE = " \t\n\r"


def _parse_line(path: Path, number: int, raw: bytes):
    """One line's JSON value, as ``json.loads`` reads it; a line that is not JSON is named."""
    try:
        line = raw.decode("utf-8")
        value, end = _SCAN(line, 0)
        if end == len(line) or not line[end:].strip(_JSON_SPACE):
            return value
    except Exception:  # anything unusual: json.loads below decides, and words the error
        pass
    try:
        return json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise RollsimError(f"{path}: line {number}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except json.JSONDecodeError as exc:
        raise RollsimError(f"{path}: line {number}: not valid JSON ({exc.msg})") from None
    except (ValueError, RecursionError) as exc:  # an integer of 5000 digits, [[[[... 100000 deep
        raise RollsimError(f"{path}: line {number}: not valid JSON ({clip(str(exc), 80)})") from None


def iter_jsonl(path: Path) -> Iterator[tuple[int, object]]:
    """``(line number, record)`` of each non-blank line of a JSON-lines file, read as it goes.

    The file is streamed, so the first bad line is reported when it is
    reached, whatever follows it. Lines end at ``\\n``.

    Raises
    ------
    RollsimError
        The file missing, unreadable, too large for memory (its records are
        usually kept: :func:`rollsim.plumbing.budget.check_file_size`), or a line that
        is not UTF-8 JSON (naming the file and line).
    """
    path = Path(path)
    check_file_size(path, 10)  # parsed JSON takes about ten times its text's bytes
    try:
        handle = open(path, "rb")
    except FileNotFoundError:
        raise RollsimError(f"{path}: not found") from None
    except OSError as exc:
        raise RollsimError(f"{path}: cannot read ({exc})") from None
    with handle:
        number = 0
        lines = iter(handle)
        while True:
            try:
                raw = next(lines, None)
            except OSError as exc:
                raise RollsimError(f"{path}: line {number + 1}: cannot read ({exc})") from None
            if raw is None:
                return
            number += 1
            # Blank as str.strip() sees it: ASCII whitespace or, once decoded, Unicode's.
            if raw.isspace() or (not raw.isascii() and raw.decode("utf-8", "replace").isspace()):
                continue
            yield number, _parse_line(path, number, raw)


def read_jsonl(path: Path) -> list:
    """Records of a JSON-lines file, with one-line errors naming file and line."""
    return [record for _, record in iter_jsonl(path)]


def read_decoded(path: Path, run: Optional[str] = None) -> list[dict]:
    """The records of a ``decoded.jsonl`` file, each checked against the schema as it is read.

    Parameters
    ----------
    path : Path
    run : str, optional
        The render the records must come from (:func:`run_identifier`): a
        record whose ``run`` differs is refused. Records without ``run``
        (another decoder's) are accepted, and so is every record when None.

    Raises
    ------
    RollsimError
        ``FILE: line N: FIELD = VALUE: reason`` for the first bad line (or
        the file's own problem: missing, unreadable, not JSON).
    """
    check = _fast_check()
    records: list[dict] = []
    for number, record in iter_jsonl(path):
        if not check(record):
            raise RollsimError(f"{path}: line {number}: {record_error(record)}")
        assert isinstance(record, dict)  # for mypy: the check accepts objects only
        if run is not None and record.get("run", run) != run:
            raise RollsimError(f"{path}: line {number}: run = {short_repr(record['run'])}: records of another render "
                               f"(this directory's is {run!r}); --allow-other-run scores them anyway")
        records.append(record)
    return records


def run_identifier(directory: Path) -> Optional[str]:
    """Which render a directory holds: 16 hex digits of the SHA-256 of its ``scene.resolved.yaml``, less the frame count.

    The resolved scene holds every value the frames depend on, the seed
    included, and the same scene and seed render the same bytes for a frame
    index whatever the number of frames; so equal identifiers mean the same
    frames (which of them, ``truth.jsonl`` says). 16 digits keep
    ``decoded.jsonl`` lines 12% longer (23 bytes on 190), the full 64 would
    keep them 37% longer.

    Returns
    -------
    str or None
        None for a folder without a resolved scene (frames from elsewhere).
    """
    from rollsim.scene.loader import MAX_SCENE_BYTES

    scene_file = Path(directory) / SCENE_NAME
    try:
        info = scene_file.stat()
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise RollsimError(f"{scene_file}: cannot read ({exc.strerror})") from None
    # A pipe or a device there would never end: only what a render writes is read.
    if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_SCENE_BYTES:
        raise RollsimError(f"{scene_file}: not a resolved scene (a regular file of at most "
                           f"{MAX_SCENE_BYTES // 1024} KiB)")
    try:
        data = scene_file.read_bytes()
    except OSError as exc:
        raise RollsimError(f"{scene_file}: cannot read ({exc.strerror})") from None
    return _digest(data)


def scene_run_identifier(scene) -> str:
    """:func:`run_identifier` of the directory a render of ``scene`` writes, from the scene in memory.

    For frames rendered in memory (the Python API's ``render``): the same
    text the render writes into ``scene.resolved.yaml``, so the same digest.
    """
    from rollsim.scene import scene_to_yaml

    return _digest(scene_to_yaml(scene).encode("utf-8"))


def _digest(data: bytes) -> str:
    # The top-level "frames: N" line, as scene_to_yaml writes it: not part of what a frame is.
    return hashlib.sha256(_FRAME_COUNT.sub(b"", data, count=1)).hexdigest()[:16]
