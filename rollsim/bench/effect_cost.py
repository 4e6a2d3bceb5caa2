"""What one effect costs a render: ms per frame with it minus without it.

Shared by ``rollsim bench accuracy`` (each effect's own cost on the scene it
measures) and ``rollsim bench render`` (every effect's marginal cost against
its target). The two scenes come from :func:`rollsim.bench.variants.effect_pair`;
they are rendered in turn, frame by frame, so that a machine whose speed
drifts slows both alike.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from rollsim.bench.variants import effect_pair
from rollsim.errors import RollsimError

if TYPE_CHECKING:
    from rollsim.scene.model import Scene


def timed_pipeline(scene: Scene):
    """A render pipeline and its setup time in ms (best of two: the first also fills caches)."""
    from rollsim.render import RenderPipeline

    seconds = []
    for _ in range(2):
        start = time.perf_counter()
        pipeline = RenderPipeline(scene)
        seconds.append(time.perf_counter() - start)
    return pipeline, 1e3 * min(seconds)


def median_ms_in_turn(pipelines: list, n_frames: int, warmup: int = 1) -> list[float]:
    """Median ms of ``render`` per frame of each pipeline, rendered in turn frame by frame.

    A pipeline that codes its frames a GOP at a time (``video_codec``) does a
    GOP's work on its first frame: then every pipeline is timed a block of
    the longest GOP at a time, each block's time over its frames.
    """
    from rollsim.render.pipeline import gop_frames

    block = max(gop_frames(pipeline.setup) for pipeline in pipelines)
    for index in range(warmup * block):
        for pipeline in pipelines:
            pipeline.render(index)
    seconds: list[list[float]] = [[] for _ in pipelines]
    for first in range(warmup * block, warmup * block + max(1, -(-n_frames // block)) * block, block):
        for pipeline, times in zip(pipelines, seconds):
            start = time.perf_counter()
            for index in range(first, first + block):
                pipeline.render(index)
            times.append((time.perf_counter() - start) / block)
    return [1e3 * float(np.median(times)) for times in seconds]


def effect_cost(scene: Scene, name: str, n_frames: int, params: dict | None = None) -> dict:
    """ms per frame (and setup ms) that effect ``name`` adds to ``scene``.

    Parameters
    ----------
    scene : Scene
    name : str
        A registered effect.
    n_frames : int
        Frames timed with and without the effect (after one warm-up frame).
    params : dict, optional
        The effect's parameters when ``scene`` does not list it
        (:func:`rollsim.bench.variants.effect_pair`).

    Returns
    -------
    dict
        ``effect``, ``listed`` (in ``scene``), ``parameters`` (as rendered),
        ``ms_with``, ``ms_without``, ``ms_added`` (ms per frame),
        ``setup_ms_added`` and ``note``; the figures are None, and the note
        says why, when the effect cannot be measured on this scene.
    """
    row = {"effect": name, "listed": name in scene.effects.enabled(), "parameters": None, "ms_with": None,
           "ms_without": None, "ms_added": None, "setup_ms_added": None, "note": ""}
    try:
        pair = effect_pair(scene, name, params)
        with_pipeline, with_setup = timed_pipeline(pair.with_effect)
        without_pipeline, without_setup = timed_pipeline(pair.without_effect)
    except RollsimError as exc:
        row["note"] = f"not measured: {exc}"
        return row
    ms_with, ms_without = median_ms_in_turn([with_pipeline, without_pipeline], n_frames)
    row.update(
        parameters=getattr(pair.with_effect.effects, name).model_dump(mode="json"),
        ms_with=ms_with,
        ms_without=ms_without,
        ms_added=ms_with - ms_without,
        setup_ms_added=with_setup - without_setup,
        note=pair.note,
    )
    return row
