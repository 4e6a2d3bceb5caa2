"""The render pipeline: assembled once per scene, then run frame by frame."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from rollsim.render.setup import SceneSetup, build_setup
from rollsim.render.stages import Stage, assemble_stages, prepare_setup
from rollsim.render.state import FrameState
from rollsim.render.truth import frame_truth


@dataclass(frozen=True)
class RenderedFrame:
    """One rendered frame and its ground truth."""

    index: int
    image: np.ndarray
    truth: dict


class RenderPipeline:
    """The stages of a scene, assembled once.

    Parameters
    ----------
    scene : Scene
        A validated scene.
    """

    def __init__(self, scene):
        self._init(build_setup(scene))

    def _init(self, setup: SceneSetup) -> None:
        self.setup = prepare_setup(setup)
        self.stages: tuple[Stage, ...] = tuple(assemble_stages(self.setup))

    @classmethod
    def from_setup(cls, setup: SceneSetup) -> "RenderPipeline":
        """A pipeline over a given (possibly modified) setup, e.g. a custom transmitter.

        The effects' per-scene hooks run unless ``setup`` is already
        prepared (a pipeline's own ``setup`` is).
        """
        pipeline = cls.__new__(cls)
        pipeline._init(setup)
        return pipeline

    @property
    def stage_names(self) -> tuple[str, ...]:
        return tuple(stage.name for stage in self.stages)

    def run_stages(self, index: int) -> FrameState:
        """Run every stage for frame ``index`` and return the final state."""
        state = FrameState(self.setup, int(index))
        for stage in self.stages:
            stage(state)
        return state

    def render(self, index: int) -> RenderedFrame:
        """Render frame ``index``: the image and its truth record."""
        state = self.run_stages(index)
        truth = frame_truth(self.setup, state.index, state.start_s, state.led_rows)
        return RenderedFrame(state.index, state.image, truth)


def iter_frames(scene, n_frames: int, start: int = 0) -> Iterator[RenderedFrame]:
    """Render frames ``start … start + n_frames − 1`` one at a time (constant memory)."""
    if n_frames < 0:
        raise ValueError(f"n_frames must be >= 0, got {n_frames}")
    pipeline = RenderPipeline(scene)
    for index in range(start, start + n_frames):
        yield pipeline.render(index)


def render_frames(scene, n_frames: int, start: int = 0) -> tuple[list[np.ndarray], list[dict]]:
    """Render frames into memory, without touching disk.

    Returns
    -------
    images : list of ndarray
    truth : list of dict
        One truth record per frame (see :mod:`rollsim.render.truth`).
    """
    frames = list(iter_frames(scene, n_frames, start))
    return [f.image for f in frames], [f.truth for f in frames]
