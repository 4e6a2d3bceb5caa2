"""The lens PSF's effect on a scene's setup, shared by ``blur`` and ``defocus``.

Not an effect: the one step both lens effects end with. Their kernels
convolve (:func:`rollsim.optics.psf.convolve_full`), so each appends its
kernel to ``setup.lens_kernels`` and the LED's coverage is recomputed from
its geometry through all of them: the footprint then is that of every lens
effect listed so far, whatever their number.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from rollsim.optics.footprint import led_rows_from_coverage
from rollsim.optics.psf import blurred_footprint

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup


def with_lens_kernel(setup: SceneSetup, kernel, **changes) -> SceneSetup:
    """``setup`` with ``kernel`` added to the lens PSF (and ``changes`` applied first).

    The LED rows are those of the blurred coverage: a row belongs to the LED
    when the LED's light in it adds up to
    :data:`~rollsim.optics.footprint.MIN_ROW_COVERAGE_PX` fully covered
    pixels, the same rule as without a PSF (where it marks the footprint's
    geometric extent). A strong blur thus counts a dim rim: the light is
    there, with its stripes, though a decoder may not find it.
    """
    setup = replace(setup, lens_kernels=setup.lens_kernels + (kernel,), **changes)
    scene = setup.scene
    fp = blurred_footprint(setup.led_centre_px, setup.led_size_px, scene.led.shape, setup.shape,
                           list(setup.lens_kernels), scene.render.footprint_edge)
    return replace(setup, footprint=fp, led_rows=led_rows_from_coverage(fp.row_coverage(scene.camera.height_px)))
