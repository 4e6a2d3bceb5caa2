"""The closed registry of effect names and their parameters.

A scene lists its effects under ``effects``; an effect that is not listed is
not computed. Names come from this registry only: a scene never names code.
Each effect's parameters are a small model with units in the names. Effects
whose parameters are not listed here yet take none.
"""

from __future__ import annotations

from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field


class _Params(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


class NoParams(_Params):
    """An effect configured entirely by the camera, LED and environment keys."""


class ShotNoise(_Params):
    """Photon shot noise. ``method``: exact Poisson, or its Gaussian approximation."""

    method: Literal["poisson", "gaussian"] = "poisson"


class ReadNoise(_Params):
    """Read noise, Gaussian in electrons (sigma: ``camera.read_noise_e``).

    ``method``: ``table`` draws from a 65,536-bin quantile table with exact
    tails (Kolmogorov distance 7.6e-6 from the normal, about 3x faster);
    ``exact`` uses numpy's Ziggurat. See :mod:`rollsim.sensor.gaussian`.
    """

    method: Literal["table", "exact"] = "table"


class ToneCurve(_Params):
    """Display gamma for ``gray8`` output: value ** (1 / gamma)."""

    gamma: float = Field(2.2, gt=0, le=10)


class Effects(_Params):
    """Which effects a scene calls for (``None`` = not listed, not computed)."""

    ambient: Optional[NoParams] = None
    shot_noise: Optional[ShotNoise] = None
    read_noise: Optional[ReadNoise] = None
    dark_current: Optional[NoParams] = None
    prnu: Optional[NoParams] = None
    dsnu: Optional[NoParams] = None
    tone_curve: Optional[ToneCurve] = None
    blur: Optional[NoParams] = None
    defocus: Optional[NoParams] = None
    bayer: Optional[NoParams] = None
    vignetting: Optional[NoParams] = None
    led_rise_time: Optional[NoParams] = None
    frame_jitter: Optional[NoParams] = None
    motion: Optional[NoParams] = None
    flicker: Optional[NoParams] = None
    blooming: Optional[NoParams] = None

    def enabled(self) -> tuple[str, ...]:
        """Names of the listed effects, in registry order."""
        return tuple(name for name in type(self).model_fields if getattr(self, name) is not None)


EFFECT_NAMES = tuple(Effects.model_fields)


def normalise_effects(value):
    """Turn the scene's ``effects`` value into ``{name: params}``.

    A bare list of names is accepted; ``name:`` with no value (YAML null) means
    default parameters; ``name: false`` removes an effect a lower layer listed.
    """
    if value is None:
        return {}
    if isinstance(value, (list, tuple)):
        return {name: {} for name in value}
    if isinstance(value, dict):
        return {name: ({} if params is None or params is True else params) for name, params in value.items() if params is not False}
    return value
