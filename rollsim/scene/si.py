"""Scene values in SI: every float a scene gives must stay a usable number once converted.

A scene's keys carry their unit in the name (``exposure_us``, ``size_mm``,
``prnu_percent``), and the numeric code works in SI. A value inside its
field's range can still be useless there: ``exposure_us = 5e-324`` is
positive, but becomes 0 s; a subnormal float has lost most of its digits;
``iso = 1e-300`` is positive, but its reciprocal overflows. This module
checks every float of a validated scene (camera, LED, link, environment,
channel, and each listed effect's parameters, found by walking the models,
so a field added later is checked too) against one rule:

* a value is finite, and 0 or a normal float;
* converted to SI by the factor its unit suffix names, it is still finite,
  and 0 only if it was 0, and normal;
* a field that must be > 0 (its model declares ``gt=0``: a duration, a
  size, a rate, a gain, anything used as a divisor or a scale) is at least
  :data:`MIN_POSITIVE_SI` in SI;
* no value is more than :data:`MAX_MAGNITUDE_SI` in SI.
"""

from __future__ import annotations

import math
import sys
from typing import Iterator, Optional

import annotated_types
from pydantic import BaseModel

from rollsim.errors import short_repr

# Unit suffix of a field name -> (its unit as written, factor to SI, SI
# unit). Longest suffixes first, so that ``_e_per_s`` is not read as
# ``_s``. A name with none of them is a plain number (a ratio, a
# probability, an ISO, an exponent).
SI_UNITS: tuple[tuple[str, str, float, str], ...] = (
    ("_e_per_s", "e-/s", 1.0, "e-/s"),
    ("_dn_per_e", "DN/e-", 1.0, "DN/e-"),
    ("_percent", "%", 1e-2, ""),
    ("_khz", "kHz", 1e3, "Hz"),
    ("_hz", "Hz", 1.0, "Hz"),
    ("_deg", "deg", math.pi / 180.0, "rad"),
    ("_lux", "lx", 1.0, "lx"),
    ("_cd", "cd", 1.0, "cd"),
    ("_ms", "ms", 1e-3, "s"),
    ("_us", "us", 1e-6, "s"),
    ("_ns", "ns", 1e-9, "s"),
    ("_km", "km", 1e3, "m"),
    ("_cm", "cm", 1e-2, "m"),
    ("_mm", "mm", 1e-3, "m"),
    ("_um", "um", 1e-6, "m"),
    ("_nm", "nm", 1e-9, "m"),
    ("_px", "px", 1.0, "px"),
    ("_dn", "DN", 1.0, "DN"),
    ("_e", "e-", 1.0, "e-"),
    ("_s", "s", 1.0, "s"),
    ("_m", "m", 1.0, "m"),
)
# Names that end like a unit but are plain numbers: the paper's p_e is a
# probability, not electrons.
PLAIN_NUMBERS = frozenset({"p_e"})
# The smallest SI magnitude of a quantity that must be positive. Far below
# any scale a camera link meets (a femtosecond, a femtometre, a gain of
# 1e-15), and far enough above the float underflow (1e-308 in float64,
# 1e-38 in the float32 stages) that the products, squares and reciprocals
# of a few such values stay finite.
MIN_POSITIVE_SI = 1e-15
# The largest SI magnitude of any scene value, for the same reason; it
# matters only for a field without a range of its own (an image position).
MAX_MAGNITUDE_SI = 1e15

_SMALLEST_NORMAL = sys.float_info.min


def si_unit(field_name: str) -> tuple[str, float, str]:
    """A field's unit as its name gives it, the factor to SI, and the SI unit.

    Parameters
    ----------
    field_name : str
        A scene key, e.g. ``"exposure_us"``.

    Returns
    -------
    unit : str
        The unit the value is given in (``"us"``), ``""`` for a plain number.
    factor : float
        What the value is multiplied by to give SI (``1e-6``).
    si_unit : str
        The SI unit (``"s"``), ``""`` for a plain number.
    """
    if field_name in PLAIN_NUMBERS:
        return "", 1.0, ""
    for suffix, unit, factor, si_unit_name in SI_UNITS:
        if field_name.endswith(suffix):
            return unit, factor, si_unit_name
    return "", 1.0, ""


def _is_usable(value: float) -> bool:
    """Whether ``value`` is finite and 0 or a normal float (not subnormal)."""
    return math.isfinite(value) and (value == 0.0 or abs(value) >= _SMALLEST_NORMAL)


def _with_unit(value: float, unit: str) -> str:
    return f"{value:.3g} {unit}" if unit else f"{value:.3g}"


def si_value_error(path: str, value: float, must_be_positive: bool) -> Optional[str]:
    """Why a scene float is no usable number in SI, as ``path = value: reason``; None if it is.

    Parameters
    ----------
    path : str
        The dotted scene key, e.g. ``"camera.exposure_us"``; its last part
        names the unit.
    value : float
        The value in the field's own unit.
    must_be_positive : bool
        The field must be > 0 (a size, a duration, a divisor): its SI value
        must then be at least :data:`MIN_POSITIVE_SI`.
    """
    unit, factor, si_unit_name = si_unit(path.rsplit(".", 1)[-1])
    head = f"{path} = {short_repr(value)}"
    if not math.isfinite(value):
        return f"{head}: must be a finite number"
    if value == 0.0:
        return None
    si = value * factor
    if abs(si) > MAX_MAGNITUDE_SI:
        return f"{head}: too large; must be at most {_with_unit(MAX_MAGNITUDE_SI / factor, unit)} in magnitude"
    if _is_usable(value) and _is_usable(si) and not (must_be_positive and abs(si) < MIN_POSITIVE_SI):
        return None
    in_si = f" (becomes {_with_unit(si, si_unit_name)} in SI)" if factor != 1.0 else ""
    if must_be_positive:
        return f"{head}: too small{in_si}; must be >= {_with_unit(MIN_POSITIVE_SI / factor, unit)}"
    # A normal float both as given and in SI.
    smallest = max(_SMALLEST_NORMAL, _SMALLEST_NORMAL / factor)
    return f"{head}: too small{in_si}; must be 0 or at least {_with_unit(smallest, unit)} in magnitude"


def _must_be_positive(field) -> bool:
    """Whether a pydantic field declares ``gt=0`` (it must be > 0)."""
    return any(isinstance(item, annotated_types.Gt) and item.gt == 0 for item in field.metadata)


def _floats(value, path: str, must_be_positive: bool) -> Iterator[tuple[str, float, bool]]:
    """``(path, value, must be > 0)`` of every float in ``value``: a model, a list or a float."""
    if isinstance(value, BaseModel):
        for name, field in type(value).model_fields.items():
            yield from _floats(getattr(value, name), f"{path}.{name}" if path else name, _must_be_positive(field))
    elif isinstance(value, (list, tuple)):
        for item in value:
            yield from _floats(item, path, must_be_positive)
    elif isinstance(value, float):
        yield path, value, must_be_positive


def si_errors(scene: BaseModel) -> list[str]:
    """One line per float of ``scene`` that is no usable number in SI (:func:`si_value_error`).

    Every float field of every section and of every listed effect's
    parameters, and the floats of list fields (``led.position_px``).
    """
    errors = (si_value_error(path, value, positive) for path, value, positive in _floats(scene, "", False))
    return [line for line in errors if line is not None]
