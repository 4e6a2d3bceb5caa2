"""Temporal noise against level: the photon-transfer line, and the noise at anchor levels.

The fit's noise statistics are pairs (8-bit level, temporal variance) from
rows that hold one level in two frames (:func:`rollsim.fit.measure.level_noise_pairs`)
and from the background. Through the fitted tone curve (:mod:`rollsim.fit.tone`) and the
ISP's vertical smoothing they become linear: a level u (fraction of the
ADC range) and a variance a + b·u, b being the gain (fraction of the range
per electron: shot noise) and a the read noise's variance; the line through
the wrong tone curve bends, which tells linear frames from sRGB ones
(:func:`tone_from_noise`). Rows clipped at
black or at full scale have lost their noise and are left out.

How much the frames give depends on the levels they hold:

- two levels far enough apart: the line, so the gain and the read noise;
- one level: the output noise there, so the gain given a read noise (the
  base scene's);
- none: neither (both from the base scene).
"""

from __future__ import annotations

import math

import numpy as np

from rollsim.fit.tone import SRGB_GAMMA, decode, decode_slope
from rollsim.isp import gaussian_kernel

# 8-bit levels this close to 0 or 255 are clipped in part and left out.
CLIP_MARGIN = 8
# Two anchors when the usable levels span at least this ratio (linear);
# else one.
MIN_LEVEL_SPAN = 1.5
# A point counts at an anchor within this fraction of its level (or 2 levels).
ANCHOR_TOLERANCE = 0.15
# The read noise's share of the lower anchor's variance where the frames
# resolve none (shot_noise_line): too small to show in them.
BOUND_FRACTION = 1e-3


def linear_level(level, gamma: float) -> np.ndarray:
    """The linear fraction of the ADC range behind an 8-bit level, through the tone curve of
    exponent γ (:mod:`rollsim.fit.tone`)."""
    return decode(np.asarray(level, dtype=np.float64) / 255.0, gamma)


def tone_slope(level, gamma: float) -> np.ndarray:
    """d(linear fraction)/d(8-bit level) of the tone curve of exponent γ at an 8-bit level."""
    return decode_slope(np.asarray(level, dtype=np.float64) / 255.0, gamma) / 255.0


def noise_gain(sigma_rows: float) -> float:
    """The variance a white noise keeps through the ISP's vertical Gaussian: Σk²."""
    kernel = gaussian_kernel(sigma_rows).astype(np.float64)
    return float(np.sum(kernel**2))


def unclipped(levels: float | np.ndarray) -> np.ndarray:
    """Which 8-bit levels (an array, or one level: a 0-d array) are clear of both clips (:data:`CLIP_MARGIN`)."""
    levels = np.asarray(levels, dtype=np.float64)
    return (levels > CLIP_MARGIN) & (levels < 255 - CLIP_MARGIN)


def photon_transfer(levels_lin: np.ndarray, variances_lin: np.ndarray) -> tuple[float, float, float, float]:
    """Least-squares line variance = a + b·level, weighted for the variance's own spread.

    Returns a, b and their one-sigma uncertainties.
    """
    weights = 1.0 / np.maximum(variances_lin, 1e-12)  # the variance of a variance ∝ its square
    design = np.column_stack([np.ones_like(levels_lin), levels_lin])
    sw = np.sqrt(weights)
    coef, *_ = np.linalg.lstsq(design * sw[:, None], variances_lin * sw, rcond=None)
    resid = (variances_lin - design @ coef) * sw
    dof = max(1, levels_lin.size - 2)
    cov = np.linalg.pinv((design * sw[:, None]).T @ (design * sw[:, None])) * float(resid @ resid) / dof
    return float(coef[0]), float(coef[1]), float(np.sqrt(max(cov[0, 0], 0.0))), float(np.sqrt(max(cov[1, 1], 0.0)))


# The fewest noise points that can tell the tone curve's family.
MIN_TONE_POINTS = 10


def tone_from_noise(levels: np.ndarray, variances: np.ndarray) -> float | None:
    """The tone curve's exponent the noise tells: 1 (linear) or sRGB's, or None where it cannot tell.

    Through the camera's own tone curve the temporal variance is a line in
    the linear level, a + b·u, with a read-noise variance a ≥ 0 and a gain
    b > 0 (:func:`photon_transfer`). Through the wrong one it bends, and the
    line fitted to it leaves the physical quadrant: sRGB's noise, taken as
    linear, is nearly flat in the level, so the line's intercept goes
    negative; linear noise through sRGB's curve falls with the level. The
    family is told where exactly one of the two curves gives a physical
    line (the planes fit-camera measures on the fitted hidden cameras of
    rollsim bench fit-camera seeds 1–4: 48 of 75 told, 46 of them rightly;
    the rest give a physical line through both curves or neither, JPEG
    and smoothing most often).

    Parameters
    ----------
    levels, variances : ndarray
        Unclipped noise points: 8-bit levels and their temporal variances.
    """
    levels, variances = np.asarray(levels, dtype=np.float64), np.asarray(variances, dtype=np.float64)
    if levels.size < MIN_TONE_POINTS:
        return None
    physical = []
    for gamma in (1.0, SRGB_GAMMA):
        a, b = photon_transfer(linear_level(levels, gamma), variances * tone_slope(levels, gamma) ** 2)[:2]
        physical.append(a >= 0.0 and b > 0.0)
    if physical[0] == physical[1]:
        return None
    return 1.0 if physical[0] else SRGB_GAMMA


def anchor_levels(levels: np.ndarray, gamma: float) -> list[float]:
    """The 8-bit levels the noise is matched at: the medians of the lowest and
    highest thirds of the points when they span :data:`MIN_LEVEL_SPAN`
    (linear), else their median; none without points."""
    levels = np.sort(np.asarray(levels, dtype=np.float64))
    if levels.size == 0:
        return []
    lin = linear_level(levels, gamma)
    third = max(1, levels.size // 3)
    low, high = float(np.median(levels[:third])), float(np.median(levels[-third:]))
    if levels.size >= 6 and lin[-third:].min() >= MIN_LEVEL_SPAN * max(lin[:third].max(), 1e-12):
        return [low, high]
    return [float(np.median(levels))]


def noise_at(levels: np.ndarray, variances: np.ndarray, anchor: float) -> float | None:
    """Mean temporal variance of the points within :data:`ANCHOR_TOLERANCE` of
    ``anchor`` (8-bit levels), or None when none is."""
    near = np.abs(np.asarray(levels) - anchor) <= max(2.0, ANCHOR_TOLERANCE * anchor)
    return float(np.mean(np.asarray(variances)[near])) if near.any() else None


def gain_given_read(level_lin: float, variance_lin: float, read_e: float) -> float:
    """The gain b (fraction of the range per electron) for which a read noise of
    ``read_e`` electrons and shot noise give ``variance_lin`` at ``level_lin``:
    the positive root of read_e²·b² + u·b − v = 0."""
    if read_e <= 0:
        return variance_lin / max(level_lin, 1e-12)
    r2 = read_e**2
    return (-level_lin + math.sqrt(level_lin**2 + 4.0 * r2 * variance_lin)) / (2.0 * r2)


def shot_noise_line(points: list[tuple[float, float]]) -> tuple[float, float]:
    """The photon-transfer line a + b·u nearest two points whose own line has no read noise (a ≤ 0).

    Parameters
    ----------
    points : list of two (u, v)
        Linear levels u > 0 (fractions of the ADC range) and the variances
        v > 0 wanted there (linear).

    Returns
    -------
    a, b : float
        The read noise's variance and the gain (fraction of the range per
        electron), both > 0.

    Notes
    -----
    A line through the points with a ≤ 0 says that the variance grows at
    least in proportion to the level: the read noise is below what the
    frames resolve. a is then held at :data:`BOUND_FRACTION` of the lower
    variance, and b is the one that minimises the squared log ratios at the
    two points (what the refinement's noise mismatch sums): the geometric
    mean of (v − a)/u.
    """
    (u0, v0), (u1, v1) = points
    a = BOUND_FRACTION * min(v0, v1)
    return a, math.sqrt(max(v0 - a, a) / u0 * max(v1 - a, a) / u1)
