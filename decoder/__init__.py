"""OpenCV stripe decoder for rolling-shutter OCC frames.

It imports only :mod:`rollsim.protocol` from rollsim, so that it also runs on
frames from a real camera.
"""
