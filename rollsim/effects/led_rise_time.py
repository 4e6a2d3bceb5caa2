"""``led_rise_time``: a first-order LED whose light lags its drive.

Replaces each row's ∫ s dt by ∫ y dt, y the LED's response with time
constant τ. See :mod:`rollsim.transmitter.led_response`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams, StageRun
from rollsim.transmitter.led_response import exposure_exact, exposure_sampled

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.render_contract.state import FrameState


class LedRiseTime(EffectParams):
    """A first-order LED: its light follows the drive with time constant ``tau_us``.

    ``method``: ``exact`` integrates the exponential segments in closed form;
    ``sampled`` averages the light at ``samples`` midpoints of each exposure
    window (a fidelity knob, compared against ``exact``). See
    :mod:`rollsim.transmitter.led_response`.
    """

    tau_us: float = Field(5.0, gt=0, le=1e6)
    method: Literal["exact", "sampled"] = "exact"
    samples: int = Field(16, ge=1, le=4096)


def build_stage(setup: SceneSetup, params: LedRiseTime) -> StageRun:
    timing, waveform, tau = setup.timing, setup.transmitter.waveform, params.tau_us * 1e-6
    if params.method == "exact":

        def run(state: FrameState) -> None:
            start, end = timing.row_windows(state.start_s)
            # The core's exact ∫ s dt is the first term of the closed form.
            state.led_exposure_s = exposure_exact(waveform, start, end, tau, state.led_exposure_s)

        return run

    def run_sampled(state: FrameState) -> None:
        start, end = timing.row_windows(state.start_s)
        state.led_exposure_s = exposure_sampled(waveform, start, end, tau, params.samples)

    return run_sampled


EFFECT = Effect(
    name="led_rise_time",
    params=LedRiseTime,
    slot="exposure",
    build_stage=build_stage,
    variant="method",
    reads=("state.start_s", "state.led_exposure_s"),
    writes=("state.led_exposure_s",),
)
