"""The row profile of a square-wave LED through a rolling shutter and an ISP, and its fit.

A row r integrates the LED over its exposure window, E rows long, so its
linear signal is the square wave (period P rows, ON for the first half)
averaged over a box of E rows:

    w(r) = (S(r + φ) − S(r + φ − E)) / E,   S(t) = P·⌊t/P⌋/2 + clip(t mod P, 0, P/2),

S being the square wave's integral. The level is u(r) = off + (on − off)·w(r)
as a fraction of the ADC range, its ON level bent by a slow envelope
(1 + c₁x + c₂x², x the distance from the LED's centre in radii: the LED's
radial profile and vignetting). The camera maps it through the tone curve
(a gamma, v^(1/γ)) to 8 bits, and the ISP's vertical filter smooths the
result with a Gaussian of σ rows. :func:`fit_stripes` fits E, σ, γ, the
levels and the envelope to the row profiles of several frames, each with its
own phase φ, by least squares (scipy).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from rollsim.isp import gaussian_kernel

__all__ = ["StripeFit", "fit_stripes", "square_wave_box", "stripe_profile"]


def _square_integral(t: np.ndarray, period: float) -> np.ndarray:
    """∫₀ᵗ of a square wave of ``period``, 1 over the first half of each period."""
    whole = np.floor(t / period)
    return whole * (period / 2) + np.clip(t - whole * period, 0.0, period / 2)


def square_wave_box(rows: np.ndarray, period_rows: float, phase_rows: float, exposure_rows: float) -> np.ndarray:
    """The square wave averaged over a box of ``exposure_rows`` ending at each row (0 … 1).

    Parameters
    ----------
    rows : ndarray
        Row indices (may be fractional).
    period_rows : float
        P, the square wave's period in rows.
    phase_rows : float
        φ: the wave is ON on [−φ, −φ + P/2) modulo P.
    exposure_rows : float
        E, the exposure in rows, > 0.
    """
    t = np.asarray(rows, dtype=np.float64) + phase_rows
    return (_square_integral(t, period_rows) - _square_integral(t - exposure_rows, period_rows)) / exposure_rows


def _smoothed(values: np.ndarray, sigma_rows: float) -> np.ndarray:
    """``values`` smoothed by the ISP's Gaussian (mirrored ends, as :func:`rollsim.isp.smooth`)."""
    if sigma_rows <= 0.05:
        return values
    kernel = gaussian_kernel(sigma_rows).astype(np.float64)
    pad = kernel.size // 2
    if pad >= values.size:
        return np.full_like(values, values.mean())
    padded = np.pad(values, pad, mode="reflect")
    return np.convolve(padded, kernel, mode="valid")


@dataclass(frozen=True)
class StripeFit:
    """What :func:`fit_stripes` found.

    Attributes
    ----------
    exposure_rows : float
        E: the exposure in rows.
    smoothing_rows : float
        σ of the ISP's vertical Gaussian, rows.
    gamma : float
        γ of the tone curve v^(1/γ) (1: linear output).
    on, off : float
        Linear ON and OFF levels at the LED's centre, fractions of the ADC range.
    envelope : (float, float)
        c₁, c₂ of the ON level's envelope.
    phases_rows : tuple of float
        Each frame's φ.
    rms_residual : float
        RMS of the residuals, in 8-bit levels.
    uncertainties : dict
        One-sigma uncertainty of ``exposure_rows``, ``smoothing_rows`` and
        ``gamma`` from the fit's Jacobian.
    """

    exposure_rows: float
    smoothing_rows: float
    gamma: float
    on: float
    off: float
    envelope: tuple
    phases_rows: tuple
    rms_residual: float
    uncertainties: dict


def stripe_profile(rows: np.ndarray, period_rows: float, phase_rows: float, exposure_rows: float,
                   smoothing_rows: float, gamma: float, on: float, off: float, envelope=(0.0, 0.0),
                   centre_row: float = 0.0, radius_rows: float = 1.0) -> np.ndarray:
    """The modelled 8-bit row profile (0 … 255, float) at ``rows`` (consecutive rows).

    Parameters are those of :class:`StripeFit` and :func:`square_wave_box`;
    ``centre_row`` and ``radius_rows`` place the envelope.
    """
    x = (np.asarray(rows, dtype=np.float64) - centre_row) / radius_rows
    top = on * (1.0 + envelope[0] * x + envelope[1] * x**2)
    level = off + (top - off) * square_wave_box(rows, period_rows, phase_rows, exposure_rows)
    out = 255.0 * np.power(np.clip(level, 0.0, 1.0), 1.0 / gamma)
    return _smoothed(out, smoothing_rows)


def _fundamental_phase(values: np.ndarray, rows: np.ndarray, period_rows: float) -> float:
    """The phase φ (rows) of a profile's component at the square wave's frequency."""
    omega = 2 * np.pi / period_rows
    centred = values - values.mean()
    c, s = np.sum(centred * np.cos(omega * rows)), np.sum(centred * np.sin(omega * rows))
    # The square wave ON on [−φ, −φ + P/2) has its fundamental ∝ sin(ω(r + φ)).
    return float((np.arctan2(c, s) / omega) % period_rows)


def fit_stripes(profiles: list[np.ndarray], rows: np.ndarray, period_rows: float, centre_row: float,
                radius_rows: float, fit_gamma: bool = True, start: StripeFit | None = None) -> StripeFit:
    """Fit the stripe model to the row profiles of several frames.

    Parameters
    ----------
    profiles : list of ndarray
        Each frame's row profile (8-bit levels, mean over the LED's central
        columns) over ``rows``.
    rows : ndarray of int
        Consecutive row indices of the profiles.
    period_rows : float
        P, from the row-time estimate: 2 / (clock · t_row).
    centre_row, radius_rows : float
        The LED's centre row and radius (for the envelope).
    fit_gamma : bool
        Fit the tone curve's γ (else γ = 1, linear output).
    start : StripeFit, optional
        A fit of similar frames to start from (one start instead of a grid).

    Returns
    -------
    StripeFit
    """
    rows = np.asarray(rows, dtype=np.float64)
    data = [np.asarray(p, dtype=np.float64) for p in profiles]
    hi = max(float(np.percentile(p, 97)) for p in data) / 255.0
    lo = min(float(np.percentile(p, 3)) for p in data) / 255.0
    phases0 = [_fundamental_phase(p, rows, period_rows) for p in data]
    n = len(data)

    def unpack(x):
        e, s, g, on, off, c1, c2 = x[:7]
        return e, s, g if fit_gamma else 1.0, on, off, (c1, c2), x[7:7 + n]

    def residuals(x):
        e, s, g, on, off, env, phases = unpack(x)
        return np.concatenate([
            stripe_profile(rows, period_rows, ph, e, s, g, on, off, env, centre_row, radius_rows) - p
            for ph, p in zip(phases, data)])

    lower = [0.05, 0.0, 0.3, 0.0, 0.0, -2.0, -2.0] + [-np.inf] * n
    # ON may exceed full scale: a saturated LED, clipped by the model as by the ADC.
    upper = [4.0 * period_rows, period_rows, 5.0, 50.0, 1.0, 2.0, 2.0] + [np.inf] * n
    best = None
    # Starts over a grid: the box and the Gaussian trade off, and the phase
    # guess from the fundamental is off by half the box.
    grid = [(e0 * period_rows, 0.5, g0, hi**g0, lo**g0, 0.0, 0.0)
            for e0 in (0.1, 0.25, 0.45, 0.7, 1.2) for g0 in ((1.0, 2.2) if fit_gamma else (1.0,))]
    if start is not None:
        grid = [(start.exposure_rows, start.smoothing_rows, start.gamma, start.on, start.off, *start.envelope)]
    for e0, s0, g0, on0, off0, c10, c20 in grid:
        x0 = [e0, s0, g0, on0, off0, c10, c20] + [ph + e0 / 2 for ph in phases0]
        x0 = np.clip(x0, [a + 1e-9 for a in lower], [b - 1e-9 for b in upper])
        result = least_squares(residuals, x0, bounds=(lower, upper), x_scale="jac", max_nfev=400)
        if best is None or result.cost < best.cost:
            best = result
    if best is None:  # the grid always has a start; this keeps the type checker informed
        raise RuntimeError("no start for the stripe fit")
    e, s, g, on, off, env, phases = unpack(best.x)
    dof = max(1, best.fun.size - best.x.size)
    rms = float(np.sqrt(np.mean(best.fun**2)))
    uncertainties = {}
    try:
        cov = np.linalg.pinv(best.jac.T @ best.jac) * (2 * best.cost / dof)
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        uncertainties = {"exposure_rows": float(sd[0]), "smoothing_rows": float(sd[1]),
                         "gamma": float(sd[2]) if fit_gamma else 0.0}
    except np.linalg.LinAlgError:
        uncertainties = {"exposure_rows": float("nan"), "smoothing_rows": float("nan"), "gamma": float("nan")}
    return StripeFit(float(e), float(s), float(g), float(on), float(off), (float(env[0]), float(env[1])),
                     tuple(float(p % period_rows) for p in phases), rms, uncertainties)
