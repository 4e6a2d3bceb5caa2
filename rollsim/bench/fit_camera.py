"""``rollsim bench fit-camera``: the camera fit on hidden cameras drawn at random, so that it is never tuned to a case.

From a seed, N hidden cameras are drawn over the ranges researchers' frames
span (:func:`draw_cameras`); each renders square-wave frames, which
:func:`rollsim.fit.fit_camera` fits (base scene ``paper-geometric``, as the
command's default), and the fit is compared with the hidden truth and
rendered beside the frames. A camera whose frames hold no readable square
wave (:func:`readable`: a stripe period under 2.5 binned rows, under four
stripe periods on the LED, or under
:data:`MIN_CONTRAST_8BIT` levels of stripe contrast in a frame rendered
without noise) is listed and not counted.

Targets (the issue's): at least 90 % of the counted cameras fitted; each
fitted camera's row time within 0.5 %, exposure within 10 % (15 % when the
LED saturates), the temporal noise of the LED's rows rendered from the fit
within 20 % of the frames', the row profiles' correlation at least 0.98;
the median fit time at most 30 s.
"""

from __future__ import annotations

import functools
import json
import math
import time
from dataclasses import asdict, dataclass, replace
from typing import Sequence

import numpy as np

from rollsim.plumbing.parallel import process_pool
from rollsim.plumbing.text_tables import format_table

BASE_SCENE = "paper-geometric"
FRAMES = 6
# Stripes below this contrast (8-bit levels, in a noise-free frame) hold no readable square wave.
MIN_CONTRAST_8BIT = 6.0
# The row-time estimator needs 8 edges (decoder.rowtime.MIN_EDGES) in a
# frame, or 6 (FEW_EDGES) in most frames; four periods leave room for the
# disk's ends, where the chords are too short to read.
MIN_PERIODS = 4.0
TARGETS = {"fitted_fraction": 0.90, "row_time": 0.005, "exposure": 0.10, "exposure_saturated": 0.15,
           "temporal_noise": 0.20, "correlation": 0.98, "median_seconds": 30.0}


@dataclass(frozen=True)
class HiddenCamera:
    """One drawn camera and scene (sizes px, times µs, levels in full scales)."""

    index: int
    width_px: int
    height_px: int
    row_time_us: float
    exposure_chips: float
    clock_hz: float
    on_full_scales: float
    led_diameter_px: float
    led_x_px: float
    led_y_px: float
    background_full_scales: float
    binning_rows: int
    jpeg_quality: int | None
    colour: bool
    iso: float
    read_noise_e: float
    srgb: bool
    smoothing_rows: float
    seed: int

    @property
    def exposure_us(self) -> float:
        return self.exposure_chips / self.clock_hz * 1e6

    @property
    def period_rows(self) -> float:
        return 2.0 / (self.clock_hz * self.row_time_us * 1e-6)


def _log_uniform(rng, low: float, high: float) -> float:
    return float(np.exp(rng.uniform(math.log(low), math.log(high))))


def draw_cameras(seed: int, n: int, max_height_px: int = 2160) -> list[HiddenCamera]:
    """``n`` hidden cameras drawn from ``seed`` over the benchmark's ranges.

    Frames of 320×240 to 3840×2160 (4:3 or 16:9), or a crop of 16 to 64
    columns (a quarter of the draws); row time 5–40 µs; exposure 0.2–4
    chips; chip clock 1–20 kHz; the LED's ON level 0.1–30 full scales and
    its diameter 3 % of the frame height to 1.5 frame heights (filling it);
    background 0 (black, a third of the draws) to 0.6 full scale; binning 1
    or 2; no JPEG (half) or quality 60–100; grey or Bayer colour; ISO
    100–3200; read noise 1–5 e⁻; sRGB tone curve or linear; ISP smoothing 0
    (half) or 0.5–1.5 rows. ``max_height_px`` caps the frame height (a
    quick check).
    """
    rng = np.random.default_rng(seed)
    cameras = []
    for index in range(n):
        height = int(round(_log_uniform(rng, 240, max(240, min(2160, max_height_px))) / 2)) * 2
        if rng.random() < 0.25:
            width = int(rng.integers(16, 65))
        else:
            width = int(round(height * (4 / 3 if rng.random() < 0.5 else 16 / 9)))
        diameter = height * _log_uniform(rng, 0.03, 1.5)
        radius = 0.5 * diameter
        x = float(rng.uniform(radius, width - radius)) if diameter < width else 0.5 * width
        y = float(rng.uniform(radius, height - radius)) if diameter < height else 0.5 * height
        cameras.append(HiddenCamera(
            index=index, width_px=width, height_px=height, row_time_us=float(rng.uniform(5.0, 40.0)),
            exposure_chips=float(rng.uniform(0.2, 4.0)), clock_hz=_log_uniform(rng, 1000.0, 20000.0),
            on_full_scales=_log_uniform(rng, 0.1, 30.0), led_diameter_px=float(diameter), led_x_px=x, led_y_px=y,
            background_full_scales=0.0 if rng.random() < 1 / 3 else float(rng.uniform(0.02, 0.6)),
            binning_rows=int(rng.choice([1, 2])),
            jpeg_quality=None if rng.random() < 0.5 else int(rng.integers(60, 101)),
            colour=bool(rng.random() < 0.5), iso=_log_uniform(rng, 100.0, 3200.0),
            read_noise_e=float(rng.uniform(1.0, 5.0)), srgb=bool(rng.random() < 0.5),
            smoothing_rows=0.0 if rng.random() < 0.5 else float(rng.uniform(0.5, 1.5)),
            seed=int(rng.integers(2, 2**31))))
    return cameras


# A phone's recording (--video): H.264 at a phone's bits per pixel (17 Mb/s
# for 1920x1080 at 30 frames/s, so a crop keeps its frame's rate per
# pixel), 4:2:0 (4:4:4 where the frame's width or height is odd), the
# frames one GOP, at rollsim's default encoding (deblocked, no B-frames, as
# a phone's encoder codes).
PHONE_BITRATE_BPS, PHONE_PIXELS, PHONE_FRAME_RATE_HZ = 17_000_000, 1920 * 1080, 30.0
MIN_VIDEO_BITRATE_BPS = 100_000


def video_recording(cam: HiddenCamera, frame_rate_hz: float = PHONE_FRAME_RATE_HZ):
    """How the hidden camera's frames are recorded with ``--video``: a :class:`rollsim.video.VideoSettings`."""
    from rollsim.video.settings import VideoSettings

    chroma = "444" if cam.width_px % 2 or cam.height_px % 2 else "420"
    bits_per_pixel = PHONE_BITRATE_BPS / (PHONE_PIXELS * PHONE_FRAME_RATE_HZ)
    bitrate = max(MIN_VIDEO_BITRATE_BPS, int(round(bits_per_pixel * cam.width_px * cam.height_px * frame_rate_hz)))
    return VideoSettings(container="mkv", bitrate_bps=bitrate, gop_frames=FRAMES, chroma=chroma)


def hidden_scene(cam: HiddenCamera, noise: bool = True, recording=None):
    """The scene that renders a hidden camera's frames: the base scene with its camera and LED
    (without its temporal noise when ``noise`` is False), recorded as ``recording``
    (:class:`rollsim.video.VideoSettings`: ``effects.video_codec``) when given."""
    from rollsim.fit.camera import gain_per_full_scale
    from rollsim.optics import led_image_size_px
    from rollsim.optics.scene_light import ambient_electron_rates, led_electron_rate
    from rollsim.scene import load_scene

    frame_rate = min(30.0, 1.0 / (1.05 * cam.height_px * cam.row_time_us * 1e-6))
    overrides = [
        f"seed={cam.seed}", f"camera.width_px={cam.width_px}", f"camera.height_px={cam.height_px}",
        f"camera.frame_rate_hz={frame_rate}", f"camera.row_time_us={cam.row_time_us}",
        f"camera.exposure_us={min(cam.exposure_us, 0.9e6 / frame_rate)}", f"camera.iso={cam.iso}",
        f"camera.read_noise_e={cam.read_noise_e}", f"camera.binning_rows={cam.binning_rows}",
        "link.pattern=square", f"link.clock_hz={cam.clock_hz}", "led.shape=disk",
        f"led.position_px=[{cam.led_x_px},{cam.led_y_px}]", "environment.ambient_lux=1",
        "camera.output=" + ("rgb8" if cam.colour else "gray8"),
    ]
    if cam.colour:
        overrides.append("effects.bayer.pattern=RGGB")
    if cam.jpeg_quality is not None:
        overrides.append(f"effects.jpeg.quality={cam.jpeg_quality}")
    if cam.srgb:
        overrides.append("effects.tone_curve.curve=srgb")
    if cam.smoothing_rows > 0:
        overrides.append(f"effects.isp_smoothing.sigma_rows_px={cam.smoothing_rows}")
    if not noise:
        overrides += ["effects.shot_noise=false", "effects.read_noise=false"]
    if recording is not None:
        from rollsim.effects.video_codec import params_of

        overrides += [f"effects.video_codec.{key}={value}" for key, value in params_of(recording).items()]
    scene = load_scene(BASE_SCENE, overrides)
    size_mm = scene.led.size_mm * cam.led_diameter_px / led_image_size_px(scene)
    scene = load_scene(BASE_SCENE, [*overrides, f"led.size_mm={size_mm}"])
    full_scale_e = 1.0 / gain_per_full_scale(scene)
    exposure_s = scene.camera.exposure_s
    per_cd = led_electron_rate(scene) / scene.led.luminous_intensity_cd * exposure_s
    background_per_lux = ambient_electron_rates(scene)[0] * exposure_s
    lux = cam.background_full_scales * full_scale_e / background_per_lux if background_per_lux > 0 else 0.0
    return load_scene(BASE_SCENE, [*overrides, f"led.size_mm={size_mm}", f"environment.ambient_lux={lux}",
                                   f"led.luminous_intensity_cd={cam.on_full_scales * full_scale_e / per_cd}"])


def readable(cam: HiddenCamera) -> tuple[bool, str]:
    """Whether the hidden camera's frames hold a readable square wave, and why not.

    The stripe period must span :data:`decoder.binning.MIN_GROUPS_PER_PERIOD`
    binned rows (a shorter one aliases: sampled once a group, it cannot be
    told from a period under two groups, and the row-time estimator
    refuses it), the LED must span :data:`MIN_PERIODS` stripe periods, and the stripes
    must reach :data:`MIN_CONTRAST_8BIT` levels in a frame rendered without
    noise (:func:`stripe_contrast_8bit`): the frames' own contrast, after
    the clip, the ambient light on the LED's face, the colour filters, the
    tone curve, the ISP and JPEG, rather than the LED's level alone.
    """
    from decoder.binning import MIN_GROUPS_PER_PERIOD

    if cam.period_rows < MIN_GROUPS_PER_PERIOD * cam.binning_rows:
        return False, (f"the stripe period spans {cam.period_rows / cam.binning_rows:.2f} binned rows "
                       f"(< {MIN_GROUPS_PER_PERIOD:g}: aliased)")
    led_rows = min(cam.led_diameter_px, cam.height_px)
    if led_rows < MIN_PERIODS * cam.period_rows:
        return False, f"the LED spans {led_rows / cam.period_rows:.1f} stripe periods (< {MIN_PERIODS:g})"
    contrast = stripe_contrast_8bit(cam)
    if contrast < MIN_CONTRAST_8BIT:
        return False, f"stripe contrast {contrast:.1f} of 255 in a noise-free frame (< {MIN_CONTRAST_8BIT:g})"
    return True, ""


def stripe_contrast_8bit(cam: HiddenCamera) -> float:
    """Stripe contrast (8-bit levels) of the hidden camera's LED in a frame rendered without noise.

    The row profile of the LED's core (the central 80 % of its rows, the
    central half of its columns, within the frame), less its mean over one
    stripe period, folded at the period: the fold's range, in the channel
    where it is largest. 0 when the LED's core is out of the frame or holds
    less than a period.
    """
    from decoder.rowtime import folded, without_envelope
    from rollsim.render import render_frames

    images, _ = render_frames(hidden_scene(cam, noise=False), 1)
    frame = np.asarray(images[0], dtype=np.float64)
    frame = frame if frame.ndim == 3 else frame[..., None]
    height, width = frame.shape[:2]
    half_rows, half_cols = 0.4 * cam.led_diameter_px, max(0.5, 0.25 * cam.led_diameter_px)
    rows = slice(max(0, int(cam.led_y_px - half_rows)), min(height, int(cam.led_y_px + half_rows) + 1))
    cols = slice(max(0, int(cam.led_x_px - half_cols)), min(width, int(cam.led_x_px + half_cols) + 1))
    core = frame[rows, cols]
    if core.shape[0] < 2 or core.shape[1] < 1:
        return 0.0
    profile = core.mean(axis=1)  # (rows, channels)
    # Folded at the stripe period: what repeats at other periods (a Bayer
    # mosaic's two rows, JPEG's eight) or not at all (the LED's envelope)
    # averages out.
    bins = int(np.clip(np.floor(cam.period_rows), 2, 32))
    folds = [folded(without_envelope(profile[:, c], cam.period_rows), cam.period_rows, bins)
             for c in range(profile.shape[1])]
    return max((float(np.ptp(f)) for f in folds if f is not None), default=0.0)


def run_camera(cam: HiddenCamera, video: bool = False, known: Sequence[str] = ()) -> dict:
    """Render, fit and compare one hidden camera; its row of the benchmark.

    ``video``: the frames are recorded as a phone's video (:func:`video_recording`),
    and the fit is told the encoding, as a video file's header tells it.
    ``known``: what the fit is told of the camera, as a user who knows it
    tells it (``exposure``, ``tone``, ``binning``; :class:`rollsim.fit.camera.Known`).
    """
    from rollsim.errors import RollsimError
    from rollsim.fit import Known, fit_camera
    from rollsim.fit.tone import NAMED_GAMMAS
    from rollsim.render import render_frames
    from rollsim.scene import load_scene

    ok, why = readable(cam)
    row = {"camera": asdict(cam), "readable": ok, "why_not_readable": why or None}
    recording = video_recording(cam, hidden_scene(cam).camera.frame_rate_hz) if video else None
    scene = hidden_scene(cam, recording=recording)
    images, _ = render_frames(scene, FRAMES)
    frames = [np.asarray(im) for im in images]
    started = time.perf_counter()
    try:
        told = Known(scene.camera.exposure_us if "exposure" in known else None,
                     NAMED_GAMMAS["srgb" if cam.srgb else "linear"] if "tone" in known else None,
                     binning_rows=cam.binning_rows if "binning" in known else None)
        fit = fit_camera(frames, cam.clock_hz, load_scene(BASE_SCENE, []), recording=recording,
                         frame_rate_hz=scene.camera.frame_rate_hz if video else None, known=told)
        seconds = time.perf_counter() - started
        comparison = fit.checked()
    except (ValueError, RollsimError) as exc:  # a refusal (no square wave), or a fault the table shows
        row.update(fitted=False, refusal=str(exc), seconds=time.perf_counter() - started)
        return row
    except Exception as exc:  # noqa: BLE001 - one camera's fault must not end the benchmark; it is shown
        row.update(fitted=False, refusal=f"fault: {type(exc).__name__}: {exc}", seconds=time.perf_counter() - started)
        return row
    again = truth_again(cam, len(frames), recording)
    est = fit.estimates
    noise = comparison.noise.get("temporal_led_bright", (0.0, 0.0))
    row.update(
        fitted=True, refusal=None, seconds=seconds, channel=fit.channel,
        row_time_error=est["row_time_us"].value / cam.row_time_us - 1.0,
        exposure_error=est["exposure_us"].value / scene.camera.exposure_us - 1.0,
        temporal_noise_error=(noise[1] / noise[0] - 1.0) if noise[0] > 0 else None,
        correlation=float(min(comparison.correlations)),
        correlation_ceiling=correlation_ceiling(frames, again, fit),
        truth_noise_error=truth_noise_error(frames, again, fit),
        binning_found=int(est["binning_rows"].value),
        # What the stripes were read as, for the misses' diagnosis.
        fitted_gamma=est["tone_gamma"].value, fitted_smoothing_rows=est["isp_smoothing_rows"].value,
        fitted_on_level=est["on_level"].value,
        not_identified=[name for name, e in est.items() if e.source == "not identified"],
    )
    return row


def truth_again(cam: HiddenCamera, n_frames: int, recording=None) -> list[np.ndarray]:
    """The hidden scene's frames rendered again with other noise (another seed)."""
    from rollsim.render import render_frames

    again, _ = render_frames(hidden_scene(replace(cam, seed=cam.seed + 1), recording=recording), n_frames)
    return [np.asarray(im) for im in again]


def correlation_ceiling(frames: Sequence[np.ndarray], again: Sequence[np.ndarray], fit) -> float:
    """The row-profile correlation the truth itself reaches: the frames against
    ``again`` (:func:`truth_again`), read as the fit's comparison reads them
    (its plane, band and aligned correlation, the least over frames). A fit
    cannot be expected to beat it: the frames' own noise bounds it."""
    from rollsim.fit.check import aligned_correlation

    rows, cols = fit.band
    return float(min(aligned_correlation(a[rows, cols].mean(axis=1), b[rows, cols].mean(axis=1), fit.period_rows)
                     for a, b in zip(fit.grey(frames), fit.grey(again))))


def truth_noise_error(frames: Sequence[np.ndarray], again: Sequence[np.ndarray], fit) -> float | None:
    """The LED's temporal noise of ``again`` (:func:`truth_again`) against the frames', as the fit's
    comparison reads it (:func:`rollsim.fit.check.noise_beside`), less 1: how near the truth comes.
    None where the frames show no such noise."""
    from rollsim.fit.check import noise_beside

    ours, theirs = noise_beside(fit.grey(frames), fit.grey(again), fit)["temporal_led_bright"]
    return theirs / ours - 1.0 if ours > 0 else None


def misses(row: dict) -> list[str]:
    """The targets a fitted camera misses."""
    if not row.get("fitted"):
        return ["refused"]
    cam = row["camera"]
    exposure_limit = TARGETS["exposure_saturated"] if cam["on_full_scales"] > 1 else TARGETS["exposure"]
    out = []
    if abs(row["row_time_error"]) > TARGETS["row_time"]:
        out.append("row time")
    if abs(row["exposure_error"]) > exposure_limit:
        out.append("exposure")
    if row["temporal_noise_error"] is None or abs(row["temporal_noise_error"]) > TARGETS["temporal_noise"]:
        out.append("noise")
    if row["correlation"] < TARGETS["correlation"]:
        out.append("correlation")
    return out


def summarise(rows: Sequence[dict], seed: int, video: bool = False, known: Sequence[str] = ()) -> dict:
    """Counts against each target, and the misses."""
    counted = [r for r in rows if r["readable"]]
    fitted = [r for r in counted if r.get("fitted")]
    times = [r["seconds"] for r in fitted]
    meet = {name: sum(1 for r in fitted if name not in misses(r))
            for name in ("row time", "exposure", "noise", "correlation")}
    return {
        "seed": seed, "video": video, "known": sorted(known), "cameras": len(rows), "counted": len(counted), "fitted": len(fitted),
        "fitted_fraction": len(fitted) / len(counted) if counted else None,
        "within_target": meet, "all_targets": sum(1 for r in fitted if not misses(r)),
        "median_seconds": float(np.median(times)) if times else None,
        "not_readable": [(r["camera"]["index"], r["why_not_readable"]) for r in rows if not r["readable"]],
        "misses": [(r["camera"]["index"], misses(r)) for r in counted if misses(r)],
        # Fitted cameras whose truth, rendered again, misses the correlation target too.
        "correlation_bounded_by_noise": [r["camera"]["index"] for r in fitted
                                         if r["correlation_ceiling"] < TARGETS["correlation"]],
        # Fitted cameras whose truth, rendered again, misses the noise target too.
        "noise_missed_by_truth": [r["camera"]["index"] for r in fitted if r.get("truth_noise_error") is None
                                  or abs(r["truth_noise_error"]) > TARGETS["temporal_noise"]],
        "targets": TARGETS,
    }


def run_bench(seed: int, cameras: int, workers: int = 1, max_height_px: int = 2160, progress=None,
              video: bool = False, known: Sequence[str] = ()) -> dict:
    """Draw, render, fit and compare ``cameras`` hidden cameras; the rows and the summary
    (``video``: recorded as a phone's video; ``known``: what the fit is told; :func:`run_camera`)."""
    drawn = draw_cameras(seed, cameras, max_height_px)
    rows = []
    if workers > 1:
        with process_pool(workers) as pool:
            for row in pool.map(functools.partial(run_camera, video=video, known=tuple(known)), drawn):
                rows.append(row)
                if progress:
                    progress(row)
    else:
        for cam in drawn:
            rows.append(run_camera(cam, video, tuple(known)))
            if progress:
                progress(rows[-1])
    return {"rows": rows, "summary": summarise(rows, seed, video, known)}


def _pct(x) -> str:
    return "" if x is None else f"{100 * x:+.2f} %"


def format_rows(rows: Sequence[dict]) -> str:
    """One line per camera."""
    table = []
    for r in rows:
        c = r["camera"]
        kind = f"{c['width_px']}x{c['height_px']}" + (" rgb" if c["colour"] else "") + (
            f" bin{c['binning_rows']}" if c["binning_rows"] > 1 else "") + (
            f" q{c['jpeg_quality']}" if c["jpeg_quality"] else "")
        scene = f"{c['on_full_scales']:.2g} FS, d {c['led_diameter_px'] / c['height_px']:.2g} H, {c['exposure_chips']:.2f} chips"
        if not r["readable"]:
            table.append((c["index"], kind, scene, f"not counted: {r['why_not_readable']}", "", "", "", "", "", "", ""))
        elif not r.get("fitted"):
            table.append((c["index"], kind, scene, f"refused: {r['refusal']}", "", "", "", "", "", "",
                          f"{r['seconds']:.1f}"))
        else:
            table.append((c["index"], kind, scene, ", ".join(misses(r)) or "all met", _pct(r["row_time_error"]),
                          _pct(r["exposure_error"]), _pct(r["temporal_noise_error"]),
                          _pct(r.get("truth_noise_error")), f"{r['correlation']:.4f}",
                          f"{r['correlation_ceiling']:.4f}", f"{r['seconds']:.1f}"))
    header = ("#", "frames", "LED", "result", "row time", "exposure", "noise", "truth's noise", "corr",
              "truth's corr", "s")
    return format_table(table, header)


def format_summary(s: dict) -> str:
    meet = s["within_target"]
    frac = "n/a" if s["fitted_fraction"] is None else f"{100 * s['fitted_fraction']:.0f} %"
    median = "n/a" if s["median_seconds"] is None else f"{s['median_seconds']:.1f} s"
    recorded = " recorded as H.264 video (a phone's 17 Mb/s at 1080p30, per pixel)" if s.get("video") else ""
    if s.get("known"):
        recorded += f", the fit told each one's {' and '.join(s['known'])}"
    return (f"seed {s['seed']}: {s['cameras']} cameras{recorded}, {s['counted']} with a readable square wave, "
            f"{s['fitted']} fitted ({frac}; target ≥ 90 %); of the fitted: row time within 0.5 % {meet['row time']}, "
            f"exposure within 10 % (15 % saturated) {meet['exposure']}, temporal noise within 20 % {meet['noise']}, "
            f"correlation ≥ 0.98 {meet['correlation']}, all four {s['all_targets']}; median fit time {median} "
            f"(target ≤ 30 s); the truth rendered again misses the correlation target on "
            f"{len(s['correlation_bounded_by_noise'])} of the fitted")


def main(args) -> int:
    import sys

    from rollsim.plumbing.outputs import write_file

    def progress(row):
        if not args.quiet:
            c = row["camera"]
            state = "not readable" if not row["readable"] else ("fitted" if row.get("fitted") else "refused")
            print(f"rollsim: bench fit-camera: camera {c['index']} ({c['width_px']}x{c['height_px']}): {state}",
                  file=sys.stderr, flush=True)

    result = run_bench(args.seed, args.cameras, args.workers, args.max_height, progress, video=args.video,
                       known=sorted(set(args.known)))
    print(format_rows(result["rows"]))
    print(format_summary(result["summary"]))
    if args.json:
        write_file(args.json, json.dumps(result, indent=2, allow_nan=False) + "\n", force=args.force)
    return 0
