"""The scene's sections (camera, LED, link, environment, channel, render) and a scene without its effects."""

from rollsim.scene_sections.model import Camera, Channel, EffectsSection, Environment, Led, Link, Render, SceneSections

__all__ = ["Camera", "Channel", "EffectsSection", "Environment", "Led", "Link", "Render", "SceneSections"]
