"""``motion``: hand shake, the LED's image moving during the frame.

Each frame's footprint is computed with every row seeing the LED where it
is at that row's mid-exposure (:mod:`rollsim.optics.motion`), and goes to
``state.footprint`` and ``state.led_rows``. Where ``led_profile`` or
``glare`` shape the LED's light, that light is an image of the LED too: a
translation moves it unchanged, so the light computed once at the rest
position is shifted per row (:func:`rollsim.optics.motion.moved_light`)
into ``state.led_light``, and the LED's rows move with it. The truth
records where each frame shows the LED's centre (``led_centre_px``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np
from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun
from rollsim.optics.footprint import led_rows_from_coverage
from rollsim.optics.motion import RestLight, centre_seen_px, footprint_at_offsets, path_from_params, path_on_grid
from rollsim.optics.psf import blur_canvas, total_radius

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState


class Motion(EffectParams):
    """Hand shake: the LED's image position moves, per axis, as a random walk
    reflected at ±``amplitude_*_px`` (steps of std ``step_*_px`` per frame),
    as a sinusoid of amplitude ``amplitude_*_px`` at ``frequency_hz``, or as
    a camera held in the hand (``handheld``): tremor of ``tremor_deg`` (rms
    angle, 8–12 Hz) on drift of ``drift_deg`` (rms, 0.1–1 Hz), in the
    camera's pan and tilt (pixels: the angle × focal length / pixel pitch)
    and its roll (``roll_tremor_deg``, ``roll_drift_deg``) about the frame's
    centre. The handheld amplitudes' defaults are assumed (see
    docs/scenes.md). See :mod:`rollsim.optics.motion`."""

    mode: Literal["random_walk", "sinusoid", "handheld"] = "random_walk"
    amplitude_x_px: float = Field(8.0, ge=0, le=1e4)
    amplitude_y_px: float = Field(8.0, ge=0, le=1e4)
    step_x_px: float = Field(2.0, ge=0, le=1e4)
    step_y_px: float = Field(2.0, ge=0, le=1e4)
    frequency_hz: float = Field(10.0, gt=0, le=1e4)
    phase_x_deg: float = Field(0.0, ge=-360, le=360)
    phase_y_deg: float = Field(90.0, ge=-360, le=360)
    tremor_deg: float = Field(0.05, ge=0, le=10)
    drift_deg: float = Field(0.3, ge=0, le=30)
    roll_tremor_deg: float = Field(0.05, ge=0, le=10)
    roll_drift_deg: float = Field(0.3, ge=0, le=30)


def build_stage(setup: SceneSetup, params: Motion) -> StageRun:
    scene, timing = setup.scene, setup.timing
    cam = scene.camera
    cx, cy = setup.led_centre_px
    lever = (cx - 0.5 * cam.width_px, cy - 0.5 * cam.height_px)
    path = path_from_params(params, scene.seed, timing.frame_period_s,
                            px_per_rad=cam.focal_length_mm * 1e-3 / (cam.pixel_pitch_um * 1e-6), lever_px=lever)
    # With a lens PSF the frame's footprint is computed on a canvas extended
    # by the PSF's reach (rows there see the LED where it is at their time)
    # and blurred as the static footprint is once per scene. The blur mixes
    # rows up to R apart, so each row sees the LED's footprint as it was up
    # to R row times away: an error of the order of R·v·t_row pixels (4e-4
    # of coverage at the defaults; 0.05 for σ = 4 px at 13,000 px/s).
    kernels = list(setup.lens_kernels)
    ry, rx = total_radius(kernels)
    height, width = setup.shape
    rows = np.arange(-ry, height + ry)
    # The rest position's light, where led_profile or glare shape it, padded once for every frame.
    light = None if setup.led_light is None else RestLight.of(setup.led_light, setup.shape)

    # Each row sees the LED at its mid-exposure, at fixed times from the frame's start.
    grid = path_on_grid(path, (rows - rows % timing.binning_rows) * timing.row_time_s, 0.5 * timing.exposure_s)

    def run(state: FrameState) -> None:
        # One evaluation of the path per frame serves the footprint and the moved light.
        offsets = grid.offset_px(state.start_s)
        canvas = footprint_at_offsets(offsets, (cx + rx, cy + ry), setup.led_size_px, scene.led.shape,
                                      (height + 2 * ry, width + 2 * rx), scene.render.footprint_edge)
        fp = blur_canvas(canvas, kernels, setup.shape) if kernels else canvas
        state.footprint = fp
        frame_offsets = offsets[ry:ry + height]
        state.led_centre_px = centre_seen_px(frame_offsets, (cx, cy))
        if light is None:
            state.led_rows = led_rows_from_coverage(fp.row_coverage(timing.height_px)) or ()
            return
        state.led_light = light.moved(frame_offsets)
        state.led_rows = moved_rows(setup.led_rows, frame_offsets[:, 1])

    return run


def moved_rows(rest_rows, dy_px: np.ndarray):
    """The LED's rows (first, last) of a frame whose row y shows the rest position's row y − dy_y:
    the rows whose source lies in the rest rows (``()`` when none does). A source past the frame's
    edge counts as the edge row, as :func:`rollsim.optics.motion.moved_light` continues the light."""
    if not rest_rows:
        return ()
    first, last = rest_rows
    # A row shows mostly its nearest source row (bilinear weights).
    source = np.clip(np.rint(np.arange(dy_px.size) - dy_px), 0, dy_px.size - 1)
    inside = np.flatnonzero((source >= first) & (source <= last))
    return (int(inside[0]), int(inside[-1])) if inside.size else ()


EFFECT = Effect(
    name="motion",
    params=Motion,
    slot="geometry",
    build_stage=build_stage,
    variant="mode",
    reads=("state.start_s", "setup.lens_kernels", "setup.led_size_px", "setup.led_light", "setup.led_rows"),
    writes=("state.footprint", "state.led_light", "state.led_rows", "state.led_centre_px"),
)
