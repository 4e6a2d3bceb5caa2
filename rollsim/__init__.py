"""rollsim: a physically based rolling-shutter simulator for optical camera communication.

The Python API (:mod:`rollsim.api`) mirrors the command line::

    import rollsim as rs
    scene = rs.load_scene("paper-default", overrides={"link.distance_cm": 10})
    frames = rs.render(scene, n_frames=60, seed=1)
    result = rs.evaluate(frames.truth, rs.decode(frames))
    fit = rs.calibrate(result)

Its names are imported on first use, so that ``import rollsim`` stays light.
"""

from rollsim.version import __version__

_API = ("Calibration", "Frame", "FrameTruth", "Frames", "MmbpModel", "Result", "SduTruth", "Truth",
        "calibrate", "decode", "evaluate", "load_scene", "render", "simulate")

__all__ = ["__version__", "sweep", *_API]


def __getattr__(name: str):
    if name in _API:
        from rollsim import api

        return getattr(api, name)
    raise AttributeError(f"module 'rollsim' has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), *_API])


def sweep(scene, grid=None, stage="analytic", **kwargs):
    """Run a sweep of ``scene`` over ``grid`` on Dask; the results as a table.

    See :func:`rollsim.sweeps.sweep` for every parameter. Imported on first
    use, so that ``import rollsim`` stays light.

    Examples
    --------
    >>> import rollsim
    >>> table = rollsim.sweep("paper-default", grid={"link.distance_cm": [5, 10]})  # doctest: +SKIP
    """
    from rollsim.sweeps import sweep as run

    return run(scene, grid, stage, **kwargs)
