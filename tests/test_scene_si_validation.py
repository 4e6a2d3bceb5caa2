"""Scene values that are valid in their unit but unusable in SI are refused at load, naming the field.

Issue 46, item 4. The property test enumerates every float field of the
scene model, the effects' parameter models included, so a field added
later is covered without touching this file.
"""

from __future__ import annotations

import math
import sys
import types
import typing
import warnings

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel

from rollsim.cli import main
from rollsim.stages.describe import describe_scene
from rollsim.effects import REGISTRY
from rollsim.errors import RollsimError, SceneError
from rollsim.scene import Scene, read_yaml, resolve_scene_path, scene_from_dict
from rollsim.scene.si import MIN_POSITIVE_SI, si_unit, si_value_error

BASE_SCENE = "paper-default"
BASE_DATA = read_yaml(resolve_scene_path(BASE_SCENE))
# paper-default lists glare, whose readable rows cost a render setup
# (0.3 s) per scene: the default run leaves it out except for glare's own
# fields; the slow run has it either way.
WITHOUT_GLARE = {"effects.glare": False}
# Parameters an effect has no default for, to list it at all.
REQUIRED_PARAMS = {"defocus": {"effects.defocus.focus_distance_cm": 10.0}}


def _model_in(annotation) -> typing.Optional[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    return next(filter(None, map(_model_in, typing.get_args(annotation))), None)


def _float_kind(annotation) -> typing.Optional[str]:
    """``"float"``, ``"list"`` (of floats, as ``led.position_px``) or None, through Optional."""
    if annotation is float:
        return "float"
    if typing.get_origin(annotation) is list and typing.get_args(annotation) == (float,):
        return "list"
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return next(filter(None, map(_float_kind, typing.get_args(annotation))), None)
    return None


def float_fields(model: type[BaseModel], prefix: str = "") -> list[tuple[str, bool]]:
    """``(dotted key, is a list)`` of every float field under ``model``, found from the models."""
    found = []
    for name, field in model.model_fields.items():
        key = f"{prefix}{name}"
        inner = _model_in(field.annotation)
        if inner is not None:
            found += float_fields(inner, key + ".")
        elif _float_kind(field.annotation) is not None:
            found.append((key, _float_kind(field.annotation) == "list"))
    return found


FLOAT_FIELDS = float_fields(Scene)
EFFECTS = {effect.name: effect for effect in REGISTRY}


def base_values(key: str, glare: bool) -> dict:
    """``--set`` values under which ``key``'s default loads: its effect listed, with what that needs."""
    values = {} if glare else dict(WITHOUT_GLARE)
    parts = key.split(".")
    if parts[0] != "effects":
        return values
    effect = EFFECTS[parts[1]]
    values.update({f"effects.{name}": {} for name, _why in effect.requires})
    values.update({f"effects.{name}": False for name, _why in effect.excludes})
    values[f"effects.{effect.name}"] = {}
    values.update(REQUIRED_PARAMS.get(effect.name, {}))
    return values


def _nonfinite(value, path: str = "") -> list[str]:
    """Paths of the non-finite floats in a describe dict."""
    if isinstance(value, dict):
        return [bad for key, item in value.items() for bad in _nonfinite(item, f"{path}.{key}")]
    if isinstance(value, (list, tuple)):
        return [bad for item in value for bad in _nonfinite(item, path)]
    return [path] if isinstance(value, float) and not math.isfinite(value) else []


def check_loads_or_names_field(key: str, value: float, is_list: bool, glare: bool) -> None:
    """Load the base scene with ``key = value``: a clean refusal naming the field, or finite figures."""
    given_value = [value, value] if is_list else value
    values = {**base_values(key, glare), key: given_value}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning, overflow or 0/0, is a failure
        try:
            scene = scene_from_dict(BASE_DATA, BASE_SCENE, values=values)
        except SceneError as exc:
            # A cross-field line names the other field and quotes this value.
            assert all("\n" not in line for line in exc.lines)
            assert key in str(exc) or f"{value:g}" in str(exc), exc.lines
            return
        try:
            info = describe_scene(scene)
        except RollsimError as exc:
            # An effect's per-scene setup may refuse a value it cannot
            # render (defocus: a blur circle over 1000 px), naming it; the
            # MMBP analysis refuses a cycle longer than its work budget
            # (0.01 Hz frames, 10 MHz chips), naming what makes it long.
            assert key in str(exc) or "for the exact sum" in str(exc), str(exc)
            return
    bad = _nonfinite(info)
    # Documented: a link that never decodes expects inf emissions (rateless.rlnc_figures).
    if info["link"].get("goodput_rlnc_bps") == 0.0:
        bad = [path for path in bad if path != ".link.expected_emissions_rlnc"]
    assert not bad, (key, value, bad)


# ------------------------------------------------------------------ the CLI case


def test_subnormal_exposure_is_one_line_through_the_cli(capsys):
    code = main(["describe", BASE_SCENE, "--set", "camera.exposure_us=5e-324"])
    err = capsys.readouterr().err
    assert code == 2
    lines = err.splitlines()
    assert len(lines) == 1 and "camera.exposure_us = 5e-324" in lines[0], err
    assert "becomes 0 s in SI" in lines[0] and "must be >= 1e-09 us" in lines[0]
    assert "Traceback" not in err


# ------------------------------------------------------------------ the rule


@pytest.mark.parametrize("path, value, positive, expected", [
    ("camera.exposure_us", 5e-324, True, "camera.exposure_us = 5e-324: too small (becomes 0 s in SI); must be >= 1e-09 us"),
    ("camera.exposure_us", 1e-12, True, "too small (becomes 1e-18 s in SI)"),
    ("camera.iso", 1e-300, True, "camera.iso = 1e-300: too small; must be >= 1e-15"),
    ("camera.prnu_percent", 1e-307, False, "must be 0 or at least 2.23e-306 % in magnitude"),
    ("link.start_offset_us", -1e-310, False, "becomes -1e-316 s in SI"),
    ("led.position_px", math.nan, False, "led.position_px = nan: must be a finite number"),
    ("led.position_px", -math.inf, False, "must be a finite number"),
    ("effects.glare.core_angle_deg", 1e-310, True, "must be >= 5.73e-14 deg"),
])
def test_unusable_values_name_field_value_and_bound(path, value, positive, expected):
    assert expected in si_value_error(path, value, positive)


@pytest.mark.parametrize("path, value, positive", [
    ("camera.exposure_us", 1e-9, True), ("camera.prnu_percent", 0.0, False), ("camera.prnu_percent", -0.0, False),
    ("link.start_offset_us", -1e9, False), ("channel.p_e", 1e-300, False), ("camera.iso", 1e7, True),
])
def test_usable_values_pass(path, value, positive):
    assert si_value_error(path, value, positive) is None


def test_unit_suffixes_give_si_factors():
    assert si_unit("exposure_us") == ("us", 1e-6, "s")
    assert si_unit("distance_cm") == ("cm", 1e-2, "m")
    assert si_unit("dark_current_e_per_s") == ("e-/s", 1.0, "e-/s")
    assert si_unit("prnu_percent") == ("%", 1e-2, "")
    assert si_unit("iso") == ("", 1.0, "")


def test_every_section_and_effect_has_its_float_fields_enumerated():
    keys = {key for key, _ in FLOAT_FIELDS}
    assert {"camera.exposure_us", "led.size_mm", "link.distance_cm", "environment.ambient_lux", "channel.p_e",
            "led.position_px", "effects.glare.core_angle_deg", "effects.defocus.focus_distance_cm"} <= keys
    with_floats = {key.split(".")[1] for key in keys if key.startswith("effects.")}
    assert with_floats >= {"blur", "glare", "motion", "led_rise_time", "dark_current"}


@pytest.mark.parametrize("key", [key for key, _ in FLOAT_FIELDS])
def test_every_fields_base_scene_loads(key):
    scene_from_dict(BASE_DATA, BASE_SCENE, values=base_values(key, glare=False))


def test_the_smallest_positive_value_is_above_float32_underflow():
    # Stages in float32 square and invert these values.
    assert MIN_POSITIVE_SI**2 > 1e-38 and 1.0 / MIN_POSITIVE_SI**2 < 3e38
    assert sys.float_info.min < MIN_POSITIVE_SI


# ------------------------------------------------------------------ the property

EDGE_VALUES = [5e-324, -5e-324, 1e-310, sys.float_info.min, 0.0, -0.0, math.inf, -math.inf, math.nan, 1e308, -1e308,
               1e-300, -1e-300, 1e-30, 1e-15, 1e-9]
ORDINARY_VALUES = [1e-3, 0.01, 0.5, 1.0, 2.5, 10.0, 90.0, 1e3, 1e5]
values = st.one_of(st.sampled_from(EDGE_VALUES), st.sampled_from(ORDINARY_VALUES),
                   st.floats(min_value=-1e4, max_value=1e4), st.floats(allow_subnormal=True))


def _is_glare(key: str) -> bool:
    return key.startswith("effects.glare.")


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(field=st.sampled_from(FLOAT_FIELDS), value=values)
def test_any_float_loads_finite_or_is_refused_naming_its_field(field, value):
    key, is_list = field
    check_loads_or_names_field(key, value, is_list, glare=_is_glare(key))


@pytest.mark.slow
@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(field=st.sampled_from(FLOAT_FIELDS), value=values, glare=st.booleans())
def test_any_float_loads_finite_or_is_refused_naming_its_field_at_length(field, value, glare):
    key, is_list = field
    check_loads_or_names_field(key, value, is_list, glare=glare or _is_glare(key))


@pytest.mark.parametrize("override, fragment", [
    ("camera.frame_rate_hz=0.01", "the hyperperiod of the frame period and the PHY-SDU duration"),
    ("link.clock_hz=1e7", "(camera.frame_rate_hz, link.clock_hz) is too long for the exact sum"),
    ("channel.p_e=0.99999999", "p_e = 0.99999999 is too close to 1 for the exact sum"),
])
def test_an_exact_sum_over_its_work_budget_is_one_line_naming_the_cause(capsys, override, fragment):
    code = main(["describe", "paper-default", "--set", override])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert err.count("\n") == 1 and fragment in err, err


def test_a_probability_named_like_a_unit_is_a_plain_number(capsys):
    # p_e ends like electrons ("_e") but is the paper's PHY-SDU error probability.
    assert main(["describe", "paper-default", "--set", "channel.p_e=1e-320"]) == 2
    err = capsys.readouterr().err
    assert "channel.p_e = 1e-320: too small; must be 0 or at least 2.23e-308 in magnitude" in err, err
