"""rollsim: a physically based rolling-shutter simulator for optical camera communication.

The Python API (:mod:`rollsim.api`) mirrors the command line (the whole
loop runs in :mod:`rollsim.api`'s examples; here, what needs no frames):

>>> import rollsim as rs
>>> scene = rs.load_scene("paper-default", overrides={"link.distance_cm": 10})
>>> frames = rs.render(scene, n_frames=60, seed=1)     # nothing rendered until iterated
>>> len(frames), frames.scene.link.distance_cm
(60, 10.0)
>>> result = rs.evaluate(frames.truth, rs.decode(frames))  # doctest: +SKIP
>>> fit = rs.calibrate(result)  # doctest: +SKIP

Its names are imported on first use, so that ``import rollsim`` stays light.
"""

from rollsim.version import __version__

_API = ("AnnotatedFrame", "Calibration", "Frame", "FrameTruth", "Frames", "MmbpModel", "Result", "SduTruth", "Truth",
        "calibrate", "decode", "evaluate", "load_scene", "render", "show", "simulate", "sweep")

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name in _API:
        from rollsim import api

        return getattr(api, name)
    raise AttributeError(f"module 'rollsim' has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), *_API])

