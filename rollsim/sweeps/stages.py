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
STAGE_COLUMNS = {"analytic": ANALYTIC_COLUMNS, "simulate": SIMULATE_COLUMNS, "run": RUN_COLUMNS}


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


def run_row(scene: Scene, options: dict, frames_dir: Optional[Path] = None) -> dict:
    """The pixel pipeline's figures of one scene: render and decode in memory, evaluate, fit.

    With ``frames_dir``, the frames are also written there as a render
    directory (frames, truth, resolved scene), committed as one output.
    """
    import numpy as np

    from rollsim.calibrate import Trace, fit_mmbp, physics_prediction
    from rollsim.calibrate.replay import replay_goodput_bps
    from rollsim.channel.scene_channel import sdu_duration_from_scene
    from rollsim.render import RenderPipeline
    from rollsim.stream import DecodedRun

    run = DecodedRun(RenderPipeline(scene), measure_stripes=True)
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
           "roi_ratio": float(np.mean(run.stripe_fractions)) if run.stripe_fractions else 0.0,
           "render_s": float(sum(run.render_s)), "decode_s": float(sum(run.decode_s))}
    physics = physics_prediction(scene)
    row.update(M_physics=physics["M"], N_physics=physics["N"])
    # The receiver's own figure, the same for every strategy (rollsim.receiver).
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

    from rollsim.outputs import staged_directory
    from rollsim.render.writer import FRAME_NAME, encode_png, frame_text
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


ROW_FUNCTIONS = {"analytic": analytic_row, "simulate": simulate_row, "run": run_row}


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
