"""Thin-lens geometry: where the LED lands on the sensor and how big it is.

The thin lens images an object at distance d through focal length f with
magnification m = f / (d - f); an LED of size l appears l·m on the sensor, or
l·m / pitch pixels. The paper's Eq. 10 ROI ratio is the MMBP layer's
approximation (:func:`rollsim.channel.analytic.roi_ratio`); the pixel layer
uses this real footprint.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rollsim.scene_sections import SceneSections


def magnification(focal_length_m: float, distance_m: float) -> float:
    """Thin-lens magnification m = f / (d - f).

    Parameters
    ----------
    focal_length_m : float
        Focal length f in metres (> 0).
    distance_m : float
        Object distance d in metres; must exceed f.

    Raises
    ------
    ValueError
        If d <= f, where the thin lens forms no real image.
    """
    if not focal_length_m > 0:
        raise ValueError(f"focal_length_m must be > 0, got {focal_length_m}")
    if not distance_m > focal_length_m:
        raise ValueError(
            f"distance_m = {distance_m} must exceed the focal length {focal_length_m} m: the thin lens diverges"
        )
    return focal_length_m / (distance_m - focal_length_m)


def image_size_px(size_m: float, focal_length_m: float, distance_m: float, pixel_pitch_m: float) -> float:
    """Size in pixels of the image of an object of size ``size_m``: l·m / pitch."""
    if not pixel_pitch_m > 0:
        raise ValueError(f"pixel_pitch_m must be > 0, got {pixel_pitch_m}")
    return size_m * magnification(focal_length_m, distance_m) / pixel_pitch_m


def covered_rows(centre_y_px: float, height_px: float, frame_height_px: int) -> tuple[int, int]:
    """First and last frame row that a footprint of ``height_px`` touches.

    Row y spans [y, y + 1) in pixel coordinates; the footprint spans
    [centre - height/2, centre + height/2]. Rows outside the frame are
    clipped. Returns ``(first, last)``; ``first > last`` when no row is
    touched (the footprint lies wholly outside the frame).
    """
    top = centre_y_px - 0.5 * height_px
    bottom = centre_y_px + 0.5 * height_px
    first = max(0, int(np.floor(top)))
    last = min(frame_height_px - 1, int(np.ceil(bottom)) - 1)
    return first, last


def led_image_size_px(scene: SceneSections) -> float:
    """Size in pixels of the scene's LED image (diameter or side)."""
    cam = scene.camera
    return image_size_px(scene.led.size_mm * 1e-3, cam.focal_length_mm * 1e-3, scene.link.distance_m, cam.pixel_pitch_um * 1e-6)


def led_centre_px(scene: SceneSections) -> tuple[float, float]:
    """``(x, y)`` pixel coordinates of the LED image centre (default: frame centre)."""
    if scene.led.position_px is not None:
        x, y = scene.led.position_px
        return float(x), float(y)
    return 0.5 * scene.camera.width_px, 0.5 * scene.camera.height_px


def led_rows(scene: SceneSections) -> tuple[int, int]:
    """First and last frame row the scene's LED footprint touches (see :func:`covered_rows`)."""
    _, y = led_centre_px(scene)
    return covered_rows(y, led_image_size_px(scene), scene.camera.height_px)
