"""Validation of numeric inputs, with one-line errors naming the parameter,
and of input paths (:func:`missing_path`).

Neutral (it imports only :mod:`rollsim.errors`): the channel analysis, the
optics and the sensor models all check their public arguments with it.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from rollsim.errors import clip

# Counts beyond 2**53 are no longer exact as float64, and the closed forms
# multiply counts by logs; refusing them is clearer than silent rounding.
MAX_COUNT = 2**53


def as_count(value, name: str, minimum: int = 0) -> int:
    """``value`` as an int >= ``minimum``; integral floats (1e6) pass, bools do not."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value) or not float(value).is_integer():
            raise ValueError(f"{name} must be an integer, got {value!r}")
        value = int(value)
    try:
        value = int(value.__index__())
    except (AttributeError, TypeError):
        raise ValueError(f"{name} must be an integer, got {value!r}") from None
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if value > MAX_COUNT:
        raise ValueError(f"{name} must be <= 2**53, got {value}")
    return value


def _as_float(value, name: str, expected: str) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {expected}, got {value!r}") from None


def as_probability(value, name: str) -> float:
    """``value`` as a float in [0, 1] (NaN rejected)."""
    value = _as_float(value, name, "a probability in [0, 1]")
    if not 0.0 <= value <= 1.0:  # also rejects NaN
        raise ValueError(f"{name} must be a probability in [0, 1], got {value!r}")
    return value


def as_positive(value, name: str, allow_zero: bool = False) -> float:
    """``value`` as a finite float > 0 (or >= 0 with ``allow_zero``)."""
    value = _as_float(value, name, "a finite number")
    ok = value >= 0.0 if allow_zero else value > 0.0
    if not (ok and math.isfinite(value)):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be finite and {bound}, got {value!r}")
    return value


def as_finite(value, name: str) -> float:
    """``value`` as a finite float."""
    value = _as_float(value, name, "a finite number")
    if not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return value


def check_nonnegative(value, name: str):
    """``value`` (a number or an array) unchanged if every element is finite and >= 0."""
    array = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(array) & (array >= 0.0)):
        shown = repr(value) if array.size <= 4 else f"an array with {int(np.sum(~(np.isfinite(array) & (array >= 0))))} bad values"
        raise ValueError(f"{name} must be finite and >= 0, got {shown}")
    return value


def unit_table_error(points, x_name: str, y_name: str) -> str | None:
    """Why ``points`` is not a table of (x, y) pairs over x in [0, 1], or None.

    The pairs are at least two and finite; x starts at 0, ends at 1 and
    rises strictly. What y may be is the caller's to check.
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2:
        return f"needs at least two [{x_name}, {y_name}] pairs"
    if not np.all(np.isfinite(pts)):
        return "has a value that is not a finite number"
    if pts[0, 0] != 0.0 or pts[-1, 0] != 1.0 or np.any(np.diff(pts[:, 0]) <= 0):
        return f"{x_name} values must rise strictly from 0 to 1: start at 0, end at 1 and increase strictly"
    return None


# Characters that make a shell word a pattern: left as typed when it matched nothing.
_GLOB_CHARS = frozenset("*?[")
# The most characters of a path that a line quotes.
_PATH_CHARS = 120


def missing_path(path) -> str | None:
    """The one-line refusal of an input path that does not exist, or None when it does.

    A pattern the shell passed unexpanded because it matched nothing
    (``my_frames/*.png``) is named as one: ``no file matches
    my_frames/*.png``, with the folder it looks in when that is missing too.
    A path the OS will not look up (too long, a NUL character, no
    permission) is not called missing: None, for the reader to report.
    """
    text = os.fspath(path)
    state = _lookup(text)
    if state is None:
        return None
    shown = clip(text, _PATH_CHARS)
    if _GLOB_CHARS.isdisjoint(text):
        return f"{shown}: {state}"
    folder = Path(text)
    while folder.parent != folder and not _GLOB_CHARS.isdisjoint(str(folder)):
        folder = folder.parent  # the part before the first pattern: where the shell looked
    if str(folder) in ("", ".") or _lookup(str(folder)) is None:
        return f"no file matches {shown}"
    return f"no file matches {shown} ({clip(str(folder), _PATH_CHARS)} does not exist)"


def _lookup(text: str) -> str | None:
    """Why ``text`` names nothing (``does not exist``, a dangling link), or None when it names something
    or the OS would not look it up."""
    try:
        os.stat(text)
    except (FileNotFoundError, NotADirectoryError):
        if os.path.islink(text):
            return f"a symbolic link to {clip(os.readlink(text), _PATH_CHARS)}, which does not exist"
        return "does not exist"
    except (OSError, ValueError):
        return None
    return None
