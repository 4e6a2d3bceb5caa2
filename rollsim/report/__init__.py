"""The report of a ``rollsim run``: ``report.md`` and its PNG plots.

:func:`write_report` reads what the earlier stages left in the run
directory (frames, truth, decoded PHY-SDUs, outcomes) and the calibration,
draws the plots (:mod:`rollsim.report.plots`) into ``plots/`` and writes
``report.md`` beside them.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rollsim.plumbing.text_tables import format_number, format_percent, markdown_table
from rollsim.report.plots import (
    plot_goodput,
    plot_message_curves,
    plot_outcome_timeline,
    plot_row_profile,
    plot_run_lengths,
    plot_sample_frame,
)

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

PLOTS_DIR = "plots"
# Frames searched for the sample frame (the one with the most decodes).
SAMPLE_SEARCH_FRAMES = 30


def sample_frame_index(decoded: list[dict], n_frames: int) -> int:
    """The frame, among the first few, with the most PHY-SDUs whose check passed."""
    counts = [0] * max(1, min(n_frames, SAMPLE_SEARCH_FRAMES))
    for record in decoded:
        if record["frame"] < len(counts) and record["check_ok"]:
            counts[record["frame"]] += 1
    return max(range(len(counts)), key=lambda k: (counts[k], -k))


def _scene_lines(scene: Scene) -> list[str]:
    cam, led, link, env = scene.camera, scene.led, scene.link, scene.environment
    effects = ", ".join(scene.effects.enabled()) or "none"
    return [
        f"- camera: {cam.width_px} × {cam.height_px} at {cam.frame_rate_hz:g} Hz, row time {cam.row_time_s * 1e6:.3f} µs, "
        f"exposure {cam.exposure_us:g} µs, ISO {cam.iso:g}, output {cam.output}",
        f"- LED: {led.shape} of {led.size_mm:g} mm, {led.luminous_intensity_cd:g} cd, at {link.distance_cm:g} cm; "
        f"ambient {env.ambient_lux:g} lx",
        f"- link: {link.clock_hz:g} Hz chips, {link.line_code}, H = {link.header_bits}, P = {link.payload_bits}, "
        f"{link.check}, G = {link.message_bytes} bytes, {link.strategy.upper()} r = {link.repeats}, pattern {link.pattern}",
        f"- effects: {effects}; seed {scene.seed}",
    ]


def _evaluation_lines(summary: dict) -> list[str]:
    rows = [*summary["counts"].items(), ("false decodes", summary["false_decodes"]),
            ("false decodes, check passed", summary.get("false_decodes_check_passed", 0))]
    lines = markdown_table(rows, ("outcome", "PHY-SDUs"))
    lines += [
        "",
        f"Fully visible: {summary['fully_visible']} of {summary['emissions']} emissions over {summary['frames']} frames "
        f"({summary.get('frames_unreadable', 0)} unreadable). PHY-SDU error rate among the fully visible: "
        f"{format_percent(summary['error_rate'])}; missed: {format_percent(summary['missed_rate'])}; undetected errors among the passed: "
        f"{format_percent(summary['undetected_error_rate'])}; false decodes per 1000 frames: "
        f"{summary['false_decodes_per_1000_frames']:.2f}.",
    ]
    return lines


def roi_figures(truth: list[dict], height_px: int) -> dict:
    """The LED's rows and position over a run's frames, from their truth records.

    Parameters
    ----------
    truth : list of dict
        ``truth.jsonl`` records.
    height_px : int
        The frames' height, rows.

    Returns
    -------
    dict
        ``roi_ratio`` (mean over frames of the LED's rows over the frame's:
        the paper's ROI ratio, Fig. 11; a frame without LED rows counts 0),
        ``roi_min``, ``roi_max``; where the truth records the LED's centre
        (``motion``), ``centre_std_px`` ((x, y) standard deviation over
        frames) and ``centre_range_px`` (the largest distance from the mean
        centre), else None for both.
    """
    fractions = np.array([(r["led_rows"][1] - r["led_rows"][0] + 1) / height_px if r.get("led_rows") else 0.0
                          for r in truth]) if truth else np.zeros(1)
    figures: dict = {"roi_ratio": float(fractions.mean()), "roi_min": float(fractions.min()),
               "roi_max": float(fractions.max()), "centre_std_px": None, "centre_range_px": None}
    centres = np.array([r["led_centre_px"] for r in truth if r.get("led_centre_px") is not None], dtype=np.float64)
    if centres.size:
        figures["centre_std_px"] = tuple(float(v) for v in centres.std(axis=0))
        figures["centre_range_px"] = float(np.hypot(*(centres - centres.mean(axis=0)).T).max())
    return figures


def _roi_lines(figures: dict) -> list[str]:
    lines = [f"ROI ratio (the share of a frame's rows that show the LED, from the truth's LED rows): "
             f"{figures['roi_ratio']:.3f} on average, {figures['roi_min']:.3f} … {figures['roi_max']:.3f} over frames."]
    if figures["centre_std_px"] is not None:
        sx, sy = figures["centre_std_px"]
        lines.append(f"The LED's centre, where the frames show it, moves {sx:.1f} px in x and {sy:.1f} px in y "
                     f"(standard deviations over frames), at most {figures['centre_range_px']:.1f} px from its mean.")
    return lines


def _calibration_lines(calibration: dict) -> list[str]:
    # Here, not at the top: `rollsim run` imports this package before its render,
    # and the calibration's SciPy while the workers render (rollsim.report.run).
    from rollsim.calibrate import goodput_text, position_text
    from rollsim.calibrate.mmbp import p_e_text
    m, ge, prediction = calibration["mmbp"], calibration["ge"], calibration.get("prediction")
    criteria = calibration["criteria"]
    parameters = {
        "mmbp": f"M = {m['M']}, N = {m['N']}, {p_e_text(m, format_number)}",
        "ge": f"p = {format_number(ge['p'])}, q = {format_number(ge['q'])}, p_e = {format_number(ge['p_e'])}",
    }
    names = {"mmbp": f"MMBP ({m['method']})", "ge": "Gilbert-Elliott (ML)"}
    rows = [
        (names[k], parameters[k], format_number(fit["loglik"], 6), format_number(criteria[k]["aic"], 6),
         format_number(criteria[k]["bic"], 6))
        for k, fit in (("mmbp", m), ("ge", ge))
    ]
    lines = markdown_table(rows, ("model", "parameters", "log L", "AIC", "BIC"))
    lines += [
        "",
        f"Selected by AIC: **{calibration['selected_by_aic']}**, by BIC: **{calibration['selected_by_bic']}**. "
        f"Mean fully received slots per frame: {m['mean_on_per_frame']:.3f}.",
    ]
    if prediction is not None:
        agree = "agrees" if (prediction["M"], prediction["N"]) == (m["M"], m["N"]) else "**disagrees**"
        lines.append(
            f"Physics prediction from the scene alone: M = {prediction['M']}, N = {prediction['N']} "
            f"({prediction['mean_whole_sdus_per_frame']:.3f} whole PHY-SDUs per frame: capture window "
            f"{prediction['capture_window_s'] * 1e3:.3f} ms, PHY-SDU {prediction['sdu_duration_s'] * 1e3:.3f} ms, "
            f"frame period {prediction['frame_period_s'] * 1e3:.3f} ms); the fit {agree}."
        )
    if calibration.get("position"):
        lines += ["", position_text(calibration["position"], format_number) + "."]
    heldout = calibration.get("heldout_loglik") or {}
    if calibration.get("selected_by_heldout"):
        scores = ", ".join(f"{name} {format_number(v, 6)}" for name, v in heldout.items() if v is not None)
        lines += ["", f"Selected by held-out likelihood (folds of frames): **{calibration['selected_by_heldout']}** ({scores})."]
    table = calibration.get("goodput")
    if table:
        lines += ["", "Goodput, each fitted model's prediction against the pixel-level trace replayed:", "",
                  "```", goodput_text(table, format_number), "```"]
    return lines


# The report's terms, each defined where it is read and named by the page and
# section of the documentation (docs/ in the repository) that says more.
TERMS = (
    ("ok", "decoded, the check passed, sequence number and payload right", "docs/evaluation.md, Evaluation"),
    ("undetected_error", "decoded, the check passed, but the bits are wrong", "docs/evaluation.md, Evaluation"),
    ("corrupted", "decoded, the check failed", "docs/evaluation.md, Evaluation"),
    ("missed", "fully visible in some frame, not decoded", "docs/evaluation.md, Evaluation"),
    ("not_visible", "never fully visible in a frame (sent wholly or partly outside the rows a frame sees), "
     "not decoded", "docs/evaluation.md, Evaluation"),
    ("false decode", "a decoded record that matches no emission (its middle row in no PHY-SDU's rows of its frame)",
     "docs/evaluation.md, Evaluation"),
    ("ROI ratio", "the share of a frame's rows that show the LED (the truth's `led_rows`; the paper's Fig. 11)",
     "docs/render.md, Ground truth: `truth.jsonl`"),
    ("M, N", "the MMBP's ON and OFF slots per cycle of a frame period: an emission in an OFF slot is never "
     "received", "docs/channel-models.md, Channel models"),
    ("p_e", "the probability that an emission in an ON slot is lost all the same; with its 95 % interval",
     "docs/channel-models.md, Channel models"),
    ("aligned", "the MMBP fitted with each emission's start placed within its frame period (per-frame alignment), "
     "as rendered data allows", "docs/calibration.md, Calibration"),
    ("RP r", "Repeat Packet: each packet sent r times in a row, then the next, cycling over the message "
     "(RS r: the whole sequence r times)", "docs/scenes.md, link.strategy"),
    ("AIC, BIC", "the models' information criteria; the lower is selected", "docs/calibration.md, Calibration"),
    ("replayed", "the scene's strategy replayed over the decoded outcome trace, from many starts",
     "docs/calibration.md, Calibration"),
)


def _terms_lines() -> list[str]:
    return markdown_table([(f"`{term}`", meaning, where) for term, meaning, where in TERMS],
                          ("term", "meaning", "more in"))


def _timing_lines(timings: dict, n_frames: int) -> list[str]:
    rows = [(stage, f"{seconds:.2f}", f"{1e3 * seconds / max(1, n_frames):.1f}") for stage, seconds in timings.items()]
    return markdown_table(rows, ("stage", "seconds", "ms per frame"))


def write_report(run_dir: Path, scene: Scene, evaluation, calibration: dict | None, timings: dict,
                 calibration_error: str | None = None, frame_figures: list | None = None,
                 calibration_figures: list | None = None) -> Path:
    """Draw the plots and write ``report.md``; returns its path.

    Parameters
    ----------
    run_dir : Path
        A run directory holding frames, ``truth.jsonl`` and ``decoded.jsonl``.
    scene : Scene
    evaluation : rollsim.stages.evaluate.Evaluation
        The outcomes and their summary.
    calibration : dict or None
        :func:`rollsim.calibrate.calibrate`'s result; None when the trace
        could not be fitted (``calibration_error`` says why).
    timings : dict
        Seconds per stage, in order.
    calibration_error : str, optional
    frame_figures, calibration_figures : list, optional
        What :func:`draw_frame_plots` and :func:`draw_calibration_plots`
        returned for this run, where they were drawn already (``rollsim
        run`` draws them in two processes at once); drawn here otherwise.
    """

    from rollsim.stages.evaluate import read_jsonl

    run_dir = Path(run_dir)
    if frame_figures is None:
        frame_figures = draw_frame_plots(run_dir, scene, evaluation)
    if calibration_figures is None:
        calibration_figures = draw_calibration_plots(run_dir, calibration)
    figures = frame_figures + calibration_figures
    truth = read_jsonl(run_dir / "truth.jsonl")
    lines = _report_lines(scene, evaluation, calibration, timings, calibration_error, len(truth), figures,
                          roi_figures(truth, scene.camera.height_px))
    report = run_dir / "report.md"
    report.write_text("\n".join(lines), encoding="utf-8")
    return report


def draw_frame_plots(run_dir: Path, scene: Scene, evaluation) -> list:
    """Draw the plots of the frames and outcomes under ``run_dir/plots``: ``(title, path)`` pairs in order.

    They need no calibration: the sample frame (the one with the most
    PHY-SDUs decoded among the first few), its row profile and the
    outcome timeline.
    """
    from decoder import inspect_frame, read_frame

    from rollsim.stages.decode import frame_files, settings_from_scene
    from rollsim.stages.evaluate import read_jsonl

    run_dir = Path(run_dir)
    plots = run_dir / PLOTS_DIR
    plots.mkdir(exist_ok=True)
    truth = read_jsonl(run_dir / "truth.jsonl")
    frame = sample_frame_index(read_jsonl(run_dir / "decoded.jsonl"), len(truth))
    image = read_frame(frame_files(run_dir)[frame])
    settings = settings_from_scene(scene)
    views = inspect_frame(image, settings.phy, settings.clock_hz, settings.row_time_s, frame)
    figures = [("A sample frame", plot_sample_frame(image, views, frame, plots / "sample_frame.png"))]
    if views:
        figures.append(("Its row profile and threshold", plot_row_profile(views[0], frame, plots / "row_profile.png")))
    if evaluation.outcomes:
        figures.append(("Outcome timeline", plot_outcome_timeline(evaluation.outcomes, truth, plots / "outcome_timeline.png")))
    return figures


# The calibration's plots, in the report's order: (title, plot function, file name).
CALIBRATION_PLOTS = (
    ("Run lengths", plot_run_lengths, "run_lengths.png"),
    ("P(message): fitted models against the trace", plot_message_curves, "message_curves.png"),
    ("Goodput: predicted against replayed", plot_goodput, "goodput.png"),
)


def calibration_plot_names(calibration: dict | None) -> list[str]:
    """The file names of the calibration's plots a report holds, in order (none without a calibration)."""
    if calibration is None:
        return []
    return [name for _, _, name in CALIBRATION_PLOTS if name != "goodput.png" or calibration.get("goodput")]


def draw_calibration_plots(run_dir: Path, calibration: dict | None, names: list[str] | None = None) -> list:
    """Draw the calibration's plots under ``run_dir/plots``: ``(title, path)`` pairs in order.

    ``names`` (file names of :func:`calibration_plot_names`) draws those
    alone; by default every one.
    """
    wanted = calibration_plot_names(calibration) if names is None else names
    if calibration is None or not wanted:
        return []
    plots = Path(run_dir) / PLOTS_DIR
    plots.mkdir(exist_ok=True)
    return [(title, plot(calibration, plots / name)) for title, plot, name in CALIBRATION_PLOTS if name in wanted]


def _report_lines(scene: Scene, evaluation, calibration: dict | None, timings: dict, calibration_error: str | None,
                  n_frames: int, figures: list, roi: dict) -> list[str]:
    """The lines of ``report.md``: the scene, time per stage, evaluation, calibration and the plots."""
    lines = [f"# rollsim run: {scene.name}", ""]
    if scene.description:
        lines += [scene.description, ""]
    lines += _scene_lines(scene) + ["", f"{n_frames} frames: render → decode → evaluate → calibrate → report.", ""]
    lines += ["## Time per stage", ""] + _timing_lines(timings, n_frames) + [""]
    lines += ["## Evaluation against the ground truth", ""] + _evaluation_lines(evaluation.summary) + [""]
    lines += _roi_lines(roi) + [""]
    if calibration is not None:
        lines += ["## Calibration", ""] + _calibration_lines(calibration) + [""]
    else:
        lines += ["## Calibration", "", f"Not possible: {calibration_error}", ""]
    lines += ["## Plots", ""]
    for title, path in figures:
        lines += [f"### {title}", "", f"![{title}]({PLOTS_DIR}/{path.name})", ""]
    lines += ["## Terms", ""] + _terms_lines() + [""]
    return lines
