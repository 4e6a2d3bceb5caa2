"""One effect, one module: the scene schema and the pipeline both come from the registry.

The last part adds a toy "constant offset" effect the way
docs/adding-an-effect.md describes, in this file only, and checks that it
appears in the scene schema and runs in the pipeline.
"""

import ast
import dataclasses
import pkgutil
from pathlib import Path
from typing import Optional, get_args

import numpy as np
import pytest
from pydantic import Field

import rollsim.effects
from rollsim.effects import REGISTRY, SLOTS, Effect, EffectParams, NoParams
from rollsim.errors import SceneError
from rollsim.render import RenderPipeline
from rollsim.render_contract.setup import SceneSetup
from rollsim.render_contract.state import FrameState
from rollsim.scene import EFFECT_NAMES, Effects, Scene, scene_from_dict, scene_model

# Modules of rollsim.effects that are not effects: the concept, and helpers
# that more than one effect's physics shares.
HELPERS = {"base", "lens", "readable"}
EFFECTS_DIR = Path(rollsim.effects.__file__).parent
# Effects of the ISP, which act on 8-bit output only.
EIGHT_BIT = {"tone_curve", "isp_smoothing", "sharpening", "jpeg", "video_codec"}


def small_scene(effects, registry=None, **camera):
    data = {
        "name": "registry",
        "seed": 3,
        "camera": {"preset": "nexus5", "width_px": 64, "height_px": 80, "row_time_us": 20.0, "output": "raw16", **camera},
        "led": {"size_mm": 30.0, "luminous_intensity_cd": 0.05},
        "link": {"distance_cm": 5.0},
        "effects": effects,
    }
    return scene_from_dict(data, registry=registry)


def minimal_listing(effect):
    """The effect with default parameters (``defocus``'s required focus
    distance given), plus the effects it requires."""
    params = {"defocus": {"focus_distance_cm": 7.5}}.get(effect.name, {})
    listing = {effect.name: params}
    listing.update({other: {} for other, _ in effect.requires})
    return listing


# ------------------------------------------------------------------ the list


def test_every_effect_module_is_registered_once():
    modules = {info.name for info in pkgutil.iter_modules([str(EFFECTS_DIR)])} - HELPERS
    registered = [effect.name for effect in REGISTRY]
    assert sorted(registered) == sorted(modules)
    assert len(set(registered)) == len(registered)
    for name in modules:
        module = __import__(f"rollsim.effects.{name}", fromlist=["EFFECT"])
        assert module.EFFECT.name == name, f"rollsim.effects.{name} defines effect {module.EFFECT.name!r}"


def test_the_scene_schema_is_the_registry():
    assert EFFECT_NAMES == tuple(Effects.model_fields) == tuple(effect.name for effect in REGISTRY)
    assert Effects.registry == REGISTRY
    for effect in REGISTRY:
        field = Effects.model_fields[effect.name]
        assert field.default is None
        assert set(get_args(field.annotation)) == {effect.params, type(None)}
    schema = Scene.model_json_schema()
    effects_schema = schema["$defs"]["Effects"]["properties"]
    assert list(effects_schema) == list(EFFECT_NAMES)


@pytest.mark.parametrize("effect", REGISTRY, ids=lambda e: e.name)
def test_the_pipeline_is_the_registry(effect):
    """Listing an effect adds its stage (in its slot) and runs its hook, and nothing else."""
    output = "rgb8" if effect.name == "bayer" else "gray8" if effect.name in EIGHT_BIT else "raw16"
    scene = small_scene(minimal_listing(effect), output=output)
    pipeline = RenderPipeline(scene)
    bare = RenderPipeline(small_scene({other: {} for other, _ in effect.requires},
                                      output="gray8" if output == "rgb8" else output))
    params = getattr(scene.effects, effect.name)
    added = [s for s in pipeline.planned_stages if s.name not in bare.stage_names]
    if effect.slot is None:
        assert not any(s.name.startswith(effect.name) for s in added)
    else:
        assert [(s.name, s.slot) for s in added if s.name.startswith(effect.name)] == [(effect.stage_name(params), effect.slot)]
    assert (effect.name in pipeline.setup.prepared) == (effect.prepare is not None)
    pipeline.render(0)


def test_stages_run_in_slot_order():
    scene = small_scene({effect.name: {} for effect in REGISTRY if effect.slot and not effect.excludes}, output="gray8")
    slots = [stage.slot for stage in RenderPipeline(scene).planned_stages]
    assert slots == sorted(slots, key=SLOTS.index)


# ---------------------------------------------------- declared inputs, outputs


@pytest.mark.parametrize("effect", REGISTRY, ids=lambda e: e.name)
def test_declared_fields_exist(effect):
    # A state's fields, and its properties over private fields (electrons over _electrons and means).
    properties = {name for name, value in vars(FrameState).items() if isinstance(value, property)}
    fields = {"state": {f.name for f in dataclasses.fields(FrameState)} | properties,
              "setup": {f.name for f in dataclasses.fields(SceneSetup)}}
    for declared in effect.reads + effect.writes:
        owner, _, name = declared.partition(".")
        assert name in fields.get(owner, ()), f"{effect.name}: {declared} is not a field"
    if effect.prepare is None:
        assert not [w for w in effect.writes if w.startswith("setup.")], f"{effect.name}: a stage cannot change the setup"


def test_a_hook_that_sets_a_field_comes_before_every_hook_that_reads_it():
    hooks = [effect for effect in REGISTRY if effect.prepare is not None]
    for i, setter in enumerate(hooks):
        for field in set(setter.writes) - set(setter.reads):
            earlier_readers = [e.name for e in hooks[:i] if field in e.reads]
            assert not earlier_readers, f"{setter.name} sets {field}, read before by {earlier_readers}"


def _effect_settings_read(tree: ast.AST) -> set[str]:
    """Names X of every ``<...>.effects.X`` in a module's code."""
    return {node.attr for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute) and node.value.attr == "effects"}


@pytest.mark.parametrize("effect", REGISTRY, ids=lambda e: e.name)
def test_an_effect_reads_no_other_effects_settings(effect):
    tree = ast.parse((EFFECTS_DIR / f"{effect.name}.py").read_text())
    assert not _effect_settings_read(tree) & set(EFFECT_NAMES)
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.module}
    others = {m.rsplit(".", 1)[1] for m in imported if m.startswith("rollsim.effects.")} - HELPERS
    assert not others, f"{effect.name} imports effects {others}"


def test_the_scan_finds_a_settings_read():
    assert _effect_settings_read(ast.parse("x = setup.scene.effects.bayer.pattern")) == {"bayer"}


def test_a_stage_cannot_set_an_undeclared_field():
    state = FrameState(setup=None, index=0)  # type: ignore[arg-type]
    with pytest.raises(AttributeError):
        state.offset_map = np.zeros(3)  # type: ignore[attr-defined]


# ------------------------------------------------------------ the descriptor


@pytest.mark.parametrize("kwargs, message", [
    (dict(slot="sensor", build_stage=lambda setup, params: None), "slot 'sensor' is not one of"),
    (dict(slot="dark"), "a stage needs a slot and a slot needs a stage"),
    (dict(build_stage=lambda setup, params: None), "a stage needs a slot"),
    (dict(), "does nothing"),
    (dict(slot="dark", build_stage=lambda setup, params: None, variant="method"), "variant 'method'"),
])
def test_a_malformed_effect_is_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Effect(name="toy", params=NoParams, **kwargs)


def test_two_effects_of_one_name_are_refused():
    with pytest.raises(ValueError, match="effects registered twice: ambient"):
        scene_model(REGISTRY + (REGISTRY[0],))


# ------------------------------------------------ a new effect, in one module


class ConstantOffset(EffectParams):
    """A constant dark offset of ``offset_e`` electrons in every pixel."""

    offset_e: float = Field(100.0, ge=0, le=1e6)


def offset_stage(setup, params):
    offset = params.offset_e

    def run(state):
        state.electrons += offset

    return run


def offset_check(scene, params) -> Optional[str]:
    if params.offset_e >= scene.camera.full_well_e:
        return f"effects.constant_offset.offset_e = {params.offset_e:g}: fills the full well"
    return None


CONSTANT_OFFSET = Effect(name="constant_offset", params=ConstantOffset, slot="dark", build_stage=offset_stage,
                         check=offset_check, writes=("state.electrons",))
WITH_OFFSET = REGISTRY + (CONSTANT_OFFSET,)


def test_a_new_effect_appears_in_the_scene_schema():
    model = scene_model(WITH_OFFSET)
    properties = model.model_json_schema()["$defs"]["Effects"]["properties"]
    assert "constant_offset" in properties and "constant_offset" not in Scene.model_json_schema()["$defs"]["Effects"]["properties"]
    scene = small_scene({"constant_offset": {"offset_e": 250}}, registry=WITH_OFFSET)
    assert scene.effects.enabled() == ("constant_offset",) and scene.effects.constant_offset.offset_e == 250
    # Its keys are validated and reported like every other effect's.
    with pytest.raises(SceneError, match=r"effects.constant_offset.offset_e = -1: out of range, allowed \[0, 1e\+06\]"):
        small_scene({"constant_offset": {"offset_e": -1}}, registry=WITH_OFFSET)
    with pytest.raises(SceneError, match=r"effects.constant_offset.offset: unknown key; did you mean 'effects.constant_offset.offset_e'"):
        small_scene({"constant_offset": {"offset": 1}}, registry=WITH_OFFSET)
    with pytest.raises(SceneError, match="effects.constant_offset.offset_e = 1e\\+06: fills the full well"):
        small_scene({"constant_offset": {"offset_e": 1e6}}, registry=WITH_OFFSET)
    # The default registry knows nothing of it.
    with pytest.raises(SceneError, match="effects.constant_offset: unknown key"):
        small_scene({"constant_offset": {}})


def test_a_new_effect_runs_in_the_pipeline():
    plain = RenderPipeline(small_scene({"ambient": {}}, registry=WITH_OFFSET))
    offset = RenderPipeline(small_scene({"ambient": {}, "constant_offset": {"offset_e": 5}}, registry=WITH_OFFSET))
    assert offset.stage_names == plain.stage_names[:4] + ("constant_offset",) + plain.stage_names[4:]
    assert [s.slot for s in offset.stages][4] == "dark"
    gain, top = offset.setup.gain_dn_per_e, 2**offset.setup.scene.camera.adc_bits - 1
    before, after = plain.render(0).image.astype(float), offset.render(0).image.astype(float)
    # Noiseless: every pixel below the ADC's top gains K·5 DN, up to rounding.
    unclipped = after < top
    assert unclipped.mean() > 0.5
    assert np.all(np.abs(after - before - gain * 5)[unclipped] <= 1.0)
    assert np.all(after[~unclipped] == top)
