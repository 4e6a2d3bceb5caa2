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


class LedRiseTime(_Params):
    """A first-order LED: its light follows the drive with time constant ``tau_us``.

    ``method``: ``exact`` integrates the exponential segments in closed form;
    ``sampled`` averages the light at ``samples`` midpoints of each exposure
    window (a fidelity knob, compared against ``exact``). See
    :mod:`rollsim.transmitter.led_response`.
    """

    tau_us: float = Field(5.0, gt=0, le=1e6)
    method: Literal["exact", "sampled"] = "exact"
    samples: int = Field(16, ge=1, le=4096)


class FrameJitter(_Params):
    """Frame start jitter: standard deviation ``std_us`` of each frame's
    offset (``independent``) or of each frame-to-frame step (``random_walk``).
    See :mod:`rollsim.sensor.frame_jitter`."""

    std_us: float = Field(20.0, ge=0, le=1e6)
    mode: Literal["independent", "random_walk"] = "independent"


class Motion(_Params):
    """Hand shake: the LED's image position moves, per axis, as a random walk
    reflected at ±``amplitude_*_px`` (steps of std ``step_*_px`` per frame)
    or as a sinusoid of amplitude ``amplitude_*_px`` at ``frequency_hz``.
    See :mod:`rollsim.optics.motion`."""

    mode: Literal["random_walk", "sinusoid"] = "random_walk"
    amplitude_x_px: float = Field(8.0, ge=0, le=1e4)
    amplitude_y_px: float = Field(8.0, ge=0, le=1e4)
    step_x_px: float = Field(2.0, ge=0, le=1e4)
    step_y_px: float = Field(2.0, ge=0, le=1e4)
    frequency_hz: float = Field(10.0, gt=0, le=1e4)
    phase_x_deg: float = Field(0.0, ge=-360, le=360)
    phase_y_deg: float = Field(90.0, ge=-360, le=360)


class Flicker(_Params):
    """Mains flicker of the ambient light: E(t) = E0·(1 + depth·cos(2π·2f·t + phase)),
    f = ``environment.mains_hz``. See :mod:`rollsim.sensor.flicker`."""

    depth: float = Field(0.3, ge=0, le=1)
    phase_deg: float = Field(0.0, ge=-360, le=360)


class Blooming(_Params):
    """Charge above ``camera.full_well_e`` spills along columns; a fraction
    ``spill_fraction`` of the excess spills (1: no anti-blooming drain), the
    rest drains away. See :mod:`rollsim.sensor.blooming`."""

    spill_fraction: float = Field(1.0, ge=0, le=1)


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
    led_rise_time: Optional[LedRiseTime] = None
    frame_jitter: Optional[FrameJitter] = None
    motion: Optional[Motion] = None
    flicker: Optional[Flicker] = None
    blooming: Optional[Blooming] = None

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
