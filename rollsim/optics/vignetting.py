"""Natural vignetting: the cos⁴θ fall-off of image irradiance off axis.

A pixel at distance r from the optical centre on the sensor sees the exit
pupil at field angle θ, tan θ = r / v, with v = f·(1 + m) the image distance
(the lens-to-sensor distance of a thin lens focused at magnification m).
Irradiance falls as cos⁴θ (one cos for the oblique pupil, one for the
oblique pixel, two for the longer distance, squared). With
cos²θ = 1 / (1 + tan²θ) the map is computed as (1 + (r/v)²)⁻², which is
exact and never takes an arc tangent.
"""

from __future__ import annotations

import numpy as np

from rollsim.plumbing.validation import as_positive


def image_distance_m(focal_length_m: float, magnification: float) -> float:
    """Thin-lens image distance v = f·(1 + m), in m (f > 0 in m, m >= 0)."""
    as_positive(focal_length_m, "focal_length_m")
    as_positive(magnification, "magnification", allow_zero=True)
    return focal_length_m * (1.0 + magnification)


def cos4_map(shape: tuple[int, int], pixel_pitch_m: float, image_distance_m: float, centre_px=None) -> np.ndarray:
    """cos⁴θ at every pixel centre.

    Parameters
    ----------
    shape : (int, int)
        ``(height, width)`` of the frame.
    pixel_pitch_m : float
    image_distance_m : float
        v, lens to sensor (> 0).
    centre_px : (float, float), optional
        ``(x, y)`` of the optical centre in pixel coordinates (pixel (x, y)
        spans [x, x+1) × [y, y+1)); default the frame centre (W/2, H/2).

    Returns
    -------
    ndarray of float64, shape ``shape``
        In (0, 1]; exactly 1 at a pixel whose centre is the optical centre.
    """
    if not (pixel_pitch_m > 0 and image_distance_m > 0):
        raise ValueError("pixel_pitch_m and image_distance_m must be > 0")
    height, width = shape
    cx, cy = (0.5 * width, 0.5 * height) if centre_px is None else centre_px
    scale = pixel_pitch_m / image_distance_m
    tx2 = ((np.arange(width) + 0.5 - cx) * scale) ** 2
    ty2 = ((np.arange(height) + 0.5 - cy) * scale) ** 2
    return 1.0 / (1.0 + ty2[:, None] + tx2[None, :]) ** 2
