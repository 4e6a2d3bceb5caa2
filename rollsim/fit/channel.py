"""Colour frames for a camera fit: the colour plane that carries the stripes.

A colour camera films a red LED mostly in its red channel, but the red
plane of a Bayer sensor is sampled on every other row and column, and the
demosaicing that fills it in shapes its stripes' edges in a way the stripe
model (one box, one Gaussian) does not hold; the green plane has twice the
samples. So the stripes' contrast-to-noise ratio (the amplitude of the row
profile's component at the stripe frequency over the temporal noise of
that profile, from frame differences) names one candidate, the green
plane is the other (:func:`plane_shortlist`); the fit is made in both,
and the one whose render, read in the other plane, lies nearer its
exposure is kept (:func:`rollsim.fit.refine.plane_kept`).
Luminance is not a candidate: it mixes channels that clip at different
levels, which no single clip and tone curve reproduce.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from rollsim.fit.measure import level_noise_pairs

# Rec. 601 luma weights (what a JPEG's Y holds).
LUMA_WEIGHTS = (0.299, 0.587, 0.114)
CANDIDATES = ("luminance", "red", "green", "blue")


def plane(frame: np.ndarray, name: str) -> np.ndarray:
    """One of :data:`CANDIDATES` of a colour frame (H, W, 3), RGB, as grey (H, W) float64."""
    rgb = np.asarray(frame, dtype=np.float64)
    if name == "luminance":
        return rgb @ np.asarray(LUMA_WEIGHTS)
    return rgb[:, :, CANDIDATES.index(name) - 1]


def stripe_contrast_to_noise(planes: Sequence[np.ndarray], period_rows: float) -> float:
    """Amplitude of the row profiles' component at the stripe frequency over
    the pixels' temporal noise (:func:`rollsim.fit.measure.level_noise_pairs`:
    rows that hold one level in two frames), per column averaged."""
    profiles = np.array([p.mean(axis=1) for p in planes])
    rows = np.arange(profiles.shape[1])
    wave = np.exp(-2j * np.pi * rows / period_rows)
    amplitude = float(np.mean(np.abs((profiles - profiles.mean(axis=1, keepdims=True)) @ wave))) * 2 / rows.size
    _, variances = level_noise_pairs(planes, slice(0, planes[0].shape[0]), slice(0, planes[0].shape[1]))
    if variances.size == 0:
        return amplitude
    return amplitude / (float(np.sqrt(np.median(variances))) / np.sqrt(planes[0].shape[1]) + 1e-9)


# The green plane is not fitted when its stripes' contrast-to-noise (their
# amplitude over one row's noise) is below this: a fit to stripes fainter
# than a few sigma a row can look precise and still be wrong (rollsim bench
# fit-camera, seed 1: green planes at 0.5 and 0.7 won on precision and
# fitted to correlations of 0.08 and −0.4; over seeds 1–2, the five green
# planes at 5 or more that won told the exposure within 5 % directly).
MIN_SAMPLED_CNR = 3.0
COLOUR_PLANES = ("red", "green", "blue")
# A Bayer sensor's best-sampled plane: half its pixels, on every row.
SAMPLED_PLANE = "green"


def plane_shortlist(frames: Sequence[np.ndarray], period_rows: float) -> list[tuple[str, list[np.ndarray]]]:
    """The colour planes worth a stripe fit: the one of the best stripe
    contrast-to-noise, and the green plane (every row sampled) unless its
    stripes' contrast-to-noise is under :data:`MIN_SAMPLED_CNR`.

    Parameters
    ----------
    frames : sequence of ndarray
        Colour frames (H, W, 3), RGB.
    period_rows : float
        The stripe period, rows.

    Returns
    -------
    list of (name, planes)
        ``name`` one of :data:`COLOUR_PLANES`; ``planes`` the frames in it
        as grey (H, W) float64; the best contrast-to-noise first.
    """
    planes = {name: [plane(f, name) for f in frames] for name in COLOUR_PLANES}
    scores = {name: stripe_contrast_to_noise(planes[name], period_rows) for name in COLOUR_PLANES}
    best = max(COLOUR_PLANES, key=lambda name: scores[name])
    names = [best]
    if best != SAMPLED_PLANE and scores[SAMPLED_PLANE] >= MIN_SAMPLED_CNR:
        names.append(SAMPLED_PLANE)
    return [(name, planes[name]) for name in names]
