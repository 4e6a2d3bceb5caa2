"""Load scenes: YAML, presets and ``--set`` overrides, into a validated Scene.

Layers, least specific first: camera preset < scene file < ``--set``. Each
layer overrides keys one by one. Row timing is one choice: whichever of
``camera.row_time_us`` / ``camera.ifg_ratio`` a more specific layer gives
replaces the other from the less specific layers; giving both in the same
layer is an error.

Every problem becomes one line naming the file, the field, the value and what
is allowed, collected into a :class:`rollsim.errors.SceneError`.
"""

from __future__ import annotations

import difflib
import re
import stat
from pathlib import Path
from collections.abc import Iterable, Mapping, Sequence
from typing import Optional, Union, get_args

import annotated_types
import yaml
from pydantic import BaseModel, ValidationError

from rollsim.effects.base import Effect
from rollsim.errors import SceneError, clip, short_repr
from rollsim.protocol import CRC8_MAX_DATA_BITS, min_header_bits, n_packets
from rollsim.protocol.rlnc import seed_space
from rollsim.scene.bundled import missing_scene
from rollsim.scene.effects import normalise_effects
from rollsim.scene.model import Scene, scene_model
from rollsim.scene.presets import DEFAULT_PRESET, PRESETS
from rollsim.scene.si import si_errors

ROW_TIMING_KEYS = ("row_time_us", "ifg_ratio")


# Limits of a scene's YAML: a real scene is a few kB, a few levels deep and
# a few hundred nodes. Anything past these is refused before it costs
# memory or time (a YAML alias bomb expands to billions of nodes).
MAX_SCENE_BYTES = 1 << 20
MAX_YAML_DEPTH = 64
MAX_YAML_NODES = 100_000
MAX_INT_DIGITS = 100


class _UniqueKeyLoader(yaml.SafeLoader):
    """Safe YAML loader that rejects duplicate keys instead of keeping the last,
    and bounds nesting depth, alias expansion and integer length."""

    def compose_node(self, parent, index):
        # The composer recurses once per level: bound the depth before
        # Python's own recursion limit turns it into a traceback.
        self._depth = getattr(self, "_depth", 0) + 1
        try:
            if self._depth > MAX_YAML_DEPTH and self.check_event(yaml.CollectionStartEvent):
                raise yaml.composer.ComposerError(
                    None, None, f"nested deeper than {MAX_YAML_DEPTH} levels", self.peek_event().start_mark
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def _construct_mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        if not isinstance(key_node, yaml.ScalarNode):
            raise yaml.constructor.ConstructorError(None, None, "a key must be a plain value, not a list or mapping",
                                                    key_node.start_mark)
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {short_repr(key)}", key_node.start_mark
            )
        seen.add(key)
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


def _construct_int(loader, node):
    digits = sum(ch.isdigit() for ch in node.value)
    if digits > MAX_INT_DIGITS:
        raise yaml.constructor.ConstructorError(None, None, f"an integer of {digits} digits (at most {MAX_INT_DIGITS})",
                                                node.start_mark)
    return yaml.SafeLoader.construct_yaml_int(loader, node)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_UniqueKeyLoader.add_constructor("tag:yaml.org,2002:int", _construct_int)

# PyYAML follows YAML 1.1, where "1e-3" (no dot) is a string and "off", "on",
# "yes" and "no" are booleans. Scenes and --set values use exponents freely,
# and `link.pattern: off` names a pattern, so floats and booleans follow YAML
# 1.2 here: only true and false are booleans.
_YAML12_FLOAT = re.compile(
    r"^(?=[-+]?\.?[0-9])[-+]?(?:[0-9][0-9_]*)?(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)?$"
    r"|^[-+]?\.(?:inf|Inf|INF)$|^\.(?:nan|NaN|NAN)$"
)
_YAML12_BOOL = re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$")
_REPLACED_TAGS = ("tag:yaml.org,2002:float", "tag:yaml.org,2002:bool")
_UniqueKeyLoader.yaml_implicit_resolvers = {
    key: [(tag, regexp) for tag, regexp in resolvers if tag not in _REPLACED_TAGS]
    for key, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_UniqueKeyLoader.add_implicit_resolver("tag:yaml.org,2002:float", _YAML12_FLOAT, list("-+0123456789."))
_UniqueKeyLoader.add_implicit_resolver("tag:yaml.org,2002:bool", _YAML12_BOOL, list("tTfF"))


def _expanded_nodes(root) -> int:
    """Nodes the document would have with every alias expanded, without expanding it.

    Aliases share node objects, so sizes are memoised per object; a node
    that contains itself (a recursive alias) is reported as unbounded.
    """
    sizes: dict[int, int] = {}
    # Post-order walk with an explicit stack: depth is bounded already, but
    # the walk must not recurse on a pathological graph either.
    stack = [(root, False)]
    visiting: set[int] = set()
    while stack:
        node, done = stack.pop()
        key = id(node)
        if key in sizes:
            continue
        children = []
        if isinstance(node, yaml.SequenceNode):
            children = node.value
        elif isinstance(node, yaml.MappingNode):
            children = [child for pair in node.value for child in pair]
        if done:
            visiting.discard(key)
            sizes[key] = min(MAX_YAML_NODES + 1, 1 + sum(sizes[id(c)] for c in children))
            continue
        if key in visiting:
            return MAX_YAML_NODES + 1  # recursive: infinite once expanded
        visiting.add(key)
        stack.append((node, True))
        stack.extend((child, False) for child in children if id(child) not in sizes)
    return sizes[id(root)]


def _load_yaml_text(text: str):
    loader = _UniqueKeyLoader(text)
    try:
        root = loader.get_single_node()
        if root is None:
            return None
        nodes = _expanded_nodes(root)
        if nodes > MAX_YAML_NODES:
            raise yaml.composer.ComposerError(
                None, None, f"expands to more than {MAX_YAML_NODES} values (aliases of aliases?)", root.start_mark
            )
        return loader.construct_document(root)
    finally:
        loader.dispose()


def _yaml_error_text(exc: Exception) -> str:
    """``line N: YAML error: problem`` of a PyYAML error, in one short line."""
    mark = getattr(exc, "problem_mark", None)
    where = f"line {mark.line + 1}: " if mark is not None else ""
    problem = getattr(exc, "problem", None) or (str(exc).splitlines() or [type(exc).__name__])[0]
    return f"{where}YAML error: {clip(problem, 120)}"


def _read_scene_text(path: Path) -> str:
    """A scene file's text: a regular file of at most :data:`MAX_SCENE_BYTES`, UTF-8."""
    try:
        info = path.stat()
    except (FileNotFoundError, NotADirectoryError):
        raise SceneError(missing_scene(path) or f"{path}: does not exist") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read scene file ({exc.strerror})") from None
    if stat.S_ISDIR(info.st_mode):
        raise SceneError(f"{path}: is a directory, not a scene file")
    if not stat.S_ISREG(info.st_mode):
        raise SceneError(f"{path}: not a regular file (a device, pipe or socket cannot be a scene file)")
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_SCENE_BYTES + 1)
    except OSError as exc:
        raise SceneError(f"{path}: cannot read scene file ({exc.strerror})") from None
    if len(data) > MAX_SCENE_BYTES:
        raise SceneError(f"{path}: larger than {MAX_SCENE_BYTES // 1024} KiB; a scene file is a few kB of YAML")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not UTF-8 text (byte {exc.start})") from None


def read_yaml(path: Union[str, Path]) -> dict:
    """Read a scene file into a dict, with one-line errors naming the file."""
    path = Path(path)
    text = _read_scene_text(path)
    try:
        data = _load_yaml_text(text)
    except yaml.YAMLError as exc:
        raise SceneError(f"{path}: {_yaml_error_text(exc)}") from None
    if data is None:
        raise SceneError(f"{path}: scene file is empty")
    if not isinstance(data, dict):
        raise SceneError(f"{path}: a scene file must be a mapping of keys, got {type(data).__name__}")
    return data


def parse_yaml_scalar(text: str, what: str):
    """A value written as YAML (``50``, ``1e-3``, ``rp``, ``[1, 2]``), as ``--set`` reads it.

    Raises
    ------
    SceneError
        Text that is not YAML, naming ``what``.
    """
    try:
        return _load_yaml_text(text) if text.strip() else None
    except (yaml.YAMLError, ValueError) as exc:
        raise SceneError(f"{what}: cannot parse {short_repr(text)} ({_yaml_error_text(exc)})") from None


def split_key_value(item: str, option: str, expected: str) -> tuple[str, str]:
    """``"link.distance_cm=5"`` as ``("link.distance_cm", "5")``.

    Raises
    ------
    SceneError
        No ``=``, or a dotted key with an empty part, naming ``option`` and
        what was ``expected``.
    """
    key, sep, text = item.partition("=")
    key = key.strip()
    if not sep or not key or any(not part for part in key.split(".")):
        raise SceneError(f"{option} {short_repr(item)}: expected {expected}")
    return key, text


def refuse_repeated_keys(given: Iterable[tuple[str, str]]) -> None:
    """Refuse a scene key given twice on the command line, which would be half dropped.

    Parameters
    ----------
    given : iterable of (option, "KEY=VALUE")
        The items of ``--set``, ``--grid`` and ``--zip`` in order. A
        malformed item is passed over: the command's own reading names the
        form it expects.

    Raises
    ------
    SceneError
        ``OPTION KEY: given twice with OPTION`` (or ``given with A and B``).
    """
    seen: dict[str, str] = {}
    for option, item in given:
        try:
            key = split_key_value(item, option, "KEY=VALUE")[0]
        except SceneError:
            continue
        if key in seen:
            twice = f"given twice with {option}" if seen[key] == option else f"given with {seen[key]} and {option}"
            raise SceneError(f"{option} {clip(key, 60)}: {twice}; give it once")
        seen[key] = option


def parse_overrides(overrides: Iterable[str], values: Optional[Mapping] = None) -> dict:
    """Turn ``["camera.exposure_us=50", ...]`` into a nested dict.

    Values are parsed as YAML scalars or flow collections, so ``50``,
    ``null``, ``true`` and ``[1, 2]`` keep their types. ``values``
    (``{"camera.exposure_us": 50, ...}``, already Python values) come after
    them, without YAML: what a sweep's cells use.
    """
    pairs = []
    for item in overrides:
        key, text = split_key_value(item, "--set", "KEY=VALUE, e.g. camera.exposure_us=50")
        try:
            value = _load_yaml_text(text) if text.strip() else None
        except (yaml.YAMLError, ValueError) as exc:
            raise SceneError(f"--set {short_repr(item)}: cannot parse the value ({_yaml_error_text(exc)})") from None
        pairs.append((key, value, item))
    for key, value in (values or {}).items():
        if not key or any(not part for part in str(key).split(".")):
            raise SceneError(f"{short_repr(key)}: expected a dotted scene key, e.g. camera.exposure_us")
        pairs.append((str(key), value, f"{key}={short_repr(value)}"))
    return _override_tree(pairs)


def _override_tree(pairs: Iterable[tuple]) -> dict:
    """Nested dict of ``(dotted key, value, how to name it)`` overrides."""
    tree: dict = {}
    for key, value, item in pairs:
        node = tree
        parts = key.split(".")
        for depth, part in enumerate(parts[:-1]):
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise SceneError(f"--set {short_repr(item)}: {clip('.'.join(parts[: depth + 1]))} is set to a value, "
                                 "not a section")
        node[parts[-1]] = value
    return tree


def _merge(base: dict, layer: Mapping) -> dict:
    """Merge ``layer`` over ``base``: mappings merge, values replace.

    Returns a new dict, and new dicts wherever both sides are mappings;
    values taken whole are shared, not copied (nothing on the way to
    validation changes them, and a sweep merges thousands of cells).
    """
    out = dict(base)
    for key, value in layer.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def _check_row_timing_layer(camera: Mapping, layer_name: str) -> list[str]:
    if all(camera.get(key) is not None for key in ROW_TIMING_KEYS):
        return [f"{layer_name}: camera.row_time_us and camera.ifg_ratio are both given; give one (the other follows)"]
    return []


def _merge_camera(layers: Sequence[tuple[str, Mapping]]) -> tuple[dict, list[str]]:
    camera: dict = {}
    errors: list[str] = []
    for layer_name, layer in layers:
        if not isinstance(layer, Mapping):
            errors.append(f"{layer_name}: camera must be a mapping of keys, got {type(layer).__name__}")
            continue
        errors += _check_row_timing_layer(layer, layer_name)
        if any(layer.get(key) is not None for key in ROW_TIMING_KEYS):
            for key in ROW_TIMING_KEYS:
                camera.pop(key, None)
        camera = _merge(camera, layer)
    return camera, errors


def resolve_layers(file_data: Mapping, overrides: Mapping, source: str) -> tuple[dict, list[str]]:
    """Merge preset, scene file and overrides into one plain dict.

    Returns the merged dict and the list of layering errors found.
    """
    errors: list[str] = []
    file_camera = file_data.get("camera") or {}
    set_camera = overrides.get("camera") or {}
    preset_name = DEFAULT_PRESET
    for layer in (file_camera, set_camera):
        if isinstance(layer, Mapping) and "preset" in layer:
            preset_name = layer["preset"]
    layers = []
    if preset_name is not None:
        if not isinstance(preset_name, str):
            errors.append(f"{source}: camera.preset = {short_repr(preset_name)}: must be a preset name "
                          f"({', '.join(PRESETS)}) or null")
            preset_name = None
        elif preset_name not in PRESETS:
            close = difflib.get_close_matches(preset_name, PRESETS, n=1, cutoff=0.0)
            errors.append(
                f"{source}: camera.preset = {short_repr(preset_name)}: unknown preset; did you mean {close[0]!r}? "
                f"(presets: {', '.join(PRESETS)})"
            )
        else:
            layers.append((f"preset {preset_name}", PRESETS[preset_name].as_dict()))
    layers += [(source, file_camera), ("--set", set_camera)]
    camera, camera_errors = _merge_camera(layers)
    errors += camera_errors
    if preset_name is not None:
        camera["preset"] = preset_name

    data = _merge(dict(file_data), {k: v for k, v in overrides.items() if k not in ("camera", "effects")})
    data["camera"] = camera
    try:
        data["effects"] = _merge_effects(file_data.get("effects"), overrides)
    except SceneError as exc:
        errors += [f"{source}: {line}" for line in exc.lines]
        data["effects"] = {}
    return data, errors


def _merge_effects(file_effects, overrides: Mapping):
    """The scene file's effects with ``--set effects…`` applied."""
    effects = normalise_effects(file_effects)
    if "effects" not in overrides:
        return effects
    set_effects = overrides["effects"]
    if not isinstance(set_effects, Mapping):
        return normalise_effects(set_effects)
    if not isinstance(effects, dict):
        return effects  # not a mapping: validation names the problem
    for name, params in set_effects.items():
        if params is False:
            effects.pop(name, None)
        elif isinstance(params, Mapping) and isinstance(effects.get(name), dict):
            effects[name] = _merge(effects[name], params)
        else:
            effects[name] = {} if params is None or params is True else params
    return effects


# ---------------------------------------------------------------- error lines


def _unwrap_model(annotation) -> Optional[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in get_args(annotation):
        found = _unwrap_model(arg)
        if found is not None:
            return found
    return None


def _model_at(loc: tuple, root: type[BaseModel]) -> Optional[type[BaseModel]]:
    """The pydantic model class that holds the field at ``loc``'s parent, from ``root``."""
    model: type[BaseModel] = root
    for part in loc[:-1]:
        field = model.model_fields.get(part) if isinstance(part, str) else None
        inner = _unwrap_model(field.annotation) if field is not None else None
        if inner is None:
            return None
        model = inner
    return model


def _fmt_number(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _range_text(loc: tuple, root: type[BaseModel]) -> str:
    model = _model_at(loc, root)
    if model is None or loc[-1] not in model.model_fields:
        return ""
    low, high, low_open, high_open = "-inf", "inf", True, True
    for item in model.model_fields[loc[-1]].metadata:
        if isinstance(item, annotated_types.Gt):
            low, low_open = _fmt_number(item.gt), True
        elif isinstance(item, annotated_types.Ge):
            low, low_open = _fmt_number(item.ge), False
        elif isinstance(item, annotated_types.Lt):
            high, high_open = _fmt_number(item.lt), True
        elif isinstance(item, annotated_types.Le):
            high, high_open = _fmt_number(item.le), False
    return f"{'(' if low_open else '['}{low}, {high}{')' if high_open else ']'}"


def _format_value(value) -> str:
    return short_repr(value)


_TYPE_WORDS = {
    "int_type": "an integer",
    "int_from_float": "an integer",
    "int_parsing": "an integer",
    "float_type": "a number",
    "float_parsing": "a number",
    "string_type": "a string",
    "list_type": "a list",
    "bool_type": "true or false",
}


def _error_line(error: Mapping, source: str, root: type[BaseModel] = Scene) -> str:
    loc = tuple(error["loc"])
    path = clip(".".join(clip(str(part), 40) for part in loc), 120)
    kind = error["type"]
    value = error.get("input")
    if kind == "extra_forbidden":
        model = _model_at(loc, root)
        valid = list(model.model_fields) if model is not None else []
        close = difflib.get_close_matches(clip(str(loc[-1]), 40), valid, n=1, cutoff=0.0)
        hint = f"; did you mean {'.'.join(str(p) for p in loc[:-1] + (close[0],))!r}?" if close else ""
        return f"{source}: {path}: unknown key{hint}"
    if kind == "missing":
        return f"{source}: {path}: required key is missing"
    if kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        return f"{source}: {path} = {_format_value(value)}: out of range, allowed {_range_text(loc, root)}"
    if kind == "literal_error":
        expected = error.get("ctx", {}).get("expected", "")
        return f"{source}: {path} = {_format_value(value)}: must be one of {expected}"
    if kind in ("too_short", "too_long"):
        return f"{source}: {path} = {_format_value(value)}: {error['msg'].lower()}"
    if kind in _TYPE_WORDS:
        return f"{source}: {path} = {_format_value(value)}: must be {_TYPE_WORDS[kind]}"
    if kind == "model_type":
        return f"{source}: {path}: must be a mapping of keys, got {type(value).__name__}"
    return f"{source}: {path} = {_format_value(value)}: {error['msg']}"


# ------------------------------------------------------- cross-field checks


# Relaxations: cross-field rules that only some models of the link depend
# on. The loader validates without knowing which model will read the scene,
# so a caller whose model does not need a rule names it (``relax=``) and
# then owns what the rule protected; everything else keeps the full rules.
# The camcomsim channel of ``rollsim simulate`` asks for both (see
# rollsim.channel.scene_channel.scene_relaxations); rendering never does.
#
# SEQUENCE_WRAP: too few link.header_bits to number every packet (0
# included) is accepted, the sequence numbers wrap; for a model that tells
# packets apart without them.
# DISTANCE_WITHOUT_LENS: link.distance_cm from 0 up to the focal length,
# where the thin lens diverges, is accepted; for a model that never images
# the LED through the lens.
SEQUENCE_WRAP = "sequence_wrap"
DISTANCE_WITHOUT_LENS = "distance_without_lens"
RELAXATIONS = (SEQUENCE_WRAP, DISTANCE_WITHOUT_LENS)
# Stands in for a relaxed ``distance_cm = 0`` while the model checks its
# range (> 0); any value in range does, it is replaced before anything reads it.
_DISTANCE_PLACEHOLDER_CM = 1.0


def _check_relax(relax: Iterable[str]) -> frozenset:
    relax = frozenset(relax)
    unknown = sorted(relax - set(RELAXATIONS))
    if unknown:
        raise ValueError(f"relax: unknown rules {unknown}; expected some of {list(RELAXATIONS)}")
    return relax


def _sequence_numbers_wrap(scene: Scene) -> bool:
    link = scene.link
    return n_packets(link.message_bytes, link.payload_bits) > 2**link.header_bits


def _distance_within_focal_length(scene: Scene) -> bool:
    return scene.link.distance_cm * 10.0 <= scene.camera.focal_length_mm


def relaxations_used(scene: Scene) -> tuple[str, ...]:
    """The relaxable rules ``scene`` breaks, in :data:`RELAXATIONS` order.

    Empty for any scene loaded without ``relax``. A model that did not ask
    for a rule checks here that its scene does not depend on it.
    """
    broken = {SEQUENCE_WRAP: _sequence_numbers_wrap(scene), DISTANCE_WITHOUT_LENS: _distance_within_focal_length(scene)}
    return tuple(rule for rule in RELAXATIONS if broken[rule])


def consistency_errors(scene: Scene, source: str, relax: Iterable[str] = ()) -> list[str]:
    """Errors between fields that are each valid on their own.

    ``relax`` names rules of :data:`RELAXATIONS` not to apply.
    """
    relax = _check_relax(relax)
    cam, link, errors = scene.camera, scene.link, []
    if cam.row_time_us is None and cam.ifg_ratio is None:
        errors.append(f"{source}: camera: give row_time_us or ifg_ratio")
    elif cam.readout_s > cam.frame_period_s * (1 + 1e-12):
        errors.append(
            f"{source}: camera.row_time_us = {_fmt_number(cam.row_time_us)}: {cam.height_px} rows take "
            f"{cam.readout_s * 1e3:.4g} ms, longer than the frame period {cam.frame_period_s * 1e3:.4g} ms "
            f"(frame_rate_hz = {_fmt_number(cam.frame_rate_hz)})"
        )
    if cam.height_px % cam.binning_rows:
        errors.append(f"{source}: camera.binning_rows = {cam.binning_rows}: must divide camera.height_px = "
                      f"{cam.height_px} (the rows are read in groups of binning_rows)")
    if cam.exposure_s > cam.frame_period_s * (1 + 1e-12):
        errors.append(
            f"{source}: camera.exposure_us = {_fmt_number(cam.exposure_us)}: longer than the frame period "
            f"{cam.frame_period_s * 1e6:.6g} us"
        )
    if cam.black_level_dn >= 2**cam.adc_bits - 1:
        errors.append(
            f"{source}: camera.black_level_dn = {cam.black_level_dn}: must be below the ADC maximum "
            f"{2 ** cam.adc_bits - 1} (adc_bits = {cam.adc_bits})"
        )
    if DISTANCE_WITHOUT_LENS not in relax and _distance_within_focal_length(scene):
        errors.append(
            f"{source}: link.distance_cm = {_fmt_number(link.distance_cm)}: the LED must be farther than the "
            f"focal length ({_fmt_number(cam.focal_length_mm)} mm), where the thin lens diverges"
        )
    packets = n_packets(link.message_bytes, link.payload_bits)
    if SEQUENCE_WRAP not in relax and _sequence_numbers_wrap(scene):
        errors.append(
            f"{source}: link.header_bits = {link.header_bits}: too few for {packets} packets "
            f"(message_bytes = {link.message_bytes}, payload_bits = {link.payload_bits}); "
            f"need at least {min_header_bits(packets)}"
        )
    if link.check == "crc8" and link.header_bits + link.payload_bits > CRC8_MAX_DATA_BITS:
        errors.append(
            f"{source}: link.payload_bits = {link.payload_bits}: header_bits + payload_bits = "
            f"{link.header_bits + link.payload_bits} exceeds {CRC8_MAX_DATA_BITS}, the longest data for which "
            f"crc8 detects every double error"
        )
    if link.strategy == "rlnc" and link.repeats != 1:
        errors.append(f"{source}: link.repeats = {link.repeats}: strategy rlnc sends every emission as a fresh "
                      "combination, so repeats must be 1")
    if link.strategy == "rlnc" and (link.header_bits < 1 or seed_space(link.header_bits) < packets):
        errors.append(f"{source}: link.header_bits = {link.header_bits}: strategy rlnc cycles through the largest "
                      f"prime number of seeds the header holds, which must be at least the {packets} source packets")
    channel = scene.channel
    if (channel.M is None) != (channel.N is None):
        errors.append(f"{source}: channel: give both M and N, or neither (null derives both from the physics)")
    elif channel.M is not None and channel.N is not None and channel.M + channel.N < 1:
        errors.append(f"{source}: channel: M + N must be at least 1")
    if cam.output == "rgb8" and scene.effects.bayer is None:
        errors.append(f"{source}: camera.output = 'rgb8': needs the bayer effect")
    errors += [f"{source}: {line}" for line in scene.effects.errors(scene)]
    errors += [f"{source}: {line}" for line in run_span_errors(scene)]
    return errors


# Chip and row counters are int64 and their times float64: past 2**53 the
# float no longer holds every integer, and a little further the int wraps.
MAX_EXACT_COUNT = 2**53
MIN_ROW_TIME_S = 1e-9


def run_span_errors(scene: Scene) -> list[str]:
    """Errors of a run that no real link could make, or that overflows 64-bit counters.

    The run is the scene's ``frames`` frames (``--frames`` sets it). A chip
    longer than the whole run sends nothing a frame could read; a run of
    more than 2**53 chips or rows overflows the exact counters.
    """
    cam, link, errors = scene.camera, scene.link, []
    if cam.row_time_s < MIN_ROW_TIME_S:
        errors.append(f"camera.ifg_ratio = {cam.ifg_ratio!r}: gives a row time of "
                      f"{cam.row_time_s * 1e9:.3g} ns; a sensor needs at least 1 ns per row")
        return errors
    run_s = scene.frames * cam.frame_period_s
    if link.pattern in ("data", "square") and link.clock_hz * run_s < 1.0:
        errors.append(
            f"link.clock_hz = {_fmt_number(link.clock_hz)}: one chip lasts {1.0 / link.clock_hz:.3g} s, longer than "
            f"the run of {scene.frames} frames ({run_s:.3g} s); allowed [{1.0 / run_s:.3g}, 1e+07] for this run"
        )
    span_s = run_s + cam.exposure_s + abs(link.start_offset_s)
    chips, rows = span_s * link.clock_hz, span_s / cam.row_time_s
    if chips > MAX_EXACT_COUNT or rows > MAX_EXACT_COUNT:
        what, count = ("chips", chips) if chips > MAX_EXACT_COUNT else ("row times", rows)
        limit = max(1, int(scene.frames * MAX_EXACT_COUNT / count))
        errors.append(
            f"frames = {scene.frames}: the run spans {count:.3g} {what}, beyond the 2**53 that 64-bit counters hold "
            f"exactly; allowed frames [1, {limit}] for this camera and link"
        )
    return errors


# ------------------------------------------------------------------ entry points


def _set_aside_zero_distance(merged: dict) -> tuple[dict, bool]:
    """``merged`` with a ``link.distance_cm`` of 0 replaced by a placeholder, and whether it was.

    The model keeps its range ``(0, 1e5]`` for everyone (its error names
    that range); only a caller that relaxed :data:`DISTANCE_WITHOUT_LENS`
    gets the 0 back, after validation.
    """
    link = merged.get("link")
    value = link.get("distance_cm") if isinstance(link, Mapping) else None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != 0:
        return merged, False
    return _merge(merged, {"link": {"distance_cm": _DISTANCE_PLACEHOLDER_CM}}), True


def _names_field_of(errors: Sequence[str], line: str) -> bool:
    """Whether one of ``errors`` is about the field ``line`` (``key = value: ...``) is about.

    A cross-field rule on the same field says more than the SI rule (the
    range for this run), so its line is the one kept.
    """
    head = line.split(" = ", 1)[0] + " = "
    return any(head in error for error in errors)


def scene_from_dict(data: Mapping, source: str = "<scene>", overrides: Iterable[str] = (),
                    values: Optional[Mapping] = None, relax: Iterable[str] = (),
                    registry: Optional[Sequence[Effect]] = None) -> Scene:
    """Validate a scene given as a dict (as read from YAML).

    Parameters
    ----------
    data : mapping
        Scene keys as in the scene file.
    source : str
        Name used in error lines (usually the file path).
    overrides : iterable of str
        ``KEY=VALUE`` overrides, as ``--set`` takes them.
    values : mapping, optional
        ``{dotted key: value}`` overrides after those, as Python values.
    relax : iterable of str, optional
        Rules of :data:`RELAXATIONS` not to apply, for a caller whose model
        does not depend on them (default none: every rule applies).
        :data:`DISTANCE_WITHOUT_LENS` also admits ``link.distance_cm = 0``,
        below the model's range; such a scene must not reach the lens.
    registry : sequence of Effect, optional
        The effects a scene may list (default :data:`rollsim.effects.REGISTRY`);
        the schema of its ``effects`` section is derived from it.

    Raises
    ------
    SceneError
        With one line per problem.
    """
    relax = _check_relax(relax)
    if not isinstance(data, Mapping):
        raise SceneError(f"{source}: a scene must be a mapping of keys, got {type(data).__name__}")
    merged, errors = resolve_layers(data, parse_overrides(overrides, values), source)
    if errors:
        raise SceneError(errors)
    zero_distance = False
    if DISTANCE_WITHOUT_LENS in relax:
        merged, zero_distance = _set_aside_zero_distance(merged)
    model = scene_model(registry)
    try:
        scene = model.model_validate(merged)
    except ValidationError as exc:
        raise SceneError([_error_line(err, source, model) for err in exc.errors()]) from None
    if zero_distance:
        # model_copy does not validate: the one value the model's range refuses.
        scene = scene.model_copy(update={"link": scene.link.model_copy(update={"distance_cm": 0.0})})
    errors = consistency_errors(scene, source, relax)
    errors += [f"{source}: {line}" for line in si_errors(scene) if not _names_field_of(errors, line)]
    if errors:
        raise SceneError(errors)
    return scene


def load_scene(path: Union[str, Path], overrides: Iterable[str] = (), relax: Iterable[str] = (),
               registry: Optional[Sequence[Effect]] = None) -> Scene:
    """Load and validate a scene file, or a bundled scene by name.

    Parameters
    ----------
    path : str or Path
        A YAML file, or the name of a bundled scene (see ``rollsim scenes``).
    overrides : iterable of str
        ``KEY=VALUE`` overrides, e.g. ``["camera.exposure_us=50"]``.
    relax : iterable of str, optional
        Rules not to apply, see :func:`scene_from_dict`.
    registry : sequence of Effect, optional
        The effects a scene may list, see :func:`scene_from_dict`.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        With one line per problem, each naming the file and field.
    """
    from rollsim.scene.bundled import resolve_scene_path

    resolved = resolve_scene_path(path)
    return scene_from_dict(read_yaml(resolved), str(path), overrides, relax=relax, registry=registry)


def scene_to_dict(scene: Scene) -> dict:
    """Plain dict of every resolved value, loadable again with :func:`scene_from_dict`."""
    data = scene.model_dump(mode="json")
    data["effects"] = {name: data["effects"][name] for name in scene.effects.enabled()}
    return data


def scene_to_yaml(scene: Scene) -> str:
    """YAML text of :func:`scene_to_dict`."""
    return yaml.safe_dump(scene_to_dict(scene), sort_keys=False)
