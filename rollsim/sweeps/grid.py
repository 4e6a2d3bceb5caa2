"""Sweep grids: the values of each swept key, and the cells they make.

``VALUES`` is one of

* a comma list, ``5,10,15`` or ``rp,rs`` (each item read as a YAML scalar);
* a range ``start:stop:step``, which includes ``stop`` when it falls on the
  grid (computed in exact decimal arithmetic, so ``0.1:0.5:0.1`` has five
  values);
* a geometric range ``geom:start:stop:count``, ``count`` values from
  ``start`` to ``stop`` inclusive (values within 1e-9 of an integer become
  that integer, so ``geom:10:10000:4`` is 10, 100, 1000, 10000).

Several ``--grid`` axes make their product, first axis outermost; the
``--zip`` keys vary together as one more axis (innermost). Each cell is
identified by its values alone: its id and seed do not depend on the grid it
is part of or on the order in which cells run.
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import json
import math
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from typing import Any, Sequence

import numpy as np

from rollsim.errors import RollsimError, clip

# A sweep of more cells than this is not a mistake to run by accident.
MAX_CELLS = 1_000_000


@dataclass(frozen=True)
class Axis:
    """One swept dimension: a key and its values, or several keys zipped."""

    keys: tuple[str, ...]
    values: tuple[tuple[Any, ...], ...]  # one tuple per point, a value per key

    def __len__(self) -> int:
        return len(self.values)


@dataclass(frozen=True)
class Cell:
    """One point of a sweep.

    Attributes
    ----------
    index : int
        Position in the grid (first axis outermost).
    values : dict
        ``{key: value}`` of every swept key.
    """

    index: int
    values: dict

    @functools.cached_property
    def key_text(self) -> str:
        """Canonical JSON of the values: the cell's identity."""
        return json.dumps(self.values, sort_keys=True, separators=(",", ":"))

    @functools.cached_property
    def id(self) -> str:
        """A short stable id from the values (file names, resume)."""
        return "cell-" + hashlib.sha256(self.key_text.encode()).hexdigest()[:12]

    def seed(self, sweep_seed: int) -> int:
        """The cell's seed: from the sweep seed and the cell's values only."""
        return _cell_seed(self.key_text, sweep_seed)

    def describe(self) -> str:
        """``key=value, …`` for error lines."""
        return clip(", ".join(f"{key}={value}" for key, value in self.values.items()), 120)


@functools.lru_cache(maxsize=None)
def _cell_seed(key_text: str, sweep_seed: int) -> int:
    key = int.from_bytes(hashlib.sha256(key_text.encode()).digest()[:8], "big")
    state = np.random.SeedSequence(sweep_seed, spawn_key=(key,)).generate_state(2, np.uint32)
    return (int(state[0]) << 31) ^ int(state[1])  # < 2**63, a valid scene seed


def _decimal(text: str, what: str) -> Decimal:
    try:
        value = Decimal(text.strip())
    except InvalidOperation:
        raise RollsimError(f"{what}: {clip(repr(text), 40)} is not a number") from None
    if not value.is_finite():
        raise RollsimError(f"{what}: {clip(repr(text), 40)} is not a finite number")
    return value


def _number(value: Decimal):
    """An int where the decimal is integral, else a float."""
    return int(value) if value == value.to_integral_value() else float(value)


def _range_values(parts: list[str], what: str) -> list:
    start, stop, step = (_decimal(p, what) for p in parts)
    if step == 0:
        raise RollsimError(f"{what}: the step of start:stop:step must not be 0")
    count = int((stop - start) / step) + 1 if (stop - start) / step >= 0 else 0
    if count < 1:
        raise RollsimError(f"{what}: {start}:{stop}:{step} holds no value (the step goes away from stop)")
    if count > MAX_CELLS:
        raise RollsimError(f"{what}: {start}:{stop}:{step} holds {count} values, more than {MAX_CELLS}")
    return [_number(start + k * step) for k in range(count)]


def _geom_values(parts: list[str], what: str) -> list:
    start, stop = (float(_decimal(p, what)) for p in parts[:2])
    count = _decimal(parts[2], what)
    if count != count.to_integral_value() or not 1 <= count <= MAX_CELLS:
        raise RollsimError(f"{what}: the count of geom:start:stop:count must be an integer in [1, {MAX_CELLS}]")
    if start <= 0 or stop <= 0:
        raise RollsimError(f"{what}: geom:start:stop:count needs start and stop > 0")
    values = np.geomspace(start, stop, int(count)).tolist()
    return [round(v) if abs(v - round(v)) <= 1e-9 * max(1.0, abs(v)) else v for v in values]


def parse_values(text, what: str = "VALUES") -> list:
    """The values of ``VALUES`` text (see the module docstring), or of a list as given.

    Raises
    ------
    RollsimError
        Malformed text, naming ``what``.
    """
    if isinstance(text, (list, tuple)):
        values = list(text)
    elif not isinstance(text, str):
        values = [text]
    else:
        from rollsim.scene.loader import parse_yaml_scalar

        stripped = text.strip()
        if not stripped:
            raise RollsimError(f"{what}: no values")
        parts = stripped.split(":")
        if parts[0] == "geom":
            if len(parts) != 4:
                raise RollsimError(f"{what}: {clip(repr(text), 60)}: expected geom:start:stop:count")
            values = _geom_values(parts[1:], what)
        elif len(parts) == 3 and "," not in stripped:
            values = _range_values(parts, what)
        elif len(parts) > 1 and "," not in stripped:
            raise RollsimError(f"{what}: {clip(repr(text), 60)}: expected a comma list, start:stop:step or "
                               "geom:start:stop:count")
        else:
            items = [item.strip() for item in stripped.split(",")]
            if any(not item for item in items):
                raise RollsimError(f"{what}: {clip(repr(text), 60)}: an empty item in the comma list")
            values = [parse_yaml_scalar(item, what) for item in items]
    if not values:
        raise RollsimError(f"{what}: no values")
    for value in values:
        if isinstance(value, float) and not math.isfinite(value):
            raise RollsimError(f"{what}: {value} is not a finite number")
    return values


def build_cells(axes: Sequence[Axis]) -> list[Cell]:
    """Every cell of the product of ``axes`` (first axis outermost).

    Raises
    ------
    RollsimError
        No axis, an axis without values, a key swept twice, or more than
        :data:`MAX_CELLS` cells.
    """
    if not axes:
        raise RollsimError("the grid is empty: give at least one --grid KEY=VALUES (or --zip)")
    keys = [key for axis in axes for key in axis.keys]
    twice = sorted({key for key in keys if keys.count(key) > 1})
    if twice:
        raise RollsimError(f"{twice[0]}: swept twice; give each key in one --grid or --zip")
    total = math.prod(len(axis) for axis in axes)
    if total > MAX_CELLS:
        raise RollsimError(f"the grid has {total} cells, more than {MAX_CELLS}")
    cells = []
    for index, point in enumerate(itertools.product(*(axis.values for axis in axes))):
        values: dict = {}
        for axis, item in zip(axes, point):
            values.update(zip(axis.keys, item))
        cells.append(Cell(index, values))
    return cells


def grid_axis(key: str, values) -> Axis:
    """A ``--grid`` axis."""
    parsed = parse_values(values, f"--grid {key}")
    return Axis((key,), tuple((v,) for v in parsed))


def zip_axis(items: dict) -> Axis:
    """The ``--zip`` axis: every key's values, equally many, varied together."""
    columns = {key: parse_values(values, f"--zip {key}") for key, values in items.items()}
    lengths = {key: len(v) for key, v in columns.items()}
    if len(set(lengths.values())) > 1:
        text = ", ".join(f"{key} has {n}" for key, n in lengths.items())
        raise RollsimError(f"--zip: the zipped keys need equally many values ({text})")
    keys = tuple(columns)
    return Axis(keys, tuple(zip(*(columns[key] for key in keys))))
