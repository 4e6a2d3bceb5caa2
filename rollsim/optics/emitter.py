"""The LED's face is not uniformly bright: its radiance profile.

A 5 mm LED's epoxy dome is a lens: seen head-on, most of its light comes
from the magnified image of the chip at the dome's centre, and the rest of
the dome glows dimmer, falling off smoothly towards the rim. rollsim models
the face's luminance as a Gaussian of the distance ρ from its centre,

    L(ρ) ∝ exp(−ρ² / 2σ²),   ρ ≤ D/2,

truncated at the face's edge and scaled so that the face still emits the
LED's luminous intensity: the profile moves light towards the centre and
conserves it (the sum of coverage × weight equals the sum of coverage, in
the discrete map as well).
"""

from __future__ import annotations

import numpy as np

from rollsim.optics.footprint import Footprint
from rollsim.numerics.portable_math import exp  # numpy's differs in the last bit between CPUs


def profiled_light(fp: Footprint, centre_px: tuple[float, float], sigma_px: float) -> Footprint:
    """The footprint's coverage weighted by a Gaussian radiance profile.

    Parameters
    ----------
    fp : Footprint
        The LED's coverage.
    centre_px : (float, float)
        ``(x, y)`` of the LED's centre in the frame, pixel coordinates (pixel
        (i, j) spans [j, j + 1) × [i, i + 1)).
    sigma_px : float
        σ of the profile in image pixels (σ on the face times the
        magnification, over the pitch), > 0.

    Returns
    -------
    Footprint
        Same box; ``coverage`` holds relative light (may exceed 1 at the
        centre), with the same sum as ``fp.coverage``.
    """
    if not sigma_px > 0:
        raise ValueError(f"sigma_px must be > 0, got {sigma_px}")
    if fp.coverage.size == 0 or not fp.coverage.any():
        return fp
    rho2 = _radius2_px2(fp, centre_px)
    # Relative to the nearest lit pixel: a profile far narrower than a pixel
    # must not underflow everywhere (its light then lands in that pixel).
    nearest = rho2[fp.coverage > 0].min()
    return _weighted(fp, exp(-(rho2 - nearest) / (2.0 * sigma_px**2)))


def radial_table_light(fp: Footprint, centre_px: tuple[float, float], radius_px: float, table) -> Footprint:
    """The footprint's coverage weighted by a measured radial radiance profile.

    Parameters
    ----------
    fp : Footprint
        The LED's coverage.
    centre_px : (float, float)
        ``(x, y)`` of the LED's centre in the frame, pixel coordinates.
    radius_px : float
        The face's radius in image pixels, > 0: the table's radius 1.
    table : sequence of (float, float)
        (radius / face radius, relative radiance) pairs, radii rising from 0
        to 1, radiances ≥ 0 and not all 0; linear between them, the last
        value beyond 1 (a square face's corners).

    Returns
    -------
    Footprint
        Same box; ``coverage`` holds relative light, with the same sum as
        ``fp.coverage`` (the face emits the same total).
    """
    if not radius_px > 0:
        raise ValueError(f"radius_px must be > 0, got {radius_px}")
    if fp.coverage.size == 0 or not fp.coverage.any():
        return fp
    pts = np.asarray(table, dtype=np.float64)
    weights = np.interp(np.sqrt(_radius2_px2(fp, centre_px)) / radius_px, pts[:, 0], pts[:, 1])
    if not (weights * fp.coverage).any():
        raise ValueError("the radial profile is zero over the whole face")
    return _weighted(fp, weights)


def _radius2_px2(fp: Footprint, centre_px: tuple[float, float]) -> np.ndarray:
    """Squared distance of each box pixel's centre from ``centre_px``, px²."""
    cx, cy = centre_px
    ys = np.arange(fp.rows.start, fp.rows.stop) + 0.5 - cy
    xs = np.arange(fp.cols.start, fp.cols.stop) + 0.5 - cx
    return ys[:, None] ** 2 + xs[None, :] ** 2


def _weighted(fp: Footprint, weights: np.ndarray) -> Footprint:
    """The coverage times ``weights``, rescaled to the coverage's sum (light conserved)."""
    light = fp.coverage * weights
    light *= fp.coverage.sum() / light.sum()
    return Footprint(fp.rows, fp.cols, light)
