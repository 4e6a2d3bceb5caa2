"""Render scenes into rolling-shutter frames with exact ground truth."""

from rollsim.render.pipeline import RenderedFrame, RenderPipeline, iter_frames, render_frames
from rollsim.render_contract.setup import SceneSetup, build_setup

__all__ = ["RenderPipeline", "RenderedFrame", "SceneSetup", "build_setup", "iter_frames", "render_frames"]


# rollsim.render(...) is the Python API's function (rollsim.api).
from rollsim.plumbing.callable_module import make_callable  # noqa: E402

make_callable(__name__)
