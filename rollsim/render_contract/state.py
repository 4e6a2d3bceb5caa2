"""The state one frame carries through the render pipeline."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from rollsim.numerics.counter_rng import stream_key
from rollsim.numerics.seeds import rng as named_rng
from rollsim.sensor.means import SeparableMeans, materialize

if TYPE_CHECKING:
    from rollsim.optics.footprint import Footprint
    from rollsim.render_contract.setup import SceneSetup


def _not_yet() -> np.ndarray:
    # An array a core stage has not filled in yet (the core's slots come
    # first, so a stage never sees one).
    return np.empty(0)


@dataclass(slots=True)
class FrameState:
    """Arrays of one frame as the stages fill them in.

    Stages meet only through these fields (slotted: a stage that sets any
    other attribute fails), so an effect's inputs and outputs are declared
    here, with their types.

    Attributes
    ----------
    setup : SceneSetup
        Per-scene constants.
    index : int
        Frame index k.
    start_s : float
        Frame start t_k in seconds.
    led_exposure_s : ndarray, shape (H,)
        ∫ s dt over each row's exposure window, in seconds at level 1.
    electrons : ndarray of float64, shape (H, W)
        Mean photo-electrons, then electrons after each noise stage. While
        ``means`` holds them as parts, reading this writes the frame (once)
        and setting it drops the parts.
    means : SeparableMeans or None
        The mean electrons as their parts (:mod:`rollsim.sensor.means`), not
        written into a frame yet: set by the LED's signal and the ambient
        light; the compiled sensor chain reads them block by block, and the
        frame is written only for a stage that reads it.
    dn : ndarray of uint16, shape (H, W)
        ADC output.
    image : ndarray
        The output frame (uint8 or uint16).
    footprint : Footprint or None
        This frame's LED coverage when it differs from the setup's (the
        ``motion`` effect); None means ``setup.footprint``.
    led_light : Footprint or None
        This frame's LED light when the light differs from the coverage
        (``led_profile`` or ``glare``) and moves (``motion``); None means the
        setup's light, or this frame's ``footprint`` where only it moves.
    led_rows : (int, int), () or None
        This frame's LED rows for the truth; ``()`` when no row is an LED
        row; None means ``setup.led_rows``.
    led_centre_px : (float, float) or None
        Where this frame shows the LED's centre (x, y), px, when it moves
        (``motion``); None: at rest, not recorded in the truth.
    ambient_row_factor : ndarray, shape (H,), or None
        Relative ambient exposure of each row (the ``flicker`` effect);
        None means 1.
    """

    setup: SceneSetup
    index: int
    start_s: float = 0.0
    led_exposure_s: np.ndarray = field(default_factory=_not_yet)
    _electrons: np.ndarray = field(default_factory=_not_yet)
    means: SeparableMeans | None = None
    dn: np.ndarray = field(default_factory=_not_yet)
    image: np.ndarray = field(default_factory=_not_yet)
    footprint: Footprint | None = None
    led_light: Footprint | None = None
    led_rows: tuple | None = None
    led_centre_px: tuple | None = None
    ambient_row_factor: np.ndarray | None = None

    @property
    def electrons(self) -> np.ndarray:
        if self.means is not None:
            self._electrons = materialize(self.means)
            self.means = None
        return self._electrons

    @electrons.setter
    def electrons(self, value: np.ndarray) -> None:
        self._electrons = value
        self.means = None

    @property
    def means_or_electrons(self) -> SeparableMeans | np.ndarray:
        """The mean electrons as their parts while no stage has written the frame, else the frame.

        For the sensor chain (:func:`rollsim.sensor.chain.run_chain`), which
        writes each block's means from the parts itself.
        """
        return self._electrons if self.means is None else self.means

    @property
    def led_footprint(self) -> Footprint:
        """The LED coverage of this frame."""
        return self.setup.footprint if self.footprint is None else self.footprint

    def rng(self, stream: str) -> np.random.Generator:
        """Random generator of ``stream`` for this frame: depends only on the
        scene seed, the stream name and the frame index, so frames can be
        rendered in any order or in parallel with identical results."""
        return named_rng(self.setup.scene.seed, stream, self.index)

    def counter_key(self, stream: str) -> np.uint64:
        """The 64-bit counter key of ``stream`` for this frame (:mod:`rollsim.numerics.counter_rng`): one
        draw of :meth:`rng`, the key a noise stage's per-pixel words derive from."""
        return stream_key(self.rng(stream))
