"""Tone curves: how an ISP maps linear signal to output code values.

A tone curve maps the linear signal above the black level, normalised to
[0, 1] of the ADC range, to the normalised output value in [0, 1]. Three
kinds cover what cameras do:

* ``gamma``: a power law v^(1/γ) (a display gamma);
* ``srgb``: the IEC 61966-2-1 sRGB encoding, linear below 0.0031308 and
  1.055 v^(1/2.4) − 0.055 above;
* ``table``: a measured curve, piecewise linear through (input, output)
  points from (0, ·) to (1, ·), as ``rollsim fit-camera`` writes it.

A :class:`ToneCurve` is a small frozen value (picklable, so it crosses
worker processes with the scene's set-up).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rollsim.numerics.portable_math import power  # numpy's differs in the last bit between CPUs
from rollsim.plumbing.validation import unit_table_error

__all__ = ["ToneCurve", "srgb_encode", "validate_table"]

SRGB_LINEAR_LIMIT = 0.0031308  # IEC 61966-2-1: below this the encoding is linear


def srgb_encode(v: np.ndarray) -> np.ndarray:
    """The sRGB encoding of linear values in [0, 1] (IEC 61966-2-1), float32."""
    v = np.asarray(v, dtype=np.float32)
    low = v * np.float32(12.92)
    # np.maximum keeps the power's argument non-negative where the branch is not taken.
    high = np.float32(1.055) * power(np.maximum(v, np.float32(SRGB_LINEAR_LIMIT)), 1 / 2.4).astype(np.float32)
    high -= np.float32(0.055)
    return np.where(v <= SRGB_LINEAR_LIMIT, low, high).astype(np.float32)


def validate_table(points) -> str | None:
    """Why ``points`` is not a usable measured curve, or None.

    The inputs run strictly up from 0 to 1; the outputs lie in [0, 1] and
    never fall (a tone curve keeps the order of brightness).
    """
    why = unit_table_error(points, "input", "output")
    if why:
        return why
    y = np.asarray(points, dtype=np.float64)[:, 1]
    if np.any((y < 0) | (y > 1)):
        return "outputs must lie in [0, 1]"
    if np.any(np.diff(y) < 0):
        return "outputs must not decrease"
    return None


@dataclass(frozen=True)
class ToneCurve:
    """A tone curve of one of three kinds (see the module docstring).

    Attributes
    ----------
    kind : {'gamma', 'srgb', 'table'}
    gamma : float
        The power law's γ (``gamma`` only).
    table : tuple of (float, float)
        The measured curve's (input, output) points (``table`` only).
    """

    kind: str = "gamma"
    gamma: float = 2.2
    table: tuple = ()

    def __post_init__(self) -> None:
        if self.kind not in ("gamma", "srgb", "table"):
            raise ValueError(f"tone curve kind {self.kind!r} is not one of gamma, srgb, table")
        if self.kind == "gamma" and not (np.isfinite(self.gamma) and self.gamma > 0):
            raise ValueError(f"tone curve gamma must be a positive number, got {self.gamma!r}")
        if self.kind == "table":
            why = validate_table(self.table)
            if why:
                raise ValueError(f"tone curve table {why}")

    def __call__(self, v: np.ndarray) -> np.ndarray:
        """Map normalised linear values in [0, 1] to normalised output values, float32."""
        v = np.clip(np.asarray(v, dtype=np.float32), 0.0, 1.0)
        if self.kind == "gamma":
            return power(v, 1.0 / self.gamma).astype(np.float32)
        if self.kind == "srgb":
            return srgb_encode(v)
        pts = np.asarray(self.table, dtype=np.float64)
        return np.interp(v, pts[:, 0], pts[:, 1]).astype(np.float32)
