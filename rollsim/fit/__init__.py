"""Fit a camera to real frames: ``rollsim fit-camera``.

:func:`fit_camera` estimates the row time, exposure, ISP smoothing, tone
curve, gain, read, row and column noise, and the LED's image from frames of
an LED sending a square wave, takes what the frames do not show from a base
scene (saying which), and makes a scene of them; :func:`compare` renders
that scene beside the frames.
"""

from rollsim.fit.camera import Known
from rollsim.fit.check import Comparison, compare
from rollsim.fit.refine import CameraFit, fit_camera

__all__ = ["CameraFit", "Comparison", "Known", "compare", "fit_camera"]
