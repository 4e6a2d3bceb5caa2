"""Fit a camera to real frames of a square-wave LED: what the frames hold, and the rest from the base scene.

:func:`fit_camera` measures the frames (:func:`rollsim.fit.camera.measure`),
reads the parameters off the statistics, makes the scene
(:func:`rollsim.fit.fitted_scene.fitted_scene`) and refines it by
rendering: the same statistics of rendered frames, in the same rows and
columns, move each parameter by the difference (indirect inference). Every
estimate says whether it came from the frames, from the base scene, or was
not identified (and why).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np

from rollsim.errors import SceneError
from rollsim.fit.binned_trial import TRIAL_BELOW, TRIAL_ROWS, found_in_pairs, paired_kept, trial_due
from rollsim.fit.binning import detect_binning
from rollsim.fit.channel import plane_shortlist
from rollsim.fit.compression import jpeg_quality
from rollsim.fit.camera import BASE, FRAMES, GIVEN, HELD_AS_GIVEN, NOT_IDENTIFIED, Estimate, ExposureChoice, Known, \
    Measured, NoiseFit, Parameters, anchor_variance, branches_by_refined_levels, corrected, direct, \
    exposure_alternatives_rows, exposure_choices, given_exposure_choice, level_ratio, levels_match, matched_terms, \
    measure, noise_anchors
from rollsim.fit.fitted_scene import fitted_scene, led_geometry
from rollsim.fit.noise import BOUND_FRACTION
from rollsim.scene.model import Scene

if TYPE_CHECKING:  # the check renders fits, and imports this module
    from rollsim.fit.check import Comparison


# Rounds of matching the noise alone once the best round is kept (each
# renders and measures once more; the first that does not bring the noise
# nearer ends them).
NOISE_ROUNDS = 2
# Exposures the stripes allow (the likeliest by their OFF level first) that
# are rendered to choose among, and how much nearer the frames another's
# render must lie to replace the first: a factor in :func:`mismatch` and a
# difference. One scene rendered with five seeds gives mismatches 0.003–0.04
# apart (paper-geometric cameras of `rollsim bench fit-camera`), and
# exposures the stripes cannot tell apart differ by as little.
EXPOSURE_RENDERS = 3
RENDERED_MARGIN = 4.0
RENDERED_GAIN = 0.1

# An exposure the user gives is noted where it lies further than this from
# every exposure the stripes' edges allow, rows (the stripe fit trades its
# exposure against the smoothing by about a row).
GIVEN_EXPOSURE_ROWS = 2.0
# How far (in sigmas of the plane's stripe fit) the most precise plane's fit,
# rendered, must miss the other plane's exposure before that plane's fit
# can replace it (:func:`plane_kept`).
PLANE_SIGMAS = 3.0
# The most rows a binned group holds, as a scene's camera.binning_rows
# (rollsim.scene_sections.model).
MAX_BINNING_ROWS = 8
# A stripe swing under this (8-bit levels: half a level) shows no stripes in
# 8-bit frames (:func:`mismatch`).
MIN_SWING_DN = 0.5


@dataclass
class CameraFit:
    """Everything :func:`fit_camera` estimated, and the scene it makes."""

    estimates: dict
    scene: Scene
    measured: Measured  # the frames' statistics the fit started from
    notes: list = field(default_factory=list)
    channel: str = "grey"  # what of the frames was fitted: grey, or a colour frame's plane (red, green, blue)
    mismatch: float = math.nan  # how far the fitted scene's render lies from the frames (:func:`mismatch`)
    # The fit rendered and set beside the frames it was fitted to
    # (:func:`rollsim.fit.check.compare`), where fit_camera made it.
    comparison: Comparison | None = None

    def checked(self) -> Comparison:
        """:attr:`comparison`, which :func:`fit_camera` sets; a ValueError for a fit made otherwise."""
        if self.comparison is None:
            raise ValueError("this fit was not checked against its frames: use rollsim.fit.compare")
        return self.comparison

    def grey(self, frames: Sequence[np.ndarray]) -> list[np.ndarray]:
        """``frames`` as the fit saw them (the chosen plane of colour frames), float64."""
        return as_fitted(frames, self.channel)

    @property
    def band(self) -> tuple[slice, slice]:
        """Rows and columns of the LED's central band (the row profiles')."""
        return self.measured.region.band

    @property
    def period_rows(self) -> float:
        """The fitted scene's stripe period, rows: 2 / (clock · row time)."""
        return 2.0 / (self.scene.link.clock_hz * self.scene.camera.row_time_s)

    @property
    def background_block(self) -> tuple[slice, slice] | None:
        """Rows and columns of the background region (None: the LED fills the frame)."""
        return self.measured.region.block

    def to_json(self) -> dict:
        return {name: e.to_json() for name, e in self.estimates.items()}


def fit_camera(frames: Sequence[np.ndarray], clock_hz: float, base: Scene, iterations: int = 4,
               progress: Callable[[str], None] | None = None, recording=None,
               frame_rate_hz: float | None = None, known: Known | None = None) -> CameraFit:
    """Fit a camera, its ISP and the LED's image to frames of a square-wave LED.

    The parameters read off the frames' statistics are then refined by
    ``iterations`` rounds of indirect inference: the fitted scene is
    rendered, the same statistics are taken from its frames (in the same
    rows and columns), and each parameter moves by the difference (see
    :func:`corrected`).

    Parameters
    ----------
    frames : sequence of ndarray
        At least two 8-bit frames of one camera, consecutive, grey (H, W) or
        RGB (H, W, 3), of an LED sending ON and OFF chips alternately at
        ``clock_hz``. Colour frames are fitted in each readable plane of
        :func:`rollsim.fit.channel.plane_shortlist` (:func:`measured_planes`),
        and the fit whose render lies nearer the other plane's stripes is
        kept (:func:`plane_kept`); the fit says which plane, and why.
    clock_hz : float
        The chip rate, Hz.
    base : Scene
        The scene whose optics, LED geometry and distance the fit keeps, and
        whose values stand in for what the frames do not show.
    iterations : int
        Rounds of refinement by rendering (0: the direct estimates); the
        kept round's noise is then matched alone (:data:`NOISE_ROUNDS`).
    progress : callable, optional
        Called with a line at each stage.
    recording : VideoSettings, optional
        The frames come from a video so encoded
        (:func:`rollsim.video.read.recording_settings`): the fitted scene
        renders through the same codec (``video_codec``), so the codec's
        loss of noise and detail is the simulator's too, and cancels.
    frame_rate_hz : float, optional
        The frames' rate (a video's); default the base scene's.
    known : Known, optional
        What the user knows of the camera (the exposure, the tone curve, the binning):
        held, not fitted, and its source ``given``.

    Returns
    -------
    CameraFit
        With its :attr:`CameraFit.comparison` (rendered and set beside the
        frames). Where the binning was neither told nor found and the
        render's row profiles correlate under 0.98 with the frames', the
        frames are fitted again in pairs of rows, and that fit is returned
        where it matches them clearly better
        (:mod:`rollsim.fit.binned_trial`).

    Raises
    ------
    ValueError
        Fewer than two frames, frames of different sizes, a binning given
        that does not divide their height, or no square wave to read
        (:class:`decoder.RowTimeError`, a ValueError).
    """
    from decoder import estimate_row_time

    say = progress or (lambda line: None)
    known = known or Known()
    frames = [np.asarray(f) for f in frames]
    if len(frames) < 2:
        raise ValueError("fit-camera needs at least two frames (the temporal noise comes from frame pairs)")
    shape = frames[0].shape
    if any(f.shape != shape for f in frames) or not (len(shape) == 2 or (len(shape) == 3 and shape[2] == 3)):
        raise ValueError("the frames must all be grey or all RGB images of one size")
    if known.binning_rows is not None and not (1 <= known.binning_rows <= MAX_BINNING_ROWS
                                               and shape[0] % known.binning_rows == 0):
        raise ValueError(f"binning_rows = {known.binning_rows}: must be 1 to {MAX_BINNING_ROWS} and divide "
                         f"the frames' height, {shape[0]} rows")
    # The cheap check first: without a square wave nothing is fitted.
    eight_bit = [np.clip(np.rint(f), 0, 255).astype(np.uint8) for f in frames]
    row_time = estimate_row_time(eight_bit, clock_hz)
    stripes_at = moving_stripes(eight_bit)
    del eight_bit
    colour = len(shape) == 3
    shape = shape[:2]
    say(f"row time {row_time[0] * 1e6:.4f} us from {len(frames)} frames of {shape[1]}x{shape[0]} px "
        + ("(colour); fitting the stripes and the noise in each colour plane" if colour
           else "(grey); fitting the stripes and the noise"))
    # A video's codec is told by its file; stills saved as JPEG show their quality.
    jpeg = jpeg_quality(frames) if recording is None else None
    if jpeg is not None:
        say(f"the frames were saved as JPEG of quality {jpeg}: the fit renders through it")
    setting = Refinement(base, shape, clock_hz, len(frames), iterations, say,
                         {"recording": recording, "frame_rate_hz": frame_rate_hz, "jpeg_quality": jpeg}, known)

    def fitted_with(told: Known, binning: tuple[int, int]) -> CameraFit:
        """The fit with ``binning`` (rows, offset), ``told`` what the user (or the trial) holds."""
        def measured(planes: list[np.ndarray]) -> Measured:
            return measure(planes, clock_hz, row_time=row_time, stripes_at=stripes_at, binning=binning,
                           tone_gamma=told.tone_gamma, binning_known=told.binning_rows is not None)
        if colour:
            candidates = measured_planes(plane_shortlist(frames, 2.0 / (clock_hz * row_time[0])), measured)
        else:
            grey = as_fitted(frames, "grey")
            candidates = [("grey", grey, measured(grey))]
        return with_check(frames, planes_fitted(dataclasses.replace(setting, known=told), candidates))

    # Binned rows are seen on the luminance of colour frames: JPEG's chroma
    # is subsampled over pairs of rows (rollsim.fit.binning).
    fit = fitted_with(known, given_binning(known) or detect_binning(as_fitted(frames, "luminance" if colour
                                                                                else "grey")))
    return binning_tried(fit, say,
                         lambda: fitted_with(dataclasses.replace(known, binning_rows=TRIAL_ROWS), (TRIAL_ROWS, 0)))


def planes_fitted(setting: Refinement, candidates: Sequence[tuple[str, list, Measured]]) -> CameraFit:
    """The fit of each plane's statistics (``candidates``: channel, planes, statistics;
    the most precise first), the one :func:`plane_kept` keeps."""
    fits = [refined(setting, candidates[0][0], candidates[0][2])]
    for channel, _, target in candidates[1:]:
        try:
            fits.append(refined(setting, channel, target))
        except (ValueError, SceneError) as exc:  # the most precise plane's fit stands alone
            setting.say(f"no fit in {channel}: {exc}")
    if len(fits) == 1:
        return fits[0]
    kept, why = plane_kept(fits, setting.n_frames)
    setting.say(f"kept the fit in {fits[kept].channel} (of {' and '.join(fit.channel for fit in fits)}): {why}")
    fits[kept].notes.append(f"Fitted in the {fits[kept].channel} plane, of the fits in "
                            f"{' and '.join(fit.channel for fit in fits)}: {why}.")
    return fits[kept]


def with_check(frames: Sequence[np.ndarray], fit: CameraFit) -> CameraFit:
    """``fit`` with its :attr:`CameraFit.comparison`: rendered and set beside ``frames``."""
    from rollsim.fit.check import compare  # the check renders fits: it imports this module

    fit.comparison = compare(frames, fit)
    return fit


def binning_tried(fit: CameraFit, say: Callable[[str], None],
                  fit_in_pairs: Callable[[], CameraFit]) -> CameraFit:
    """``fit``, or the frames' fit in pairs of rows (``fit_in_pairs``) where that matches
    them clearly better (:mod:`rollsim.fit.binned_trial`)."""
    correlation = min(fit.checked().correlations)
    if not trial_due(fit.measured.paired_residual_ratio, fit.scene.camera.binning_rows,
                     fit.scene.camera.height_px, correlation):
        return fit
    say(f"the fit's render correlates {correlation:.4f} with the frames' row profiles (< {TRIAL_BELOW:g}): "
        "fitting them again in pairs of rows, as a binned readout reads them")
    try:
        paired = fit_in_pairs()
    except (ValueError, SceneError) as exc:
        say(f"no fit in pairs of rows: {exc}")
        return fit
    kept, why = paired_kept((correlation, fit.mismatch), (min(paired.checked().correlations), paired.mismatch))
    say(why)
    if not kept:
        fit.notes.append(f"Tried: {why}; the fit in rows is kept.")
        return fit
    paired.estimates["binning_rows"] = found_in_pairs(TRIAL_ROWS, why)
    paired.notes.append(f"Binned readout found by a second fit: {why}.")
    return paired


def plane_kept(fits: Sequence[CameraFit], n_frames: int) -> tuple[int, str]:
    """Which of two colour planes' fits to keep (0: the first, the most precise), and why.

    Each plane's stripe fit can be precise and wrong: a red plane sampled on
    every other row does not tell 1.5 rows of exposure from 3, and a render
    of either matches it there. The exposure is one for every plane, so each
    fit's scene is rendered and read in the other plane (where the frames'
    statistics are the other fit's ``measured``), and the second fit replaces the
    first where its render lies nearer the first plane's exposure than the
    first's lies to the second plane's, and the first's misses by more than
    :data:`PLANE_SIGMAS` sigmas of the second plane's stripe fit; where both
    renders lie within those sigmas, the other planes do not tell the fits
    apart, and the fit whose render lies nearer the frames in its own plane
    (:attr:`CameraFit.mismatch`) is kept. The stripes' shape
    tells the exposure only within a stripe period, so fits an exposure
    half a period or more apart (whole periods, chosen by the levels) are
    not compared, nor are renders whose ON level in the other plane is not
    the frames' within :data:`rollsim.fit.camera.LEVEL_MATCH` (the
    estimators' biases depend on the level).
    """
    first, second = fits
    rows_apart = abs(first.scene.camera.exposure_s - second.scene.camera.exposure_s) / first.scene.camera.row_time_s
    if rows_apart >= first.period_rows / 2:
        return 0, (f"the fits' exposures lie {rows_apart / first.period_rows:.2f} stripe periods apart, "
                   f"which the stripes' shape does not tell; the {first.channel} plane's is the more precise")
    first_across = exposure_mismatch_in(first.scene, n_frames, second.channel, second.measured)
    second_across = exposure_mismatch_in(second.scene, n_frames, first.channel, first.measured)
    if first_across is None or second_across is None:
        return 0, (f"a render's levels in the other plane are not the frames'; the {first.channel} plane's "
                   "exposure is the more precise")
    # A render's exposure, read in a plane, differs from the frames' by both
    # readings' errors: the other plane's stripe fit's sigma, twice over.
    other = second.measured.stripes
    sd = exposure_precision(second.measured) * other.exposure_rows / max(1.0, other.exposure_rows)
    noise = 2.0 * (PLANE_SIGMAS * sd) ** 2
    if max(first_across, second_across) <= noise and second.mismatch < first.mismatch:
        # Each fit's render holds the other plane's stripes: read in the other
        # plane, the frames do not tell the two apart; in its own, the fit
        # whose render lies nearer the frames is the better.
        return 1, (f"rendered and read in the other plane, each fit's exposure is within {PLANE_SIGMAS:g} sigmas "
                   f"(mismatch {first_across:.3g} and {second_across:.3g}); in its own plane, the {second.channel} "
                   f"fit's render lies nearer the frames (mismatch {second.mismatch:.3g} against "
                   f"{first.mismatch:.3g})")
    if not first_across > max(noise, second_across):
        return 0, (f"rendered and read in the other plane, its exposure is within {PLANE_SIGMAS:g} sigmas or the "
                   f"nearer (mismatch {first_across:.3g} against {second_across:.3g} for the {second.channel} "
                   f"plane's fit); the {first.channel} plane's exposure is the more precise")
    return 1, (f"rendered and read in the other plane, its exposure is the nearer, and the {first.channel} plane's "
               f"fit misses it by more than {PLANE_SIGMAS:g} sigmas (mismatch {second_across:.3g} against "
               f"{first_across:.3g})")


@dataclass(frozen=True)
class Refinement:
    """What every plane's refinement shares: the base scene, the frames' shape (rows, columns),
    the chip rate (Hz), the number of frames, the rounds, the progress callback, how the
    frames were encoded (:func:`rollsim.fit.fitted_scene.fitted_scene`'s ``recording``,
    ``frame_rate_hz`` and ``jpeg_quality``) and what the user told of the camera."""

    base: Scene
    shape: tuple
    clock_hz: float
    n_frames: int
    iterations: int
    say: Callable[[str], None]
    encoding: dict
    known: Known = Known()


def refined(setting: Refinement, channel: str, target: Measured) -> CameraFit:
    """The fit of the frames' statistics ``target`` (in ``channel``), refined by rendering
    (:func:`fit_camera`'s rounds)."""
    say = setting.say
    say(f"exposure {target.stripes.exposure_rows:.2f} rows (direct, {channel}); "
        f"refining by rendering, {setting.iterations} rounds")
    direct_params, noise = direct(target, setting.base)

    def rendered_trial(p: Parameters) -> tuple:
        """(mismatch, parameters, scene, notes, the rendered frames' statistics) of ``p``."""
        trial_notes: list[str] = []
        trial_scene = fitted_scene(setting.base, setting.shape, setting.clock_hz, target, p, trial_notes,
                                   plane=channel, **setting.encoding)
        trial_rendered = measure_rendered(trial_scene, setting.n_frames, channel, target)
        return mismatch(target, trial_rendered, p.gamma), p, trial_scene, trial_notes, trial_rendered

    held = given_exposure(setting.known, target)  # the exposure given, rows, or None
    given_notes: list[str] = []
    if held is not None:
        choice, apart_rows = given_exposure_choice(target, held)
        choices, kept = [choice], 0
        trials = [rendered_trial(with_exposure(direct_params, choice))]
        say(f"exposure {held:.2f} rows, as given; held")
        if apart_rows > GIVEN_EXPOSURE_ROWS:
            given_notes.append(
                f"The exposure given, {held * target.row_time_s * 1e6:.1f} us ({held:.2f} rows), lies "
                f"{apart_rows:.1f} rows from the nearest the stripes' edges allow: the frames read another "
                "exposure (or a smoothing that widens the edges); it is held as given.")
    else:
        choices = exposure_choices(target, setting.base)
        trials = [rendered_trial(with_exposure(direct_params, c)) for c in choices[:EXPOSURE_RENDERS]]
        kept = rendered_choice([t[0] for t in trials])
        choices = [choices[kept]] + choices[:kept] + choices[kept + 1:]
        say(f"exposure {choices[0].exposure_rows:.2f} rows" + (f", of the {len(trials)} the stripes allow rendered"
                                                                if len(trials) > 1 else ", the one the stripes allow"))

    def rounds(best: tuple, count: int) -> tuple:
        """The best of ``best`` (a :func:`rendered_trial`) and ``count`` rounds refined from it."""
        score, params, scene, notes, rendered = best
        for k in range(count):
            params = corrected(params, noise, target, rendered)
            if held is not None:
                params = dataclasses.replace(params, exposure_rows=held)
            score, params, scene, notes, rendered = rendered_trial(params)
            say(f"round {k + 1} of {count}: exposure {scene.camera.exposure_us:.1f} us, "
                f"ISO {scene.camera.iso:.0f} (mismatch {score:.3g})")
            if score < best[0]:
                best = score, params, scene, notes, rendered
        return best

    best = rounds(trials[kept], setting.iterations)
    # Where the renders chose (a clear margin), they decided; else the refined
    # levels may place the face's light in another branch.
    branches = branches_by_refined_levels(best[1], target, setting.base) if kept == 0 and held is None else None
    if branches is not None:
        # The levels propose, a render confirms: that branch is refined in
        # turn, half the rounds first, and kept only where its render lies
        # nearer the frames by RENDERED_MARGIN. The branches make the same
        # stripes where nothing clips and the pipeline is linear, and their
        # refined renders then differ by their noise; the levels, refined,
        # still err by a fraction of a period's step.
        say(f"the refined levels put the OFF level nearest the face's light at {branches[0].exposure_rows:.2f} rows; "
            "refining from there")
        half = (setting.iterations + 1) // 2
        other = rounds(rendered_trial(with_exposure(best[1], branches[0])), half)
        moved = RENDERED_MARGIN * other[0] < best[0]
        say(f"mismatch {other[0]:.3g} there, {best[0]:.3g} before: " + ("moved" if moved else "kept"))
        if moved:
            best, choices = rounds(other, setting.iterations - half), branches
    _, params, scene, notes, rendered = best
    # The rounds move every parameter at once, and the round kept is the best
    # in all; its noise is then matched alone: the gain and read noise move,
    # the linear levels stay (the scene's LED and ambient light follow the gain).
    for _ in range(NOISE_ROUNDS):
        trial = dataclasses.replace(params, **{name: getattr(corrected(params, noise, target, rendered), name)
                                               for name in ("k_lin", "read_lin", "read_held")})
        _, trial, trial_scene, trial_notes, trial_rendered = rendered_trial(trial)
        if noise_mismatch(target, trial_rendered, trial.gamma) >= noise_mismatch(target, rendered, params.gamma):
            break
        params, scene, notes, rendered = trial, trial_scene, trial_notes, trial_rendered
        say(f"noise matched: ISO {scene.camera.iso:.0f}")
    return CameraFit(estimates(target, params, noise, scene, setting.base, choices, setting.known), scene, target,
                     notes + given_notes, channel, mismatch(target, rendered, params.gamma))


def given_binning(known: Known) -> tuple[int, int] | None:
    """The binning the user gave, groups from row 0 until the stripes choose
    (:func:`rollsim.fit.binning.nearest_offset`); None: detected from the frames."""
    return None if known.binning_rows is None else (known.binning_rows, 0)


def given_exposure(known: Known, target: Measured) -> float | None:
    """The exposure the user gave, in the frames' rows (None: not given)."""
    if known.exposure_us is None:
        return None
    return known.exposure_us * 1e-6 / target.row_time_s


def with_exposure(p: Parameters, choice: ExposureChoice) -> Parameters:
    """``p`` with another exposure the stripes allow and the linear levels it implies."""
    return dataclasses.replace(p, exposure_rows=choice.exposure_rows, on_lin=choice.on, off_lin=max(0.0, choice.off))


def rendered_choice(mismatches: Sequence[float]) -> int:
    """Which of the rendered exposure choices to keep, given each render's :func:`mismatch`.

    The first (the likeliest by its OFF level) unless another's render lies
    nearer the frames by a factor of :data:`RENDERED_MARGIN` and by more
    than :data:`RENDERED_GAIN`; then the nearest. The choices make the same
    stripes only where nothing clips and the pipeline is linear: rendered
    through the camera's clip, colour filter and JPEG, a wrong one can fail
    plainly. Where none does, their mismatches differ by the renders' noise,
    and the OFF level decides.
    """
    nearest = int(np.argmin(mismatches))
    first = mismatches[0]
    clear = first > RENDERED_MARGIN * mismatches[nearest] and first - mismatches[nearest] > RENDERED_GAIN
    return nearest if clear else 0


def exposure_precision(m: Measured) -> float:
    """The stripe fit's relative one-sigma uncertainty of the exposure (inf when not known)."""
    s = m.stripes
    sd = s.uncertainties.get("exposure_rows", math.nan)
    if not (math.isfinite(sd) and sd > 0 and s.exposure_rows > 0):
        return math.inf  # a singular fit (a flat plane) tells nothing
    return sd / s.exposure_rows


def measured_planes(shortlist: Sequence[tuple[str, list[np.ndarray]]],
                    measure_plane: Callable[[list[np.ndarray]], Measured]) -> list[tuple[str, list[np.ndarray], Measured]]:
    """Each colour plane of ``shortlist`` the fit can read, with its frames and statistics,
    the one whose stripe fit tells the exposure most precisely (:func:`exposure_precision`) first.

    Its uncertainty grows both with faint stripes and with a model that
    does not hold them (a demosaiced plane's edges): the criterion a
    contrast-to-noise ratio alone misses. A plane the fit cannot read (no
    LED in it) is passed over; the last such error is raised when every
    plane fails.
    """
    readable: list[tuple[float, int, str, list[np.ndarray], Measured]] = []
    error: ValueError | None = None
    for order, (name, planes) in enumerate(shortlist):
        try:
            m = measure_plane(planes)
        except ValueError as exc:
            error = exc
            continue
        readable.append((exposure_precision(m), order, name, planes, m))
    if not readable:
        assert error is not None  # the shortlist holds the best plane at least
        raise error
    return [(name, planes, m) for _, _, name, planes, m in sorted(readable, key=lambda r: r[:2])]


def measure_rendered(scene: Scene, n_frames: int, channel: str, target: Measured) -> Measured:
    """The fit's statistics of ``n_frames`` frames rendered from ``scene``, taken as
    the frames' were: in their channel, region and stripe fit's start, with the
    binning rendered (groups from row 0)."""
    from rollsim.render import render_frames

    images, _ = render_frames(one_gop(scene, n_frames), n_frames)
    return measure(as_fitted(images, channel), scene.link.clock_hz, row_time=(scene.camera.row_time_s, 0.0),
                   region=target.region, start=target.stripes, binning=(scene.camera.binning_rows, 0))


def exposure_mismatch_in(scene: Scene, n_frames: int, channel: str, target: Measured) -> float | None:
    """The exposure term of :func:`shape_mismatch` between the frames (``target``: their
    statistics in ``channel``) and frames rendered from ``scene``, read in the same plane;
    None where the render's levels there are not the frames' (:func:`rollsim.fit.camera.levels_match`)
    or its stripes cannot be read."""
    try:
        rendered = measure_rendered(scene, n_frames, channel, target)
    except ValueError:
        return None
    if not levels_match(target, rendered):
        return None
    return exposure_mismatch(target, rendered)


def one_gop(scene: Scene, n_frames: int) -> Scene:
    """``scene`` with its ``video_codec`` (if any) coding ``n_frames`` frames as one GOP:
    a longer GOP would render frames that are not measured."""
    codec = scene.effects.video_codec
    if codec is None or (codec.gop_frames or math.inf) <= n_frames:
        return scene
    return scene.model_copy(update={"effects": scene.effects.model_copy(
        update={"video_codec": codec.model_copy(update={"gop_frames": n_frames})})})


def moving_stripes(frames: Sequence[np.ndarray]) -> tuple[slice, float] | None:
    """The rows and the centre column where the stripes move between frames
    (:func:`decoder.stripe_region.stripe_region` on the first frames, as the
    row-time estimator reads them), or None where nothing is seen to move."""
    from decoder.rowtime import REGION_FRAMES
    from decoder.stripe_region import stripe_region

    region = stripe_region(list(frames[:REGION_FRAMES]))
    if region is None:
        return None
    weights = region.column_weights
    return region.rows, float(np.sum(weights * (np.arange(weights.size) + 0.5)) / np.sum(weights))


def as_fitted(images, channel: str) -> list[np.ndarray]:
    """Rendered frames as the fit sees the frames: grey, or the colour frames' chosen plane."""
    from rollsim.fit.channel import plane

    if channel == "grey":
        return [np.asarray(im, dtype=np.float64) for im in images]
    return [plane(im, channel) for im in images]


def mismatch(target: Measured, rendered: Measured, gamma: float) -> float:
    """How far the statistics of frames rendered from a fit lie from the frames':
    squared differences of the stripes' shape (relative to the exposure; γ as is),
    squared log ratios of the levels and of the noise at the anchor levels.
    The refinement keeps the round with the least (it never ends worse than
    it began, as measured).

    A render that shows no stripes where the frames do (a swing,
    :meth:`rollsim.fit.stripes.StripeFit.swing_dn`, under
    :data:`MIN_SWING_DN`: its OFF rows clip too) is infinitely far, however
    near the levels beyond full scale its fit reports.
    """
    t, r = target.stripes, rendered.stripes
    if r.swing_dn(rendered.stripes_period_rows) < MIN_SWING_DN <= t.swing_dn(target.stripes_period_rows):
        return math.inf
    mine, theirs = matched_terms(target, rendered)  # a render's fit may read the reflected exposure
    total = shape_mismatch(target, rendered)
    total += (t.gamma - r.gamma) ** 2 + _log_ratio(mine.on, theirs.on) ** 2 + _log_ratio(mine.off, theirs.off) ** 2
    return total + 0.25 * noise_mismatch(target, rendered, gamma)


def shape_mismatch(target: Measured, rendered: Measured) -> float:
    """The stripes' shape terms of :func:`mismatch`: :func:`exposure_mismatch` and the squared
    difference of the smoothing relative to the frames' exposure (rows, at least one)."""
    scale = max(1.0, target.stripes.exposure_rows)  # rows
    return exposure_mismatch(target, rendered) + ((target.stripes.smoothing_rows - rendered.stripes.smoothing_rows)
                                                  / scale) ** 2


def exposure_mismatch(target: Measured, rendered: Measured) -> float:
    """The squared difference of the exposure, as :func:`rollsim.fit.camera.matched_terms` reads
    it (whole periods and the reflection set aside), relative to the frames' (rows, at least one)."""
    mine, theirs = matched_terms(target, rendered)  # a render's fit may read the reflected exposure
    return ((mine.exposure_rows - theirs.exposure_rows) / max(1.0, target.stripes.exposure_rows)) ** 2


def _log_ratio(x: float | None, y: float | None) -> float:
    return math.log(level_ratio(x, y))


def noise_mismatch(target: Measured, rendered: Measured, gamma: float) -> float:
    """Squared log ratios of the temporal variance at the noise's anchor levels, summed (0: matched)."""
    return sum(_log_ratio(anchor_variance(target, a), anchor_variance(rendered, a)) ** 2
               for a in noise_anchors(target, gamma))


def jpeg_estimate(scene: Scene) -> Estimate:
    """The JPEG quality the fitted scene renders through (:mod:`rollsim.fit.compression`), or why none."""
    jpeg = scene.effects.jpeg
    if jpeg is not None:
        return Estimate(float(jpeg.quality), None, "", "the IJG quality whose JPEG round trip changes the fewest "
                        "pixels of the frames' unclipped blocks")
    return Estimate(0.0, None, "", "rendered without JPEG", NOT_IDENTIFIED,
                    "no IJG quality's round trip leaves the frames as they are: not compressed, compressed nearly "
                    "losslessly (quality 95 and above) or with the camera's own tables, or too few of the frames' "
                    "blocks are unclipped and not flat")


def noise_sources(noise: NoiseFit, p: Parameters) -> dict[str, tuple[str, str | None]]:
    """(source, reason) of the gain and of the read noise: the direct fit's, unless the refinement
    held the read noise at its bound (:func:`rollsim.fit.noise.shot_noise_line`)."""
    out = {"gain": (noise.gain_source, noise.reason if noise.gain_source != FRAMES else None),
           "read": (noise.read_source, noise.reason if noise.read_source != FRAMES else None)}
    if p.read_held:
        out["read"] = (NOT_IDENTIFIED, "the noise grows in proportion to the level: the read noise is below what "
                                       f"the frames resolve (rendered at {BOUND_FRACTION:g} of the lower level's "
                                       "variance)")
    return out


def estimates(m: Measured, p: Parameters, noise: NoiseFit, scene: Scene, base: Scene,
              choices: Sequence[ExposureChoice], known: Known | None = None) -> dict:
    """Every parameter of the fitted scene with its uncertainty and source; ``choices``
    are the exposures the stripes allow, the one kept first; ``known``, what the user gave."""
    known = known or Known()
    cam = scene.camera
    t_row_us = m.row_time_s * 1e6
    unc = m.stripes.uncertainties
    if m.region.disk is None:
        no_background = "no background: the LED fills the frame"
    elif m.region.block is None:
        no_background = "no background clear of the LED's halo"
    elif m.background is not None and m.background < 128:
        no_background = "the background is clipped at black"
    else:
        no_background = "the background is clipped at full scale"
    if known.exposure_us is not None:
        exposure = Estimate(cam.exposure_us, None, "us", known.exposure_how, GIVEN)
    else:
        exposure = Estimate(cam.exposure_us, unc.get("exposure_rows", math.nan) * t_row_us, "us",
                            "width of the box that rounds the stripes' edges (ramps between clipped plateaus and "
                            "the OFF runs' widths when saturated); whole periods and the reflection E <-> P - E "
                            "chosen by the OFF level, or by rendering where that tells them apart; refined by "
                            "rendering",
                            alternatives=tuple(e * t_row_us for e in exposure_alternatives_rows(
                                cam.exposure_us / t_row_us, m.stripes_period_rows, choices)))
    tone_how = "exponent of the tone curve (1 linear, 2.4 sRGB, rollsim.fit.tone), "
    if known.tone_gamma is not None:
        tone = Estimate(p.gamma, None, "", tone_how + HELD_AS_GIVEN, GIVEN)
    else:
        tone = Estimate(p.gamma, unc.get("gamma"), "", tone_how + ("told by the noise against the level (photon "
                                                                   "transfer)" if m.stripes.gamma_given
                                                                   else "from the edges"))
    sources = noise_sources(noise, p)
    out = {
        "row_time_us": Estimate(t_row_us, m.row_time_sd_s * 1e6, "us", "stripe period of the square wave"),
        "exposure_us": exposure,
        "isp_smoothing_rows": Estimate(p.smoothing_rows, unc.get("smoothing_rows"), "rows",
                                       "sigma of the ISP's vertical Gaussian, from the edges' shape"),
        "tone_gamma": tone,
        "gain_dn_per_e": Estimate(cam.gain_dn_per_e_at_iso, None, "DN/e", "slope of the photon-transfer line "
                                  "(or the noise at one level), refined by rendering", *sources["gain"]),
        "iso": Estimate(cam.iso, None, "", "the gain over the preset's", *sources["gain"]),
        "read_noise_e": Estimate(cam.read_noise_e, None, "e-", "intercept of the photon-transfer line",
                                 *sources["read"]),
        "on_level": Estimate(p.on_lin, None, "full scales", "the LED's linear ON level at its centre (stripe fit; "
                             "above 1 when saturated), refined by rendering"),
        "off_level": Estimate(p.off_lin, None, "full scales", "the OFF rows' linear level, refined by rendering"),
        "profile_rms_residual": Estimate(m.stripes.rms_residual, None, "8-bit", "stripe fit's residual"),
    }
    for name, value, how in (("row_noise_e", p.row_lin, "row means of background frame differences"),
                             ("column_fpn_e", p.col_lin, "column means of the background's mean frame")):
        if value is not None:
            out[name] = Estimate(value / p.k_lin, None, "e-", how)
        else:
            effect = getattr(base.effects, name.rsplit("_", 1)[0], None)
            std = float(getattr(effect, "std_e", 0.0) or 0.0)
            out[name] = Estimate(std, None, "e-", how, NOT_IDENTIFIED, no_background)
    if m.background is not None:
        out["background_level"] = Estimate(m.background, None, "8-bit", "median of the background block's mean")
        out["temporal_noise_background"] = Estimate(m.background_noise.pixel_std if m.background_noise else 0.0,
                                                    None, "8-bit", "frame differences over sqrt 2, background")
    out["ambient_lux"] = Estimate(scene.environment.ambient_lux, None, "lx",
                                  "from the background's level" if m.background is not None else
                                  "from the OFF rows' level (the ambient light on the LED's face)")
    if scene.effects.video_codec is None:  # a video's codec is its file's, not fitted
        out["jpeg_quality"] = jpeg_estimate(scene)
    if known.binning_rows is not None:
        out["binning_rows"] = Estimate(float(scene.camera.binning_rows), None, "rows",
                                       "rows in groups (binned readout), " + HELD_AS_GIVEN, GIVEN)
    else:
        out["binning_rows"] = Estimate(float(scene.camera.binning_rows), None, "rows",
                                       "rows in groups (binned readout): near-identical rows, the order of their "
                                       "steps, or the stripes' edges in steps of two rows (rollsim.fit.binning)")
    out.update(led_geometry(m, scene))
    lens = base.camera
    for name, value, unit in (("focal_length_mm", lens.focal_length_mm, "mm"), ("f_number", lens.f_number, ""),
                              ("distance_cm", base.link.distance_cm, "cm")):
        out[name] = Estimate(float(value), None, unit, "kept", BASE,
                             "frames of a square wave show neither the lens nor the distance")
    return out
