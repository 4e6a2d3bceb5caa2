"""A first-order LED: its light y(t) follows the drive s(t) with time constant τ.

τ·dy/dt = s − y. The drive s(t) is the waveform: piecewise constant at the
chip rate, chip c at level s_c over [t_c, t_c + T_c). Inside chip c the light
relaxes exponentially towards s_c:

    y(t) = s_c + (Y_c − s_c)·exp(−(t − t_c)/τ),      Y_c = y(t_c),
    Y_{c+1} = s_c + (Y_c − s_c)·a,                   a = exp(−T_c/τ),

which is the same as summing the response to every past edge,
y(t) = s(t) − Σ_{edges t_j ≤ t} Δ_j·exp(−(t − t_j)/τ) with Δ_j the level step
at edge j. Integrating the differential equation over a window [t_a, t_b]
gives the exposure in closed form,

    ∫ y dt = ∫ s dt − τ·(y(t_b) − y(t_a)),

exact, with ∫ s dt from the waveform's exact integral. Light is conserved:
over a window whose ends see the same y, the LED emits what it was driven to.

The unknown past enters through Y at the first chip needed; the recurrence
starts :data:`HISTORY_TAU` time constants earlier from the level of that
chip, whose error then weighs exp(−40) ≈ 4e-18. Work per call is
O(chips spanned + 40·τ·f) plus O(1) per time, with no sampling of time.

``sampled`` is the fidelity knob: the mean of y at K midpoints of each
window (midpoint rule), y exact at each. Its error falls as O(1/K) while the
spacing t_exp/K is longer than τ (y looks like steps) and as O(1/K²) once
the spacing resolves τ.
"""

from __future__ import annotations

import math

import numpy as np

from rollsim.numerics.portable_math import exp  # numpy's differs in the last bit between CPUs

# Time constants of history before the first time asked for.
HISTORY_TAU = 40.0
# Chips per pass of the recurrence over a long history (bounds memory).
_CHUNK_CHIPS = 1 << 20


def _relax(levels: np.ndarray, a: float, y_start: float) -> np.ndarray:
    """Y_{m+1} = a·Y_m + (1 − a)·s_m for m = 0…n−1, from Y_0 = ``y_start``; returns Y_1…Y_n."""
    # Imported here: an unlisted rise time must not cost scipy.signal's import.
    from scipy.signal import lfilter

    out, _ = lfilter([1.0 - a], [1.0, -a], levels, zi=[a * y_start])
    return out


def chip_start_output(waveform, first_chip: int, last_chip: int, tau_s: float) -> np.ndarray:
    """y at the start of chips ``first_chip … last_chip``.

    Parameters
    ----------
    waveform : Waveform
    first_chip, last_chip : int
        Chip indices, ``first_chip <= last_chip``.
    tau_s : float
        LED time constant τ in seconds (> 0).

    Returns
    -------
    ndarray of float64, shape (last_chip − first_chip + 1,)
        Relative light output Y_c at t_c.
    """
    a = math.exp(-waveform.chip_period_s / tau_s)
    history = max(1, math.ceil(HISTORY_TAU * tau_s * waveform.clock_hz))
    chip = first_chip - history
    y = float(waveform.chip_level(np.int64(chip)))
    # The history only hands its last value on; long histories go in chunks.
    while chip < first_chip - 1:
        stop = min(first_chip - 1, chip + _CHUNK_CHIPS)
        y = float(_relax(waveform.chip_level(np.arange(chip, stop, dtype=np.int64)), a, y)[-1])
        chip = stop
    levels = waveform.chip_level(np.arange(first_chip - 1, last_chip, dtype=np.int64))
    return _relax(levels, a, y)


def led_output(waveform, t_s, tau_s: float) -> np.ndarray:
    """Relative light output y(t) of the LED at times ``t_s``, exactly.

    Parameters
    ----------
    waveform : Waveform
        The drive s(t).
    t_s : array_like of float
        Times in seconds. They should span a short range (a frame): the
        work grows with the number of chips between the first and last.
    tau_s : float
        Time constant τ in seconds (> 0).

    Returns
    -------
    ndarray of float64, shaped like ``t_s``
    """
    chip, frac = waveform.chip_position(t_s)
    if chip.size == 0:
        return np.zeros(chip.shape)
    first = int(chip.min())
    start_output = chip_start_output(waveform, first, int(chip.max()), tau_s)[chip - first]
    level = waveform.chip_level(chip)
    return level + (start_output - level) * exp(-(frac * waveform.chip_period_s) / tau_s)


def exposure_exact(waveform, t_start_s, t_end_s, tau_s: float, step_exposure_s=None) -> np.ndarray:
    """∫ y dt over windows [t_start, t_end], in closed form.

    Parameters
    ----------
    waveform : Waveform
    t_start_s, t_end_s : ndarray of float
        Window bounds in seconds (same shape).
    tau_s : float
        Time constant τ in seconds.
    step_exposure_s : ndarray, optional
        ∫ s dt over the same windows, if already computed
        (:meth:`Waveform.exposure`).

    Returns
    -------
    ndarray of float64
        Seconds at level 1.
    """
    t_start_s, t_end_s = np.asarray(t_start_s, dtype=np.float64), np.asarray(t_end_s, dtype=np.float64)
    if step_exposure_s is None:
        step_exposure_s = waveform.exposure(t_start_s, t_end_s)
    y = led_output(waveform, np.stack([t_start_s, t_end_s]), tau_s)
    return step_exposure_s - tau_s * (y[1] - y[0])


def exposure_sampled(waveform, t_start_s, t_end_s, tau_s: float, samples: int) -> np.ndarray:
    """∫ y dt over windows by the midpoint rule with ``samples`` points per window.

    Same parameters and units as :func:`exposure_exact`; y is exact at each
    sample, so the only error is the quadrature's.
    """
    t_start_s, t_end_s = np.asarray(t_start_s, dtype=np.float64), np.asarray(t_end_s, dtype=np.float64)
    width = t_end_s - t_start_s
    fractions = (np.arange(samples) + 0.5) / samples
    times = t_start_s[..., None] + width[..., None] * fractions
    return led_output(waveform, times, tau_s).mean(axis=-1) * width
