"""Scene files: YAML scenes validated into typed objects.

See docs/scenes.md for every key, its unit and range.
"""

from rollsim.scene.bundled import bundled_scene_dir, bundled_scene_paths, resolve_scene_path
from rollsim.scene.effects import EFFECT_NAMES, Effects, EffectsBase
from rollsim.scene.loader import (
    load_scene,
    parse_overrides,
    read_yaml,
    scene_from_dict,
    scene_to_dict,
    scene_to_yaml,
)
from rollsim.scene.model import Camera, Channel, Environment, Led, Link, Render, Scene, scene_model
from rollsim.scene.presets import DEFAULT_PRESET, PRESETS, CameraPreset

__all__ = [
    "Camera",
    "CameraPreset",
    "Channel",
    "DEFAULT_PRESET",
    "EFFECT_NAMES",
    "Effects",
    "EffectsBase",
    "Environment",
    "Led",
    "Link",
    "PRESETS",
    "Render",
    "Scene",
    "bundled_scene_dir",
    "bundled_scene_paths",
    "load_scene",
    "parse_overrides",
    "read_yaml",
    "resolve_scene_path",
    "scene_from_dict",
    "scene_model",
    "scene_to_dict",
    "scene_to_yaml",
]
