"""A camera fit's statistics of the frames, and the parameters read off them.

:func:`measure` runs the estimators in the order each needs the last:

1. the row time, from the stripe period (:func:`decoder.estimate_row_time`,
   run first by :func:`rollsim.fit.refine.fit_camera`): the one statistic
   without which nothing is fitted;
2. the LED's region (:func:`rollsim.fit.measure.find_led_region`): its disk,
   or that it fills the frame, and a background block when there is one;
3. the noise (:mod:`rollsim.fit.noise`): pairs (level, temporal variance)
   from the rows that hold one unclipped level in two frames, which tell a
   linear tone curve from sRGB where they can (:func:`rollsim.fit.noise.tone_from_noise`);
   and, from the background, its noise, row noise and column pattern;
4. the exposure, the ISP's vertical smoothing, the tone curve's γ (unless
   the noise told it) and the linear ON and OFF levels, from the stripes'
   shape (:mod:`rollsim.fit.stripes`); clipped ON rows are modelled as the
   ADC clips them, so a saturated LED gives its exposure from the ramps and
   the OFF runs' widths;
5. the LED's radial profile, from the brightest frame, when there is a disk.

Each estimate carries its source: ``frames``, ``base scene`` (what frames
of a square wave never show: the lens, the distance) or ``not identified``
(what these frames do not show, with the reason; its value is then the base
scene's). :func:`direct` reads the parameters off the statistics, and
:func:`corrected` moves them by what separates the frames' statistics from
those of frames rendered with them (:func:`rollsim.fit.refine.fit_camera`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from rollsim.fit.binning import binned_if_nearer, detect_binning, nearest_offset
from rollsim.fit.measure import LedRegion, TemporalNoise, column_pattern_std, find_led_region, level_noise_pairs, \
    temporal_noise
from rollsim.fit.noise import MIN_LEVEL_SPAN, anchor_levels, gain_given_read, linear_level, noise_at, noise_gain, \
    photon_transfer, shot_noise_line, tone_from_noise, tone_slope, unclipped
from rollsim.fit.stripes import MAX_GAMMA, MIN_GAMMA, StripeFit, exposure_for_off_level, fit_residuals, fit_stripes, \
    levels_for_whole_periods, profile_extremes, reflected_levels, rows_the_model_holds, whole_periods_in
from rollsim.scene.model import Scene
from rollsim.sensor.adc import full_scale_electrons

# Radial profile bins (fractions of the radius) and the least variation worth an effect.
PROFILE_BINS = 8
PROFILE_MIN_VARIATION = 0.05
# The fraction cut off each end of a ring's pixels before their mean (a hot pixel, a clipped one).
PROFILE_TRIM = 0.1
# The LED's halo (blur, glare) reaches this many radii from its centre: the background lies beyond.
HALO_RADII = 1.8

FRAMES, BASE, NOT_IDENTIFIED, GIVEN = "frames", "base scene", "not identified", "given"
# How a value the user gave is found: it is not.
HELD_AS_GIVEN = "held as given"


@dataclass(frozen=True)
class Known:
    """What the user knows of the camera and tells the fit: held, not fitted.

    Attributes
    ----------
    exposure_us : float, optional
        The exposure, µs (a camera set by hand, or a still's EXIF
        ExposureTime). The stripes tell it only up to whole stripe periods
        and the reflection E ↔ P − E; told, it picks among those and is
        held through the refinement.
    tone_gamma : float, optional
        The tone curve's exponent (:mod:`rollsim.fit.tone`: 1 linear, 2.4
        sRGB), where the frames' noise and stripes tell it poorly.
    exposure_how : str
        Who told the exposure, for ``fit.json``'s ``how`` (the user, or the
        stills' EXIF: :func:`rollsim.fit.exif.exposure_how`).
    binning_rows : int, optional
        Rows read as one (binned readout, a sensor mode's), where JPEG and
        the ISP's smoothing hide the pairs from the frames
        (:mod:`rollsim.fit.binning`); the groups start at row 0 unless
        another offset's stripe fit is clearly nearer
        (:func:`rollsim.fit.binning.nearest_offset`).
    """

    exposure_us: float | None = None
    tone_gamma: float | None = None
    exposure_how: str = HELD_AS_GIVEN
    binning_rows: int | None = None


@dataclass(frozen=True)
class Estimate:
    """One fitted quantity: value, one-sigma uncertainty (None: not known), unit, how, and its source.

    ``source`` is ``frames``, ``base scene``, ``not identified`` or ``given``
    (by the user: :class:`Known`); ``reason`` says why a quantity is not
    from the frames.
    """

    value: float
    uncertainty: float | None
    unit: str
    how: str
    source: str = FRAMES
    reason: str | None = None
    alternatives: tuple[float, ...] = ()  # other values the frames allow as well (same unit)

    def to_json(self) -> dict:
        unc = self.uncertainty if self.uncertainty is not None and math.isfinite(self.uncertainty) else None
        out: dict = {"value": self.value, "uncertainty": unc, "unit": self.unit, "how": self.how, "source": self.source}
        if self.reason:
            out["reason"] = self.reason
        if self.alternatives:
            out["alternatives"] = list(self.alternatives)
        return out


def gain_per_full_scale(scene: Scene) -> float:
    """The camera's gain as a fraction of the ADC range (above black) per electron."""
    cam = scene.camera
    return 1.0 / full_scale_electrons(cam.adc_bits, cam.black_level_dn, cam.gain_dn_per_e_at_iso)


def radial_profile(brightest_lin: np.ndarray, region: LedRegion, on_rows: np.ndarray, off_lin: float) -> list | None:
    """The LED's radial profile (radius / R, relative radiance) from the rows lit in the brightest frame,
    or None when it is flat within :data:`PROFILE_MIN_VARIATION`, there is no disk, or its halves
    above and below the centre disagree by more than that.

    Each ring's level is the trimmed mean of its pixels (:data:`PROFILE_TRIM` off each end): a
    median of 8-bit pixels a few levels above the OFF level moves by a whole level, a quarter of
    the ring's. The halves read other rows, so other stripe phases: a radiance profile is the
    same in both, what the stripes' rows lent a ring is not.
    """
    from scipy.stats import trim_mean

    disk = region.disk
    if disk is None:
        return None
    yy, xx = np.mgrid[0:brightest_lin.shape[0], 0:brightest_lin.shape[1]]
    r = np.hypot(xx + 0.5 - disk.centre_x_px, yy + 0.5 - disk.centre_y_px) / disk.radius_px
    inside = (r < 0.9) & on_rows[:, None]
    if inside.sum() < 50:
        return None
    edges = np.linspace(0.0, 0.9, PROFILE_BINS + 1)

    def ring_levels(where: np.ndarray) -> np.ndarray:
        index = np.digitize(r[where], edges) - 1
        values = brightest_lin[where] - off_lin
        return np.array([trim_mean(values[index == i], PROFILE_TRIM) if np.any(index == i) else np.nan
                         for i in range(PROFILE_BINS)])

    levels = ring_levels(inside)
    if np.any(~np.isfinite(levels)) or levels[0] <= 0:
        return None
    rel = np.clip(levels / levels[0], 0.0, None)
    if np.ptp(rel) < PROFILE_MIN_VARIATION:
        return None
    above = yy + 0.5 < disk.centre_y_px
    halves = [ring_levels(inside & above), ring_levels(inside & ~above)]
    if all(np.all(np.isfinite(h)) for h in halves):
        if np.max(np.abs(halves[0] - halves[1])) / levels[0] > PROFILE_MIN_VARIATION:
            return None
    centres = 0.5 * (edges[:-1] + edges[1:])
    radii = np.concatenate([[0.0], centres, [1.0]])
    values_out = np.concatenate([[rel[0]], rel, [rel[-1]]])
    return [[round(float(a), 4), round(float(b), 4)] for a, b in zip(radii, values_out)]


def radial_profile_from_knots(stripes: StripeFit, region: LedRegion) -> list | None:
    """The LED's radial profile (radius / R, relative radiance) from the stripe
    fit's ON levels along the rows, or None when it is flat within
    :data:`PROFILE_MIN_VARIATION` or there is no disk.

    For a saturated LED the brightest frame is flat where the light clips,
    but the fit's ON levels, modelled beyond full scale, still vary.
    """
    disk = region.disk
    if disk is None:
        return None
    x = np.abs(np.asarray(stripes.knot_rows) - disk.centre_y_px) / disk.radius_px
    on = np.asarray(stripes.on_knots)
    if not on.max() > 0:
        return None
    edges = np.linspace(0.0, 0.9, PROFILE_BINS + 1)
    centres = 0.5 * (edges[:-1] + edges[1:])
    order = np.argsort(x)
    rel = np.interp(centres, x[order], on[order] / on.max())
    if np.ptp(rel) < PROFILE_MIN_VARIATION or not rel[0] > 0:
        return None
    radii = np.concatenate([[0.0], centres, [1.0]])
    values = np.concatenate([[rel[0]], rel, [rel[-1]]]) / rel[0]
    return [[round(float(a), 4), round(float(b), 4)] for a, b in zip(radii, values)]


# ------------------------------------------------------------------ measure


@dataclass(frozen=True)
class Measured:
    """The statistics :func:`measure` takes from a set of frames (the fit's data).

    Levels are 8-bit; ``None`` marks a statistic these frames do not hold.
    """

    row_time_s: float
    row_time_sd_s: float
    region: LedRegion
    background: float | None  # median of the background block's mean
    stripes: StripeFit
    noise_levels: np.ndarray  # the LED's unclipped rows that hold one level in two frames: 8-bit level …
    noise_variances: np.ndarray  # … and temporal variance, 8-bit²
    background_noise: TemporalNoise | None
    row_noise: float | None  # the background's row temporal noise, 8-bit
    column_pattern: float | None  # the background's column offsets, 8-bit
    profile: list | None
    binning: tuple[int, int]  # binned readout seen: (k, offset of the first group); (1, 0) none
    stripes_period_rows: float  # the stripe period the stripes were fitted with
    # The stripes' fit in pairs of rows over their fit in rows (residuals),
    # where the frames' binning was neither told nor seen (else None).
    paired_residual_ratio: float | None = None


# The fewest stripe periods the LED's band must hold: the stripes' fit reads the
# exposure from whole periods' edges, and the check aligns profiles over one.
MIN_BAND_PERIODS = 2.0


def measure(frames: Sequence[np.ndarray], clock_hz: float, row_time: tuple[float, float],
            region: LedRegion | None = None, start: StripeFit | None = None,
            stripes_at: tuple[slice, float] | None = None, binning: tuple[int, int] | None = None,
            tone_gamma: float | None = None, binning_known: bool = False) -> Measured:
    """The fit's statistics of a set of frames (see the module docstring, steps 1–5).

    ``row_time`` is the row time and its uncertainty (s, s), estimated first
    (:func:`rollsim.fit.refine.fit_camera`: the cheap check). ``region``
    skips its estimation (rendered frames of a fit are measured where the
    frames were); ``start`` starts the stripe fit from an earlier one.
    ``stripes_at`` (rows, centre column where the stripes move between
    frames) checks the region found (:func:`rollsim.fit.measure.find_led_region`).
    ``binning`` (k, offset) skips its detection (:func:`rollsim.fit.binning.detect_binning`
    on ``frames``): colour frames' is seen on their luminance, rendered
    frames' is what was rendered; ``binning_known``: its k was given by the
    user (:class:`Known`), the groups' first row row 0 unless the stripes
    tell another (:func:`rollsim.fit.binning.nearest_offset`). ``tone_gamma`` (given by the user) is the
    tone curve's exponent the stripes are fitted with, instead of the one
    the noise tells. A ValueError says why frames cannot be
    measured: among others, an LED whose band holds fewer than
    :data:`MIN_BAND_PERIODS` stripe periods (a colour plane's fit passes
    that plane over, :func:`rollsim.fit.refine.measured_planes`).
    """
    shape = frames[0].shape
    row_time_s, row_time_sd = row_time
    period = 2.0 / (clock_hz * row_time_s)
    stack = np.asarray(frames, dtype=np.float64)
    brightest, mean_frame = stack.max(axis=0), stack.mean(axis=0)
    if region is None:
        region = find_led_region(stack, HALO_RADII, period, stripes_at)
    del stack
    rows, cols = region.band
    if rows.stop - rows.start < MIN_BAND_PERIODS * period:
        raise ValueError(f"the LED's rows hold {(rows.stop - rows.start) / period:.1f} stripe periods "
                         f"(< {MIN_BAND_PERIODS:g}): too few to fit the stripes")
    if binning is None:
        binning = detect_binning(frames)
    profiles = [f[rows, cols].mean(axis=1) for f in frames]
    levels, variances = level_noise_pairs(frames, rows, cols)
    keep = unclipped(levels)
    # The stripes' shape tells the tone curve poorly (it trades against the
    # exposure and the smoothing): a curve the user knows is taken, else the
    # noise tells linear from sRGB where it can. Rendered frames keep the start's.
    gamma = None if start is not None else tone_gamma if tone_gamma is not None else (
        tone_from_noise(levels[keep], variances[keep]))
    stripes = fit_stripes(profiles, np.arange(rows.start, rows.stop), period, start=start, binning=binning,
                          gamma=gamma)
    paired_ratio = None
    if start is None and binning_known:
        stripes, binning = nearest_offset(stripes, profiles, np.arange(rows.start, rows.stop), period, binning[0])
    elif start is None and binning == (1, 0):
        # Pairs that JPEG or smoothing hid from the rows' steps still show in the stripes' edges.
        stripes, binning, paired_ratio = binned_if_nearer(stripes, profiles, np.arange(rows.start, rows.stop),
                                                          period)
    if start is None:
        # Ends of the band the square wave does not hold (an LED's rim in a
        # crop it fills, a halo) are left out; rendered frames are measured
        # in the rows kept (their ``region``).
        held = rows_the_model_holds(fit_residuals(stripes, profiles, np.arange(rows.start, rows.stop), period,
                                                  binning), period)
        if held != slice(0, len(profiles[0])):
            rows = slice(rows.start + held.start, rows.start + held.stop)
            region = dataclasses.replace(region, band=(rows, cols))
            profiles = [p[held] for p in profiles]
            levels, variances = level_noise_pairs(frames, rows, cols)
            keep = unclipped(levels)
            stripes = fit_stripes(profiles, np.arange(rows.start, rows.stop), period, binning=binning, gamma=gamma)
    background = bg_noise = row_noise = column = None
    if region.block is not None:
        block = region.block
        background = float(np.median(mean_frame[block]))
        bg_noise = temporal_noise(frames, *block)
        if bool(unclipped(background)):
            row_noise = bg_noise.row_std
            column = column_pattern_std(mean_frame, *block, len(frames), bg_noise.pixel_std)
    band_max = brightest[rows, cols].mean(axis=1)
    on_rows = np.zeros(shape[0], dtype=bool)
    on_rows[rows] = band_max >= np.percentile(band_max, 60)
    if max(stripes.on_knots) > 1.0:  # saturated: the brightest frame is flat where it clips
        profile = radial_profile_from_knots(stripes, region)
    else:
        profile = radial_profile(linear_level(brightest, stripes.gamma), region, on_rows, stripes.off)
    return Measured(row_time_s, row_time_sd, region, background, stripes, levels[keep], variances[keep], bg_noise,
                    row_noise, column, profile, binning, period, paired_ratio)


# --------------------------------------------------------------- parameters


@dataclass(frozen=True)
class Parameters:
    """The scene's fitted parameters, before they become a scene (linear levels:
    fractions of the ADC range; gains: fractions of it per electron)."""

    exposure_rows: float
    smoothing_rows: float
    gamma: float
    on_lin: float  # the LED's ON level at its centre
    off_lin: float  # its OFF level (ambient light on its face)
    k_lin: float  # gain
    read_lin: float  # read noise
    row_lin: float | None  # row noise (None: the base scene's)
    col_lin: float | None  # column pattern (None: the base scene's)
    # The read noise held at its bound, below what the frames resolve
    # (rollsim.fit.noise.shot_noise_line).
    read_held: bool = False


@dataclass(frozen=True)
class NoiseFit:
    """Gain and read noise (linear), and where each came from."""

    k_lin: float
    read_lin: float
    gain_source: str
    read_source: str
    reason: str | None


@dataclass(frozen=True)
class Anchor:
    """A level the noise is matched at: the background's, or the LED rows' (8-bit)."""

    level: float
    background: bool


def usable_background(m: Measured) -> tuple[float, TemporalNoise] | None:
    """The background's level and noise when it is clear of both clips (its noise intact), else None."""
    if m.background is None or m.background_noise is None or not bool(unclipped(m.background)):
        return None
    return m.background, m.background_noise


def noise_anchors(m: Measured, gamma: float) -> list[Anchor]:
    """The levels the noise is matched at: the background (when usable) and the
    LED rows' highest third when its linear level is :data:`rollsim.fit.noise.MIN_LEVEL_SPAN`
    apart from the background's; without a background, the LED rows' lowest
    and highest thirds (:func:`rollsim.fit.noise.anchor_levels`)."""
    led = anchor_levels(m.noise_levels, gamma)
    background = usable_background(m)
    if background is None:
        return [Anchor(level, False) for level in led]
    bg = Anchor(float(background[0]), True)
    if led:
        ratio = float(linear_level(led[-1], gamma)) / max(float(linear_level(bg.level, gamma)), 1e-12)
        if ratio >= MIN_LEVEL_SPAN or ratio <= 1.0 / MIN_LEVEL_SPAN:
            return sorted([bg, Anchor(led[-1], False)], key=lambda a: a.level)
    return [bg]


def anchor_variance(m: Measured, anchor: Anchor) -> float | None:
    """The temporal variance (8-bit²) the frames show at an anchor, or None."""
    if anchor.background:
        return m.background_noise.pixel_std**2 if m.background_noise is not None else None
    return noise_at(m.noise_levels, m.noise_variances, anchor.level)


def noise_from_points(m: Measured, gamma: float, smoothing_rows: float, base: Scene) -> NoiseFit:
    """Gain and read noise from the noise points (see :mod:`rollsim.fit.noise`)."""
    keep = noise_gain(smoothing_rows)
    levels, variances = m.noise_levels, m.noise_variances
    background = usable_background(m)
    if background is not None:
        levels = np.concatenate([levels, [background[0]]])
        variances = np.concatenate([variances, [background[1].pixel_std**2]])
    u = linear_level(levels, gamma)
    var = variances * tone_slope(levels, gamma) ** 2 / keep
    read_e = base.camera.read_noise_e
    anchors = noise_anchors(m, gamma)
    if len(anchors) == 2:
        a, b = photon_transfer(u, var)[:2]
        if a > 0 and b > 0:
            return NoiseFit(b, math.sqrt(a), FRAMES, FRAMES, None)
    if anchors:
        anchor = anchors[-1]
        v = anchor_variance(m, anchor)
        u_a = float(linear_level(anchor.level, gamma))
        if v is not None and u_a > 0:
            v_lin = v * float(tone_slope(anchor.level, gamma)) ** 2 / keep
            k = gain_given_read(u_a, v_lin, read_e)
            if k > 0:
                why = ("the unclipped rows hold one level: gain and read noise are not separable"
                       if len(anchors) == 1 else "the photon-transfer line has no positive intercept")
                return NoiseFit(k, read_e * k, FRAMES, NOT_IDENTIFIED, why)
    k = gain_per_full_scale(base)
    return NoiseFit(k, read_e * k, NOT_IDENTIFIED, NOT_IDENTIFIED,
                    "no row holds one unclipped level in two frames, and there is no unclipped background")


# Whole stripe periods of exposure the fit considers beyond the shortest.
MAX_WHOLE_PERIODS = 4
# The lowest OFF level (fraction of the ADC range) a choice of exposure may imply.
MIN_OFF_LEVEL = -0.005


@dataclass(frozen=True)
class ExposureChoice:
    """One exposure the stripes allow, and the linear levels it implies.

    ``reflected``: the reflection E ↔ P − E of the fitted exposure;
    ``whole_periods``: the stripe periods added to it; ``off_at_face``: the
    exposure moved within its branch to put an OFF level below zero at the
    face's (:func:`exposure_choices`).
    """

    exposure_rows: float
    on: float
    off: float
    reflected: bool
    whole_periods: int
    off_at_face: bool = False


def face_level(m: Measured, base: Scene) -> float:
    """The ambient light on the LED's face (linear, fraction of the ADC range): the
    background's times the base scene's face over background reflectance; 0 without a background."""
    if m.background is None:
        return 0.0
    return float(linear_level(m.background, m.stripes.gamma)) * base.led.face_reflectance / max(
        base.environment.background_reflectance, 1e-9)


def exposure_choices(m: Measured, base: Scene) -> list[ExposureChoice]:
    """The exposures the stripes allow, the most likely first.

    The stripes' shape tells the exposure only up to whole periods and the
    reflection E ↔ P − E (:func:`rollsim.fit.stripes.levels_for_whole_periods`,
    :func:`rollsim.fit.stripes.reflected_levels`): frames rendered with any
    of these choices are the same where they do not clip. Each implies its
    own OFF level. An LED is dark when OFF: the choices are ordered by how
    near their OFF level is to the ambient light on the LED's face
    (:func:`face_level`).

    Light is never negative. A choice whose OFF level is below zero (beyond
    the fit's noise, :data:`MIN_OFF_LEVEL`) is not possible as it stands, but
    its branch may be: the stripe fit trades exposure against smoothing
    (both widen the ramps), and a shift of the fitted exposure by a row
    moves the OFF level a choice of many more rows implies by much more.
    Where the frames show a background (the face's light is measured), such
    a choice is replaced by the exposure of its branch (its whole periods,
    and the half of a period its remainder lies in) that puts the OFF level
    at the face's, with the profile's least and greatest levels kept
    (:func:`rollsim.fit.stripes.exposure_for_off_level`); it keeps its place
    in the order. Without a background the face's light is only assumed
    dark, and an LED filling the frame often has light on its face: such a
    choice is left out, as is a branch without such an exposure (unless
    every choice is).

    The levels tell whole periods only where some choice's OFF level lies
    within one period's step (:func:`off_step_per_period`) of the face's
    light. Where none does, they point past every choice: the fewest whole
    periods come first.
    """
    s, period = m.stripes, m.stripes_period_rows
    on0, off0 = s.on, s.off  # ON above OFF: rollsim.fit.stripes.right_way_up
    candidates = exposure_branches(s.exposure_rows, on0, off0, period)
    face = face_level(m, base)
    y_min, y_max = profile_extremes(s.exposure_rows, on0, off0, period)
    ranked = []
    for c in candidates:
        if c.off >= MIN_OFF_LEVEL:
            ranked.append((abs(c.off - face), c))
            continue
        if m.background is None:
            continue  # the face's light is not measured, only assumed dark: no level to move the choice to
        e = c.exposure_rows - c.whole_periods * period
        pinned = exposure_for_off_level(y_min, y_max, face, period, c.whole_periods, upper_half=e >= 0.5 * period)
        if pinned is not None:
            ranked.append((abs(c.off - face),
                           ExposureChoice(pinned[0], pinned[1], face, c.reflected, c.whole_periods, True)))
    if not ranked:
        ranked = [(abs(c.off - face), c) for c in candidates]
    if min(distance for distance, _ in ranked) > off_step_per_period(s.exposure_rows, on0, off0, period):
        # No choice's OFF level comes within a period's step of the face's
        # light: the levels point past every choice (the fit's levels are not
        # the LED's: its ON rows clip, or the tone curve is not the camera's),
        # and tell nothing of the whole periods. The fewest stand, as the
        # stripes' shape read them; the OFF level orders the rest.
        return [c for _, c in sorted(ranked, key=lambda item: (item[1].whole_periods, item[0]))]
    return [c for _, c in sorted(ranked, key=lambda item: item[0])]


def given_exposure_choice(m: Measured, exposure_rows: float) -> tuple[ExposureChoice, float]:
    """The exposure the user gave (rows), with the linear levels of the branch nearest it, and how far
    that branch lies (rows).

    Of the exposures the stripes allow (:func:`exposure_branches`: whole
    periods, any number, and the reflection), the nearest to the one given carries the
    ON and OFF levels that make the frames' stripes; the refinement then
    holds the exposure given and moves the levels to it. A branch far from
    the exposure given (more than a row or so) says the stripes' edges read
    another exposure: the camera's, or the value given, is not what it
    seems.
    """
    s, period = m.stripes, m.stripes_period_rows
    branches = []
    for reflected, (e, a, b) in branch_starts(s.exposure_rows, s.on, s.off, period):
        k = max(0, round((exposure_rows - e) / period))  # as many whole periods as the exposure given holds
        exposure, on, off = levels_for_whole_periods(e, a, b, period, k)
        branches.append(ExposureChoice(float(exposure), float(on), float(off), reflected, k))
    nearest = min(branches, key=lambda c: abs(c.exposure_rows - exposure_rows))
    return (ExposureChoice(float(exposure_rows), nearest.on, max(0.0, nearest.off), nearest.reflected,
                           nearest.whole_periods),
            abs(nearest.exposure_rows - exposure_rows))


def off_step_per_period(exposure_rows: float, on: float, off: float, period_rows: float) -> float:
    """How much each whole stripe period more lowers the OFF level (linear) that makes the same stripes:
    Δ₀·P/(2·E₀) (:func:`rollsim.fit.stripes.levels_for_whole_periods`), the same from E₀ and from P − E₀."""
    return float(abs(on - off) * period_rows / (2.0 * max(exposure_rows, 1e-9 * period_rows)))


def branch_starts(exposure_rows: float, on: float, off: float,
                  period_rows: float) -> list[tuple[bool, tuple[float, float, float]]]:
    """The first exposure of each branch that makes the same stripes as ``exposure_rows`` (rows) with
    linear levels ``on`` and ``off``: (reflected, (E, ON, OFF)) for E₀ within one period, and for
    P − E₀ where E₀ is not a whole number of periods."""
    whole = whole_periods_in(exposure_rows, period_rows)
    e0, a0, b0 = levels_for_whole_periods(exposure_rows, on, off, period_rows, -whole)
    starts = [(False, (float(e0), float(a0), float(b0)))]
    if 0 < e0 < period_rows:
        e1, a1, b1 = reflected_levels(float(e0), a0, b0, period_rows)
        starts.append((True, (float(e1), float(a1), float(b1))))
    return starts


def exposure_branches(exposure_rows: float, on: float, off: float, period_rows: float) -> list[ExposureChoice]:
    """Every exposure that makes the same stripes as ``exposure_rows`` (rows) with linear
    levels ``on`` and ``off``, with the levels each implies: its E₀ within one period
    and P − E₀, each with 0 to :data:`MAX_WHOLE_PERIODS` whole periods
    (``reflected`` and ``whole_periods`` relative to E₀)."""
    branches = []
    for reflected, (e, a, b) in branch_starts(exposure_rows, on, off, period_rows):
        for k in range(MAX_WHOLE_PERIODS + 1):
            exposure, level_on, level_off = levels_for_whole_periods(float(e), a, b, period_rows, k)
            branches.append(ExposureChoice(float(exposure), float(level_on), float(level_off), reflected, k))
    return branches


def branches_by_refined_levels(p: Parameters, m: Measured, base: Scene) -> list[ExposureChoice] | None:
    """The exposures a refined fit's levels allow, the one whose OFF level lies nearest the face's
    light first; None where that is the fit's own (or none lies within a period's step of it).

    The first choice (:func:`exposure_choices`) orders the whole periods by
    the stripe fit's levels, which carry its biases (smoothing traded for
    exposure, JPEG's and the ISP's effect on the levels). Refined by
    rendering, the levels are the scene's that make the frames' stripes,
    biases cancelled: their OFF level, mapped to every branch, places the
    face's light better. With a background, a branch's OFF level a little
    below zero is the fit's error, not negative light: the nearest counts.
    Without one, the face is only assumed dark, and branches below zero
    (beyond :data:`MIN_OFF_LEVEL`) are left out. The others follow the first
    (the fit's alternatives) where their OFF level is not below zero.
    """
    period = m.stripes_period_rows
    branches = exposure_branches(p.exposure_rows, p.on_lin, p.off_lin, period)
    own = branches[0]  # E₀, no whole period
    step = off_step_per_period(own.exposure_rows, own.on, own.off, period)
    face = face_level(m, base)
    if m.background is None:
        branches = [c for c in branches if c.off >= MIN_OFF_LEVEL]
    if not branches:
        return None
    ranked = sorted(branches, key=lambda c: abs(c.off - face))
    first = ranked[0]
    if abs(first.off - face) > step:
        return None  # the levels point past every branch (see exposure_choices)
    if abs(first.exposure_rows - p.exposure_rows) < 1e-6 * period:
        return None  # the fit's own branch
    # The others are the fit's alternatives: only those of light that is not negative.
    return [first] + [c for c in ranked[1:] if c.off >= MIN_OFF_LEVEL]


def resolve_exposure(m: Measured, base: Scene) -> tuple[float, float, float]:
    """The exposure (rows) and linear ON and OFF levels: the first of :func:`exposure_choices`."""
    best = exposure_choices(m, base)[0]
    return best.exposure_rows, best.on, best.off


def exposure_alternatives_rows(exposure_rows: float, period_rows: float,
                               choices: Sequence[ExposureChoice]) -> list[float]:
    """The other choices' exposures (rows), moved as the first choice was moved to ``exposure_rows``.

    The refinement moves the first choice by a fraction of a period; the
    others keep their relation to it: with E₀ the exposure within the first
    period, a choice is E₀ (or P − E₀, reflected) plus its whole periods.
    Ascending, without the first choice and without repeats.
    """
    first = choices[0]
    within = exposure_rows - first.whole_periods * period_rows
    e0 = period_rows - within if first.reflected else within
    out = set()
    for c in choices[1:]:
        e = (period_rows - e0 if c.reflected else e0) + c.whole_periods * period_rows
        if e > 0 and abs(e - exposure_rows) > 1e-9 * period_rows:
            out.add(round(e, 9))
    return sorted(out)


def direct(m: Measured, base: Scene) -> tuple[Parameters, NoiseFit]:
    """Parameters read straight off the statistics."""
    s = m.stripes
    noise = noise_from_points(m, s.gamma, s.smoothing_rows, base)
    exposure, on, off = resolve_exposure(m, base)
    slope = float(tone_slope(m.background, s.gamma)) if m.background is not None else 0.0
    keep = noise_gain(s.smoothing_rows)
    row_lin = m.row_noise * slope / math.sqrt(keep) if m.row_noise is not None else None
    col_lin = m.column_pattern * slope if m.column_pattern is not None else None
    return Parameters(float(exposure), s.smoothing_rows, s.gamma, float(on), max(0.0, float(off)), noise.k_lin,
                      noise.read_lin, row_lin, col_lin), noise


# The rendered stripes' ON level within this factor of the frames' for the
# shape (exposure, smoothing, tone curve) to be corrected by :func:`corrected`.
LEVEL_MATCH = 2.0


def level_ratio(x: float | None, y: float | None) -> float:
    """x / y of two positive statistics; 1 (no change) when either is missing or not positive."""
    return x / y if x is not None and y is not None and y > 0 and x > 0 else 1.0


def levels_match(target: Measured, rendered: Measured) -> bool:
    """Whether a render's stripes show the frames' ON level within :data:`LEVEL_MATCH`,
    as :func:`matched_terms` reads both: only then are their shapes compared."""
    mine, theirs = matched_terms(target, rendered)
    return 1.0 / LEVEL_MATCH <= level_ratio(mine.on, theirs.on) <= LEVEL_MATCH


@dataclass(frozen=True)
class StripeTerms:
    """An exposure and its linear levels as a stripe fit reports them, and where they came from.

    A stripe fit reports an exposure E₀ in (0, P] (whole periods removed,
    :func:`rollsim.fit.stripes.whole_periods_removed`) or its reflection
    P − E₀, with the levels that make the same profile. ``whole_periods``
    and ``reflected`` map the terms back to the exposure they stand for
    (:meth:`exposure_and_levels`).
    """

    exposure_rows: float
    on: float
    off: float
    whole_periods: int = 0
    reflected: bool = False

    @classmethod
    def of(cls, exposure_rows: float, on: float, off: float, period_rows: float, like_rows: float) -> StripeTerms:
        """The terms of an exposure (rows) and its levels: of E₀ and P − E₀, the one nearer ``like_rows``.

        Fits of the frames and of their render, and the parameters rendered,
        are compared in the one chart nearest the frames' fit
        (``like_rows``): in another, a longer exposure reads as a shorter one.
        """
        whole = whole_periods_in(exposure_rows, period_rows)
        e0, on0, off0 = levels_for_whole_periods(exposure_rows, on, off, period_rows, -whole)
        terms = cls(float(e0), float(on0), float(off0), whole, False)
        if 0.0 < e0 < period_rows:
            e1, on1, off1 = reflected_levels(float(e0), on0, off0, period_rows)
            if abs(e1 - like_rows) < abs(e0 - like_rows):
                terms = cls(float(e1), float(on1), float(off1), whole, True)
        return terms

    def exposure_and_levels(self, period_rows: float) -> tuple[float, float, float]:
        """The exposure (rows) and linear ON and OFF levels the terms stand for."""
        e, on, off = self.exposure_rows, self.on, self.off
        tiny = 1e-6 * period_rows  # both maps divide by the exposure they start from
        if self.reflected:  # a correction may move P − E₀ out of the period it reflects within
            e = min(max(e, tiny), period_rows - tiny)
            e, on, off = reflected_levels(e, on, off, period_rows)
        e, on, off = levels_for_whole_periods(max(e, tiny), on, off, period_rows, self.whole_periods)
        return float(e), float(on), float(off)


def matched_terms(target: Measured, rendered: Measured) -> tuple[StripeTerms, StripeTerms]:
    """The frames' stripe fit and their render's, in the frames' fit's chart (:meth:`StripeTerms.of`)."""
    t, r, period = target.stripes, rendered.stripes, target.stripes_period_rows
    mine = StripeTerms(t.exposure_rows, t.on, t.off)
    return mine, StripeTerms.of(r.exposure_rows, r.on, r.off, period, t.exposure_rows)


def corrected(p: Parameters, noise: NoiseFit, target: Measured, rendered: Measured) -> Parameters:
    """One step of indirect inference: move each parameter by what separates the
    frames' statistic from the same statistic of frames rendered with ``p``.

    The estimators' biases (JPEG's, sharpening's, the tone curve's and the
    clip's effect on the edges and on the noise) are then the simulator's,
    and cancel. Shape parameters move by the difference, levels by the
    ratio. The exposure and the levels move in the stripe fit's own terms
    (:class:`StripeTerms`: an exposure of whole periods more, or reflected,
    reads as E₀ or P − E₀ with other levels) and are mapped back, so a
    choice of exposure keeps its branch. The noise moves the photon-transfer line a + b·u so that its
    variance at each anchor level scales by the ratio of the two measured
    there; with one anchor the read noise (in electrons) is kept.
    """
    t, r = target.stripes, rendered.stripes
    mine, theirs = matched_terms(target, rendered)
    period = target.stripes_period_rows
    a, b = p.read_lin**2, p.k_lin
    read_held = False
    scaled = []
    for anchor in noise_anchors(target, p.gamma):
        rate = level_ratio(anchor_variance(target, anchor), anchor_variance(rendered, anchor))
        u = float(linear_level(anchor.level, p.gamma))
        scaled.append((u, rate * (a + b * u)))
    if noise.read_source == FRAMES and len(scaled) == 2 and scaled[1][0] > scaled[0][0]:
        (u0, v0), (u1, v1) = scaled
        b_new = (v1 - v0) / (u1 - u0)
        a_new = v0 - b_new * u0
        if b_new > 0 and a_new <= 0:  # the noise grows in proportion to the level, or faster
            a_new, b_new = shot_noise_line(scaled)
            read_held = True
        elif not (b_new > 0 and a_new > 0):  # a variance that falls with the level: scale both alike
            s = math.sqrt((v0 / (a + b * u0)) * (v1 / (a + b * u1)))
            a_new, b_new = a * s, b * s
    elif scaled and noise.gain_source == FRAMES:
        u1, v1 = scaled[-1]
        read_e = p.read_lin / p.k_lin
        b_new = gain_given_read(u1, v1, read_e)
        a_new = (read_e * b_new) ** 2
    else:
        a_new, b_new = a, b
    # The shape estimators' biases depend on the stripes' level: compared at
    # levels far apart (a colour plane's response to the LED not yet
    # matched), they move the shape the wrong way. The levels move first.
    shape = levels_match(target, rendered)
    now = StripeTerms.of(p.exposure_rows, p.on_lin, p.off_lin, period, mine.exposure_rows)
    moved = dataclasses.replace(
        now, exposure_rows=now.exposure_rows + (mine.exposure_rows - theirs.exposure_rows if shape else 0.0),
        on=now.on * level_ratio(mine.on, theirs.on), off=now.off * level_ratio(mine.off, theirs.off))
    exposure, on, off = moved.exposure_and_levels(period)
    return Parameters(
        exposure_rows=max(0.05, exposure),
        smoothing_rows=max(0.0, p.smoothing_rows + t.smoothing_rows - r.smoothing_rows) if shape else p.smoothing_rows,
        gamma=min(MAX_GAMMA, max(MIN_GAMMA, p.gamma + t.gamma - r.gamma)) if shape else p.gamma,
        on_lin=min(60.0, on),
        off_lin=max(0.0, off),
        k_lin=b_new,
        read_lin=math.sqrt(a_new),
        row_lin=None if p.row_lin is None else p.row_lin * level_ratio(target.row_noise, rendered.row_noise),
        col_lin=None if p.col_lin is None else p.col_lin * level_ratio(target.column_pattern, rendered.column_pattern),
        read_held=read_held,
    )
