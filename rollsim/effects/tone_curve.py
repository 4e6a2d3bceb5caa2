"""``tone_curve``: the ISP's tone curve for 8-bit output (gamma, sRGB or measured).

The curve acts inside the core's 8-bit conversion, after the black clip and
before rounding: the hook sets ``setup.tone`` and the output stage's table
lookup applies it (:func:`rollsim.sensor.adc.dn_to_gray8`). No stage of its
own, so it costs nothing per frame. The curves are
:class:`rollsim.sensor.tone.ToneCurve`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Literal, Optional

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams
from rollsim.sensor.tone import ToneCurve as Curve
from rollsim.sensor.tone import validate_table

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup
    from rollsim.scene_sections import SceneSections


class ToneCurve(EffectParams):
    """The tone curve of ``gray8`` or ``rgb8`` output.

    ``curve``: ``gamma`` (default: v^(1/``gamma``)), ``srgb`` (IEC 61966-2-1)
    or ``table`` (a measured curve: ``table`` is a list of [input, output]
    pairs, inputs rising from 0 to 1, outputs in [0, 1] and never falling,
    interpolated linearly; input is the linear signal above the black level
    as a fraction of the ADC range).
    """

    curve: Literal["gamma", "srgb", "table"] = "gamma"
    gamma: float = Field(2.2, gt=0, le=10)
    table: Optional[list[list[float]]] = None


def check(scene: SceneSections, params: ToneCurve) -> str | None:
    if scene.camera.output not in ("gray8", "rgb8"):
        return "effects.tone_curve: applies to camera.output = 'gray8' or 'rgb8' only"
    if params.curve == "table":
        if params.table is None:
            return "effects.tone_curve.table: curve 'table' needs a table of [input, output] pairs"
        why = validate_table(params.table)
        if why:
            return f"effects.tone_curve.table: {why}"
    elif params.table is not None:
        return f"effects.tone_curve.table: given, but curve is {params.curve!r}; set curve: table"
    return None


def tone_of(params: ToneCurve) -> Curve:
    """The :class:`rollsim.sensor.tone.ToneCurve` these parameters describe."""
    table = tuple(tuple(p) for p in params.table) if params.table is not None else ()
    return Curve(kind=params.curve, gamma=params.gamma, table=table)


def prepare(setup: SceneSetup, params: ToneCurve) -> SceneSetup:
    return replace(setup, tone=tone_of(params))


EFFECT = Effect(name="tone_curve", params=ToneCurve, prepare=prepare, check=check, writes=("setup.tone",))
