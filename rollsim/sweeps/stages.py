"""What a sweep computes for one cell, stage by stage.

Each stage is a function of a validated scene (and the sweep's options) to a
flat row of figures, with units in the column names:

``analytic``
    The MMBP (M, N) the scene's physics gives, the ROI ratio (LED rows over
    frame rows; and the paper's Eq. 10 with the scene's own lens and sensor),
    p0 and P(message) for RP and RS at the scene's r and N_p, and the
    expected goodput of both. No rendering.
``simulate``
    The event simulator on the scene's channel: means of goodput and
    duration with 95 % intervals over ``runs`` runs.
``run``
    The pixel pipeline in memory (render → decode → evaluate, frame by
    frame), the MMBP fit of the outcomes, and the goodput of the scene's
    strategy replayed over the outcome trace.
``envelope``
    The same frames read by rollsim's decoder and by the genie-aided
    reference receiver (:mod:`rollsim.stages.genie`): each one's ok fraction of the
    fully visible PHY-SDUs with its 95 % Wilson interval, and where the cell
    sits (exposure in chips, rows per chip, stripe SNR, LED level over the
    background, ON level in full wells: :func:`envelope_physics`).

:func:`compute_cells` is what a worker runs: it validates each cell's scene
again from the base scene's data (small to send) and never raises: a cell
that fails records its error and the others go on.
"""

from __future__ import annotations

import math
import time
import traceback
from pathlib import Path
from typing import TYPE_CHECKING, Optional

from rollsim.errors import RollsimError, clip

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

COMMON_COLUMNS = ("cell", "cell_id", "seed", "status", "error", "seconds")
ANALYTIC_COLUMNS = (
    "M", "N", "roi_ratio", "roi_ratio_eq10", "sdu_duration_s", "capture_window_s", "n_packets", "repeats", "p_e",
    "p0_rp", "p0_rs", "p_message_rp", "p_message_rs", "goodput_rp_bps", "goodput_rs_bps",
    "expected_emissions_rlnc", "goodput_rlnc_bps",
)
SIMULATE_COLUMNS = (
    "channel", "runs", "M", "N", "p_e", "completed_fraction", "goodput_bps_mean", "goodput_bps_ci_low",
    "goodput_bps_ci_high", "duration_s_mean", "duration_s_ci_low", "duration_s_ci_high", "emissions_mean",
)
RUN_COLUMNS = (
    "frames", "emissions", "fully_visible", "ok", "corrupted", "missed", "undetected_error", "not_visible",
    "false_decodes", "error_rate", "roi_ratio", "M", "N", "p_e", "p_e_ci_low", "p_e_ci_high", "on_emissions",
    "on_failures", "mean_on_per_frame",
    "M_physics", "N_physics", "goodput_replayed_bps", "replay_trace_rounds", "goodput_predicted_bps", "fit_error",
    "message_decodable", "message_ok", "goodput_received_bps", "render_s", "decode_s",
)
# Where a cell sits (envelope_physics), then each receiver's outcomes.
ENVELOPE_PHYSICS_COLUMNS = (
    "exposure_chips", "rows_per_chip", "stripe_snr_db", "stripe_snr_peak_db", "led_to_background", "on_full_wells",
)
RECEIVER_COLUMNS = (
    "ok", "corrupted", "missed", "undetected_error", "ok_fraction", "ok_ci_low", "ok_ci_high", "false_decodes",
    "false_decodes_passed",
)
ENVELOPE_COLUMNS = (
    "frames", "emissions", "fully_visible", *ENVELOPE_PHYSICS_COLUMNS, *RECEIVER_COLUMNS,
    *(f"genie_{name}" for name in RECEIVER_COLUMNS), "render_s", "decode_s", "genie_s",
)
STAGE_COLUMNS = {"analytic": ANALYTIC_COLUMNS, "simulate": SIMULATE_COLUMNS, "run": RUN_COLUMNS,
                 "envelope": ENVELOPE_COLUMNS}


def _packets(scene: Scene) -> int:
    from rollsim.protocol import n_packets

    return n_packets(scene.link.message_bytes, scene.link.payload_bits)


def analytic_row(scene: Scene, options: dict) -> dict:
    """The analytic figures of one scene (see the module docstring)."""
    from rollsim.channel.prediction import link_prediction

    prediction = link_prediction(scene)
    return {name: prediction[name] for name in ANALYTIC_COLUMNS}


def simulate_row(scene: Scene, options: dict) -> dict:
    """The event simulator's figures of one scene, ``options["runs"]`` runs on ``options["channel"]``."""
    from rollsim.channel.scene_channel import simulate_scene

    result = simulate_scene(scene, options["channel"], runs=options["runs"], max_emissions=options["max_emissions"],
                            workers=1)
    summary = result.summary()
    metrics = summary["metrics"]
    row = {"channel": options["channel"], "runs": summary["runs"], "M": summary["channel"].get("M"),
           "N": summary["channel"].get("N"), "p_e": scene.channel.p_e,
           "completed_fraction": summary["completed_fraction"], "emissions_mean": metrics["emissions"]["mean"]}
    for name in ("goodput_bps", "duration_s"):
        ci = metrics[name].get("ci95") or (None, None)
        row.update({f"{name}_mean": metrics[name]["mean"], f"{name}_ci_low": ci[0], f"{name}_ci_high": ci[1]})
    return row


def _predicted_goodput_bps(fit, link, n: int, sdu_s: float) -> float:
    """Expected goodput of the fitted MMBP for the link's strategy."""
    from rollsim.channel.analytic import mmbp_expected_goodput_bps
    from rollsim.channel.rateless import rlnc_figures

    if link.strategy == "rlnc":
        return rlnc_figures(fit.M, fit.N, fit.p_e, n, link.payload_bits, sdu_s)[1]
    return mmbp_expected_goodput_bps(fit.M, fit.N, link.repeats, fit.p_e, n, link.strategy, link.payload_bits, sdu_s)


def run_row(scene: Scene, options: dict, frames_dir: Optional[Path] = None, measure_roi: bool = True) -> dict:
    """The pixel pipeline's figures of one scene: render and decode in memory, evaluate, fit.

    With ``frames_dir``, the frames are also written there as a render
    directory (frames, truth, resolved scene), committed as one output.
    Without ``measure_roi``, the decoder reads the frames without
    measuring its stripe rows (:func:`decoder.decode_frame`, the same
    PHY-SDUs as :func:`decoder.inspect_frame` in a third of the time) and
    ``roi_ratio`` is None.
    """
    import numpy as np

    from rollsim.calibrate import Trace, fit_mmbp, physics_prediction
    from rollsim.calibrate.replay import replay_goodput_bps
    from rollsim.channel.scene_channel import sdu_duration_from_scene
    from rollsim.render import RenderPipeline
    from rollsim.sweeps.stream import DecodedRun

    run = DecodedRun(RenderPipeline(scene), measure_stripes=measure_roi)
    if frames_dir is not None:
        _write_frames(run, scene, frames_dir)
    else:
        for index in range(scene.frames):
            run.step(index)
    evaluation = run.evaluation()
    summary = evaluation.summary
    counts = summary["counts"]
    row = {"frames": scene.frames, "emissions": summary["emissions"], "fully_visible": summary["fully_visible"],
           **{name: counts[name] for name in ("ok", "corrupted", "missed", "undetected_error", "not_visible")},
           "false_decodes": summary["false_decodes"], "error_rate": summary["error_rate"],
           "roi_ratio": (float(np.mean(run.stripe_fractions)) if run.stripe_fractions else 0.0) if measure_roi else None,
           "render_s": float(sum(run.render_s)), "decode_s": float(sum(run.decode_s))}
    physics = physics_prediction(scene)
    row.update(M_physics=physics["M"], N_physics=physics["N"])
    # The receiver's own figure, the same for every strategy (rollsim.stages.receiver).
    message = summary["message"]
    row.update(message_decodable=message["decodable"], message_ok=message["message_ok"],
               goodput_received_bps=message["goodput_bps"])
    link, sdu_s, n = scene.link, sdu_duration_from_scene(scene), _packets(scene)
    trace = Trace.from_outcomes(evaluation.outcomes, run.truth, scene)
    success = trace.success
    try:
        fit = fit_mmbp(trace)
    except ValueError as exc:
        row["fit_error"] = clip(str(exc), 200)
    else:
        row.update(M=fit.M, N=fit.N, p_e=fit.p_e, p_e_ci_low=fit.p_e_ci95[0], p_e_ci_high=fit.p_e_ci95[1],
                   on_emissions=fit.on_emissions, on_failures=fit.on_failures,
                   mean_on_per_frame=fit.mean_on_per_frame,
                   goodput_predicted_bps=_predicted_goodput_bps(fit, link, n, sdu_s))
    # The replay cycles a trace through the repetition strategies' schedules.
    if success.size and link.strategy != "rlnc":
        replay = replay_goodput_bps(success, link.repeats, n, link.payload_bits, sdu_s, strategy=link.strategy)
        # Below a few rounds the cyclic replay reuses the trace's outcomes: say how many it holds.
        row.update(goodput_replayed_bps=replay["goodput_bps"], replay_trace_rounds=replay["trace_rounds"])
    return row


def _write_frames(run, scene: Scene, frames_dir: Path) -> None:
    """Step every frame of ``run`` and write it as a render directory, committed at the end."""
    import json

    from rollsim.plumbing.outputs import staged_directory
    from rollsim.render.png import encode_png
    from rollsim.render.writer import FRAME_NAME, frame_text
    from rollsim.scene import scene_to_yaml

    with staged_directory(frames_dir) as staging:
        (staging / "frames").mkdir()
        (staging / "scene.resolved.yaml").write_text(scene_to_yaml(scene), encoding="utf-8")
        with open(staging / "truth.jsonl", "w", encoding="utf-8") as truth:
            for index in range(scene.frames):
                frame = run.step(index)
                png = encode_png(frame.image, frame_text(scene, frame.truth))
                (staging / "frames" / FRAME_NAME.format(index)).write_bytes(png)
                truth.write(json.dumps(frame.truth, separators=(",", ":")) + "\n")


def _db(ratio: float) -> Optional[float]:
    """20·log10 of an amplitude ratio; None where it is 0 (no signal)."""
    return 20.0 * math.log10(ratio) if ratio > 0 else None


def envelope_physics(setup, led_rows) -> dict:
    """Where a scene sits in the decoder's operating envelope, from its physics.

    Parameters
    ----------
    setup : SceneSetup
        The prepared setup (``RenderPipeline(scene).setup``).
    led_rows : (int, int) or None
        The LED's rows of a frame (the truth's ``led_rows``).

    Returns
    -------
    dict
        ``exposure_chips`` (exposure over the chip duration), ``rows_per_chip``
        (chip duration over the row time), ``stripe_snr_db``: 20·log10 of the
        ON–OFF gap of a row mean over the noise σ of that mean, the median
        over ``led_rows`` (``stripe_snr_peak_db``: the best row). The row mean
        is the ideal (matched-filter) one the genie reads, whose SNR² is
        Σ_j g_j²/v_j over the row's pixels (g_j the gap up to the clip, v_j
        the noise variance at mid level, electrons:
        :func:`rollsim.effects.readable.stripe_gap_and_variance`, as
        :func:`rollsim.stages.genie.pixel_model` uses them). ``led_to_background``:
        the LED's time-averaged light in the pixels of its body (half the
        ON–OFF gap: Manchester is ON half the time) over the background's
        level, electrons (None without ambient light). ``on_full_wells``: the
        brightest pixel's ON level (unclipped electrons) in full wells.
    """
    import numpy as np

    from rollsim.effects.readable import row_stripe_snr, stripe_gap_and_variance

    scene, cam = setup.scene, setup.scene.camera
    chip_s = 1.0 / scene.link.clock_hz
    row = {"exposure_chips": cam.exposure_s / chip_s, "rows_per_chip": chip_s / cam.row_time_s}
    light = (setup.led_light if setup.led_light is not None else setup.footprint).dense(setup.shape)
    covered = setup.footprint.dense(setup.shape)
    gap_e, variance_e2 = stripe_gap_and_variance(light, covered, setup)
    snr = row_stripe_snr(gap_e, variance_e2)
    rows = snr[led_rows[0]:led_rows[1] + 1] if led_rows else snr[:0]
    row["stripe_snr_db"] = _db(float(np.median(rows))) if rows.size else None
    row["stripe_snr_peak_db"] = _db(float(np.max(rows))) if rows.size else None
    on_gap_e = light * (setup.led_e_per_s * cam.exposure_s)
    background_e = setup.background_e_per_s * cam.exposure_s if "ambient" in scene.effects.enabled() else 0.0
    body = covered >= 0.5
    led_mean_e = 0.5 * float(np.mean(on_gap_e[body])) if body.any() else 0.0
    row["led_to_background"] = led_mean_e / background_e if background_e > 0 else None
    off_e = np.zeros(setup.shape)
    if background_e > 0:
        off_e += (setup.background_e_per_s * (1.0 - covered) + setup.face_e_per_s * covered) * cam.exposure_s
    row["on_full_wells"] = float(np.max(off_e + on_gap_e)) / cam.full_well_e
    return row


def receiver_figures(summary: dict, prefix: str = "") -> dict:
    """One receiver's outcomes among the fully visible PHY-SDUs, with the ok fraction's 95 % Wilson interval.

    Parameters
    ----------
    summary : dict
        :func:`rollsim.stages.evaluate.summarise` of its records.
    prefix : str
        Put before every column name (``"genie_"``).
    """
    from rollsim.calibrate import wilson_interval

    counts, fully = summary["fully_visible_counts"], summary["fully_visible"]
    low, high = wilson_interval(counts["ok"], fully) if fully else (None, None)
    row = {name: counts[name] for name in ("ok", "corrupted", "missed", "undetected_error")}
    row.update(ok_fraction=counts["ok"] / fully if fully else None, ok_ci_low=low, ok_ci_high=high,
               false_decodes=summary["false_decodes"], false_decodes_passed=summary["false_decodes_check_passed"])
    return {prefix + name: value for name, value in row.items()}


def envelope_row(scene: Scene, options: dict) -> dict:
    """rollsim's decoder and the genie-aided receiver on the same frames of one scene.

    ``scene.frames`` frames are rendered in memory; each is decoded by
    :mod:`decoder` (:class:`rollsim.sweeps.stream.DecodedRun`) and by
    :func:`rollsim.stages.genie.genie_decode`, and both record sets are evaluated
    against the same truth. Columns: :data:`ENVELOPE_COLUMNS`.
    """
    from rollsim.stages.evaluate import evaluate
    from rollsim.stages.genie import genie_decode
    from rollsim.render import RenderPipeline
    from rollsim.sweeps.stream import DecodedRun

    run = DecodedRun(RenderPipeline(scene))
    setup = run.pipeline.setup
    genie_records: list[dict] = []
    genie_s = 0.0
    for index in range(scene.frames):
        frame = run.step(index)
        start = time.perf_counter()
        genie_records.extend(genie_decode(frame.image, frame.truth, setup))
        genie_s += time.perf_counter() - start
    decoded = run.evaluation()
    genie = evaluate(run.truth, genie_records, setup.transmitter)
    led_rows = next((t["led_rows"] for t in run.truth if t.get("led_rows")), None)
    return {"frames": scene.frames, "emissions": decoded.summary["emissions"],
            "fully_visible": decoded.summary["fully_visible"], **envelope_physics(setup, led_rows),
            **receiver_figures(decoded.summary), **receiver_figures(genie.summary, "genie_"),
            "render_s": float(sum(run.render_s)), "decode_s": float(sum(run.decode_s)), "genie_s": genie_s}


ROW_FUNCTIONS = {"analytic": analytic_row, "simulate": simulate_row, "run": run_row, "envelope": envelope_row}


def _finite_or_none(value):
    """JSON-safe figures: NaN and inf become None (the table's null)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def compute_cell(stage: str, base: dict, source: str, overrides: list, values: dict, options: dict,
                 frames_dir=None) -> dict:
    """One cell's figures, or its error: never raises for the cell's own failure.

    Returns
    -------
    dict
        The stage's columns, ``status`` (``"ok"`` or ``"error"``), ``error``
        (one line, or None) and ``seconds``.
    """
    from rollsim.scene import scene_from_dict

    start = time.perf_counter()
    try:
        scene = scene_from_dict(base, source, overrides, values)
        if stage == "run":
            row = run_row(scene, options, frames_dir)
        else:
            row = ROW_FUNCTIONS[stage](scene, options)
        row = {name: _finite_or_none(value) for name, value in row.items()}
        row.update(status="ok", error=None)
    except (RollsimError, ValueError, ArithmeticError, MemoryError, OSError) as exc:
        row = {"status": "error", "error": clip(" ".join(str(exc).split()) or type(exc).__name__, 300)}
    except Exception as exc:  # a bug: keep the cell's record, say where
        where = traceback.extract_tb(exc.__traceback__)[-1]
        row = {"status": "error", "error": clip(f"{type(exc).__name__}: {exc} ({Path(where.filename).name}:"
                                                f"{where.lineno})", 300)}
    row["seconds"] = time.perf_counter() - start
    return row


def compute_cells(batch: list, stage: str, base: dict, source: str, overrides: list, options: dict,
                  frames_root=None) -> list[dict]:
    """A worker's task: every cell of ``batch`` (``[(index, id, seed, values), …]``), in order.

    ``overrides`` are the sweep's ``--set`` items, before each cell's values.
    """
    rows = []
    for index, cell_id, seed, values in batch:
        frames_dir = Path(frames_root) / cell_id if frames_root is not None else None
        row = compute_cell(stage, base, source, overrides, values, options, frames_dir)
        row.update(cell=index, cell_id=cell_id, seed=seed)
        rows.append(row)
    return rows
