"""Render scenes into rolling-shutter frames with exact ground truth."""

from rollsim.render.pipeline import RenderedFrame, RenderPipeline, iter_frames, render_frames
from rollsim.render.setup import SceneSetup, build_setup
from rollsim.render.stages import EFFECT_BUILDERS, SLOTS

__all__ = ["EFFECT_BUILDERS", "RenderPipeline", "RenderedFrame", "SLOTS", "SceneSetup", "build_setup", "iter_frames", "render_frames"]
