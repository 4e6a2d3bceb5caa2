"""The image signal processor after the ADC: smoothing, sharpening, compression.

Each function maps an 8-bit image (grey (H, W) or RGB (H, W, 3)) to an image
of the same shape and dtype; the effects ``isp_smoothing``, ``sharpening``
and ``jpeg`` run them on a frame's output (the tone curve and the black clip
are in the 8-bit conversion itself: :mod:`rollsim.sensor.adc`).
"""

from rollsim.isp.filters import gaussian_kernel, sharpen, smooth
from rollsim.isp.jpeg import jpeg_dc_step, jpeg_round_trip

__all__ = ["gaussian_kernel", "jpeg_dc_step", "jpeg_round_trip", "sharpen", "smooth"]
