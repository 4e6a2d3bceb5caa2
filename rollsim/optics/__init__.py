"""Optics: thin-lens geometry, the LED footprint and radiometry."""

from rollsim.optics.geometry import (
    covered_rows,
    image_size_px,
    led_centre_px,
    led_image_size_px,
    led_rows,
    magnification,
)

__all__ = ["covered_rows", "image_size_px", "led_centre_px", "led_image_size_px", "led_rows", "magnification"]
