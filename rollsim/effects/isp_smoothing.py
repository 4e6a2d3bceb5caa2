"""``isp_smoothing``: the ISP's noise filter, a Gaussian mostly down the columns.

Phone and Raspberry Pi ISPs denoise the luma with filters that also smooth
across rows, widening a rolling-shutter stripe's edges beyond the exposure
box (a real camera's 10–90 % edge rise of ~5 rows at 9.1 µs per row). The
stage runs on the 8-bit image (:func:`rollsim.isp.smooth`); a step edge's
10–90 % rise grows by 2.563 σ.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from rollsim.effects.base import EffectParams, isp_effect
from rollsim.isp import smooth


# The widest Gaussian the stage takes, px (an ISP's denoiser spans a few rows).
MAX_SIGMA_PX = 50.0


class IspSmoothing(EffectParams):
    """Gaussian smoothing of the 8-bit image: ``sigma_rows_px`` (px, [0, 50],
    default 1) across rows, ``sigma_cols_px`` (px, [0, 50], default 0) along them."""

    sigma_rows_px: float = Field(1.0, ge=0, le=MAX_SIGMA_PX)
    sigma_cols_px: float = Field(0.0, ge=0, le=MAX_SIGMA_PX)


def apply(image: np.ndarray, params: IspSmoothing) -> np.ndarray:
    return smooth(image, params.sigma_rows_px, params.sigma_cols_px)


EFFECT = isp_effect("isp_smoothing", IspSmoothing, "denoise", apply)
