"""Per-scene constants of the render, computed once before any frame.

Everything here depends on the scene only, not on the frame: timing, the
transmitter, the LED footprint, and the electron rates of the LED, the
background and the LED's face. Rates are electrons per second for one pixel
fully covered, before the sensor's noise (QE applied;
:mod:`rollsim.optics.scene_light`).

An effect's per-scene hook (:attr:`rollsim.effects.Effect.prepare`) returns
a new setup with some of these fields changed; the fields below the core's
are those hooks' declared outputs, which later hooks and the stages read
instead of another effect's settings.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rollsim.optics import led_centre_px, led_image_size_px, magnification
from rollsim.optics.footprint import Footprint, footprint, led_rows_from_coverage
from rollsim.optics.scene_light import ambient_electron_rates, led_electron_rate
from rollsim.optics.vignetting import image_distance_m
from rollsim.sensor import RowTiming
from rollsim.sensor.tone import ToneCurve
from rollsim.transmitter import Transmitter, transmitter_from_scene

if TYPE_CHECKING:
    from rollsim.scene_sections import SceneSections
    from rollsim.video import VideoSettings


@dataclass(frozen=True)
class SceneSetup:
    """What every frame of a scene shares.

    Attributes
    ----------
    scene : SceneSections
    timing : RowTiming
    transmitter : Transmitter
    footprint : Footprint
        LED coverage on its bounding box: where the LED's body hides the
        background (and, without ``led_profile`` or ``glare``, where its light falls).
    led_centre_px : (float, float)
    led_size_px : float
    led_rows : (int, int) or None
        First and last LED row (rows covered by at least
        :data:`~rollsim.optics.footprint.MIN_ROW_COVERAGE_PX` of pixel area,
        of the blurred coverage when a lens PSF is listed); None if none is.
    led_e_per_s, background_e_per_s, face_e_per_s : float or ndarray
        Electron rates per fully covered pixel (see module docstring): one
        value for every pixel, or an (H, W) map once an effect makes them
        depend on the pixel (vignetting, a colour filter array).
    gain_dn_per_e : float
        Conversion gain at the set ISO.
    image_distance_m : float
        Lens-to-sensor distance: the image plane of the LED's distance, or of
        the focus distance (``defocus``).
    prepared : tuple of str or None
        Effects whose per-scene hooks have run
        (:func:`rollsim.render.stages.prepare_setup`); None before.
    led_light : Footprint or None
        Where the LED's light falls, in units of a fully covered pixel at the
        face's mean luminance, when an effect spreads it beyond the footprint
        (``led_profile``, ``glare``); None means ``footprint``.
    lens_kernels : tuple
        The lens PSF's kernels, in the order they convolve (``blur``,
        ``defocus``); empty for a sharp image.
    cfa_pattern, demosaic : str or None
        The colour filter array's top-left 2×2 block and the demosaic method
        of ``rgb8`` output (``bayer``); None for a monochrome sensor.
    tone : ToneCurve or None
        The tone curve of ``gray8`` and ``rgb8`` output (``tone_curve``); None
        for linear.
    video_codec : VideoSettings or None
        The encoding the finished frames pass through, a GOP at a time
        (``video_codec``: :class:`rollsim.render.pipeline.RenderPipeline`); None for none.
    """

    scene: SceneSections
    timing: RowTiming
    transmitter: Transmitter
    footprint: Footprint
    led_centre_px: tuple
    led_size_px: float
    led_rows: tuple | None
    # Scalars, or per-pixel maps once an effect (bayer, vignetting) makes them vary.
    led_e_per_s: float | np.ndarray
    background_e_per_s: float | np.ndarray
    face_e_per_s: float | np.ndarray
    gain_dn_per_e: float
    image_distance_m: float
    prepared: tuple | None = None
    # Declared outputs of the effects' per-scene hooks.
    led_light: Footprint | None = None
    lens_kernels: tuple = ()
    cfa_pattern: str | None = None
    demosaic: str | None = None
    tone: ToneCurve | None = None
    video_codec: VideoSettings | None = None

    @property
    def shape(self) -> tuple[int, int]:
        return self.scene.camera.height_px, self.scene.camera.width_px


def build_setup(scene: SceneSections) -> SceneSetup:
    """Compute a scene's :class:`SceneSetup`."""
    cam = scene.camera
    centre = led_centre_px(scene)
    size = led_image_size_px(scene)
    fp = footprint(centre, size, scene.led.shape, (cam.height_px, cam.width_px), scene.render.footprint_edge)
    background, face = ambient_electron_rates(scene)
    f_m = cam.focal_length_mm * 1e-3
    return SceneSetup(
        scene=scene,
        timing=RowTiming.from_camera(cam),
        transmitter=transmitter_from_scene(scene),
        footprint=fp,
        led_centre_px=centre,
        led_size_px=size,
        led_rows=led_rows_from_coverage(fp.row_coverage(cam.height_px)),
        led_e_per_s=led_electron_rate(scene),
        background_e_per_s=background,
        face_e_per_s=face,
        gain_dn_per_e=cam.gain_dn_per_e_at_iso,
        image_distance_m=image_distance_m(f_m, magnification(f_m, scene.link.distance_m)),
    )
