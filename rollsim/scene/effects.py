"""The closed registry of effect names and their parameters.

A scene lists its effects under ``effects``; an effect that is not listed is
not computed. Names come from this registry only: a scene never names code.
Each effect's parameters are a small model with units in the names. Effects
whose parameters are not listed here yet take none.
"""

from __future__ import annotations

from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field

from rollsim.errors import SceneError, short_repr


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
    ``exact`` uses numpy's Ziggurat. See :mod:`rollsim.gaussian`.
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


class Blur(_Params):
    """Lens blur: a Gaussian PSF on the LED's image and the background it hides.

    ``sigma_px``: standard deviation in pixels. ``kernel``: ``separable``
    (two 1-D passes) or ``full`` (one 2-D convolution); they agree to float
    precision. ``truncate_sigma``: kernel radius in standard deviations; at
    5 the mass cut off is 5.7e-7 per axis (the kernel is renormalised, so
    light is conserved) and the kernel's variance is σ² to 2e-5.
    See :mod:`rollsim.optics.psf`.
    """

    sigma_px: float = Field(1.0, gt=0, le=100)
    kernel: Literal["separable", "full"] = "separable"
    truncate_sigma: float = Field(5.0, ge=1, le=10)


class Defocus(_Params):
    """Thin-lens defocus: a disk PSF whose diameter is the circle of confusion
    of the LED's distance for a lens focused at ``focus_distance_cm`` with
    aperture f/N (``camera.f_number``). See :mod:`rollsim.optics.psf`."""

    focus_distance_cm: float = Field(gt=0, le=1e5)

    @property
    def focus_distance_m(self) -> float:
        return self.focus_distance_cm * 1e-2


class Vignetting(_Params):
    """Natural vignetting, cos⁴ of the field angle. ``optical_centre_px``:
    ``[x, y]`` of the optical axis on the sensor; ``null`` = frame centre."""

    optical_centre_px: Optional[list[float]] = Field(None, min_length=2, max_length=2)


class Bayer(_Params):
    """A Bayer colour filter array with spectral channel responses.

    ``pattern``: the top-left 2×2 block. ``demosaic``: OpenCV's
    ``bilinear``, ``edge_aware`` or ``vng`` (for ``camera.output: rgb8``);
    ``edge_aware`` by default, the closest of the three to the full-colour
    image and faster than ``vng`` (``rollsim bench accuracy``).
    ``sensitivities``: the camera spectral sensitivities shipped with
    colour-science, scaled to a peak of ``camera.qe``. ``led_fwhm_nm``: full
    width at half maximum of the LED's spectrum. ``spectral_step_nm``:
    integration step, or ``peak`` to treat the LED as a line at its peak
    wavelength. See :mod:`rollsim.optics.spectral`.
    """

    pattern: Literal["RGGB", "BGGR", "GRBG", "GBRG"] = "RGGB"
    demosaic: Literal["bilinear", "edge_aware", "vng"] = "edge_aware"
    sensitivities: Literal["nikon_5100", "sigma_sdmerill"] = "nikon_5100"
    led_fwhm_nm: float = Field(20.0, gt=0, le=300)
    spectral_step_nm: Literal[1, 5, 10, "peak"] = 1


class LedProfile(_Params):
    """The LED face's radiance: a Gaussian of the distance from its centre,
    σ = ``core_sigma_mm`` on the face, truncated at its edge, scaled so that
    the face emits the LED's luminous intensity. See :mod:`rollsim.optics.emitter`."""

    core_sigma_mm: float = Field(1.0, gt=0, le=1e3)


class Glare(_Params):
    """Veiling glare of the lens: a fraction ``fraction`` of the LED's light
    is scattered into a Moffat halo of core angle ``core_angle_deg`` whose
    wings fall as θ^(−2·``exponent``). See :mod:`rollsim.optics.glare`."""

    fraction: float = Field(0.05, ge=0, le=1)
    core_angle_deg: float = Field(2.0, gt=0, le=60)
    exponent: float = Field(2.0, gt=1, le=10)


class Effects(_Params):
    """Which effects a scene calls for (``None`` = not listed, not computed)."""

    ambient: Optional[NoParams] = None
    shot_noise: Optional[ShotNoise] = None
    read_noise: Optional[ReadNoise] = None
    dark_current: Optional[NoParams] = None
    prnu: Optional[NoParams] = None
    dsnu: Optional[NoParams] = None
    tone_curve: Optional[ToneCurve] = None
    blur: Optional[Blur] = None
    defocus: Optional[Defocus] = None
    bayer: Optional[Bayer] = None
    led_profile: Optional[LedProfile] = None
    glare: Optional[Glare] = None
    vignetting: Optional[Vignetting] = None
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
        for name in value:
            if not isinstance(name, str):
                raise SceneError(f"effects: {short_repr(name)}: a list of effects holds effect names "
                                 f"({', '.join(EFFECT_NAMES)})")
        return {name: {} for name in value}
    if isinstance(value, dict):
        return {name: ({} if params is None or params is True else params) for name, params in value.items() if params is not False}
    return value
