"""Render stages: the core chain and the effects registry.

A stage is a callable that takes a :class:`FrameState` and fills in or
modifies its arrays. Each has a ``slot``; the pipeline runs slots in the
order of :data:`SLOTS` (the EMVA 1288 order for the sensor), core stage first
within a slot. The core (timing, exact exposure integral, footprint, full
well, ADC, output) always runs; every other stage comes from an effect the
scene lists. Effects are looked up by name in :data:`EFFECT_BUILDERS`, a
closed registry: a scene never names code.

A new effect slots in by adding a builder here (and its parameters to
:mod:`rollsim.scene.effects`); the core stages do not change.

Per-scene hooks. An effect that changes what every frame shares rather than
adding work to each frame (a lens PSF reshapes the LED's coverage map;
vignetting and a colour filter array make the electron rates per-pixel maps)
registers a hook in :data:`SETUP_HOOKS`: a function ``SceneSetup ->
SceneSetup``. :func:`prepare_setup` runs the hooks of the listed effects
once per scene, in registry order, before any stage is built; the
pipeline's stages and truth then read the prepared setup. Its effects build
no stage of their own (their builder returns None), so they cost nothing
per frame beyond the arrays they change. The rates a hook leaves are a float
or an (H, W) map; the stages take either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Callable

import numpy as np

from rollsim.errors import RollsimError
from rollsim.optics.motion import motion_footprint, path_from_params
from rollsim.optics.psf import blur_canvas, total_radius
from rollsim.render import hooks
from rollsim.render.setup import led_rows_from_coverage
from rollsim.seeds import rng as named_rng
from rollsim.sensor import electrons_to_dn, gray8_lut
from rollsim.sensor.blooming import bloom
from rollsim.sensor.cfa import demosaic, poisson_by_phase
from rollsim.sensor.flicker import flicker_row_factor
from rollsim.scene.frame_jitter_limits import frame_jitter_error, frame_margin_s
from rollsim.sensor.frame_jitter import FrameJitter
from rollsim.gaussian import standard_normal
from rollsim.sensor.poisson import poisson
from rollsim.transmitter.led_response import exposure_exact, exposure_sampled

if TYPE_CHECKING:
    from rollsim.render.setup import SceneSetup

SLOTS = (
    "timing",  # frame start time (frame_jitter)
    "geometry",  # this frame's LED footprint (motion)
    "exposure",  # per-row integral of the LED waveform (led_rise_time) and ambient light (flicker)
    "signal",  # mean photo-electrons: LED, ambient light
    "dark",  # dark current
    "shot",  # photon shot noise
    "fixed_pattern",  # PRNU gain map, DSNU offset map
    "blooming",  # charge above full well spills along columns
    "full_well",  # clip to [0, full well]
    "read",  # read noise
    "adc",  # conversion gain, black level, quantisation
    "output",  # gray8 / raw16
)


@dataclass(frozen=True)
class Stage:
    """A named step of the pipeline, bound to its per-scene constants."""

    name: str
    slot: str
    run: Callable

    def __call__(self, state) -> None:
        self.run(state)


def _on_box(rate, fp):
    """A rate on the footprint's bounding box: a float as is, a map sliced."""
    return rate[fp.rows, fp.cols] if np.ndim(rate) else rate


# ------------------------------------------------------------------ core


def frame_start_stage(setup: SceneSetup) -> Stage:
    period = setup.timing.frame_period_s

    def run(state):
        state.start_s = state.index * period

    return Stage("frame_start", "timing", run)


def led_exposure_stage(setup: SceneSetup) -> Stage:
    timing, waveform = setup.timing, setup.transmitter.waveform

    def run(state):
        start, end = timing.row_windows(state.start_s)
        state.led_exposure_s = waveform.exposure(start, end)

    return Stage("led_exposure", "exposure", run)


def led_signal_stage(setup: SceneSetup) -> Stage:
    """Mean electrons of the LED: light × rate × ∫ s dt, per row (the light is the
    coverage unless ``led_profile`` or ``glare`` spread it: ``setup.led_light``)."""
    rate, shape = setup.led_e_per_s, setup.shape
    static = setup.footprint if setup.led_light is None else setup.led_light
    # Per-pixel rates (vignetting, a CFA) fold into the static coverage once;
    # a moving footprint's are folded per frame.
    static_coverage = static.coverage * _on_box(rate, static) if np.ndim(rate) else static.coverage
    scalar_rate = 1.0 if np.ndim(rate) else rate

    def coverage_of(fp):
        if fp is static:
            return static_coverage
        return fp.coverage * _on_box(rate, fp) if np.ndim(rate) else fp.coverage

    def run(state):
        fp = static if state.footprint is None else state.footprint
        electrons = np.zeros(shape)
        if fp.coverage.size:
            row_signal = scalar_rate * state.led_exposure_s[fp.rows]
            electrons[fp.rows, fp.cols] = coverage_of(fp) * row_signal[:, None]
        state.electrons = electrons

    return Stage("led_signal", "signal", run)


def full_well_stage(setup: SceneSetup) -> Stage:
    full_well = setup.scene.camera.full_well_e

    def run(state):
        np.clip(state.electrons, 0.0, full_well, out=state.electrons)

    return Stage("full_well", "full_well", run)


def adc_stage(setup: SceneSetup) -> Stage:
    cam, gain = setup.scene.camera, setup.gain_dn_per_e

    def run(state):
        state.dn = electrons_to_dn(state.electrons, gain, cam.black_level_dn, cam.adc_bits)

    return Stage("adc", "adc", run)


def output_stage(setup: SceneSetup) -> Stage:
    cam, effects = setup.scene.camera, setup.scene.effects
    if cam.output == "raw16":

        def run(state):
            state.image = state.dn

        return Stage("raw16", "output", run)
    if cam.output == "gray8":
        gamma = effects.tone_curve.gamma if effects.tone_curve is not None else None
        # Every DN maps to one gray level: a table lookup per pixel.
        lut = gray8_lut(cam.black_level_dn, cam.adc_bits, gamma)

        def run(state):
            state.image = lut[state.dn]

        return Stage("gray8" if gamma is None else "gray8_tone_curve", "output", run)
    if cam.output == "rgb8":
        # The scene loader lets rgb8 through only with the bayer effect.
        bayer, lut = effects.bayer, gray8_lut(cam.black_level_dn, cam.adc_bits)
        assert bayer is not None

        def run(state):
            state.image = demosaic(lut[state.dn], bayer.pattern, bayer.demosaic)

        return Stage(f"rgb8[{bayer.demosaic}]", "output", run)
    raise RollsimError(f"camera.output = {cam.output!r} is not available yet in this version of rollsim")


CORE_BUILDERS = (frame_start_stage, led_exposure_stage, led_signal_stage, full_well_stage, adc_stage, output_stage)


# ---------------------------------------------------------------- effects


def ambient_stage(setup: SceneSetup, params) -> Stage:
    """Ambient light: a lit background, hidden where the LED covers it, and
    ambient light reflected by the LED's face (which raises its OFF level)."""
    t_exp = setup.timing.exposure_s
    background = setup.background_e_per_s * t_exp  # a float, or a map (vignetting, a CFA)

    def correction_of(fp):
        # In the footprint the face replaces the background in proportion to coverage.
        return (_on_box(setup.face_e_per_s, fp) * t_exp - _on_box(background, fp)) * fp.coverage

    static_correction = correction_of(setup.footprint)

    def run(state):
        fp = state.led_footprint
        correction = static_correction if state.footprint is None else correction_of(fp)
        factor = state.ambient_row_factor  # flicker
        if factor is None:
            state.electrons += background
        else:
            state.electrons += background * factor[:, None]
            correction = correction * factor[fp.rows, None]
        if correction.size:
            state.electrons[fp.rows, fp.cols] += correction

    return Stage("ambient", "signal", run)


def dark_current_stage(setup: SceneSetup, params) -> Stage:
    dark = setup.scene.camera.dark_current_e_per_s * setup.timing.exposure_s

    def run(state):
        state.electrons += dark

    return Stage("dark_current", "dark", run)


def shot_noise_stage(setup: SceneSetup, params) -> Stage:
    if params.method == "poisson":
        # A mosaic is sampled by CFA phase, where the sampler's fast runs are.
        sampler = poisson if setup.scene.effects.bayer is None else poisson_by_phase

        def run(state):
            state.electrons = sampler(state.rng("shot_noise"), state.electrons)

    else:
        # Gaussian approximation N(μ, μ): one (table) normal deviate per pixel.
        def run(state):
            mean = state.electrons.astype(np.float32)
            noise = standard_normal(state.rng("shot_noise"), mean.shape, "table")
            noise *= np.sqrt(mean)
            noise += mean
            state.electrons = noise

    return Stage(f"shot_noise[{params.method}]", "shot", run)


def _fixed_map(setup: SceneSetup, stream: str) -> np.ndarray:
    # Fixed-pattern maps depend on the scene seed only (no frame key): the
    # same camera in every frame.
    return named_rng(setup.scene.seed, stream).standard_normal(setup.shape, dtype=np.float32)


def prnu_stage(setup: SceneSetup, params) -> Stage:
    gain_map = np.float32(1.0) + np.float32(0.01 * setup.scene.camera.prnu_percent) * _fixed_map(setup, "prnu")

    def run(state):
        state.electrons *= gain_map

    return Stage("prnu", "fixed_pattern", run)


def dsnu_stage(setup: SceneSetup, params) -> Stage:
    offset_map = np.float32(setup.scene.camera.dsnu_e) * _fixed_map(setup, "dsnu")

    def run(state):
        state.electrons += offset_map

    return Stage("dsnu", "fixed_pattern", run)


def read_noise_stage(setup: SceneSetup, params) -> Stage:
    sigma = np.float32(setup.scene.camera.read_noise_e)

    def run(state):
        noise = standard_normal(state.rng("read_noise"), state.electrons.shape, params.method)
        noise *= sigma
        noise += state.electrons
        state.electrons = noise

    return Stage(f"read_noise[{params.method}]", "read", run)


def tone_curve_stage(setup: SceneSetup, params):
    # The tone curve acts inside the gray8 conversion (before rounding to 8
    # bits); output_stage reads its gamma. No stage of its own.
    if setup.scene.camera.output != "gray8":
        raise RollsimError("effects.tone_curve: applies to camera.output = 'gray8' only")
    return None


def led_rise_time_stage(setup: SceneSetup, params) -> Stage:
    """First-order LED response: replaces each row's ∫ s dt by ∫ y dt."""
    timing, waveform, tau = setup.timing, setup.transmitter.waveform, params.tau_us * 1e-6
    if params.method == "exact":

        def run(state):
            start, end = timing.row_windows(state.start_s)
            # The core's exact ∫ s dt is the first term of the closed form.
            state.led_exposure_s = exposure_exact(waveform, start, end, tau, state.led_exposure_s)

    else:

        def run(state):
            start, end = timing.row_windows(state.start_s)
            state.led_exposure_s = exposure_sampled(waveform, start, end, tau, params.samples)

    return Stage(f"led_rise_time[{params.method}]", "exposure", run)


def frame_jitter_stage(setup: SceneSetup, params) -> Stage:
    """Frame k starts at k·T_f + ε_k."""
    cam = setup.scene.camera
    error = frame_jitter_error(cam, params)  # the loader refuses such scenes too
    if error:
        raise RollsimError(error)
    margin = frame_margin_s(cam.frame_period_s, cam.readout_s, cam.exposure_s)
    jitter = FrameJitter(setup.scene.seed, params.std_us * 1e-6, params.mode, margin)

    def run(state):
        state.start_s += jitter.offset_s(state.index)

    return Stage(f"frame_jitter[{params.mode}]", "timing", run)


def motion_stage(setup: SceneSetup, params) -> Stage:
    """Hand shake: this frame's LED footprint, each row seeing the LED where it is then."""
    scene, timing = setup.scene, setup.timing
    path = path_from_params(params, scene.seed, timing.frame_period_s)
    # With a lens PSF the frame's footprint is computed on a canvas extended
    # by the PSF's reach (rows there see the LED where it is at their time)
    # and blurred as the static footprint is once per scene. The blur mixes
    # rows up to R apart, so each row sees the LED's footprint as it was up
    # to R row times away: an error of the order of R·v·t_row pixels (4e-4
    # of coverage at the defaults; 0.05 for σ = 4 px at 13,000 px/s).
    kernels = hooks.lens_kernels(scene)[0]
    ry, rx = total_radius(kernels)
    height, width = setup.shape
    cx, cy = setup.led_centre_px
    rows = np.arange(-ry, height + ry)

    def run(state):
        mid_exposure_s = state.start_s + rows * timing.row_time_s + 0.5 * timing.exposure_s
        canvas = motion_footprint(path, (cx + rx, cy + ry), setup.led_size_px, scene.led.shape,
                                  (height + 2 * ry, width + 2 * rx), mid_exposure_s, scene.render.footprint_edge)
        fp = blur_canvas(canvas, kernels, setup.shape) if kernels else canvas
        state.footprint = fp
        state.led_rows = led_rows_from_coverage(fp.row_coverage(timing.height_px)) or ()

    return Stage(f"motion[{params.mode}]", "geometry", run)


def flicker_stage(setup: SceneSetup, params) -> Stage:
    """Mains flicker: each row's mean ambient illuminance over its exposure."""
    timing, mains_hz, phase = setup.timing, setup.scene.environment.mains_hz, math.radians(params.phase_deg)

    def run(state):
        start, _ = timing.row_windows(state.start_s)
        state.ambient_row_factor = flicker_row_factor(start, timing.exposure_s, mains_hz, params.depth, phase)

    return Stage("flicker", "exposure", run)


def blooming_stage(setup: SceneSetup, params) -> Stage:
    full_well = setup.scene.camera.full_well_e

    def run(state):
        bloom(state.electrons, full_well, params.spill_fraction)

    return Stage("blooming", "blooming", run)


def per_scene_only(setup: SceneSetup, params):
    # The effect's work is all in its per-scene hook (SETUP_HOOKS).
    return None


EFFECT_BUILDERS = {
    "ambient": ambient_stage,
    "dark_current": dark_current_stage,
    "shot_noise": shot_noise_stage,
    "prnu": prnu_stage,
    "dsnu": dsnu_stage,
    "read_noise": read_noise_stage,
    "tone_curve": tone_curve_stage,
    "led_rise_time": led_rise_time_stage,
    "frame_jitter": frame_jitter_stage,
    "motion": motion_stage,
    "flicker": flicker_stage,
    "blooming": blooming_stage,
    "blur": per_scene_only,
    "defocus": per_scene_only,
    "led_profile": per_scene_only,
    "glare": per_scene_only,
    "bayer": per_scene_only,
    "vignetting": per_scene_only,
}

# (effect names, hook), run in this order: the CFA recomputes the rates from
# spectra before the PSF and vignetting scale them; one PSF hook serves blur
# and defocus, whose kernels convolve when both are listed.
SETUP_HOOKS = (
    (("bayer",), hooks.colour_filter_array),
    (("blur", "defocus"), hooks.lens_psf),
    (("led_profile", "glare"), hooks.emitter_light),
    (("vignetting",), hooks.vignetting),
)


def prepare_setup(setup: SceneSetup):
    """Run the per-scene hooks of the listed effects once (see the module docstring).

    A setup already prepared is returned as it is.
    """
    if setup.prepared is not None:
        return setup
    listed = set(setup.scene.effects.enabled())
    ran = []
    for names, hook in SETUP_HOOKS:
        if listed.intersection(names):
            setup = hook(setup)
            ran += [name for name in names if name in listed]
    return replace(setup, prepared=tuple(ran))


def assemble_stages(setup: SceneSetup) -> list[Stage]:
    """The stages of a scene, in slot order: the core plus the listed effects only."""
    stages = [builder(setup) for builder in CORE_BUILDERS]
    effects = setup.scene.effects
    for name in effects.enabled():
        builder = EFFECT_BUILDERS.get(name)
        if builder is None:
            raise RollsimError(f"effects.{name}: this effect is not available yet in this version of rollsim")
        stage = builder(setup, getattr(effects, name))
        if stage is not None:
            stages.append(stage)
    order = {slot: i for i, slot in enumerate(SLOTS)}
    core = {id(s) for s in stages[: len(CORE_BUILDERS)]}
    # Stable sort: by slot, core first within a slot, then registry order.
    return sorted(stages, key=lambda s: (order[s.slot], id(s) not in core))
