"""A genie-aided reference receiver: the bound a stripe decoder can approach.

It reads a rendered frame the way a stripe decoder does (a row profile, then
chip decisions, then line decoding and the check code), but it is told what a
decoder has to estimate:

* **the chip timing**: when every chip starts, from the transmitter and the
  frame's truth record (frame start, row time, exposure);
* **the exposure kernel**: a box of the exposure time; row r of frame k
  integrates the LED over [t_k + r·t_row, t_k + r·t_row + t_exp]
  (:func:`exposure_weights`);
* **where the LED's light falls** (``setup.led_light``, else the footprint):
  the row profile is a matched filter across the columns
  (:func:`genie_profile`);
* **the chips around each PHY-SDU**, and, to fit the levels, the true chips
  of the PHY-SDU itself (data-aided; :func:`fit_levels`).

What it still has to do is decide the chips of each fully visible PHY-SDU
from noisy row means: maximum-likelihood sequence detection (Viterbi) under
the model

    y_r = off_r + gain_r · R_r(s_r) + n_r,   s_r = Σ_c w_rc · x_c,   x_c ∈ {0, 1},

with Gaussian n_r of standard deviation σ_r (:func:`detect_chips`). R_r is
the row's expected response in electrons above OFF: gap_r·s_r while no pixel
clips, and exactly the weighted sum of clipped pixels once some do
(:class:`RowResponse`; a bright LED at a high ISO clips most of its light).
off_r and gain_r come from a local least-squares fit with the true chips
(:func:`fit_levels`). The line decoding then repairs at most one invalid
symbol per PHY-SDU from what flipping each chip would cost
(:func:`flip_costs`, :meth:`rollsim.protocol.PhyFormat.decode_coded`), as
the decoder does from its chips' reliabilities. Nothing with this
structure (row means, then chips, then the line code with this repair
rule) can read more PHY-SDUs, so the gap between :mod:`decoder` and
:func:`genie_decode` on the same frames is what the decoder loses to
estimating timing, levels and regions.

Modelled: the box exposure, the LED's OFF level (``led.off_level``), the
clip of every pixel at the full well or the ADC's range, each pixel's gap,
OFF level and noise as the setup predicts them (ambient light, the LED's
face, glare, vignetting), frame jitter (the truth's start time). Not
modelled: the LED's rise time (``led_rise_time``: a longer kernel than the
box), a tone curve or JPEG (the frame is taken as linear in electrons),
ISP filters that mix rows, flicker (beyond the fit's linear trend in row),
motion (the genie uses the static footprint), and a Bayer frame's
demosaicing (its channels are averaged).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from rollsim.effects.readable import stripe_gap_and_variance
from rollsim.sensor.adc import full_scale_electrons

if TYPE_CHECKING:
    from rollsim.render_contract.setup import SceneSetup

# Rows beyond a PHY-SDU's own, on each side, used to fit its levels (chips).
LEVEL_MARGIN_CHIPS = 8
# Largest detector memory L (chips in a row's band, floor(t_exp/T_c) + 2):
# 2^(L-1) states, so exposures shorter than 13 chips.
MAX_MEMORY_CHIPS = 14
# Smallest row noise, as a fraction of the ON-OFF gap (noiseless frames).
SIGMA_FLOOR_FRACTION = 1e-4
# σ of a normal from its median absolute deviation.
_MAD_TO_SIGMA = 1.4826


# ------------------------------------------------------------------ profile


@dataclass(frozen=True)
class PixelModel:
    """What the genie knows of every pixel of the LED's light, electrons.

    Attributes
    ----------
    weights : ndarray of float64, shape (H, W)
        Matched-filter weight g_j / v_j of each pixel (1/e⁻; 0 where no
        LED light falls or the pixel is clipped even when OFF).
    gap_e : ndarray of float64, shape (H, W)
        Electrons a fully ON exposure adds, before any clip (g_j).
    off_e : ndarray of float64, shape (H, W)
        Mean OFF electrons (ambient light and dark current, as listed).
    headroom_e : ndarray of float64, shape (H, W)
        Electrons between the OFF level and the clip (full well or ADC
        range, the smaller), ≥ 0 (h_j).
    variance_e2 : ndarray of float64, shape (H, W)
        Noise variance halfway between OFF and ON, electrons².
    """

    weights: np.ndarray
    gap_e: np.ndarray
    off_e: np.ndarray
    headroom_e: np.ndarray
    variance_e2: np.ndarray


def _off_electrons(setup: SceneSetup, covered: np.ndarray) -> np.ndarray:
    """Mean OFF electrons of every pixel: ambient light and dark current (as listed)."""
    cam, listed = setup.scene.camera, set(setup.scene.effects.enabled())
    off_e = np.zeros(covered.shape)
    if "ambient" in listed:
        off_e += (setup.background_e_per_s * (1.0 - covered) + setup.face_e_per_s * covered) * cam.exposure_s
    if "dark_current" in listed:
        off_e += cam.dark_current_e_per_s * cam.exposure_s
    return off_e


def pixel_model(setup: SceneSetup) -> PixelModel:
    """Each pixel's LED gap, headroom to the clip, noise and matched-filter weight.

    The weight of pixel j is g'_j / v_j, g'_j the gap up to the clip and v_j
    the noise variance at the midpoint
    (:func:`rollsim.effects.readable.stripe_gap_and_variance`, as the
    readable rows are defined): maximum-ratio combining, the row mean with
    the best stripe SNR.

    Parameters
    ----------
    setup : SceneSetup
        A prepared setup (``RenderPipeline(scene).setup``).

    Returns
    -------
    PixelModel
    """
    cam = setup.scene.camera
    light = (setup.led_light if setup.led_light is not None else setup.footprint).dense(setup.shape)
    covered = setup.footprint.dense(setup.shape)
    clipped_gap_e, variance_e2 = stripe_gap_and_variance(light, covered, setup)
    clip_e = min(cam.full_well_e, full_scale_electrons(cam.adc_bits, cam.black_level_dn, setup.gain_dn_per_e))
    off_e = _off_electrons(setup, covered)
    gap_e = np.broadcast_to(light * (setup.led_e_per_s * cam.exposure_s), setup.shape).astype(np.float64)
    return PixelModel(clipped_gap_e / variance_e2, gap_e, off_e, np.maximum(clip_e - off_e, 0.0), variance_e2)


@dataclass(frozen=True)
class RowResponse:
    """Expected row mean above OFF at exposure level s, with the clip: R_r(s).

    With pixel j of row r weighted w_j (Σ_j w_j = 1 over the row), gap g_j
    and headroom h_j to the clip,

        R_r(s) = Σ_j w_j · min(g_j·s, h_j) = Σ_j w_j·g_j · min(s, t_j),  t_j = h_j/g_j,

    electrons, for s in [0, 1]: piecewise linear, exact. Pixels that never
    clip (t_j ≥ 1) add up to one slope per row; the others keep their
    breakpoint, sorted by row then t (one flat array, searched at once).

    Attributes
    ----------
    slope_e : ndarray, shape (rows,)
        Σ w_j·g_j over the pixels of each row that never clip.
    keys : ndarray
        t_j + 2·i of every clipping pixel (row position i), ascending.
    cum_gt, cum_g : ndarray
        Prefix sums of w_j·g_j·t_j and w_j·g_j in the order of ``keys``
        (a leading 0).
    row_start, row_end : ndarray of int64, shape (rows,)
        Each row's span of ``keys``.
    """

    slope_e: np.ndarray
    keys: np.ndarray
    cum_gt: np.ndarray
    cum_g: np.ndarray
    row_start: np.ndarray
    row_end: np.ndarray

    def __call__(self, row, s) -> np.ndarray:
        """R at rows ``row`` (positions in the profile) and levels ``s`` (broadcast), electrons."""
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
        row = np.broadcast_to(np.asarray(row, dtype=np.int64), s.shape)
        k = np.searchsorted(self.keys, s + 2.0 * row, side="right")
        clipped = self.cum_gt[k] - self.cum_gt[self.row_start[row]]  # pixels with t_j <= s
        open_ = self.cum_g[self.row_end[row]] - self.cum_g[k]  # pixels with t_j > s
        return self.slope_e[row] * s + clipped + s * open_


def row_response(weights: np.ndarray, gap_e: np.ndarray, headroom_e: np.ndarray) -> RowResponse:
    """The :class:`RowResponse` of rows of pixels.

    Parameters
    ----------
    weights : ndarray, shape (rows, W)
        Pixel weights, each row summing to 1.
    gap_e, headroom_e : ndarray, shape (rows, W)
        g_j and h_j, electrons (≥ 0).
    """
    wg = weights * gap_e
    t = np.divide(headroom_e, gap_e, out=np.full(gap_e.shape, np.inf), where=gap_e > 0)
    slope = np.sum(np.where(t >= 1.0, wg, 0.0), axis=1)
    row, col = np.nonzero((t < 1.0) & (wg > 0))
    keys = t[row, col] + 2.0 * row
    order = np.argsort(keys, kind="stable")
    keys, g = keys[order], wg[row, col][order]
    positions = 2.0 * np.arange(weights.shape[0])
    return RowResponse(
        slope_e=slope,
        keys=keys,
        cum_gt=np.concatenate([[0.0], np.cumsum(g * (keys - 2.0 * row[order]))]),
        cum_g=np.concatenate([[0.0], np.cumsum(g)]),
        row_start=np.searchsorted(keys, positions, side="left"),
        row_end=np.searchsorted(keys, positions + 1.5, side="left"),
    )


@dataclass(frozen=True)
class GenieProfile:
    """Matched-filter row means of the LED's rows, and what the genie expects of them.

    Attributes
    ----------
    rows : ndarray of int64, shape (n,)
        Frame rows, ascending (rows with no LED light are left out).
    values_dn : ndarray of float64, shape (n,)
        Weighted mean of each row's pixels, in frame units (DN of the frame:
        8-bit levels for ``gray8``, raw DN for ``raw16``).
    response : RowResponse
        Expected mean above OFF against the exposure level, electrons.
    off_e : ndarray of float64, shape (n,)
        Expected OFF mean of each row, electrons (ambient light, dark
        current).
    noise_shape : ndarray of float64, shape (n,)
        Expected noise standard deviation of each row's mean, relative
        (largest 1).
    """

    rows: np.ndarray
    values_dn: np.ndarray
    response: RowResponse
    off_e: np.ndarray
    noise_shape: np.ndarray

    def __len__(self) -> int:
        return int(self.rows.size)


def _gray(image: np.ndarray) -> np.ndarray:
    """A frame as float64 (H, W): colour frames averaged over their channels."""
    image = np.asarray(image)
    if image.ndim == 3:
        return image.mean(axis=2, dtype=np.float64)
    if image.ndim != 2:
        raise ValueError(f"image must have shape (H, W) or (H, W, 3), got {image.shape}")
    return image.astype(np.float64)


def genie_profile(image: np.ndarray, setup: SceneSetup, led_rows) -> GenieProfile:
    """Row profile over the LED's light: each row's matched-filter mean.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, 3)
        The rendered frame. A colour frame is averaged over its channels
        first (the weights then come from the sensor's per-pixel rates, an
        approximation after demosaicing).
    setup : SceneSetup
        The prepared setup the frame was rendered with.
    led_rows : (int, int)
        First and last LED row of the frame (the truth's ``led_rows``).

    Returns
    -------
    GenieProfile
        Rows ``led_rows[0] … led_rows[1]`` that hold LED light.
    """
    gray = _gray(image)
    if gray.shape != setup.shape:
        raise ValueError(f"image has shape {gray.shape}, the scene's frames {setup.shape}")
    first, last = int(led_rows[0]), int(led_rows[1])
    if not 0 <= first <= last < setup.shape[0]:
        raise ValueError(f"led_rows = {led_rows}: not rows of a {setup.shape[0]}-row frame")
    model = pixel_model(setup)
    band = slice(first, last + 1)
    total = model.weights[band].sum(axis=1)
    keep = np.flatnonzero(total > 0) + first
    w = model.weights[keep] / total[keep - first][:, None]
    values = np.einsum("ij,ij->i", w, gray[keep])
    off = np.einsum("ij,ij->i", w, model.off_e[keep])
    noise = np.sqrt(np.einsum("ij,ij->i", w * w, model.variance_e2[keep]))
    response = row_response(w, model.gap_e[keep], model.headroom_e[keep])
    return GenieProfile(keep.astype(np.int64), values, response, off, _relative(noise))


def _relative(x: np.ndarray) -> np.ndarray:
    peak = float(np.max(x)) if x.size else 0.0
    return x / peak if peak > 0 else np.ones_like(x)


# ------------------------------------------------------------ forward model


@dataclass(frozen=True)
class ExposureWeights:
    """Fraction of each row's exposure that each chip covers: a banded matrix.

    Row r covers chips ``last_chip[r] - L + 1 … last_chip[r]`` (oldest
    first) with weights ``weights[r]``; every other chip has weight 0. Each
    row's weights sum to 1.

    Attributes
    ----------
    last_chip : ndarray of int64, shape (rows,)
        Last chip each row's exposure touches (absolute chip index).
    weights : ndarray of float64, shape (rows, L)
        w_rc = |row window ∩ chip c| / t_exp, dimensionless.
    """

    last_chip: np.ndarray
    weights: np.ndarray

    @property
    def memory(self) -> int:
        """L: chips in each row's band."""
        return int(self.weights.shape[1])

    @property
    def first_chip(self) -> np.ndarray:
        """First chip of each row's band (its weight may be 0)."""
        return self.last_chip - (self.memory - 1)

    @property
    def first_touched(self) -> np.ndarray:
        """First chip each row's exposure touches (weight > 0)."""
        return self.first_chip + np.argmax(self.weights > 0, axis=1)

    def dense(self, first_chip: int, n_chips: int) -> np.ndarray:
        """The weights as a dense (rows, n_chips) matrix over chips ``first_chip …``.

        Weights of chips outside the range are dropped.
        """
        out = np.zeros((self.weights.shape[0], n_chips))
        column = self.first_chip[:, None] - first_chip + np.arange(self.memory)
        inside = (column >= 0) & (column < n_chips)
        rows = np.broadcast_to(np.arange(self.weights.shape[0])[:, None], column.shape)
        out[rows[inside], column[inside]] = self.weights[inside]
        return out

    def levels(self, chip_values: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """s_r = Σ_c w_rc·x_c for chips x = ``chip_values(chip indices)`` (0 or 1)."""
        chips = self.first_chip[:, None] + np.arange(self.memory)
        return np.sum(self.weights * chip_values(chips), axis=1)


def _positive(value: float, name: str) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {value}")
    return value


def memory_chips(exposure_chips: float) -> int:
    """L = floor(t_exp/T_c) + 2: the most chips one row's exposure can touch (plus one)."""
    exposure_chips = _positive(exposure_chips, "exposure_chips")
    memory = int(np.floor(exposure_chips)) + 2
    if memory > MAX_MEMORY_CHIPS:
        raise ValueError(f"exposure_chips = {exposure_chips}: at most {MAX_MEMORY_CHIPS - 2} chips "
                         f"({2 ** (MAX_MEMORY_CHIPS - 1)} detector states)")
    return memory


def exposure_weights(start_chip, start_frac, exposure_chips: float) -> ExposureWeights:
    """Closed-form chip overlaps of box exposures, in chip units.

    Parameters
    ----------
    start_chip : array_like of int, shape (rows,)
        Chip in which each row's exposure starts.
    start_frac : array_like of float, shape (rows,)
        Where in that chip it starts, a fraction in [0, 1).
    exposure_chips : float
        Exposure time over the chip period, t_exp/T_c (> 0).

    Returns
    -------
    ExposureWeights
        Band of L = :func:`memory_chips` chips per row.

    Raises
    ------
    ValueError
        ``exposure_chips`` not > 0 (or too long for the detector).
    """
    memory = memory_chips(exposure_chips)
    chip = np.asarray(start_chip, dtype=np.int64)
    frac = np.asarray(start_frac, dtype=np.float64)
    end = frac + exposure_chips  # relative to the start chip
    last = np.ceil(end).astype(np.int64) - 1  # a window ending on a chip edge does not touch the next chip
    offset = last[:, None] - (memory - 1) + np.arange(memory)  # band chips, relative to the start chip
    overlap = np.minimum(offset + 1.0, end[:, None]) - np.maximum(offset, frac[:, None])
    return ExposureWeights(chip + last, np.maximum(overlap, 0.0) / exposure_chips)


def grid_weights(n_rows: int, rows_per_chip: float, exposure_chips: float, first_start_chips: float = 0.0) -> ExposureWeights:
    """Exposure weights of an evenly spaced row grid, in chip units.

    Row r's exposure starts at ``first_start_chips + r / rows_per_chip``
    chips (chip 0 starts at 0).

    Parameters
    ----------
    n_rows : int
    rows_per_chip : float
        T_c / t_row (> 0).
    exposure_chips : float
        t_exp / T_c (> 0).
    first_start_chips : float
        Start of row 0's exposure, chips.

    Raises
    ------
    ValueError
        ``rows_per_chip`` or ``exposure_chips`` not > 0.
    """
    rows_per_chip = _positive(rows_per_chip, "rows_per_chip")
    start = first_start_chips + np.arange(int(n_rows)) / rows_per_chip
    chip = np.floor(start)
    return exposure_weights(chip.astype(np.int64), start - chip, exposure_chips)


def frame_weights(setup: SceneSetup, truth_record: dict, rows) -> ExposureWeights:
    """Exposure weights of a frame's rows against the transmitter's chips.

    Parameters
    ----------
    setup : SceneSetup
        Its transmitter's waveform gives the chip clock and phase.
    truth_record : dict
        The frame's truth (``start_s``, ``row_time_s``, ``exposure_s``, in
        seconds; the start includes any frame jitter).
    rows : array_like of int
        Frame rows.

    Raises
    ------
    ValueError
        ``row_time_s`` or ``exposure_s`` not > 0.
    """
    row_time_s = _positive(truth_record["row_time_s"], "row_time_s")
    exposure_s = _positive(truth_record["exposure_s"], "exposure_s")
    waveform = setup.transmitter.waveform
    rows = np.asarray(rows, dtype=np.int64)
    k = int(truth_record.get("binning_rows", 1))  # a binned group's rows start with its first
    starts_s = float(truth_record["start_s"]) + (rows - rows % k).astype(np.float64) * row_time_s
    chip, frac = waveform.chip_position(starts_s)
    return exposure_weights(chip, frac, exposure_s * waveform.clock_hz)


# ------------------------------------------------------------------- levels


@dataclass(frozen=True)
class Levels:
    """Each PHY-SDU's model of every row: y_r = off_r + gain_r·R_r(s_r) + noise.

    Attributes
    ----------
    off : ndarray of float64, shape (n_sdus, rows)
        OFF level, frame units (DN).
    gain : ndarray of float64, shape (n_sdus, rows)
        Frame units per electron of the row response R (DN/e⁻).
    sigma : ndarray of float64, shape (n_sdus, rows)
        Noise standard deviation of each row mean, DN.
    """

    off: np.ndarray
    gain: np.ndarray
    sigma: np.ndarray


def _masked_median(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Median of each row of ``x`` over ``mask`` (the lower middle value; inf if none)."""
    ordered = np.sort(np.where(mask, x, np.inf), axis=1)
    count = mask.sum(axis=1)
    return ordered[np.arange(x.shape[0]), np.maximum(count - 1, 0) // 2]


def fit_levels(values: np.ndarray, rows: np.ndarray, drive: np.ndarray, noise_shape: np.ndarray,
               fit_rows: np.ndarray, off_shape: np.ndarray | None = None) -> Levels:
    """Data-aided least-squares levels, one local fit per PHY-SDU.

    Each PHY-SDU's rows (``fit_rows``) are fitted with

        y_r = (b0 + b1·ρ + c·o_r) + (a0 + a1·ρ)·d_r,

    ρ the row centred and scaled to [-1, 1] over the fit, d_r the expected
    response to the true chips (``drive``, e.g. R_r(s_r) in electrons, or
    s_r itself) and o_r the expected OFF level's shape (``off_shape``, e.g.
    the OFF mean in electrons; the LED's face and the background differ):
    an OFF level and a gain, each with a linear trend in row (vignetting,
    the footprint's chord, a mismatch of the expected light) on top of what
    the setup predicts. Rows are weighted by
    their expected noise. The noise scale is robust, 1.4826 × the median
    absolute normalised residual, at least :data:`SIGMA_FLOOR_FRACTION` of
    the largest fitted gap.

    Parameters
    ----------
    values : ndarray, shape (rows,)
        Row means y_r, DN.
    rows : ndarray, shape (rows,)
        Their frame rows.
    drive : ndarray, shape (rows,)
        d_r with the true chips.
    noise_shape : ndarray, shape (rows,)
        Relative noise standard deviation of each row (> 0).
    fit_rows : ndarray of bool, shape (n_sdus, rows)
        The rows each PHY-SDU's fit uses.
    off_shape : ndarray, shape (rows,), optional
        o_r; None for none (c = 0).

    Returns
    -------
    Levels
        ``gain`` in DN per unit of ``drive``.
    """
    rows = np.asarray(rows, dtype=np.float64)
    count = fit_rows.sum(axis=1)
    lo = np.where(count > 0, np.min(np.where(fit_rows, rows, np.inf), axis=1, initial=np.inf), 0.0)
    hi = np.where(count > 0, np.max(np.where(fit_rows, rows, -np.inf), axis=1, initial=-np.inf), 0.0)
    centre, half = 0.5 * (lo + hi), np.maximum(0.5 * (hi - lo), 1.0)
    rho = (rows[None, :] - centre[:, None]) / half[:, None]
    ones = np.ones_like(rho)
    off_shape = np.zeros_like(rows) if off_shape is None else np.asarray(off_shape, dtype=np.float64)
    design = np.stack([ones, rho, off_shape * ones, drive * ones, drive * rho], axis=2)
    row_weight = np.where(fit_rows, 1.0 / noise_shape, 0.0)  # 1/σ of each equation
    # pinv: the least-squares solution, of least norm where columns coincide (a constant o_r).
    coef = np.einsum("nij,nj->ni", np.linalg.pinv(design * row_weight[:, :, None]), values * row_weight)
    off = coef[:, 0:1] + coef[:, 1:2] * rho + coef[:, 2:3] * off_shape
    gain = coef[:, 3:4] + coef[:, 4:5] * rho
    residual = np.abs(values - off - gain * drive) / noise_shape
    scale = _MAD_TO_SIGMA * _masked_median(residual, fit_rows)
    largest_gap = np.max(np.where(fit_rows, np.abs(gain * drive), 0.0), axis=1)
    floor = np.maximum(SIGMA_FLOOR_FRACTION * largest_gap, np.finfo(float).tiny)
    return Levels(off, gain, np.maximum(scale, floor)[:, None] * noise_shape)


# ---------------------------------------------------------------- detection


@dataclass(frozen=True)
class ChipDecisions:
    """Chips decided for each PHY-SDU.

    Attributes
    ----------
    chips : ndarray of uint8, shape (n_sdus, n_chips)
    metric : ndarray of float64, shape (n_sdus,)
        Σ (y − model)²/σ² of the decided sequence over the PHY-SDU's rows.
    confidence : ndarray of float64, shape (n_sdus,)
        tanh(Δ/4), Δ the smallest path-metric difference at a merge along
        the survivor (a soft-output Viterbi's reliability: 2·P(right) − 1 of
        that merge's decision, in [0, 1]).
    """

    chips: np.ndarray
    metric: np.ndarray
    confidence: np.ndarray


def _pattern_bits(memory: int) -> np.ndarray:
    """(L, 2^L) bits of every window pattern, oldest chip the most significant bit."""
    patterns = np.arange(2**memory)
    return ((patterns[None, :] >> (memory - 1 - np.arange(memory))[:, None]) & 1).astype(np.float64)


def _branch_costs(values, off, gain, sigma, weights: ExposureWeights, sdu_first_chip: np.ndarray,
                  n_chips: int, response: Callable[[np.ndarray, np.ndarray], np.ndarray] | None) -> np.ndarray:
    """Cost of every window pattern at every step: shape (n_sdus, n_chips + L - 1, 2^L).

    Step j of PHY-SDU i ends at chip ``sdu_first_chip[i] + j``; a row enters
    the step of the last chip it touches, and the PHY-SDUs whose chips it
    touches.
    """
    memory = weights.memory
    n_sdus = sdu_first_chip.size
    sdu, row = _members(weights, sdu_first_chip, n_chips)
    step = weights.last_chip[row] - sdu_first_chip[sdu]
    level = weights.weights[row] @ _pattern_bits(memory)  # (pairs, 2^L)
    drive = level if response is None else response(row[:, None], level)
    model = off[sdu, row][:, None] + gain[sdu, row][:, None] * drive
    cost = np.square((values[row][:, None] - model) / sigma[sdu, row][:, None])
    costs = np.zeros((n_sdus, n_chips + memory - 1, 2**memory))
    np.add.at(costs, (sdu, step), cost)
    return costs


def _members(weights: ExposureWeights, sdu_first_chip: np.ndarray, n_chips: int) -> tuple[np.ndarray, np.ndarray]:
    """(PHY-SDU, row) pairs of the rows whose exposure touches each PHY-SDU's chips, as two index arrays."""
    member = ((weights.last_chip[None, :] >= sdu_first_chip[:, None])
              & (weights.first_touched[None, :] < sdu_first_chip[:, None] + n_chips))
    sdu, row = np.nonzero(member)
    return sdu, row


def _per_sdu(first: np.ndarray, values, off, gain, sigma) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The row means as float64, and off, gain and sigma broadcast to (n_sdus, rows)."""
    values = np.asarray(values, dtype=np.float64)
    shape = (first.size, values.size)
    return (values, *(np.broadcast_to(np.asarray(x, dtype=np.float64), shape) for x in (off, gain, sigma)))


def _force_known(costs: np.ndarray, sdu_first_chip: np.ndarray, n_chips: int,
                 chip_values: Callable[[np.ndarray], np.ndarray]) -> None:
    """Rule out, in place, the patterns whose newest chip contradicts a known chip after the PHY-SDU."""
    trailing = costs.shape[1] - n_chips
    if trailing == 0:
        return
    known = chip_values(sdu_first_chip[:, None] + n_chips + np.arange(trailing))  # (n_sdus, trailing)
    newest = np.arange(costs.shape[2]) & 1
    wrong = newest[None, None, :] != known[:, :, None]
    costs[:, n_chips:, :][wrong] = np.inf


def _viterbi(costs: np.ndarray, start_state: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minimum-cost chip sequences through the branch costs.

    Parameters
    ----------
    costs : ndarray, shape (n, steps, 2^L)
    start_state : ndarray of int, shape (n,)
        The L − 1 chips before step 0, oldest the most significant bit.

    Returns
    -------
    chips : ndarray of uint8, shape (n, steps)
    metric : ndarray, shape (n,)
    merge_gap : ndarray, shape (n,)
        Smallest difference between the two paths merging into the survivor.
    """
    n, steps, patterns = costs.shape
    states = patterns // 2
    shift = states.bit_length() - 2  # L - 2: where the oldest chip of a state sits
    metric = np.full((n, states), np.inf)
    metric[np.arange(n), start_state] = 0.0
    previous = np.arange(patterns) >> 1  # state before each pattern: its oldest L - 1 chips
    choice = np.zeros((n, steps, states), dtype=np.int8)
    candidates = np.zeros((n, steps, 2, states))
    for j in range(steps):  # one vectorised step per chip
        # pattern p = oldest·2^(L-1) + new state: axis 1 is the oldest chip.
        cand = (metric[:, previous] + costs[:, j, :]).reshape(n, 2, states)
        choice[:, j] = np.argmin(cand, axis=1)
        candidates[:, j] = cand
        metric = np.min(cand, axis=1)
    state = np.argmin(metric, axis=1)
    best = metric[np.arange(n), state]
    chips = np.zeros((n, steps), dtype=np.uint8)
    merge_gap = np.full(n, np.inf)
    index = np.arange(n)
    for j in range(steps - 1, -1, -1):
        chips[:, j] = state & 1
        oldest = choice[index, j, state]
        kept = candidates[index, j, oldest, state]
        merge_gap = np.minimum(merge_gap, candidates[index, j, 1 - oldest, state] - kept)
        state = (oldest.astype(np.int64) << shift) | (state >> 1)
    return chips, best, merge_gap


def detect_chips(values, off, gain, sigma, weights: ExposureWeights, sdu_first_chip, n_chips: int,
                 chip_values: Callable[[np.ndarray], np.ndarray],
                 response: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> ChipDecisions:
    """Maximum-likelihood chips of PHY-SDUs from row means (Viterbi).

    Minimises Σ_r (y_r − off_r − gain_r·R_r(s_r))² / σ_r², s_r = Σ_c w_rc·x_c,
    over the PHY-SDU's chips x ∈ {0, 1}^n_chips and the rows whose exposure
    touches them (R_r(s) = s without a ``response``: y = off + gap·s). The
    chips before and after are known (``chip_values``). The state is the
    last L − 1 chips (2^(L−1) states, L = ``weights.memory``); one numpy
    step per chip index covers every state and every PHY-SDU.

    Parameters
    ----------
    values : ndarray, shape (rows,)
        Row means y_r.
    off, gain, sigma : ndarray, broadcastable to (n_sdus, rows)
        Each PHY-SDU's model of every row (sigma > 0): off and sigma in the
        units of ``values``, gain in those units per unit of R (the ON-OFF
        gap without a ``response``).
    weights : ExposureWeights
        The rows' chip weights (absolute chip indices).
    sdu_first_chip : array_like of int, shape (n_sdus,)
        First chip of each PHY-SDU.
    n_chips : int
        Chips per PHY-SDU.
    chip_values : callable
        Known chip values (0/1) at an array of chip indices, for the chips
        just outside each PHY-SDU.
    response : callable, optional
        R(row position, s): the expected row response at exposure level s
        (e.g. :class:`RowResponse`, with the clip); None for R(s) = s.

    Returns
    -------
    ChipDecisions
    """
    first = np.atleast_1d(np.asarray(sdu_first_chip, dtype=np.int64))
    if n_chips < 1:
        raise ValueError(f"n_chips must be >= 1, got {n_chips}")
    values, off, gain, sigma = _per_sdu(first, values, off, gain, sigma)
    if not np.all(sigma > 0):
        raise ValueError("sigma must be > 0 for every row")
    memory = weights.memory
    costs = _branch_costs(values, off, gain, sigma, weights, first, n_chips, response)
    _force_known(costs, first, n_chips, chip_values)
    before = chip_values(first[:, None] - (memory - 1) + np.arange(memory - 1)).astype(np.int64)
    start_state = np.sum(before << (memory - 2 - np.arange(memory - 1)), axis=1)
    chips, metric, merge_gap = _viterbi(costs, start_state)
    return ChipDecisions(chips[:, :n_chips], metric, np.tanh(merge_gap / 4.0))


def flip_costs(values, off, gain, sigma, weights: ExposureWeights, sdu_first_chip, chips: np.ndarray,
               chip_values: Callable[[np.ndarray], np.ndarray],
               response: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """What flipping each decided chip alone would add to the sequence's cost Σ (y − model)²/σ².

    The reliability of each chip's decision (twice its log-likelihood
    ratio, the others fixed) for :func:`rollsim.protocol.linecode.repair`.
    After :func:`detect_chips` it is >= 0 up to rounding: no single flip
    beats the maximum-likelihood sequence.

    Parameters
    ----------
    values, off, gain, sigma, weights, sdu_first_chip, chip_values, response
        As :func:`detect_chips`.
    chips : ndarray of uint8, shape (n_sdus, n_chips)
        The decided chips of each PHY-SDU.

    Returns
    -------
    ndarray of float64, shape (n_sdus, n_chips)
        Clipped at 0.
    """
    first = np.atleast_1d(np.asarray(sdu_first_chip, dtype=np.int64))
    n_sdus, n_chips = chips.shape
    values, off, gain, sigma = _per_sdu(first, values, off, gain, sigma)
    sdu, row = _members(weights, first, n_chips)
    band = weights.first_chip[row][:, None] + np.arange(weights.memory)  # (pairs, L) absolute chips
    offset = band - first[sdu][:, None]
    own = (offset >= 0) & (offset < n_chips)
    bits = np.where(own, chips[sdu[:, None], np.clip(offset, 0, n_chips - 1)], chip_values(band)).astype(np.float64)
    w = weights.weights[row]
    level = np.sum(w * bits, axis=1)
    # Column 0: the decided sequence; column 1 + k: chip k of the band flipped.
    levels = np.concatenate([level[:, None], level[:, None] + w * (1.0 - 2.0 * bits)], axis=1)
    drive = levels if response is None else response(row[:, None], levels)
    cost = np.square((values[row][:, None] - off[sdu, row][:, None] - gain[sdu, row][:, None] * drive)
                     / sigma[sdu, row][:, None])
    added = np.where(own & (w > 0), cost[:, 1:] - cost[:, :1], 0.0)
    out = np.zeros((n_sdus, n_chips))
    np.add.at(out, (np.broadcast_to(sdu[:, None], offset.shape)[own], offset[own]), added[own])
    return np.maximum(out, 0.0)


# ------------------------------------------------------------ the receiver


def _fit_rows(weights: ExposureWeights, sdu_first_chip: np.ndarray, n_chips: int, margin_chips: int) -> np.ndarray:
    """Rows touching each PHY-SDU's chips widened by ``margin_chips`` on each side: (n_sdus, rows)."""
    lo = sdu_first_chip[:, None] - margin_chips
    hi = sdu_first_chip[:, None] + n_chips - 1 + margin_chips
    return (weights.last_chip[None, :] >= lo) & (weights.first_touched[None, :] <= hi)


def _status(decoded) -> list[str]:
    return ["ok" if ok else ("code_error" if not code else "check_failed")
            for ok, code in zip(decoded.check_ok.tolist(), decoded.code_ok.tolist())]


def genie_decode(image: np.ndarray, truth_record: dict, setup: SceneSetup) -> list[dict]:
    """Read every fully visible PHY-SDU of a frame with the genie's knowledge.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, 3)
        The rendered frame.
    truth_record : dict
        The frame's truth (:func:`rollsim.render.truth.frame_truth`).
    setup : SceneSetup
        The prepared setup it was rendered with (``RenderPipeline.setup``).

    Returns
    -------
    list of dict
        One record per fully visible PHY-SDU, in the format of
        :meth:`decoder.DecodedPhySdu.to_record`, with the truth's
        ``first_row_f``/``last_row_f``; status ``ok``, ``check_failed`` or
        ``code_error``. The SYNC's chips are detected but not checked: the
        genie knows where the PHY-SDU is. One invalid line-code symbol is
        repaired from the chips' flip costs (:func:`flip_costs`).
    """
    from decoder.records import DecodedPhySdu

    sdus = [s for s in truth_record["sdus"] if s["fully_visible"]]
    if not sdus or not truth_record.get("led_rows"):
        return []
    tx = setup.transmitter
    phy, chips_of = tx.phy, tx.waveform.chips.values
    profile = genie_profile(image, setup, truth_record["led_rows"])
    weights = frame_weights(setup, truth_record, profile.rows)
    first = np.array([s["tx"] for s in sdus], dtype=np.int64) * phy.sdu_chips
    off_level = float(tx.waveform.off_level / tx.waveform.on_level)

    def response(row: np.ndarray, s: np.ndarray) -> np.ndarray:
        # An OFF chip still emits off_level of ON: the LED's light is off_level + (1 - off_level)·s of ON.
        return profile.response(row, off_level + (1.0 - off_level) * s)

    drive = response(np.arange(len(profile)), weights.levels(chips_of))  # electrons, with the true chips
    levels = fit_levels(profile.values_dn, profile.rows, drive, profile.noise_shape,
                        _fit_rows(weights, first, phy.sdu_chips, LEVEL_MARGIN_CHIPS), profile.off_e)
    decided = detect_chips(profile.values_dn, levels.off, levels.gain, levels.sigma, weights, first,
                           phy.sdu_chips, chips_of, response)
    reliability = flip_costs(profile.values_dn, levels.off, levels.gain, levels.sigma, weights, first, decided.chips,
                             chips_of, response)
    decoded = phy.decode_coded(decided.chips[:, phy.sync_chips:], reliability[:, phy.sync_chips:])
    status = _status(decoded)
    frame = int(truth_record["frame"])
    return [
        DecodedPhySdu(
            frame=frame,
            first_row_f=float(sdu["first_row_f"]),
            last_row_f=float(sdu["last_row_f"]),
            sequence=int(decoded.sequence[i]),
            bits="".join("1" if b else "0" for b in decoded.payload[i].tolist()),
            check_ok=bool(decoded.check_ok[i]),
            confidence=float(decided.confidence[i]),
            status=status[i],
        ).to_record()
        for i, sdu in enumerate(sdus)
    ]
