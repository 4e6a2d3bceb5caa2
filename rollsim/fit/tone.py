"""The tone curves the camera fit uses: one family, by one exponent, from linear to sRGB and beyond.

A camera's 8-bit tone curve is, in nearly every case, linear (raw or
machine-vision output) or sRGB-shaped (a phone's JPEG, a webcam, a
video). The fit's family holds both exactly: for an exponent γ > 1,

    v = (1 + a)·x^(1/γ) − a  above a toe,  v = s·x  below it,

with a = 0.055·(γ − 1)/1.4, and the toe's break and slope s where the
line meets the power curve tangentially. γ = 1 is the identity and
γ = :data:`SRGB_GAMMA` (2.4, a = 0.055) is IEC 61966-2-1 sRGB: the
tangent toe breaks at x = 0.00304 with slope 12.92, where the standard
breaks at 0.0031308 with slope 12.92 (the two differ by less than 0.002
of full scale, 0.4 of a level). For γ ≤ 1 the curve is the power x^(1/γ).

All levels here are fractions of the ADC range (linear x, encoded v, both
in [0, 1]).
"""

from __future__ import annotations

import math

import numpy as np

# The exponent at which the family is sRGB.
SRGB_GAMMA = 2.4
_SRGB_OFFSET = 0.055

# The curves a user may name (``rollsim fit-camera --tone``), by their exponent.
NAMED_GAMMAS = {"linear": 1.0, "srgb": SRGB_GAMMA}


def offset(gamma: float) -> float:
    """a(γ): 0 at γ ≤ 1, sRGB's 0.055 at :data:`SRGB_GAMMA`, linear in γ between and beyond."""
    return _SRGB_OFFSET * (gamma - 1.0) / (SRGB_GAMMA - 1.0) if gamma > 1.0 else 0.0


def toe(gamma: float) -> tuple[float, float]:
    """The toe's break x₀ (linear) and slope s, where s·x meets (1 + a)·x^(1/γ) − a tangentially;
    (0, 1) without a toe (γ ≤ 1)."""
    a = offset(gamma)
    if a <= 0.0:
        return 0.0, 1.0
    x0 = (a / ((1.0 + a) * (1.0 - 1.0 / gamma))) ** gamma
    return x0, (1.0 + a) / gamma * x0 ** (1.0 / gamma - 1.0)


def encode(x, gamma: float) -> np.ndarray:
    """The 8-bit-bound level v (fraction of full scale) of a linear level x, both clipped to [0, 1]."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    a = offset(gamma)
    if a <= 0.0:
        return np.power(x, 1.0 / gamma)
    x0, s = toe(gamma)
    # In place: the stripe fit evaluates this over every row of every frame at each step.
    flat = x.reshape(-1)
    v = np.power(flat, 1.0 / gamma)
    v *= 1.0 + a
    v -= a
    toe_rows = flat <= x0
    v[toe_rows] = s * flat[toe_rows]
    return v.reshape(x.shape)


def decode(v, gamma: float) -> np.ndarray:
    """The linear level x behind an encoded level v (both fractions of full scale, in [0, 1])."""
    v = np.clip(np.asarray(v, dtype=np.float64), 0.0, 1.0)
    a = offset(gamma)
    if a <= 0.0:
        return np.power(v, gamma)
    x0, s = toe(gamma)
    return np.where(v <= s * x0, v / s, np.power((np.maximum(v, s * x0) + a) / (1.0 + a), gamma))


def decode_slope(v, gamma: float) -> np.ndarray:
    """dx/dv of :func:`decode` at encoded levels v (v below 1/510 is taken as 1/510: a power's slope is
    unbounded at 0)."""
    v = np.clip(np.asarray(v, dtype=np.float64), 1.0 / 510.0, 1.0)
    a = offset(gamma)
    if a <= 0.0:
        return gamma * np.power(v, gamma - 1.0)
    x0, s = toe(gamma)
    return np.where(v <= s * x0, 1.0 / s,
                    gamma / (1.0 + a) * np.power((np.maximum(v, s * x0) + a) / (1.0 + a), gamma - 1.0))


# Points of the table a fitted scene's tone curve is written as (other than
# linear and sRGB): dense near black, where the toe and the power are steep.
TABLE_POINTS = 64


def scene_tone_curve(gamma: float) -> dict | None:
    """The ``effects.tone_curve`` parameters that render the family's curve at ``gamma``:
    None for linear, ``srgb`` at :data:`SRGB_GAMMA`, else a ``table``."""
    if gamma == 1.0:
        return None
    if math.isclose(gamma, SRGB_GAMMA, abs_tol=1e-9):
        return {"curve": "srgb"}
    inputs = np.concatenate([[0.0], np.geomspace(1e-5, 1.0, TABLE_POINTS - 1)])
    outputs = np.maximum.accumulate(encode(inputs, gamma))
    return {"curve": "table", "table": [[round(float(x), 9), round(float(v), 9)] for x, v in zip(inputs, outputs)]}
