"""The row profile of a square-wave LED through a rolling shutter and an ISP, and its fit.

A row r integrates the LED over its exposure window, E rows long, so its
linear signal is the square wave (period P rows, ON for the first half)
averaged over a box of E rows:

    w(r) = (S(r + φ) − S(r + φ − E)) / E,   S(t) = P·⌊t/P⌋/2 + clip(t mod P, 0, P/2),

S being the square wave's integral. The level is u(r) = off(r) + (on(r) − off(r))·w(r)
as a fraction of the ADC range; the ON and OFF levels vary slowly along the
LED (its radial profile, vignetting, glare from the ON rows around an OFF
one): each is linear between knots a few stripe periods apart, shared by
all frames. ON may exceed full scale (a saturated LED): the model clips as
the ADC does. The camera maps the level through the tone curve (of exponent
γ: linear at 1, sRGB at 2.4, :mod:`rollsim.fit.tone`) to 8 bits, and the
ISP's vertical filter smooths the result with a Gaussian of σ rows.
:func:`fit_stripes` fits E, σ, γ (unless the noise told it), the knots'
levels and each frame's phase φ to the row profiles of several frames by
least squares (scipy).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np
from scipy.optimize import OptimizeResult, least_squares

from rollsim.fit.tone import SRGB_GAMMA, decode, encode


__all__ = ["StripeFit", "fit_stripes", "square_wave_box", "stripe_profile", "stripe_profiles"]


def _square_integral(t: np.ndarray, period: float) -> np.ndarray:
    """∫₀ᵗ of a square wave of ``period``, 1 over the first half of each period."""
    whole = np.floor(t / period)
    return whole * (period / 2) + np.clip(t - whole * period, 0.0, period / 2)


def square_wave_box(rows: np.ndarray, period_rows: float, phase_rows: float | np.ndarray,
                    exposure_rows: float) -> np.ndarray:
    """The square wave averaged over a box of ``exposure_rows`` ending at each row (0 … 1).

    Parameters
    ----------
    rows : ndarray
        Row indices (may be fractional).
    period_rows : float
        P, the square wave's period in rows.
    phase_rows : float or ndarray
        φ: the wave is ON on [−φ, −φ + P/2) modulo P (an array broadcast against ``rows``).
    exposure_rows : float
        E, the exposure in rows, > 0.
    """
    t = np.asarray(rows, dtype=np.float64) + phase_rows
    return (_square_integral(t, period_rows) - _square_integral(t - exposure_rows, period_rows)) / exposure_rows


def box_level_range(exposure_chips: float) -> tuple[float, float]:
    """The least and greatest fraction ON over a box of ``exposure_chips`` chips
    on the square pattern (ON one chip, OFF the next).

    The box spans k = ⌊E/2⌋ whole periods (k chips ON) and r = E − 2k chips
    more, of which between max(0, r − 1) and min(r, 1) are ON.
    """
    whole = math.floor(exposure_chips / 2)
    rest = exposure_chips - 2 * whole
    return (whole + max(0.0, rest - 1.0)) / exposure_chips, (whole + min(rest, 1.0)) / exposure_chips


# The model's Gaussian reaches this many σ: its tail beyond (e^-32 of the
# peak) is below float64's resolution of the sum, so the kernel's length
# steps with σ without a step in the profile.
MODEL_KERNEL_SIGMAS = 8.0


def model_kernel(sigma_rows: float) -> np.ndarray:
    """The ISP's vertical Gaussian as the fit models it: float64, unit sum, smooth in σ.

    The fit differentiates the profile by finite differences, steps of about
    1e-8 of σ. The rendered kernel (:func:`rollsim.isp.gaussian_kernel`) is
    float32, whose weights move in steps of 6e-8, and ends at 4σ, where its
    length steps by two rows: either hides or swamps the derivative, and σ
    stays where the fit started it.
    """
    radius = max(1, int(np.ceil(MODEL_KERNEL_SIGMAS * sigma_rows)))
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    kernel = np.exp(-0.5 * (x / sigma_rows) ** 2)
    return kernel / kernel.sum()


def _smoothed(values: np.ndarray, sigma_rows: float) -> np.ndarray:
    """``values`` smoothed by the ISP's Gaussian (mirrored ends, as :func:`rollsim.isp.smooth`).

    ``values``: one profile, or several (one a row of a 2-D array), each smoothed alone.
    """
    if sigma_rows <= 0.05:
        return values
    kernel = model_kernel(sigma_rows)
    pad = kernel.size // 2
    profiles = np.atleast_2d(values)  # the kernel and the mirrored ends made once for all the profiles
    if pad >= profiles.shape[1]:
        out = np.array([np.full_like(v, v.mean()) for v in profiles])
    else:
        padded = np.pad(profiles, ((0, 0), (pad, pad)), mode="reflect")
        out = np.array([np.convolve(v, kernel, mode="valid") for v in padded])
    return out.reshape(values.shape)


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
        γ of the tone curve (:mod:`rollsim.fit.tone`; 1: linear output, 2.4: sRGB).
    on, off : float
        Linear ON and OFF levels (medians of the knots'), fractions of the
        ADC range.
    knot_rows : tuple of float
        Rows of the envelope's knots.
    on_knots, off_knots : tuple of float
        The ON and OFF levels at the knots.
    phases_rows : tuple of float
        Each frame's φ.
    rms_residual : float
        RMS of the residuals, in 8-bit levels.
    uncertainties : dict
        One-sigma uncertainty of ``exposure_rows``, ``smoothing_rows`` and
        ``gamma`` from the fit's Jacobian.
    gamma_given : bool
        γ was given (told by the frames' noise), not fitted.
    """

    exposure_rows: float
    smoothing_rows: float
    gamma: float
    on: float
    off: float
    knot_rows: tuple
    on_knots: tuple
    off_knots: tuple
    phases_rows: tuple
    rms_residual: float
    uncertainties: dict
    gamma_given: bool = False

    def swing_dn(self, period_rows: float) -> float:
        """The stripes' swing as the frames show it, 8-bit levels: the box's least and
        greatest level (:func:`box_level_range`) between the OFF and ON levels,
        clipped at full scale, through the tone curve (0 where both clip).

        Levels beyond full scale leave it unchanged: it is what they cannot say.
        """
        low, high = box_level_range(2.0 * self.exposure_rows / period_rows)
        shown = encode([self.off + (self.on - self.off) * w for w in (low, high)], self.gamma)
        return 255.0 * abs(float(shown[1]) - float(shown[0]))


# A camera's tone curve is concave (γ ≥ 1: sRGB is 2.4 in this family); a little
# below 1 is left for the estimator's noise.
MIN_GAMMA, MAX_GAMMA = 0.8, 5.0
# The envelope's knots are at least this many stripe periods apart, and at most MAX_KNOTS in all.
KNOT_PERIODS = 4.0
MAX_KNOTS = 24


def knot_rows(rows: np.ndarray, period_rows: float) -> np.ndarray:
    """Rows of the envelope's knots: evenly over ``rows``, :data:`KNOT_PERIODS`
    stripe periods apart or wider, at most :data:`MAX_KNOTS`, at least 2."""
    span = float(rows[-1] - rows[0]) if rows.size > 1 else 1.0
    count = int(min(MAX_KNOTS, max(2, np.floor(span / (KNOT_PERIODS * period_rows)) + 1)))
    return np.linspace(float(rows[0]), float(rows[-1]), count)


def stripe_profile(rows: np.ndarray, period_rows: float, phase_rows: float, exposure_rows: float,
                   smoothing_rows: float, gamma: float, on, off, knots: np.ndarray | None = None,
                   binning: tuple[int, int] = (1, 0)) -> np.ndarray:
    """The modelled 8-bit row profile (0 … 255, float) at ``rows`` (consecutive rows).

    Parameters are those of :class:`StripeFit` and :func:`square_wave_box`;
    ``on`` and ``off`` are levels (floats), or their values at ``knots``
    (rows), interpolated linearly between them. ``binning`` (k, offset):
    rows in groups of k, the groups starting at rows offset + j·k, each row
    exposed as its group's first (binned readout).
    """
    return stripe_profiles(rows, period_rows, [phase_rows], exposure_rows, smoothing_rows, gamma, on, off, knots,
                           binning)[0]


def stripe_profiles(rows: np.ndarray, period_rows: float, phases_rows: Sequence[float], exposure_rows: float,
                    smoothing_rows: float, gamma: float, on, off, knots: np.ndarray | None = None,
                    binning: tuple[int, int] = (1, 0)) -> np.ndarray:
    """:func:`stripe_profile` for each of several frames' phases φ, shape (frames, rows).

    The frames share everything but their phase, so the envelope and the
    exposed rows are computed once: the stripe fit evaluates this at each
    step of its least squares, the profiles of up to :data:`MAX_FIT_FRAMES`
    frames at a time. Each value is the one :func:`stripe_profile` gives.
    """
    rows = np.asarray(rows, dtype=np.float64)
    if knots is not None:
        on = np.interp(rows, knots, on)
        off = np.interp(rows, knots, off)
    k, offset = binning
    exposed = rows - np.mod(rows - offset, k) if k > 1 else rows
    phases = np.asarray(phases_rows, dtype=np.float64)[:, None]
    level = off + (on - off) * square_wave_box(exposed[None, :], period_rows, phases, exposure_rows)
    out = 255.0 * encode(level, gamma)
    return _smoothed(out, smoothing_rows)


def _fundamental_phase(values: np.ndarray, rows: np.ndarray, period_rows: float) -> float:
    """The phase φ (rows) of a profile's component at the square wave's frequency."""
    omega = 2 * np.pi / period_rows
    centred = values - values.mean()
    c, s = np.sum(centred * np.cos(omega * rows)), np.sum(centred * np.sin(omega * rows))
    # The square wave ON on [−φ, −φ + P/2) has its fundamental ∝ sin(ω(r + φ)).
    return float((np.arctan2(c, s) / omega) % period_rows)


# Frames whose profiles the fit uses, at most (evenly spread over the set):
# the shape is shared, and more frames add time, not information.
MAX_FIT_FRAMES = 6
# Each grid start runs this many evaluations; the best goes on to convergence.
SCOUT_EVALUATIONS = 40

# Profiles whose top (97th percentile) reaches this fraction of full scale
# clip: the LED's ON level above it shows only in the ramps, and the model
# chosen is fitted again from ON levels this many times the top's (the
# ramps of an LED far above the clip are a small part of the exposure's
# box; started at the clip, least squares stays in a valley where a longer
# exposure makes the ramps).
CLIPPED_PROFILE = 0.97
SATURATED_ON_STARTS = (8.0,)


@dataclass(frozen=True)
class _Layout:
    """Where each parameter sits in the least-squares vector."""

    fit_smoothing: bool
    fit_gamma: bool
    n_knots: int
    n_frames: int
    given_gamma: float = 1.0  # γ where it is not fitted

    @property
    def size(self) -> int:
        return 1 + self.fit_smoothing + self.fit_gamma + 2 * self.n_knots + self.n_frames

    def unpack(self, x: np.ndarray):
        i = 1
        s = x[i] if self.fit_smoothing else 0.0
        i += self.fit_smoothing
        g = x[i] if self.fit_gamma else self.given_gamma
        i += self.fit_gamma
        nk = self.n_knots
        return x[0], s, g, x[i:i + nk], x[i + nk:i + 2 * nk], x[i + 2 * nk:]

    def pack(self, e, s, g, on, off, phases) -> np.ndarray:
        head = [e] + ([s] if self.fit_smoothing else []) + ([g] if self.fit_gamma else [])
        return np.array(head + list(on) + list(off) + list(phases), dtype=np.float64)

    def bounds(self, period_rows: float) -> tuple[np.ndarray, np.ndarray]:
        # ON may exceed full scale: a saturated LED, clipped by the model as by the ADC.
        lower = self.pack(0.05, 0.0, MIN_GAMMA, [0.0] * self.n_knots, [0.0] * self.n_knots, [-np.inf] * self.n_frames)
        upper = self.pack(4.0 * period_rows, period_rows, MAX_GAMMA, [60.0] * self.n_knots, [1.0] * self.n_knots,
                          [np.inf] * self.n_frames)
        return lower, upper

    def sparsity(self, rows: np.ndarray, knots: np.ndarray, margin_rows: float) -> np.ndarray:
        """Which residuals each parameter moves: a frame's phase its own rows
        only, a knot the rows up to its neighbours and ``margin_rows`` beyond
        (the smoothing's reach)."""
        n_rows = rows.size
        pattern = np.zeros((self.n_frames * n_rows, self.size), dtype=bool)
        shared = 1 + self.fit_smoothing + self.fit_gamma
        pattern[:, :shared] = True
        reach = np.zeros((n_rows, self.n_knots), dtype=bool)
        for k in range(self.n_knots):
            lo = knots[k - 1] if k > 0 else -np.inf
            hi = knots[k + 1] if k + 1 < self.n_knots else np.inf
            reach[:, k] = (rows >= lo - margin_rows) & (rows <= hi + margin_rows)
        for f in range(self.n_frames):
            block = slice(f * n_rows, (f + 1) * n_rows)
            pattern[block, shared:shared + self.n_knots] = reach
            pattern[block, shared + self.n_knots:shared + 2 * self.n_knots] = reach
            pattern[block, shared + 2 * self.n_knots + f] = True
        return pattern


def _bic(result, n_residuals: int) -> float:
    """The Bayesian information criterion of a least-squares fit (Gaussian residuals)."""
    rss = max(2.0 * float(result.cost), 1e-300)
    return n_residuals * math.log(rss / n_residuals) + result.x.size * math.log(n_residuals)


def _solve(layout: _Layout, starts: list, residuals, period_rows: float, sparsity) -> OptimizeResult:
    """The best least-squares solution over ``starts``: each scouted for
    :data:`SCOUT_EVALUATIONS` evaluations, the best run to convergence."""
    lower, upper = layout.bounds(period_rows)
    scouted = []
    for x0 in starts:
        x0 = np.clip(x0, lower + 1e-9, upper - 1e-9)
        budget = SCOUT_EVALUATIONS if len(starts) > 1 else 400
        scouted.append(least_squares(residuals, x0, bounds=(lower, upper), x_scale="jac", max_nfev=budget,
                                     jac_sparsity=sparsity, tr_solver="lsmr"))
    best = min(scouted, key=lambda r: r.cost)
    if len(starts) > 1:
        best = least_squares(residuals, best.x, bounds=(lower, upper), x_scale="jac", max_nfev=400,
                             jac_sparsity=sparsity, tr_solver="lsmr")
    return best


def fit_stripes(profiles: list[np.ndarray], rows: np.ndarray, period_rows: float,
                start: StripeFit | None = None, binning: tuple[int, int] = (1, 0),
                gamma: float | None = None) -> StripeFit:
    """Fit the stripe model to the row profiles of several frames.

    The smoothing σ and the tone curve's γ are kept only where the frames
    ask for them: the model without one (σ = 0, γ = 1) is chosen when its
    Bayesian information criterion is lower, so a camera without an ISP is
    not given one to trade against its exposure. A ``gamma`` given (told by
    the frames' noise) is not fitted.

    Parameters
    ----------
    profiles : list of ndarray
        Each frame's row profile (8-bit levels, mean over the LED's central
        columns) over ``rows``; at most :data:`MAX_FIT_FRAMES` are used.
    rows : ndarray of int
        Consecutive row indices of the profiles.
    period_rows : float
        P, from the row-time estimate: 2 / (clock · t_row).
    start : StripeFit, optional
        A fit of similar frames over the same rows to start from (one start
        instead of a grid, and its choice of σ and γ).
    binning : (int, int)
        Binned readout (k, offset), as :func:`stripe_profile`.
    gamma : float, optional
        The tone curve's γ, given; None: fitted (or 1). With ``start``, the
        start's given γ is kept.

    Returns
    -------
    StripeFit
    """
    rows = np.asarray(rows, dtype=np.float64)
    data = fitted_profiles(profiles)
    knots = knot_rows(rows, period_rows) if start is None else np.asarray(start.knot_rows)
    nk, n = knots.size, len(data)
    target = np.concatenate(data)
    hi = max(float(np.percentile(p, 97)) for p in data) / 255.0
    lo = min(float(np.percentile(p, 3)) for p in data) / 255.0
    phases0 = [_fundamental_phase(p, rows, period_rows) for p in data]

    def grid_starts(layout, on_times_top, gammas=None):
        # A grid: the box and the Gaussian trade off, and the phase guess
        # from the fundamental is off by half the box. ON starts at the
        # profiles' top (decoded), or that many times it.
        if gammas is None:
            gammas = (1.0, SRGB_GAMMA) if layout.fit_gamma else (layout.given_gamma,)
        return [layout.pack(e0 * period_rows, 0.5, g0, [float(decode(hi, g0)) * on_times_top] * nk,
                            [float(decode(lo, g0))] * nk, [ph + e0 * period_rows / 2 for ph in phases0])
                for e0 in (0.1, 0.25, 0.45, 0.7, 1.2) for g0 in gammas]

    def sparsity_of(layout):
        return layout.sparsity(rows, knots, 4.0 * period_rows)  # σ ≤ P, the kernel within 4σ

    def make_residuals(layout):
        def residuals(x):
            e, s, g, on, off, phases = layout.unpack(x)
            return stripe_profiles(rows, period_rows, phases, e, s, g, on, off, knots, binning).ravel() - target
        return residuals

    if start is not None and start.gamma_given:
        gamma = start.gamma
    if start is not None:
        layouts = [_Layout(start.smoothing_rows > 0, gamma is None and start.gamma != 1.0, nk, n,
                           1.0 if gamma is None else gamma)]
    elif gamma is not None:
        layouts = [_Layout(sm, False, nk, n, gamma) for sm in (True, False)]
    else:
        layouts = [_Layout(sm, ga, nk, n) for sm in (True, False) for ga in (True, False)]
    fits = []
    for layout in layouts:
        if start is not None:
            starts = [layout.pack(start.exposure_rows, start.smoothing_rows, start.gamma, start.on_knots,
                                  start.off_knots, [ph + start.exposure_rows / 2 for ph in phases0])]
        else:
            starts = grid_starts(layout, 1.0)
        fits.append((layout, _solve(layout, starts, make_residuals(layout), period_rows, sparsity_of(layout))))
    layout, best = min(fits, key=lambda f: _bic(f[1], target.size))
    if start is None and hi >= CLIPPED_PROFILE:
        # The profiles clip: the chosen model is fitted again from ON levels
        # far above the clip (SATURATED_ON_STARTS) and its γ, and the nearer kept.
        chosen_gamma = (layout.unpack(best.x)[2],)
        for on in SATURATED_ON_STARTS:
            far = _solve(layout, grid_starts(layout, on, chosen_gamma), make_residuals(layout), period_rows,
                         sparsity_of(layout))
            if far.cost < best.cost:
                best = far
    e, s, g, on, off, phases = layout.unpack(best.x)
    dof = max(1, best.fun.size - best.x.size)
    rms = float(np.sqrt(np.mean(best.fun**2)))
    uncertainties = {"exposure_rows": math.nan, "smoothing_rows": 0.0, "gamma": 0.0}
    try:
        jac = best.jac.toarray() if hasattr(best.jac, "toarray") else best.jac
        cov = np.linalg.pinv(jac.T @ jac) * (2 * best.cost / dof)
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        uncertainties["exposure_rows"] = float(sd[0])
        if layout.fit_smoothing:
            uncertainties["smoothing_rows"] = float(sd[1])
        if layout.fit_gamma:
            uncertainties["gamma"] = float(sd[1 + layout.fit_smoothing])
    except np.linalg.LinAlgError:
        pass
    fit = StripeFit(float(e), float(s), float(g), float(np.median(on)), float(np.median(off)),
                    tuple(float(k) for k in knots), tuple(float(v) for v in on), tuple(float(v) for v in off),
                    tuple(float(p % period_rows) for p in phases), rms, uncertainties, gamma is not None)
    return whole_periods_removed(right_way_up(fit, period_rows), period_rows)


def fitted_profiles(profiles: Sequence[np.ndarray]) -> list[np.ndarray]:
    """The profiles :func:`fit_stripes` fits: at most :data:`MAX_FIT_FRAMES`, spread over the frames, float64."""
    data = [np.asarray(p, dtype=np.float64) for p in profiles]
    if len(data) > MAX_FIT_FRAMES:
        data = [data[int(i)] for i in np.linspace(0, len(data) - 1, MAX_FIT_FRAMES).round()]
    return data


def fit_residuals(fit: StripeFit, profiles: Sequence[np.ndarray], rows: np.ndarray, period_rows: float,
                  binning: tuple[int, int] = (1, 0)) -> np.ndarray:
    """The fitted profiles less the fit's model, 8-bit levels: (frames fitted, rows).

    ``profiles``, ``rows``, ``period_rows`` and ``binning`` are those the fit was given.
    """
    rows = np.asarray(rows, dtype=np.float64)
    knots = np.asarray(fit.knot_rows)
    return np.array([p - stripe_profile(rows, period_rows, phase, fit.exposure_rows, fit.smoothing_rows, fit.gamma,
                                        np.asarray(fit.on_knots), np.asarray(fit.off_knots), knots, binning)
                     for phase, p in zip(fit.phases_rows, fitted_profiles(profiles))])


# An end of the band whose residual (RMS over a stripe period) is this many
# times the band's median is not the square wave's: the rim of an LED that
# fills a crop but not its rows, a halo. It is left out and the fit redone.
MAX_END_RESIDUAL = 3.0


def rows_the_model_holds(residuals: np.ndarray, period_rows: float, min_periods: float = 4.0) -> slice:
    """The rows (indices into the fitted profiles) left when each end of the band
    is trimmed, a stripe period at a time, while its residual RMS exceeds
    :data:`MAX_END_RESIDUAL` times the median period's.

    The whole band when trimming would leave less than half of it or fewer
    than ``min_periods`` periods: a model that holds nowhere is not mended
    by cutting.
    """
    n = residuals.shape[-1]
    size = max(1, int(np.ceil(period_rows)))
    edges = np.arange(0, n + 1, size)
    if edges[-1] != n:
        edges = np.append(edges, n)
    rms = np.array([np.sqrt(np.mean(residuals[:, a:b] ** 2)) for a, b in zip(edges[:-1], edges[1:])])
    if rms.size < 3:
        return slice(0, n)
    bad = rms > MAX_END_RESIDUAL * max(float(np.median(rms)), 1e-12)
    first, last = 0, rms.size
    while first < last and bad[first]:
        first += 1
    while last > first and bad[last - 1]:
        last -= 1
    start, stop = int(edges[first]), int(edges[last])
    if stop - start < max(0.5 * n, min_periods * period_rows):
        return slice(0, n)
    return slice(start, stop)


def right_way_up(fit: StripeFit, period_rows: float) -> StripeFit:
    """The same profile with its ON level above its OFF level.

    A wave fitted upside down (ON below OFF) is the same wave half a period
    on, with the levels swapped (w_E(r + P/2) = 1 − w_E(r)). Fits of frames
    and of their renders are compared level by level
    (:func:`rollsim.fit.camera.corrected`): both must say ON of the same rows.
    """
    if fit.on >= fit.off:
        return fit
    return replace(fit, on=fit.off, off=fit.on, on_knots=fit.off_knots, off_knots=fit.on_knots,
                   phases_rows=tuple(float((p + 0.5 * period_rows) % period_rows) for p in fit.phases_rows))


def levels_for_whole_periods(e_rows: float, on, off, period_rows: float, whole: int) -> tuple:
    """The ON and OFF levels that, with ``whole`` more stripe periods of
    exposure, make the same row profile as ``on`` and ``off`` with ``e_rows``.

    A box of E = E₀ + k·P rows holds k whole periods (k·P/2 rows ON) and
    the box of E₀: w_E = (k·P/2 + E₀·w_E₀)/E. So the same profile needs the
    contrast Δ = Δ₀·E/E₀ and the OFF level off₀ − Δ₀·k·P/(2·E₀): the
    stripes alone tell the exposure modulo one period (two chips), and
    each more period lowers the OFF level by Δ₀·P/(2·E₀).

    Returns ``(exposure_rows, on, off)``; ``whole`` may be negative.
    """
    on, off = np.asarray(on, dtype=np.float64), np.asarray(off, dtype=np.float64)
    delta = on - off
    exposure = e_rows + whole * period_rows
    new_off = off - delta * whole * period_rows / (2.0 * e_rows)
    return exposure, new_off + delta * exposure / e_rows, new_off


def reflected_levels(e_rows: float, on, off, period_rows: float) -> tuple:
    """The exposure P − E and the levels that make the same row profile as E.

    Half a period on, the square wave is its own complement (w_E(r + P/2)
    = 1 − w_E(r)), so a box of P − E gives w_(P−E) = (P/2 − E + E·w_E)/(P − E)
    at a shifted phase: the same shape with Δ' = Δ·(P − E)/E and the OFF
    level off − Δ·(P/2 − E)/E. Returns ``(exposure_rows, on, off)``.
    """
    on, off = np.asarray(on, dtype=np.float64), np.asarray(off, dtype=np.float64)
    delta = on - off
    new_delta = delta * (period_rows - e_rows) / e_rows
    new_off = off - delta * (0.5 * period_rows - e_rows) / e_rows
    return period_rows - e_rows, new_off + new_delta, new_off


def profile_extremes(e_rows: float, on: float, off: float, period_rows: float) -> tuple[float, float]:
    """The least and greatest level of the row profile (before smoothing) that ``on``, ``off`` and ``e_rows`` make.

    Every exposure and levels that make the same profile (:func:`levels_for_whole_periods`,
    :func:`reflected_levels`) give the same two.
    """
    low, high = box_level_range(2.0 * e_rows / period_rows)
    return off + (on - off) * low, off + (on - off) * high


def exposure_for_off_level(y_min: float, y_max: float, off: float, period_rows: float, whole: int,
                           upper_half: bool) -> tuple[float, float] | None:
    """The exposure whose OFF level is ``off`` and whose profile spans ``y_min`` … ``y_max``, and its ON level.

    With E = k·P + r·P/2 (k ``whole`` periods, r in [0, 2) chips), the
    fraction ON over the box spans (k + max(0, r − 1))/E … (k + min(r, 1))/E
    (:func:`box_level_range`), so with the OFF level fixed the ratio
    ρ = (y_min − off)/(y_max − off) fixes r: r = 1 + ρ(k + 1) − k in the upper
    half of a period (r ≥ 1), r = k/ρ − k in the lower half. Returns
    ``(exposure_rows, on)``, or None where no exposure of that branch makes
    the profile (ρ outside [0, 1), or r outside its half).
    """
    if not y_max > off or y_min < off:
        return None
    rho = (y_min - off) / (y_max - off)
    if upper_half:
        rest = 1.0 + rho * (whole + 1) - whole
        valid = 1.0 <= rest < 2.0
    else:
        rest = whole / rho - whole if rho > 0 else math.inf
        valid = 0.0 < rest < 1.0
    if not valid:
        return None
    exposure_chips = 2.0 * whole + rest
    high = box_level_range(exposure_chips)[1]
    return exposure_chips * period_rows / 2.0, off + (y_max - off) / high


def whole_periods_in(exposure_rows: float, period_rows: float) -> int:
    """k, the whole stripe periods of E = E₀ + k·P beyond its E₀ in (0, P] (0 for E ≤ P)."""
    return max(0, int(math.ceil(exposure_rows / period_rows - 1e-9)) - 1)


def whole_periods_removed(fit: StripeFit, period_rows: float) -> StripeFit:
    """The same profile with the exposure brought into (0, P] (see :func:`levels_for_whole_periods`)."""
    whole = whole_periods_in(fit.exposure_rows, period_rows)
    if whole == 0:
        return fit
    e0, on0, off0 = levels_for_whole_periods(fit.exposure_rows, fit.on_knots, fit.off_knots, period_rows, -whole)
    return replace(fit, exposure_rows=float(e0), on=float(np.median(on0)), off=float(np.median(off0)),
                   on_knots=tuple(float(v) for v in on0), off_knots=tuple(float(v) for v in off0))
