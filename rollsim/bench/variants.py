"""Fidelity knobs and the scene variants ``rollsim bench accuracy`` renders.

A *knob* is a scene key with an accuracy/time trade-off; its *settings* are
listed most accurate first, and the first is the *reference* every other
setting is measured against (on the same frames and seed). A knob whose
effect the scene does not list is measured with that effect added at its
default parameters, so that one command covers every knob on any scene.

Every variant is built from the resolved scene (:func:`scene_to_dict`) plus
``--set``-style overrides, so it is validated like any scene.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rollsim.errors import RollsimError
from rollsim.sensor.adc import full_scale_electrons
from rollsim.scene import scene_from_dict
from rollsim.scene.loader import scene_to_dict

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

# The effects that add noise: removed for the "noiseless" image, so that a
# setting and its reference differ only by the knob.
NOISE_EFFECTS = ("shot_noise", "read_noise", "dark_current", "prnu", "dsnu")

# The defocus effect has no default focus distance; the cost table focuses
# the lens 1.5x beyond the LED, as the bundled effect-defocus scene does.
DEFOCUS_FOCUS_FACTOR = 1.5


@dataclass(frozen=True)
class Setting:
    """One value of a knob: its label and the overrides that select it."""

    label: str
    overrides: tuple[str, ...]


@dataclass(frozen=True)
class Knob:
    """A fidelity knob.

    Attributes
    ----------
    name : str
        Short name (``--knobs``).
    key : str
        The scene key it sets.
    effect : str or None
        The effect that holds the key (added when the scene does not list it).
    settings : tuple of Setting
        Most accurate first: ``settings[0]`` is the reference.
    noise : bool
        A noise method: compared by the distribution of flat fields, since
        the noiseless image does not depend on it.
    full_colour : bool
        A demosaicing method: no setting is exact, so every setting's image is
        compared with the full-colour image (see :mod:`rollsim.bench.accuracy`),
        and the reference is the setting measured closest to it.
    """

    name: str
    key: str
    effect: str | None
    settings: tuple[Setting, ...]
    noise: bool = False
    full_colour: bool = False


def _values(key: str, values) -> tuple[Setting, ...]:
    return tuple(Setting(str(value), (f"{key}={value}",)) for value in values)


def _rise_time_settings(samples=(64, 16, 4, 1)) -> tuple[Setting, ...]:
    key = "effects.led_rise_time"
    exact = Setting("exact", (f"{key}.method=exact",))
    return (exact,) + tuple(Setting(f"sampled K={k}", (f"{key}.method=sampled", f"{key}.samples={k}")) for k in samples)


KNOBS = (
    Knob("footprint_edge", "render.footprint_edge", None,
         _values("render.footprint_edge", ("exact", "supersample16", "supersample4", "supersample1"))),
    Knob("shot_noise", "effects.shot_noise.method", "shot_noise",
         _values("effects.shot_noise.method", ("poisson", "gaussian")), noise=True),
    Knob("read_noise", "effects.read_noise.method", "read_noise",
         _values("effects.read_noise.method", ("exact", "table")), noise=True),
    Knob("blur_kernel", "effects.blur.kernel", "blur", _values("effects.blur.kernel", ("full", "separable"))),
    Knob("blur_truncation", "effects.blur.truncate_sigma", "blur",
         _values("effects.blur.truncate_sigma", (10, 5, 3, 2))),
    Knob("demosaic", "effects.bayer.demosaic", "bayer",
         _values("effects.bayer.demosaic", ("edge_aware", "bilinear", "vng")), full_colour=True),
    Knob("spectral_step", "effects.bayer.spectral_step_nm", "bayer",
         _values("effects.bayer.spectral_step_nm", (1, 5, 10, "peak"))),
    Knob("led_rise_time", "effects.led_rise_time", "led_rise_time", _rise_time_settings()),
)
KNOB_NAMES = tuple(knob.name for knob in KNOBS)


def knob_by_name(name: str) -> Knob:
    for knob in KNOBS:
        if knob.name == name:
            return knob
    raise RollsimError(f"unknown knob {name!r}; knobs: {', '.join(KNOB_NAMES)}")


def _variant(data: dict, source: str, overrides) -> Scene:
    return scene_from_dict(data, source, list(overrides))


def _with_colour_output(data: dict) -> list[str]:
    """Make ``data`` give RGB frames (the bayer effect's demosaiced output); notes."""
    notes = []
    if data["camera"]["output"] != "rgb8":
        data["camera"]["output"] = "rgb8"
        notes.append("camera.output: rgb8")
    if "tone_curve" in data["effects"]:
        del data["effects"]["tone_curve"]
        notes.append("tone_curve removed (gray8 only)")
    return notes


@dataclass(frozen=True)
class KnobScenes:
    """The scenes of one knob's measurement.

    Attributes
    ----------
    data : dict
        The scene with the knob's effect (resolved), before any setting.
    added : str
        What was added to the scene for the knob ("" when nothing).
    source : str
        Scene name for error lines.
    """

    data: dict
    added: str
    source: str

    def scene(self, setting: Setting, noiseless: bool = False, extra=()):
        """The scene of ``setting``; ``noiseless`` removes every noise effect."""
        removed = [f"effects.{name}=false" for name in NOISE_EFFECTS] if noiseless else []
        return _variant(self.data, self.source, [*setting.overrides, *removed, *extra])


def knob_scenes(scene: Scene, knob: Knob) -> KnobScenes:
    """The base of a knob's variants: ``scene`` with the knob's effect listed."""
    data = scene_to_dict(scene)
    notes = []
    if knob.effect is not None and knob.effect not in data["effects"]:
        data["effects"][knob.effect] = {}
        notes.append(knob.effect)
    if knob.effect == "bayer":
        notes += _with_colour_output(data)
    return KnobScenes(data, ", ".join(notes), scene.name)


# ------------------------------------------------------------ flat fields


def flat_field_overrides(ambient_lux: float, reflectance: float) -> list[str]:
    """Overrides that turn a scene into a flat field: a lit background, no LED.

    The LED is moved far out of the frame (and sends ``off``), so every pixel
    sees the same Lambertian background; effects that modulate the light in
    time or move the LED are removed.
    """
    return [
        "link.pattern=off",
        "led.position_px=[-1e9, -1e9]",
        "effects.ambient=null",
        "effects.flicker=false",
        "effects.motion=false",
        # float(): a numpy scalar's repr (np.float32(...)) is no scene value.
        f"environment.ambient_lux={float(ambient_lux)!r}",
        f"environment.background_reflectance={float(reflectance)!r}",
    ]


def flat_field_levels_e(scene: Scene, low_e: float = 2.0) -> list[float]:
    """Signal levels (mean photo-electrons per pixel) of the flat fields.

    A low level of ``low_e`` electrons, where the Gaussian approximation of
    shot noise is worst; a high level at 75 % of what the sensor can record
    (the smaller of the full well and the ADC's range, less dark charge);
    and their geometric mean.
    """
    cam = scene.camera
    adc_e = full_scale_electrons(cam.adc_bits, cam.black_level_dn, cam.gain_dn_per_e_at_iso)
    dark_e = cam.dark_current_e_per_s * cam.exposure_s if "dark_current" in scene.effects else 0.0
    high = 0.75 * min(cam.full_well_e, adc_e) - dark_e
    if high <= low_e:
        return [high] if high > 0 else []
    return [low_e, math.sqrt(low_e * high), high]


# ---------------------------------------------------------- effect costs


@dataclass(frozen=True)
class EffectPair:
    """The scenes with and without one effect, for its cost."""

    effect: str
    with_effect: Scene
    without_effect: Scene
    listed: bool
    note: str


def effect_pair(scene: Scene, name: str, params: dict | None = None) -> EffectPair:
    """``scene`` with and without effect ``name``.

    Parameters
    ----------
    scene : Scene
    name : str
        A registered effect.
    params : dict, optional
        The effect's parameters when ``scene`` does not list it (default:
        the effect's defaults; for ``defocus``, a focus distance
        :data:`DEFOCUS_FOCUS_FACTOR` times the LED's distance). An effect the
        scene lists keeps the scene's parameters.

    Raises
    ------
    RollsimError
        When the effect cannot be measured on this scene (the message says why).
    """
    base = scene_to_dict(scene)
    listed = name in base["effects"]
    with_data, without_data = copy.deepcopy(base), copy.deepcopy(base)
    notes = []
    if listed:
        del without_data["effects"][name]
        if name == "ambient" and "flicker" in without_data["effects"]:
            del without_data["effects"]["flicker"]
            notes.append("flicker removed too (it needs ambient)")
        if name == "bayer" and without_data["camera"]["output"] == "rgb8":
            without_data["camera"]["output"] = "gray8"
            notes.append("without it: camera.output gray8")
    else:
        if name == "tone_curve" and base["camera"]["output"] != "gray8":
            raise RollsimError("applies to camera.output gray8 only")
        if params is not None:
            params = copy.deepcopy(params)
        elif name == "defocus":
            params = {"focus_distance_cm": DEFOCUS_FOCUS_FACTOR * scene.link.distance_cm}
            notes.append(f"focus_distance_cm {params['focus_distance_cm']:g}")
        else:
            params = {}
        if name == "flicker" and "ambient" not in base["effects"]:
            with_data["effects"]["ambient"] = without_data["effects"]["ambient"] = {}
            notes.append("ambient added to both (flicker needs it)")
        with_data["effects"][name] = params
        if name == "bayer":
            notes += _with_colour_output(with_data)
    return EffectPair(name, _variant(with_data, scene.name, ()), _variant(without_data, scene.name, ()), listed,
                      "; ".join(notes))

