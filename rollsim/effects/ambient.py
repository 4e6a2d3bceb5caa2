"""``ambient``: ambient light on the background and on the LED's face.

A lit background, hidden where the LED covers it, and ambient light
reflected by the LED's face (which raises its OFF level). The illuminances
come from ``environment`` (:mod:`rollsim.optics.scene_light`); the
``flicker`` effect modulates them row by row through
``state.ambient_row_factor``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rollsim.effects.base import Effect, NoParams, StageRun, on_box

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState


def build_stage(setup: SceneSetup, params: NoParams) -> StageRun:
    t_exp = setup.timing.exposure_s
    background = setup.background_e_per_s * t_exp  # a float, or a map (vignetting, a CFA)

    def correction_of(fp):
        # In the footprint the face replaces the background in proportion to coverage.
        return (on_box(setup.face_e_per_s, fp) * t_exp - on_box(background, fp)) * fp.coverage

    static_correction = correction_of(setup.footprint)

    def run(state: FrameState) -> None:
        fp = state.led_footprint
        correction = static_correction if state.footprint is None else correction_of(fp)
        factor = state.ambient_row_factor  # flicker
        level = background
        if factor is not None:  # a level per row (an (H, 1) column), or a map
            level = background * factor[:, None]
            correction = correction * factor[fp.rows, None]
        means = state.means
        if means is not None and means.accepts("background"):
            # Joins the LED's light as a part: no frame written (rollsim.sensor.means).
            state.means = means.with_ambient(level, fp.rows, fp.cols, correction)
            return
        state.electrons += level
        if correction.size:
            state.electrons[fp.rows, fp.cols] += correction

    return run


EFFECT = Effect(
    name="ambient",
    params=NoParams,
    slot="signal",
    build_stage=build_stage,
    reads=("state.footprint", "state.ambient_row_factor", "state.means", "setup.background_e_per_s", "setup.face_e_per_s"),
    writes=("state.electrons", "state.means"),
)
