"""EMVA 1288 characterisation of a camera from its frames.

The standard's linear camera model gives a pixel's mean and temporal
variance in DN as

    μ_y = μ_y.dark + K·μ_e,        σ²_y = σ²_y.dark + K·(μ_y − μ_y.dark),
    μ_y.dark = black + K·I_d·t,    σ²_y.dark = K²·(σ_d² + I_d·t) + σ_q²,

with K the conversion gain (DN/e⁻), σ_d the read noise, I_d the dark
current and σ_q² = 1/12 DN² the quantisation noise. The temporal variance of
a pair of frames is half the variance of their difference, which removes
every fixed pattern; the spatial variance of an average of L frames, less
the temporal variance over L, is the fixed pattern's: DSNU in the dark,
PRNU in the light. These functions estimate each quantity from frames
(arrays of DN), as a camera's data sheet would give it, and are checked
against rollsim's own sensor, whose values are known.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

QUANTISATION_VARIANCE_DN2 = 1.0 / 12.0


def pair_mean_and_variance(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Mean (DN) and temporal variance (DN²) of two frames of the same exposure.

    The temporal variance is var(a − b)/2: the fixed patterns cancel.
    """
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.shape != b.shape or a.size < 2:
        raise ValueError(f"a pair needs two frames of one shape with 2 or more pixels, got {a.shape} and {b.shape}")
    return float(0.5 * (a.mean() + b.mean())), float(np.var(a - b) / 2.0)


def spatial_variance(stack: Sequence[np.ndarray]) -> tuple[float, float]:
    """Spatial variance (DN²) of the fixed pattern of L frames, and their mean (DN).

    The variance of the L-frame average, less the temporal variance over L
    (estimated from the frames' deviations from their average).
    """
    frames = np.asarray(stack, dtype=np.float64)
    if frames.ndim != 3 or frames.shape[0] < 2:
        raise ValueError(f"a stack needs 2 or more frames of one shape, got shape {frames.shape}")
    count = frames.shape[0]
    average = frames.mean(axis=0)
    temporal = float(np.mean(frames.var(axis=0, ddof=1)))
    return float(average.var() - temporal / count), float(average.mean())


@dataclass(frozen=True)
class Characterisation:
    """A camera's EMVA 1288 figures.

    Attributes
    ----------
    gain_dn_per_e : float
        Conversion gain K.
    read_noise_e : float
        Temporal dark noise σ_d at zero exposure, e⁻.
    dark_current_e_per_s : float
    dsnu_e : float
        Spatial deviation of the dark image at the stacks' exposure, e⁻.
    prnu_percent : float
        Spatial deviation of the photo-response, % of the signal.
    linearity_error_percent : float
        Largest deviation of the signal from a line through its exposures,
        % of the mean signal (EMVA 1288's LE, over 5–95 % of saturation).
    """

    gain_dn_per_e: float
    read_noise_e: float
    dark_current_e_per_s: float
    dsnu_e: float
    prnu_percent: float
    linearity_error_percent: float


def characterise(
    exposures_s: Sequence[float],
    bright_pairs: Sequence[tuple[np.ndarray, np.ndarray]],
    dark_pairs: Sequence[tuple[np.ndarray, np.ndarray]],
    bright_stack: Sequence[np.ndarray],
    dark_stack: Sequence[np.ndarray],
) -> Characterisation:
    """EMVA 1288 figures from a photon-transfer series and two frame stacks.

    Parameters
    ----------
    exposures_s : sequence of float
        Exposure of each pair, seconds, at a constant irradiance.
    bright_pairs, dark_pairs : sequence of (ndarray, ndarray)
        Two frames at each exposure, lit and dark.
    bright_stack, dark_stack : sequence of ndarray
        Frames for the spatial non-uniformity, lit (about half saturation)
        and dark, at one exposure: the dark stack's mean is the lit one's
        dark signal.
    """
    exposures = np.asarray(exposures_s, dtype=np.float64)
    if len(exposures) < 3 or len(bright_pairs) != len(exposures) or len(dark_pairs) != len(exposures):
        raise ValueError("give three or more exposures, each with a bright and a dark pair")
    bright = np.array([pair_mean_and_variance(*pair) for pair in bright_pairs])
    dark = np.array([pair_mean_and_variance(*pair) for pair in dark_pairs])
    signal, signal_variance = bright[:, 0] - dark[:, 0], bright[:, 1] - dark[:, 1]
    gain = float(np.polyfit(signal, signal_variance, 1)[0])
    # Dark mean and variance against exposure: slopes K·I_d and K²·I_d; the
    # variance's intercept is K²·σ_d² + σ_q².
    dark_current = float(np.polyfit(exposures, dark[:, 0], 1)[0]) / gain
    intercept = float(np.polyfit(exposures, dark[:, 1], 1)[1])
    read_noise = float(np.sqrt(max(intercept - QUANTISATION_VARIANCE_DN2, 0.0))) / gain
    dark_spatial, dark_mean = spatial_variance(dark_stack)
    bright_spatial, bright_mean = spatial_variance(bright_stack)
    dsnu = float(np.sqrt(max(dark_spatial, 0.0))) / gain
    prnu = 100.0 * float(np.sqrt(max(bright_spatial - dark_spatial, 0.0))) / (bright_mean - dark_mean)
    fit = np.polyval(np.polyfit(exposures, signal, 1), exposures)
    linearity = 100.0 * float(np.max(np.abs(signal - fit))) / float(np.mean(signal))
    return Characterisation(gain, read_noise, dark_current, dsnu, prnu, linearity)
