"""Colour frames for a camera fit: luminance, or the channel that carries the stripes.

A colour camera films a red LED mostly in its red channel: luminance mixes
in the green and blue channels' noise for little signal. Each candidate
(luminance, red, green, blue) is scored by its stripe contrast-to-noise
ratio, the amplitude of the row profile's component at the stripe
frequency over the temporal noise of that profile (from frame
differences); the fit runs on the best, and says which.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from rollsim.fit.measure import level_noise_pairs

# Rec. 601 luma weights (what a JPEG's Y holds).
LUMA_WEIGHTS = (0.299, 0.587, 0.114)
CANDIDATES = ("luminance", "red", "green", "blue")


def candidate_planes(frame: np.ndarray) -> dict:
    """The grey planes a colour frame (H, W, 3), RGB, offers, float64."""
    return {name: plane(frame, name) for name in CANDIDATES}


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


def choose_channel(frames: Sequence[np.ndarray], period_rows: float) -> tuple[str, list[np.ndarray]]:
    """The candidate plane with the best stripe contrast-to-noise, and the frames in it.

    Parameters
    ----------
    frames : sequence of ndarray
        Colour frames (H, W, 3), RGB.
    period_rows : float
        The stripe period, rows.

    Returns
    -------
    (name, planes)
        ``name`` one of :data:`CANDIDATES`; ``planes`` the frames as grey (H, W) float64.
    """
    split = [candidate_planes(f) for f in frames]
    scores = {name: stripe_contrast_to_noise([s[name] for s in split], period_rows) for name in CANDIDATES}
    best = max(CANDIDATES, key=lambda name: scores[name])
    return best, [s[best] for s in split]
