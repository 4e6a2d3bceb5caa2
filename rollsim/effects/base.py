"""What an effect is: its parameters, its slot, its per-scene setup and its per-frame stage.

An effect is one module of :mod:`rollsim.effects` that defines an
:class:`Effect`: the pydantic model of its parameters (the keys a scene
gives under ``effects.<name>``), and what it does to the render:

* ``prepare``: a per-scene hook ``(setup, params) -> setup``, run once
  before any stage is built, for an effect that changes what every frame
  shares (a lens PSF reshapes the LED's coverage; vignetting makes the
  electron rates per-pixel maps);
* ``build_stage``: ``(setup, params) -> run``, a function of one frame's
  :class:`~rollsim.render_contract.state.FrameState`, run in the effect's ``slot``
  (:data:`SLOTS`, the EMVA 1288 order for the sensor);
* ``check``: ``(scene, params) -> str or None``, why a scene cannot have
  the effect (the scene loader reports it as a line naming the field).

Effects meet only through declared fields: a hook writes fields of
:class:`~rollsim.render_contract.setup.SceneSetup` and a stage reads and writes
fields of :class:`~rollsim.render_contract.state.FrameState` (a slotted dataclass, so
an undeclared field is an error), never another effect's settings. ``reads``
and ``writes`` name those fields (``"state.electrons"``,
``"setup.lens_kernels"``); a test checks that they exist.

The scene schema and the render pipeline are both derived from the one list
:data:`rollsim.effects.REGISTRY`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict

from rollsim.numerics.seeds import rng as named_rng
from rollsim.sensor.chain import ChainStep

if TYPE_CHECKING:
    from rollsim.optics.footprint import Footprint
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState
    from rollsim.scene_sections import SceneSections

SLOTS = (
    "timing",  # frame start time (frame_jitter)
    "geometry",  # this frame's LED footprint (motion)
    "exposure",  # per-row integral of the LED waveform (led_rise_time) and ambient light (flicker)
    "signal",  # mean photo-electrons: LED, ambient light
    "photo_response",  # PRNU: each pixel's gain on its photo-electrons
    "dark",  # dark current, with its own non-uniformity and hot pixels
    "shot",  # shot noise of the photo- and dark electrons
    "blooming",  # charge above full well spills along columns
    "full_well",  # clip to [0, full well]
    "offset",  # fixed offsets of the dark signal, which survive the clip: DSNU, column pattern
    "read",  # read noise, row noise
    "adc",  # conversion gain, black level, quantisation
    "output",  # gray8 / raw16 / rgb8, with the black clip and the tone curve
    "denoise",  # the ISP, on the 8-bit image: smoothing
    "sharpen",  # unsharp masking
    "compress",  # JPEG
)


class EffectParams(BaseModel):
    """Base of every effect's parameters: frozen, strict, no unknown keys."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


class NoParams(EffectParams):
    """An effect configured entirely by the camera, LED and environment keys."""


StageRun = Callable[["FrameState"], None]


@dataclass(frozen=True)
class Stage:
    """A named step of the pipeline, bound to its per-scene constants.

    ``chain_step`` marks a step of the sensor chain from shot noise to the
    output (:mod:`rollsim.sensor.chain`): consecutive such stages run as one
    pass (:func:`rollsim.render.stages.fuse_chain`), with the same result.
    """

    name: str
    slot: str
    run: StageRun
    chain_step: Optional[ChainStep] = None

    def __call__(self, state: FrameState) -> None:
        self.run(state)


@dataclass(frozen=True)
class Effect:
    """One effect of the closed registry.

    Attributes
    ----------
    name : str
        The key under a scene's ``effects``.
    params : type of EffectParams
        Its parameters; the class docstring documents them, with units.
    slot : str or None
        Where its stage runs (one of :data:`SLOTS`); None for an effect with
        no per-frame stage.
    build_stage : callable or None
        ``(setup, params) -> run``: the per-frame work, bound once per scene.
    chain_step : callable or None
        ``(setup, params) -> ChainStep or None``: the stage's step of the
        sensor chain, for an effect the chain can run in its one pass.
    prepare : callable or None
        ``(setup, params) -> setup``: the per-scene hook.
    check : callable or None
        ``(scene, params) -> str or None``: why the scene cannot have it.
    variant : str or None
        The parameter whose value names the stage's variant
        (``shot_noise[poisson]``).
    requires, excludes : tuple of (str, str)
        Effects it needs listed, or cannot be listed with, each with the reason.
    reads, writes : tuple of str
        The ``state.*`` and ``setup.*`` fields it reads and writes.
    setup_bytes_per_pixel : int
        Peak memory of its per-scene work beyond the render's own, in bytes
        per frame pixel (see :mod:`rollsim.render.pipeline`).
    """

    name: str
    params: type[EffectParams]
    slot: Optional[str] = None
    build_stage: Optional[Callable[[Any, Any], StageRun]] = None
    prepare: Optional[Callable[[Any, Any], Any]] = None
    check: Optional[Callable[[Any, Any], Optional[str]]] = None
    variant: Optional[str] = None
    requires: tuple[tuple[str, str], ...] = ()
    excludes: tuple[tuple[str, str], ...] = ()
    reads: tuple[str, ...] = ()
    writes: tuple[str, ...] = ()
    setup_bytes_per_pixel: int = 0
    chain_step: Optional[Callable[[Any, Any], Optional[ChainStep]]] = None

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ValueError(f"effect name {self.name!r} must be a Python identifier (it is a scene key)")
        if not (isinstance(self.params, type) and issubclass(self.params, EffectParams)):
            raise ValueError(f"effect {self.name}: params must be a subclass of EffectParams")
        if (self.slot is None) != (self.build_stage is None):
            raise ValueError(f"effect {self.name}: a stage needs a slot and a slot needs a stage")
        if self.slot is not None and self.slot not in SLOTS:
            raise ValueError(f"effect {self.name}: slot {self.slot!r} is not one of {', '.join(SLOTS)}")
        if self.slot is None and self.prepare is None:
            raise ValueError(f"effect {self.name}: does nothing (no stage and no per-scene hook)")
        if self.variant is not None and self.variant not in self.params.model_fields:
            raise ValueError(f"effect {self.name}: variant {self.variant!r} is not one of its parameters")

    def stage_name(self, params: EffectParams) -> str:
        """The stage's name in the pipeline: the effect's, with its variant."""
        return self.name if self.variant is None else f"{self.name}[{getattr(params, self.variant)}]"

    def stage(self, setup: SceneSetup, params: EffectParams) -> Optional[Stage]:
        """Its stage bound to ``setup``, or None for a per-scene-only effect."""
        if self.build_stage is None or self.slot is None:
            return None
        step = self.chain_step(setup, params) if self.chain_step is not None else None
        return Stage(self.stage_name(params), self.slot, self.build_stage(setup, params), step)

    def errors(self, scene: SceneSections, params: EffectParams, listed: frozenset) -> list[str]:
        """Why ``scene`` cannot have this effect: its check, requirements and exclusions."""
        errors = [f"effects.{self.name}: {why}; list the {other} effect too"
                  for other, why in self.requires if other not in listed]
        errors += [f"effects.{self.name}: {why}; list one or the other"
                   for other, why in self.excludes if other in listed]
        found = self.check(scene, params) if self.check is not None else None
        return errors + ([found] if found else [])


def on_box(rate: float | np.ndarray, fp: Footprint) -> float | np.ndarray:
    """A rate on a footprint's bounding box: a float as is, an (H, W) map sliced."""
    return rate[fp.rows, fp.cols] if isinstance(rate, np.ndarray) and rate.ndim else rate


def identity_seed(scene: SceneSections) -> int:
    """The seed of the camera's fixed patterns: ``camera.identity_seed``, or the scene's seed."""
    seed = scene.camera.identity_seed
    return scene.seed if seed is None else seed


def fixed_pattern_rng(setup: SceneSetup, stream: str) -> np.random.Generator:
    """The generator of a fixed pattern: the camera's identity and the stream
    name only (no frame key), so the same camera in every frame and every
    render, whatever the noise seed."""
    return named_rng(identity_seed(setup.scene), stream)


def fixed_pattern_map(setup: SceneSetup, stream: str) -> np.ndarray:
    """A standard normal map of the frame's shape, float32, the same in every frame (see :func:`fixed_pattern_rng`)."""
    return fixed_pattern_rng(setup, stream).standard_normal(setup.shape, dtype=np.float32)


def isp_effect(name: str, params: type[EffectParams], slot: str,
               transform: Callable[[np.ndarray, Any], np.ndarray]) -> Effect:
    """An ISP effect: ``transform(image, params)`` on the frame's 8-bit output, in ``slot``.

    Refused (naming the field) unless ``camera.output`` is ``gray8`` or ``rgb8``.
    """

    def check(scene: SceneSections, given: EffectParams) -> Optional[str]:
        if scene.camera.output not in ("gray8", "rgb8"):
            return f"effects.{name}: acts on 8-bit output; set camera.output to 'gray8' or 'rgb8'"
        return None

    def build_stage(setup: SceneSetup, given: EffectParams) -> StageRun:
        def run(state: FrameState) -> None:
            state.image = transform(state.image, given)

        return run

    return Effect(name=name, params=params, slot=slot, build_stage=build_stage, check=check,
                  reads=("state.image",), writes=("state.image",))
