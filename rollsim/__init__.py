"""rollsim: a physically based rolling-shutter simulator for optical camera communication."""

from rollsim.version import __version__

__all__ = ["__version__", "sweep"]


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
