"""Render stages: the core chain, and the pipeline assembled from the effects registry.

A stage is a callable that takes a :class:`FrameState` and fills in or
modifies its arrays. Each has a ``slot``; the pipeline runs slots in the
order of :data:`~rollsim.effects.base.SLOTS` (the EMVA 1288 order for the
sensor), core stage first within a slot. The core (timing, exact exposure
integral, footprint, full well, ADC, output) always runs; every other stage
comes from an effect the scene lists, each defined in its own module of
:mod:`rollsim.effects` (its parameters, slot, per-scene hook and stage).

Per-scene hooks. An effect that changes what every frame shares rather than
adding work to each frame (a lens PSF reshapes the LED's coverage map;
vignetting and a colour filter array make the electron rates per-pixel maps)
has a ``prepare`` hook, ``(setup, params) -> setup``. :func:`prepare_setup`
runs the hooks of the listed effects once per scene, in registry order,
before any stage is built; the pipeline's stages and truth then read the
prepared setup. The rates a hook leaves are a float or an (H, W) map; the
stages take either.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from rollsim.effects.base import SLOTS, Stage, on_box
from rollsim.errors import RollsimError
from rollsim.sensor import electrons_to_dn, gray8_lut
from rollsim.sensor.cfa import demosaic
from rollsim.sensor.chain import CHAIN_ORDER, Adc, ChainKeys, ChainStep, run_chain, run_noiseless_chain
from rollsim.sensor.means import SeparableMeans

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup

__all__ = ["SLOTS", "Stage", "assemble_stages", "fuse_chain", "prepare_setup"]

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
    static_coverage = static.coverage * on_box(rate, static) if np.ndim(rate) else static.coverage
    scalar_rate = 1.0 if np.ndim(rate) else rate

    def coverage_of(fp):
        if fp is static:
            return static_coverage
        return fp.coverage * on_box(rate, fp) if np.ndim(rate) else fp.coverage

    def run(state):
        if state.led_light is not None:
            fp = state.led_light
        else:
            fp = static if state.footprint is None else state.footprint
        if fp.coverage.size:
            # As parts (rollsim.sensor.means): the frame is written only if a
            # stage reads it; the compiled chain reads the parts.
            state.means = SeparableMeans(shape, fp.rows, fp.cols, coverage_of(fp),
                                         scalar_rate * state.led_exposure_s[fp.rows])
        else:
            state.electrons = np.zeros(shape)

    return Stage("led_signal", "signal", run)


def full_well_stage(setup: SceneSetup) -> Stage:
    full_well = setup.scene.camera.full_well_e

    def run(state):
        np.clip(state.electrons, 0.0, full_well, out=state.electrons)

    return Stage("full_well", "full_well", run, ChainStep("full_well", float(full_well)))


def adc_stage(setup: SceneSetup) -> Stage:
    cam, gain = setup.scene.camera, setup.gain_dn_per_e

    def run(state):
        state.dn = electrons_to_dn(state.electrons, gain, cam.black_level_dn, cam.adc_bits)

    return Stage("adc", "adc", run, ChainStep("adc", Adc(float(gain), int(cam.black_level_dn), int(cam.adc_bits))))


def output_stage(setup: SceneSetup) -> Stage:
    cam = setup.scene.camera
    if cam.output == "raw16":

        def run(state):
            state.image = state.dn

        return Stage("raw16", "output", run, ChainStep("output", None))
    if cam.output == "gray8":
        # Every DN maps to one gray level: a table lookup per pixel (with the tone curve's).
        lut = gray8_lut(cam.black_level_dn, cam.adc_bits, setup.tone)

        def run(state):
            state.image = lut[state.dn]

        return Stage("gray8" if setup.tone is None else "gray8_tone_curve", "output", run, ChainStep("output", lut))
    if cam.output == "rgb8":
        # The scene loader lets rgb8 through only with the bayer effect.
        pattern, method, lut = setup.cfa_pattern, setup.demosaic, gray8_lut(cam.black_level_dn, cam.adc_bits, setup.tone)
        if pattern is None or method is None:
            raise RollsimError("camera.output = 'rgb8': needs the bayer effect")

        def finish(mosaic):
            return demosaic(mosaic, pattern, method)

        def run(state):
            state.image = finish(lut[state.dn])

        # The table joins the sensor chain (no frame of DN written); the
        # demosaicing follows it.
        return Stage(f"rgb8[{method}]", "output", run, ChainStep("output", lut, finish=finish))
    raise RollsimError(f"camera.output = {cam.output!r} is not available yet in this version of rollsim")


def binning_stage(setup: SceneSetup) -> Stage | None:
    """Binned readout (``camera.binning_rows`` = k > 1): each group of k rows,
    exposed together (:meth:`rollsim.sensor.RowTiming.row_windows`), is
    averaged (rounded half up) and written to all k rows. The mean is kept;
    the temporal variance of the k independent rows falls k-fold."""
    k = setup.scene.camera.binning_rows
    if k == 1:
        return None

    def run(state):
        image = state.image
        groups = image.reshape(image.shape[0] // k, k, *image.shape[1:]).astype(np.uint32)
        mean = ((groups.sum(axis=1) + k // 2) // k).astype(image.dtype)
        state.image = np.repeat(mean, k, axis=0)

    return Stage("binning", "output", run)


CORE_BUILDERS = (frame_start_stage, led_exposure_stage, led_signal_stage, full_well_stage, adc_stage, output_stage,
                 binning_stage)


def _check_effects(setup: SceneSetup) -> None:
    # The scene loader reports these too; a scene built another way is refused here.
    errors = setup.scene.effects.errors(setup.scene)
    if errors:
        raise RollsimError(errors[0])


def prepare_setup(setup: SceneSetup) -> SceneSetup:
    """Run the per-scene hooks of the listed effects once (see the module docstring).

    A setup already prepared is returned as it is.
    """
    if setup.prepared is not None:
        return setup
    _check_effects(setup)
    ran = []
    for effect, params in setup.scene.effects.listed():
        if effect.prepare is not None:
            setup = effect.prepare(setup, params)
            ran.append(effect.name)
    return replace(setup, prepared=tuple(ran))


def assemble_stages(setup: SceneSetup) -> list[Stage]:
    """The stages of a scene, in slot order: the core plus the listed effects only.

    ``setup`` comes from :func:`prepare_setup`, which checked the effects.
    """
    core = [stage for stage in (builder(setup) for builder in CORE_BUILDERS) if stage is not None]
    stages = [effect.stage(setup, params) for effect, params in setup.scene.effects.listed()]
    order = {slot: i for i, slot in enumerate(SLOTS)}
    # Stable sort: by slot, core first within a slot, then registry order.
    ranked = [(order[s.slot], 0, s) for s in core] + [(order[s.slot], 1, s) for s in stages if s is not None]
    return [s for *_, s in sorted(ranked, key=lambda item: item[:2])]


# ------------------------------------------------------------ the chain


# The steps that make the electrons float32: a chain that starts with one
# always runs fused. A chain that starts later (the clip or the ADC after
# blooming or a fixed-pattern offset) runs fused when the electrons it is
# given are float32, as the kernel takes them; on the float64 means of a
# render without noise, the clip, the ADC and the output table run in one
# compiled float64 pass (run_noiseless_chain), else its stages one by one.
_NOISE_STEPS = ("shot", "read")


def _chain_run_length(stages: list[Stage], first: int) -> int:
    """How many stages from ``first`` on form one sensor chain: steps in chain order."""
    step = stages[first].chain_step
    if step is None:
        return 0
    rank = CHAIN_ORDER.index(step.kind)
    length = 1
    for stage in stages[first + 1:]:
        following = stage.chain_step
        if following is None or CHAIN_ORDER.index(following.kind) <= rank:
            break
        rank = CHAIN_ORDER.index(following.kind)
        length += 1
    return length


def fused_chain_stage(run: list[Stage]) -> Stage:
    """One stage doing the work of ``run``'s chain steps in one pass (:mod:`rollsim.sensor.chain`).

    Each noise step keys its counter stream from its own named stream, as
    the stage alone does, so the result is the same bytes as the stages run
    one by one (tested).
    """
    steps = {stage.chain_step.kind: stage.chain_step for stage in run if stage.chain_step is not None}
    shot, read = steps.get("shot"), steps.get("read")
    full_well = steps["full_well"].value if "full_well" in steps else None
    adc = steps["adc"].value if "adc" in steps else None
    output = steps.get("output")
    last = CHAIN_ORDER[max(CHAIN_ORDER.index(kind) for kind in steps)]

    noise_first = run[0].chain_step is not None and run[0].chain_step.kind in _NOISE_STEPS

    noiseless = adc is not None and shot is None and read is None

    def run_float64(state):
        # float64 electrons: the stages' own arithmetic, in one compiled pass
        # where the run has no noise, reaches the ADC and the kernels are used.
        done = run_noiseless_chain(state.electrons, full_well, adc, None if output is None else output.value) \
            if noiseless else None
        if done is None:
            for stage in run:
                stage(state)
            return
        # What the stages one by one leave: the clipped electrons, the DN, the output.
        state.electrons, state.dn = done.electrons, done.dn
        if last == "output":
            state.image = done.dn if output.value is None else (
                done.image if output.finish is None else output.finish(done.image))

    def run_fused(state):
        if not noise_first and (state.means is not None or state.electrons.dtype != np.float32):
            run_float64(state)
            return
        keys = ChainKeys(shot=None if shot is None else state.counter_key(shot.stream),
                         read=None if read is None else state.counter_key(read.stream))
        result = run_chain(state.means_or_electrons, None if shot is None else shot.value, keys, full_well_e=full_well,
                           read_sigma_e=None if read is None else read.value, adc=adc,
                           lut=None if output is None else output.value)
        if last in ("shot", "full_well", "read"):
            state.electrons = result
        elif last == "adc" or output.value is None:  # raw16 output is the DN
            state.dn = result
        if last == "output":
            state.image = result if output.finish is None else output.finish(result)

    return Stage("+".join(stage.name for stage in run), run[0].slot, run_fused)


def fuse_chain(stages: list[Stage]) -> list[Stage]:
    """``stages`` with each run of two or more consecutive sensor-chain steps fused into one stage."""
    fused: list[Stage] = []
    index = 0
    while index < len(stages):
        length = _chain_run_length(stages, index)
        if length >= 2:
            fused.append(fused_chain_stage(stages[index:index + length]))
            index += length
        else:
            fused.append(stages[index])
            index += 1
    return fused
