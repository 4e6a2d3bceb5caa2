"""Fit a camera to real frames of a square-wave LED, and check the fit by rendering it.

:func:`fit_camera` runs the estimators in the order each needs the last:

1. the row time, from the stripe period (:func:`decoder.estimate_row_time`);
2. the LED's disk (:func:`rollsim.fit.measure.find_led_disk`) and the
   background level;
3. the exposure, the ISP's vertical smoothing, the tone curve's γ and the
   linear ON and OFF levels, from the stripes' shape (:mod:`rollsim.fit.stripes`):
   the exposure is the width of the box that rounds the square wave's edges;
4. the noise, linearised through the fitted tone curve and the smoothing's
   noise gain: the photon-transfer line (variance against level) of the
   temporal noise gives the conversion gain (its slope) and the read noise
   (its intercept); row noise and column pattern from the background;
5. the LED's radial profile, from the brightest frame.

It maps them onto a scene (the base scene's optics and LED geometry kept):
the ISO from the gain, the LED's size and position from the disk, its
intensity from the ON level, the ambient light from the background, and the
ISP effects. :func:`compare` renders the fitted scene and sets its row
profiles and noise beside the frames'.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from rollsim.fit.measure import (
    LedDisk,
    TemporalNoise,
    background_level,
    central_band,
    column_pattern_std,
    disk_mask,
    find_led_disk,
    level_noise_pairs,
    temporal_noise,
)
from rollsim.fit.stripes import StripeFit, fit_stripes
from rollsim.isp import gaussian_kernel
from rollsim.scene.model import Scene
from rollsim.sensor.adc import full_scale_electrons

# Radial profile bins (fractions of the radius) and the least variation worth an effect.
PROFILE_BINS = 8
PROFILE_MIN_VARIATION = 0.05
# Below these the fit leaves the effect out (a smaller figure is the estimator's noise).
MIN_SMOOTHING_ROWS = 0.3
MIN_GAMMA_CHANGE = 0.05
# The LED's halo (blur, glare) reaches this many radii from its centre: the background lies beyond.
HALO_RADII = 1.8
# 8-bit levels this close to 0 or 255 are clipped in part and left out of the noise fit.
CLIP_MARGIN = 8


@dataclass(frozen=True)
class Estimate:
    """One fitted quantity: value, one-sigma uncertainty (None: not known) and unit."""

    value: float
    uncertainty: float | None
    unit: str
    how: str

    def to_json(self) -> dict:
        unc = self.uncertainty if self.uncertainty is not None and math.isfinite(self.uncertainty) else None
        return {"value": self.value, "uncertainty": unc, "unit": self.unit, "how": self.how}


@dataclass
class CameraFit:
    """Everything :func:`fit_camera` estimated, and the scene it makes."""

    estimates: dict
    scene: Scene
    measured: Measured  # the frames' statistics the fit started from
    notes: list = field(default_factory=list)

    @property
    def band(self) -> tuple[slice, slice]:
        """Rows and columns of the LED's central band (the row profiles')."""
        return self.measured.band

    @property
    def background_block(self) -> tuple[slice, slice]:
        """Rows and columns of the background region (the noise's)."""
        return self.measured.block

    def to_json(self) -> dict:
        return {name: e.to_json() for name, e in self.estimates.items()}


# ------------------------------------------------------------------ helpers


def background_block(shape: tuple[int, int], disk: LedDisk, margin_radii: float = HALO_RADII) -> tuple[slice, slice]:
    """The largest rectangle of whole rows or whole columns clear of the LED and its halo."""
    h, w = shape
    top = int(max(0, math.floor(disk.centre_y_px - margin_radii * disk.radius_px)))
    bottom = int(min(h, math.ceil(disk.centre_y_px + margin_radii * disk.radius_px)))
    left = int(max(0, math.floor(disk.centre_x_px - margin_radii * disk.radius_px)))
    right = int(min(w, math.ceil(disk.centre_x_px + margin_radii * disk.radius_px)))
    candidates = [((slice(0, top), slice(0, w)), top * w), ((slice(bottom, h), slice(0, w)), (h - bottom) * w),
                  ((slice(0, h), slice(0, left)), h * left), ((slice(0, h), slice(right, w)), h * (w - right))]
    block, area = max(candidates, key=lambda c: c[1])
    if area < 256:
        raise ValueError("the LED fills the frame: no background to measure the noise on")
    return block


def gain_per_full_scale(scene: Scene) -> float:
    """The camera's gain as a fraction of the ADC range (above black) per electron."""
    cam = scene.camera
    return 1.0 / full_scale_electrons(cam.adc_bits, cam.black_level_dn, cam.gain_dn_per_e_at_iso)


def _slope(level: float | np.ndarray, gamma: float) -> np.ndarray:
    """d(linear fraction)/d(8-bit level) of the tone curve v^(1/γ) at an 8-bit level."""
    v = np.clip(np.asarray(level, dtype=np.float64) / 255.0, 1.0 / 510.0, 1.0)
    return gamma * v ** (gamma - 1.0) / 255.0


def _linear(level, gamma: float):
    return np.clip(np.asarray(level, dtype=np.float64) / 255.0, 0.0, 1.0) ** gamma


def noise_gain(sigma_rows: float) -> float:
    """The variance a white noise keeps through the ISP's vertical Gaussian: Σk²."""
    kernel = gaussian_kernel(sigma_rows).astype(np.float64)
    return float(np.sum(kernel**2))


def bright_rows_noise(levels: np.ndarray, variances: np.ndarray, keep: np.ndarray) -> tuple[float, float]:
    """Temporal noise (8-bit levels) of the brightest quarter of the kept rows, and their mean level.

    ``levels`` and ``variances`` are :func:`rollsim.fit.measure.level_noise_pairs`'s;
    (0, 0) when no row is kept.
    """
    if not keep.any():
        return 0.0, 0.0
    top = keep & (levels >= np.percentile(levels[keep], 75))
    return float(np.sqrt(np.mean(variances[top]))), float(np.mean(levels[top]))


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


def radial_profile(brightest_lin: np.ndarray, disk: LedDisk, on_rows: np.ndarray, off_lin: float) -> list | None:
    """The LED's radial profile (radius / R, relative radiance) from the rows lit in the brightest frame,
    or None when it is flat within :data:`PROFILE_MIN_VARIATION`."""
    yy, xx = np.mgrid[0:brightest_lin.shape[0], 0:brightest_lin.shape[1]]
    r = np.hypot(xx + 0.5 - disk.centre_x_px, yy + 0.5 - disk.centre_y_px) / disk.radius_px
    inside = (r < 0.9) & on_rows[:, None]
    if inside.sum() < 50:
        return None
    edges = np.linspace(0.0, 0.9, PROFILE_BINS + 1)
    index = np.digitize(r[inside], edges) - 1
    values = brightest_lin[inside] - off_lin
    medians = np.array([np.median(values[index == i]) if np.any(index == i) else np.nan for i in range(PROFILE_BINS)])
    if np.any(~np.isfinite(medians)) or medians[0] <= 0:
        return None
    rel = np.clip(medians / medians[0], 0.0, None)
    if np.ptp(rel) < PROFILE_MIN_VARIATION:
        return None
    centres = 0.5 * (edges[:-1] + edges[1:])
    radii = np.concatenate([[0.0], centres, [1.0]])
    values_out = np.concatenate([[rel[0]], rel, [rel[-1]]])
    return [[round(float(a), 4), round(float(b), 4)] for a, b in zip(radii, values_out)]


# --------------------------------------------------------------------- fit


@dataclass(frozen=True)
class Measured:
    """The statistics :func:`measure` takes from a set of frames (the fit's data)."""

    row_time_s: float
    row_time_sd_s: float
    disk: LedDisk
    background: float
    stripes: StripeFit
    band: tuple[slice, slice]
    block: tuple[slice, slice]
    transfer: tuple  # a, b, a_sd, b_sd of the photon-transfer line, linear, before the ISP's smoothing
    background_noise: TemporalNoise
    row_e_per_k: float  # row noise over the gain (linear fraction)
    col_e_per_k: float  # column pattern over the gain
    profile: list | None
    on_noise: float  # temporal noise of the LED's brightest unclipped rows, 8-bit levels
    on_noise_level: float  # their mean 8-bit level


def measure(frames: Sequence[np.ndarray], clock_hz: float, start: StripeFit | None = None) -> Measured:
    """The fit's statistics of a set of frames (see the module docstring, steps 1–5)."""
    from decoder import estimate_row_time

    shape = frames[0].shape
    row_time_s, row_time_sd = estimate_row_time([f.astype(np.uint8) for f in frames], clock_hz)
    period = 2.0 / (clock_hz * row_time_s)
    brightest = np.max(frames, axis=0)
    mean_frame = np.mean(frames, axis=0)
    disk = find_led_disk(brightest, float(np.median(mean_frame)))
    background = background_level(mean_frame, disk_mask(shape, disk, HALO_RADII))
    rows, cols = central_band(disk, shape)
    profiles = [f[rows, cols].mean(axis=1) for f in frames]
    stripes = fit_stripes(profiles, np.arange(rows.start, rows.stop), period, disk.centre_y_px, disk.radius_px,
                          start=start)
    gamma = stripes.gamma
    keep = noise_gain(stripes.smoothing_rows)
    block = background_block(shape, disk)
    bg_noise = temporal_noise(frames, *block)
    levels, variances = level_noise_pairs(frames, rows, cols)
    bg_slope = float(_slope(background, gamma))
    lv = np.concatenate([_linear(levels, gamma), [float(_linear(background, gamma))]])
    var = np.concatenate([variances * _slope(levels, gamma) ** 2, [bg_noise.pixel_std**2 * bg_slope**2]]) / keep
    # Clipped levels (the black clip, a saturated LED) have lost their noise.
    out_levels = np.concatenate([levels, [background]])
    usable = (out_levels > CLIP_MARGIN) & (out_levels < 255 - CLIP_MARGIN) & (lv > 0)
    if usable.sum() < 3:
        raise ValueError("fewer than 3 rows of the LED are neither black nor saturated: no noise to fit")
    transfer = photon_transfer(lv[usable], var[usable])
    on_noise, on_level = bright_rows_noise(levels, variances, usable[:-1])
    row_lin = bg_noise.row_std * bg_slope / math.sqrt(keep)
    col_lin = column_pattern_std(mean_frame, *block, len(frames), bg_noise.pixel_std) * bg_slope
    brightest_lin = _linear(brightest, gamma)
    band_max = brightest[rows, cols].mean(axis=1)
    on_rows = np.zeros(shape[0], dtype=bool)
    on_rows[rows] = band_max >= np.percentile(band_max, 60)
    profile = radial_profile(brightest_lin, disk, on_rows, stripes.off)
    return Measured(row_time_s, row_time_sd, disk, background, stripes, (rows, cols), block, transfer, bg_noise,
                    row_lin, col_lin, profile, on_noise, on_level)


@dataclass(frozen=True)
class Parameters:
    """The scene's fitted parameters, before they become a scene."""

    exposure_rows: float
    smoothing_rows: float
    gamma: float
    k_lin: float  # gain, fraction of the ADC range per electron
    read_lin: float  # read noise, fraction of the ADC range
    row_lin: float
    col_lin: float


def _direct(m: Measured, base: Scene) -> Parameters:
    """Parameters read straight off the statistics (the base scene's gain and
    read noise where the photon-transfer line is unusable: a slope or intercept
    that is not positive)."""
    a, b = m.transfer[:2]
    k_lin = b if b > 0 else gain_per_full_scale(base)
    read_lin = math.sqrt(a) if a > 0 else base.camera.read_noise_e * k_lin
    return Parameters(m.stripes.exposure_rows, m.stripes.smoothing_rows, m.stripes.gamma, k_lin,
                      read_lin, m.row_e_per_k, m.col_e_per_k)


def _corrected(p: Parameters, target: Measured, rendered: Measured) -> Parameters:
    """One step of indirect inference: move each parameter by what separates the
    frames' statistic from the same statistic of frames rendered with ``p``.

    The estimators' biases (JPEG's, sharpening's and the tone curve's effect
    on the edges and on the noise) are then the simulator's, and cancel. The
    noise moves the photon-transfer line a + b·u (read variance a, gain b)
    so that its variance at the background's and the LED's levels u scales
    by the squared ratio of the two temporal noises measured there.
    """
    def ratio(x, y):
        return x / y if y > 0 and x > 0 else 1.0

    u_bg = max(float(_linear(target.background, p.gamma)), 0.0)
    u_on = max(float(_linear(target.on_noise_level, p.gamma)), u_bg + 1e-6)
    a, b = p.read_lin**2, p.k_lin
    r_bg = ratio(target.background_noise.pixel_std, rendered.background_noise.pixel_std) ** 2
    r_on = ratio(target.on_noise, rendered.on_noise) ** 2
    v_bg, v_on = r_bg * (a + b * u_bg), r_on * (a + b * u_on)
    b_new = (v_on - v_bg) / (u_on - u_bg)
    a_new = v_bg - b_new * u_bg
    if not (b_new > 0 and a_new > 0):  # the two levels disagree: scale both alike
        scale = math.sqrt(r_bg * r_on)
        a_new, b_new = a * scale, b * scale
    return Parameters(
        exposure_rows=max(0.05, p.exposure_rows + target.stripes.exposure_rows - rendered.stripes.exposure_rows),
        smoothing_rows=max(0.0, p.smoothing_rows + target.stripes.smoothing_rows - rendered.stripes.smoothing_rows),
        gamma=min(5.0, max(0.3, p.gamma + target.stripes.gamma - rendered.stripes.gamma)),
        k_lin=b_new,
        read_lin=math.sqrt(a_new),
        row_lin=p.row_lin * ratio(target.row_e_per_k, rendered.row_e_per_k),
        col_lin=p.col_lin * ratio(target.col_e_per_k, rendered.col_e_per_k),
    )


def fit_camera(frames: Sequence[np.ndarray], clock_hz: float, base: Scene, iterations: int = 4) -> CameraFit:
    """Fit a camera, its ISP and the LED's image to frames of a square-wave LED.

    The parameters read off the frames' statistics are then refined by
    ``iterations`` rounds of indirect inference: the fitted scene is
    rendered, the same statistics are taken from its frames, and each
    parameter moves by the difference (see :func:`_corrected`).

    Parameters
    ----------
    frames : sequence of ndarray
        At least two 8-bit grey frames (H, W) of one camera, consecutive, of
        an LED sending ON and OFF chips alternately at ``clock_hz``.
    clock_hz : float
        The chip rate, Hz.
    base : Scene
        The scene whose optics, LED geometry and distance the fit keeps.
    iterations : int
        Rounds of refinement by rendering (0: the direct estimates).

    Returns
    -------
    CameraFit
    """
    from rollsim.render import render_frames

    frames = [np.asarray(f, dtype=np.float64) for f in frames]
    if len(frames) < 2:
        raise ValueError("fit-camera needs at least two frames (the temporal noise comes from frame pairs)")
    shape = frames[0].shape
    if any(f.shape != shape for f in frames) or len(shape) != 2:
        raise ValueError("the frames must all be grey images of one size")
    target = measure(frames, clock_hz)
    params = _direct(target, base)
    notes: list[str] = []
    scene = fitted_scene(base, shape, clock_hz, target, params, notes)
    for _ in range(iterations):
        images, _ = render_frames(scene, len(frames))
        rendered = measure([np.asarray(im, dtype=np.float64) for im in images], clock_hz, start=target.stripes)
        params = _corrected(params, target, rendered)
        notes = []  # the notes of the last scene only
        scene = fitted_scene(base, shape, clock_hz, target, params, notes)
    return CameraFit(_estimates(target, params, scene), scene, target, notes)


def _estimates(m: Measured, p: Parameters, scene: Scene) -> dict:
    cam = scene.camera
    b, b_sd = m.transfer[1], m.transfer[3]
    rel_b = b_sd / b if b > 0 else None
    t_row_us = m.row_time_s * 1e6
    return {
        "row_time_us": Estimate(t_row_us, m.row_time_sd_s * 1e6, "us", "stripe period of the square wave"),
        "exposure_us": Estimate(cam.exposure_us, m.stripes.uncertainties.get("exposure_rows", math.nan) * t_row_us,
                                "us", "width of the box that rounds the stripes' edges, refined by rendering"),
        "isp_smoothing_rows": Estimate(p.smoothing_rows, m.stripes.uncertainties.get("smoothing_rows"), "rows",
                                       "sigma of the ISP's vertical Gaussian, from the edges' shape"),
        "tone_gamma": Estimate(p.gamma, m.stripes.uncertainties.get("gamma"), "",
                               "gamma of the tone curve v^(1/gamma), from the edges' shape"),
        "gain_dn_per_e": Estimate(cam.gain_dn_per_e_at_iso, None if rel_b is None else rel_b * cam.gain_dn_per_e_at_iso,
                                  "DN/e", "slope of the photon-transfer line, refined by rendering"),
        "iso": Estimate(cam.iso, None if rel_b is None else rel_b * cam.iso, "", "the gain over the preset's"),
        "read_noise_e": Estimate(cam.read_noise_e, None, "e-", "intercept of the photon-transfer line"),
        "row_noise_e": Estimate(p.row_lin / p.k_lin, None, "e-", "row means of background frame differences"),
        "column_fpn_e": Estimate(p.col_lin / p.k_lin, None, "e-", "column means of the background's mean frame"),
        "background_level": Estimate(m.background, None, "8-bit", "median of the mean frame outside the LED"),
        "temporal_noise_background": Estimate(m.background_noise.pixel_std, None, "8-bit",
                                              "consecutive frame differences over sqrt 2, background"),
        "led_centre_x_px": Estimate(m.disk.centre_x_px, None, "px", "median chord midpoint"),
        "led_centre_y_px": Estimate(m.disk.centre_y_px, None, "px", "circle fitted to the chords"),
        "led_diameter_px": Estimate(2 * m.disk.radius_px, None, "px", "circle fitted to the chords"),
        "on_level": Estimate(m.stripes.on, None, "fraction of the ADC range", "stripe fit, linear"),
        "off_level": Estimate(m.stripes.off, None, "fraction of the ADC range", "stripe fit, linear"),
        "profile_rms_residual": Estimate(m.stripes.rms_residual, None, "8-bit", "stripe fit's residual"),
    }


def fitted_scene(base: Scene, shape, clock_hz: float, m: Measured, p: Parameters, notes: list) -> Scene:
    """The base scene with the fitted camera, ISP, LED image and ambient light."""
    from rollsim.optics import led_image_size_px
    from rollsim.optics.scene_light import ambient_electron_rates
    from rollsim.render.tuning import on_level_electrons
    from rollsim.scene import scene_from_dict

    data = base.model_dump(mode="json", exclude_none=True)
    camera = data["camera"]
    camera.pop("ifg_ratio", None)
    row_time_s, disk, stripes, background = m.row_time_s, m.disk, m.stripes, m.background
    gamma = p.gamma if abs(p.gamma - 1.0) >= MIN_GAMMA_CHANGE else 1.0
    smoothing = p.smoothing_rows if p.smoothing_rows >= MIN_SMOOTHING_ROWS else 0.0
    iso = base.camera.iso * p.k_lin / gain_per_full_scale(base)  # the gain is proportional to the ISO
    read_e, row_e, col_e, profile = p.read_lin / p.k_lin, p.row_lin / p.k_lin, p.col_lin / p.k_lin, m.profile
    frame_period_s = 1.0 / camera["frame_rate_hz"]
    exposure_us = min(p.exposure_rows * row_time_s, frame_period_s - shape[0] * row_time_s) * 1e6
    if exposure_us < p.exposure_rows * row_time_s * 1e6:
        notes.append("the exposure is cut to what the base scene's frame rate leaves")
    camera.update(width_px=shape[1], height_px=shape[0], row_time_us=row_time_s * 1e6,
                  exposure_us=max(exposure_us, 1e-3), iso=min(max(iso, 1.0), 1e7), read_noise_e=min(read_e, 1e4),
                  output="gray8")
    data["link"].update(clock_hz=clock_hz, pattern="square")
    effects = {name: value for name, value in data.get("effects", {}).items()
               if name not in ("tone_curve", "isp_smoothing", "row_noise", "column_fpn", "led_profile", "sharpening",
                               "jpeg", "glare")}
    effects.update(ambient={}, shot_noise={"method": "poisson"}, read_noise={"method": "table"})
    if gamma != 1.0:
        effects["tone_curve"] = {"curve": "gamma", "gamma": round(gamma, 4)}
    if smoothing > 0:
        effects["isp_smoothing"] = {"sigma_rows_px": round(smoothing, 4)}
    if row_e > 0.05 * read_e:
        effects["row_noise"] = {"std_e": round(row_e, 4)}
    if col_e > 0.05 * read_e:
        effects["column_fpn"] = {"std_e": round(col_e, 4)}
    if profile is not None:
        effects["led_profile"] = {"profile": "table", "radial_table": profile}
    data["effects"] = effects
    data["led"]["position_px"] = [disk.centre_x_px, disk.centre_y_px]
    data["led"]["shape"] = "disk"
    sized = scene_from_dict(data, "fitted scene")
    data["led"]["size_mm"] = sized.led.size_mm * (2 * disk.radius_px) / led_image_size_px(sized)

    # Ambient light from the background's linear level; the LED from its ON level.
    sized = scene_from_dict(data, "fitted scene")
    cam = sized.camera
    k_lin = gain_per_full_scale(sized)
    bg_rate, _ = ambient_electron_rates(sized)
    wanted_bg_e = float(_linear(background, gamma)) / k_lin
    if bg_rate > 0:
        data["environment"]["ambient_lux"] = sized.environment.ambient_lux * wanted_bg_e / (bg_rate * cam.exposure_s)
    sized = scene_from_dict(data, "fitted scene")
    # The linear ON level over the LED's centre rows; the intensity is linear in it.
    on_e = stripes.on * (1.0 + stripes.envelope[1] / 3.0) / k_lin  # the envelope's mean over the disk's rows
    led_e = on_level_electrons(sized) - (ambient_electron_rates(sized)[1] * cam.exposure_s)
    face_e = on_level_electrons(sized) - led_e
    if led_e > 0 and on_e > face_e:
        data["led"]["luminous_intensity_cd"] = sized.led.luminous_intensity_cd * (on_e - face_e) / led_e
    else:
        notes.append("the LED's ON level does not clear the ambient light on its face: intensity kept")
    return scene_from_dict(data, "fitted scene")


# ----------------------------------------------------------------- compare


def aligned_correlation(a: np.ndarray, b: np.ndarray, period_rows: float, step: float = 0.1) -> float:
    """Pearson correlation of two row profiles, ``b`` shifted by the best fraction of a
    stripe period in [−P/2, P/2] (a free-running camera's stripes sit at any phase).

    The ends, P/2 rows each, are left out so that every shift compares the same rows.
    """
    margin = int(math.ceil(period_rows / 2)) + 1
    if a.size <= 2 * margin + 2:
        raise ValueError("the row profiles are shorter than a stripe period")
    rows = np.arange(a.size, dtype=np.float64)
    inner = rows[margin:-margin]
    best = -1.0
    for shift in np.arange(-period_rows / 2, period_rows / 2 + step, step):
        moved = np.interp(inner + shift, rows, b)
        r = float(np.corrcoef(a[margin:-margin], moved)[0, 1])
        best = max(best, r)
    return best


@dataclass(frozen=True)
class Comparison:
    """The frames beside frames rendered from the fit."""

    correlations: tuple  # per frame pair, aligned Pearson r of the row profiles
    noise: dict  # name -> (frames, rendered), 8-bit levels
    profile_pair: tuple  # (frames' first profile, rendered first profile), for the report's plot


def output_noise(frames: Sequence[np.ndarray], fit: CameraFit) -> dict:
    """The temporal and fixed-pattern noise of frames in the fit's regions, 8-bit levels."""
    bg = temporal_noise(frames, *fit.background_block)
    levels, variances = level_noise_pairs(frames, *fit.band)
    bright_noise, _ = bright_rows_noise(levels, variances, np.ones(levels.size, dtype=bool))
    mean_frame = np.mean(frames, axis=0)
    block_rows, block_cols = fit.background_block
    return {
        "temporal_background": bg.pixel_std,
        "temporal_led_on": bright_noise,
        "row_temporal_background": bg.row_std,
        "column_pattern_background": column_pattern_std(mean_frame, block_rows, block_cols, len(frames),
                                                        bg.pixel_std),
    }


def compare(frames: Sequence[np.ndarray], fit: CameraFit) -> Comparison:
    """Render the fitted scene (as many frames) and set it beside the frames."""
    from rollsim.render import render_frames

    frames = [np.asarray(f, dtype=np.float64) for f in frames]
    images, _ = render_frames(fit.scene, len(frames))
    rendered = [np.asarray(im, dtype=np.float64) for im in images]
    rows, cols = fit.band
    period = 2.0 / (fit.scene.link.clock_hz * fit.scene.camera.row_time_s)
    real = [f[rows, cols].mean(axis=1) for f in frames]
    sim = [f[rows, cols].mean(axis=1) for f in rendered]
    correlations = tuple(aligned_correlation(a, b, period) for a, b in zip(real, sim))
    ours, theirs = output_noise(frames, fit), output_noise(rendered, fit)
    return Comparison(correlations, {k: (ours[k], theirs[k]) for k in ours}, (real[0], sim[0]))
