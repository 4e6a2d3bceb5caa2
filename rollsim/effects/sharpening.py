"""``sharpening``: the ISP's unsharp mask.

Phone ISPs sharpen after denoising, which overshoots at a stripe's edges:
the row profile gains a ringing of amplitude a times the edge's detail. The
stage runs on the 8-bit image (:func:`rollsim.isp.sharpen`); on a sinusoid
of f cycles per pixel it multiplies the amplitude by
1 + a·(1 − exp(−2π²σ²f²)).
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from rollsim.effects.base import EffectParams, isp_effect
from rollsim.isp import sharpen


class Sharpening(EffectParams):
    """Unsharp masking of the 8-bit image: gain ``amount`` ([0, 5], default 0.5)
    on the detail below a Gaussian of ``sigma_px`` (px, (0, 20], default 1)."""

    amount: float = Field(0.5, ge=0, le=5)
    sigma_px: float = Field(1.0, gt=0, le=20)


def apply(image: np.ndarray, params: Sharpening) -> np.ndarray:
    return sharpen(image, params.amount, params.sigma_px)


EFFECT = isp_effect("sharpening", Sharpening, "sharpen", apply)
