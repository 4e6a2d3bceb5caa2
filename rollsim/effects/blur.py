"""``blur``: lens blur, a Gaussian PSF on the LED's image and the background it hides.

See :mod:`rollsim.optics.psf`; the coverage is recomputed through the lens's
kernels by :mod:`rollsim.effects.lens`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from pydantic import Field

from rollsim.effects.base import Effect, EffectParams
from rollsim.effects.lens import with_lens_kernel
from rollsim.optics.psf import gaussian_kernel_1d

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup


class Blur(EffectParams):
    """Lens blur: a Gaussian PSF on the LED's image and the background it hides.

    ``sigma_px``: standard deviation in pixels. ``kernel``: ``separable``
    (two 1-D passes) or ``full`` (one 2-D convolution); they agree to float
    precision. ``truncate_sigma``: kernel radius in standard deviations; at
    5 the mass cut off is 5.7e-7 per axis (the kernel is renormalised, so
    light is conserved) and the kernel's variance is σ² to 2e-5.
    See :mod:`rollsim.optics.psf`.
    """

    sigma_px: float = Field(1.0, gt=0, le=100)
    kernel: Literal["separable", "full"] = "separable"
    truncate_sigma: float = Field(5.0, ge=1, le=10)


def blur_kernel(params: Blur):
    """The Gaussian kernel: a separable pair of 1-D arrays or one 2-D array."""
    k = gaussian_kernel_1d(params.sigma_px, params.truncate_sigma)
    return (k, k) if params.kernel == "separable" else k[:, None] * k[None, :]


def prepare(setup: SceneSetup, params: Blur) -> SceneSetup:
    return with_lens_kernel(setup, blur_kernel(params))


EFFECT = Effect(
    name="blur",
    params=Blur,
    prepare=prepare,
    reads=("setup.lens_kernels", "setup.led_size_px"),
    writes=("setup.lens_kernels", "setup.footprint", "setup.led_rows"),
)
