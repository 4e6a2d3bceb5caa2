"""Mains flicker of the ambient light, integrated over each row's exposure.

A lamp on an AC supply of frequency f flickers at 2f (its power follows the
square of the current). The illuminance is modelled as

    E(t) = E0·(1 + m·cos(2π·2f·t + φ)),

with modulation depth m in [0, 1] and phase φ at t = 0 (the start of frame
0). Row y integrates it over its own window [t_a, t_b], exactly:

    ∫ E dt / (E0·t_exp) = 1 + m·sinc(2f·t_exp)·cos(2π·2f·t_mid + φ),

t_mid = (t_a + t_b)/2 and sinc(x) = sin(πx)/(πx). The factor varies slowly
with the row, so it shows as bands with a period of 1/(2f·t_row) rows,
drifting from frame to frame unless the frame rate divides 2f; an exposure
of a whole number of flicker periods (t_exp = n/(2f)) cancels them.
"""

from __future__ import annotations

import numpy as np

from rollsim.numerics.clock import chip_position
from rollsim.plumbing.validation import as_finite, as_positive, as_probability


def flicker_row_factor(t_start_s, exposure_s: float, mains_hz: float, depth: float, phase_rad: float = 0.0) -> np.ndarray:
    """Mean relative ambient illuminance over exposure windows.

    Parameters
    ----------
    t_start_s : array_like of float
        Start of each window, in seconds.
    exposure_s : float
        Window length t_exp in seconds.
    mains_hz : float
        Mains frequency f in Hz (the light flickers at 2f).
    depth : float
        Modulation depth m in [0, 1].
    phase_rad : float
        Phase φ of the flicker at t = 0, in radians.

    Returns
    -------
    ndarray of float64
        (1/t_exp)·∫ (1 + m·cos(2π·2f·t + φ)) dt over each window, in [1 − m, 1 + m].
    """
    exposure_s = as_positive(exposure_s, "exposure_s", allow_zero=True)
    mains_hz = as_positive(mains_hz, "mains_hz")
    depth = as_probability(depth, "depth")
    phase_rad = as_finite(phase_rad, "phase_rad")
    flicker_hz = 2.0 * mains_hz
    # Flicker cycles elapsed at the window's middle, reduced to [0, 1) exactly
    # (double-float product, as for the chip position): t may be hours.
    _, cycles = chip_position(t_start_s, 0.0, flicker_hz)
    cycles = cycles + mains_hz * exposure_s
    return 1.0 + depth * np.sinc(flicker_hz * exposure_s) * np.cos(2.0 * np.pi * cycles + phase_rad)
