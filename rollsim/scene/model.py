"""The validated scene: its sections (:mod:`rollsim.scene_sections`) and its
``effects`` section, derived from the effects registry.
"""

from __future__ import annotations

import functools
from typing import Optional, Sequence

from pydantic import create_model

from rollsim.effects import REGISTRY
from rollsim.effects.base import Effect
from rollsim.plumbing.text_tables import Shown, quantity
from rollsim.scene.effects import Effects, effects_model
from rollsim.scene_sections.model import Camera, Channel, Environment, Led, Link, Render, SceneSections

__all__ = ["Camera", "Channel", "Environment", "Led", "Link", "Render", "Scene", "scene_model"]


class Scene(Shown, SceneSections):
    """A validated scene. Build it with :func:`rollsim.scene.load_scene`.

    Its sections are those of :class:`~rollsim.scene_sections.SceneSections`; the
    ``effects`` section is derived from the effects registry. Its repr is one
    line of its key figures (camera, row time, exposure, distance, clock,
    pattern), not its hundred fields.
    """

    effects: Effects = Effects()

    def _figures(self):
        camera, link = self.camera, self.link
        pattern = link.pattern
        if pattern == "data":
            pattern = f"data ({link.strategy.upper()}" + ("" if link.strategy == "rlnc" else f" r={link.repeats}") + ")"
        return repr(self.name), [
            ("camera", f"{camera.width_px}x{camera.height_px} {camera.output}"),
            ("row time", quantity(camera.row_time_s * 1e6, "µs")),
            ("exposure", quantity(camera.exposure_us, "µs")),
            ("distance", quantity(link.distance_cm, "cm")),
            ("clock", quantity(link.clock_hz, "Hz")),
            ("pattern", pattern),
        ]


def scene_model(registry: Optional[Sequence[Effect]] = None) -> type[Scene]:
    """The scene model whose ``effects`` section is derived from ``registry``.

    The default registry (:data:`rollsim.effects.REGISTRY`) gives
    :class:`Scene`; another (e.g. with an effect under development) gives a
    subclass of it, whose scenes render in this process (they do not pickle
    to worker processes).
    """
    registry = REGISTRY if registry is None else tuple(registry)
    return Scene if registry == REGISTRY else _scene_model(registry)


@functools.lru_cache(maxsize=8)
def _scene_model(registry: tuple[Effect, ...]) -> type[Scene]:
    effects = effects_model(registry)
    return create_model("Scene", __base__=Scene, __module__=__name__, effects=(effects, effects()))
