"""The render pipeline: assembled once per scene, then run frame by frame."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Iterator

import numpy as np

from rollsim.plumbing.budget import check_memory
from rollsim.render_contract.setup import SceneSetup, build_setup
from rollsim.render.stages import Stage, assemble_stages, fuse_chain, prepare_setup
from rollsim.render_contract.state import FrameState
from rollsim.render.truth import frame_truth

if TYPE_CHECKING:
    from rollsim.scene.model import Scene


@dataclass(frozen=True)
class RenderedFrame:
    """One rendered frame and its ground truth."""

    index: int
    image: np.ndarray
    truth: dict


# Peak bytes per pixel of one process rendering a frame, set-up included,
# measured as peak resident memory at 1920x1080: 73 B/px with the default
# effects, 89 with defocus, 105 with a Bayer CFA and rgb8 output, 155 with
# every effect at once; with a quarter's margin. A test
# (tests/render/test_render_memory.py) keeps it an upper bound.
RENDER_BYTES_PER_PIXEL = 192
# An effect's per-scene work may need more, on top: its
# ``Effect.setup_bytes_per_pixel`` (the glare's FFT convolution).
# Tables and buffers that do not scale with the frame (quantile tables, ...).
RENDER_FIXED_BYTES = 32 * 2**20
_SAMPLE_BYTES = {"gray8": 1, "raw16": 2, "rgb8": 3}


def render_memory_bytes(scene: Scene, workers: int = 1, frames_held: int = 0) -> int:
    """Peak bytes of rendering ``scene`` with ``workers`` processes.

    Parameters
    ----------
    scene : Scene
    workers : int
        Processes rendering at once, each with its own pipeline.
    frames_held : int
        Finished images kept in memory (an in-memory render).
    """
    pixels = scene.camera.width_px * scene.camera.height_px
    per_pixel = RENDER_BYTES_PER_PIXEL + sum(effect.setup_bytes_per_pixel for effect, _ in scene.effects.listed())
    per_process = per_pixel * pixels + RENDER_FIXED_BYTES
    return workers * per_process + frames_held * pixels * _SAMPLE_BYTES[scene.camera.output]


def check_render_memory(scene: Scene, workers: int = 1, frames_held: int = 0) -> None:
    """Refuse a frame size (times workers, times frames held) over the memory budget."""
    cam = scene.camera
    what = f"camera.width_px x height_px = {cam.width_px} x {cam.height_px}"
    if workers > 1:
        what += f" with {workers} workers"
    if frames_held:
        what += f", {frames_held} frames held in memory"
    check_memory(what, render_memory_bytes(scene, workers, frames_held))


class RenderPipeline:
    """The stages of a scene, assembled once.

    Parameters
    ----------
    scene : Scene
        A validated scene.
    fuse : bool
        Run consecutive steps of the sensor chain (shot noise to output) as
        one pass (:func:`rollsim.render.stages.fuse_chain`): the same
        frames, faster. Without it every stage runs alone and fills in its
        own field of the frame state (``dn`` for one).

    Raises
    ------
    BudgetError
        A frame too large for the memory budget (:mod:`rollsim.plumbing.budget`).
    """

    def __init__(self, scene: Scene, fuse: bool = True):
        check_render_memory(scene)
        self._init(build_setup(scene), fuse)

    def _init(self, setup: SceneSetup, fuse: bool = True) -> None:
        self.setup = prepare_setup(setup)
        # The coded GOP of a scene with video_codec: its first frame's index and its frames.
        self._gop: tuple[int, list[RenderedFrame]] | None = None
        # The stages as the scene lists them, and as they run (chain steps fused).
        self.planned_stages: tuple[Stage, ...] = tuple(assemble_stages(self.setup))
        self.stages: tuple[Stage, ...] = tuple(fuse_chain(list(self.planned_stages)) if fuse else self.planned_stages)

    @classmethod
    def from_setup(cls, setup: SceneSetup, fuse: bool = True) -> "RenderPipeline":
        """A pipeline over a given (possibly modified) setup, e.g. a custom transmitter.

        The effects' per-scene hooks run unless ``setup`` is already
        prepared (a pipeline's own ``setup`` is).
        """
        pipeline = cls.__new__(cls)
        pipeline._init(setup, fuse)
        return pipeline

    @property
    def stage_names(self) -> tuple[str, ...]:
        """The names of the scene's stages, one per core step and listed effect (before fusing)."""
        return tuple(stage.name for stage in self.planned_stages)

    def run_stages(self, index: int) -> FrameState:
        """Run every stage for frame ``index`` and return the final state."""
        state = FrameState(self.setup, int(index))
        for stage in self.stages:
            stage(state)
        return state

    def render(self, index: int) -> RenderedFrame:
        """Render frame ``index``: the image and its truth record.

        With ``video_codec`` the frame comes out of its GOP's coding: the
        GOP's frames are rendered and coded together the first time one of
        them is asked for, and kept until a frame of another GOP is.
        """
        if self.setup.video_codec is None:
            return self._render_stages(index)
        gop = gop_frames(self.setup)
        first = int(index) // gop * gop
        if self._gop is None or self._gop[0] != first:
            self._gop = None  # the old GOP's frames go before the new one's are made
            self._gop = (first, self._coded_gop(first, gop))
        return self._gop[1][int(index) - first]

    def _render_stages(self, index: int) -> RenderedFrame:
        state = self.run_stages(index)
        truth = frame_truth(self.setup, state.index, state.start_s, state.led_rows, state.led_centre_px)
        return RenderedFrame(state.index, state.image, truth)

    def _coded_gop(self, first: int, gop: int) -> list[RenderedFrame]:
        """Frames ``first`` … ``first + gop − 1`` rendered, then encoded and decoded as one GOP."""
        from rollsim.video.roundtrip import gop_round_trip

        assert self.setup.video_codec is not None  # render() comes here only with the effect
        frames = [self._render_stages(i) for i in range(first, first + gop)]
        coded = gop_round_trip([f.image for f in frames], self.setup.video_codec,
                               self.setup.scene.camera.frame_rate_hz)
        return [RenderedFrame(f.index, image, f.truth) for f, image in zip(frames, coded)]


def gop_frames(setup: SceneSetup) -> int:
    """Frames a scene's ``video_codec`` codes together (its GOP); 1 without the effect."""
    if setup.video_codec is None:
        return 1
    return setup.video_codec.gop_for(setup.scene.camera.frame_rate_hz)


def iter_frames(scene: Scene, n_frames: int, start: int = 0) -> Iterator[RenderedFrame]:
    """Render frames ``start … start + n_frames − 1`` one at a time (constant memory)."""
    if n_frames < 0:
        raise ValueError(f"n_frames must be >= 0, got {n_frames}")
    pipeline = RenderPipeline(scene)
    for index in range(start, start + n_frames):
        yield pipeline.render(index)


def render_frames(scene: Scene, n_frames: int, start: int = 0) -> tuple[list[np.ndarray], list[dict]]:
    """Render frames into memory, without touching disk.

    Returns
    -------
    images : list of ndarray
    truth : list of dict
        One truth record per frame (see :mod:`rollsim.render.truth`).
    """
    check_render_memory(scene, frames_held=n_frames)
    frames = list(iter_frames(scene, n_frames, start))
    return [f.image for f in frames], [f.truth for f in frames]
