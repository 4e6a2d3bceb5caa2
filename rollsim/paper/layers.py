"""rollsim's three layers on one setting: analytic, event simulator, pixel pipeline.

Each function maps a scene (and options) to a small dict of figures with
units in the names; :mod:`rollsim.paper.compare` puts them beside the
paper's numbers.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

BASE_SCENE = "paper-default"


def load(overrides, relax=()):
    """``paper-default`` with ``overrides`` (``KEY=VALUE`` items)."""
    from rollsim.scene import load_scene

    return load_scene(BASE_SCENE, list(overrides), relax=relax)


def analytic_figures(scene: Scene) -> dict:
    """ROI ratio, M, N, expected goodput and throughput from the physics and the MMBP.

    The throughput is ``(H + P)`` bits per received PHY-SDU: the MMBP
    receives ``M (1 - p_e)`` of every ``M + N`` emissions of ``T_p`` each.
    """
    from rollsim.channel.prediction import link_prediction

    link = link_prediction(scene)
    M, N = link["M"], link["N"]
    bits = scene.link.header_bits + scene.link.payload_bits
    throughput = bits * M * (1.0 - link["p_e"]) / ((M + N) * link["sdu_duration_s"]) if M + N else 0.0
    return {"roi_ratio": link["roi_ratio"], "M": M, "N": N, "goodput_bps": link["goodput_bps"],
            "throughput_bps": throughput}


def event_figures(scene: Scene, channel: str, runs: int, workers: int = 1) -> dict:
    """Means over ``runs`` runs of the event simulator on ``channel`` (seeded by the scene)."""
    from rollsim.channel.scene_channel import simulate_scene

    result = simulate_scene(scene, channel, runs=runs, workers=workers)
    return {"goodput_bps": float(result.goodput_bps.mean()), "throughput_bps": float(result.throughput_bps.mean()),
            "completed_fraction": float(result.completed.mean()), "runs": runs}


def pixel_figures(overrides: tuple, frames: int, measure_roi: bool = True) -> dict:
    """The pixel pipeline on ``paper-default`` with ``overrides``, ``frames`` frames, in memory.

    Goodput is the scene's strategy replayed over the decoded outcome
    trace (for rlnc, the receiver's: :mod:`rollsim.stages.receiver`); throughput is ``(H + P)`` bits per correctly decoded PHY-SDU
    over the frames' duration, and ``throughput_bound_bps`` the most that
    whole PHY-SDUs in the measured ROI allow
    (:func:`rollsim.channel.analytic.throughput_bound_bps`); the ROI ratio is the mean fraction of rows
    in which the decoder reads the LED's stripes
    (:func:`decoder.stripe_row_fraction`), whether or not a whole PHY-SDU
    fits in them, as the paper measured it. Without ``measure_roi`` the
    ROI is not measured (the decoder's stripe rows cost two thirds of its
    time) and ``roi_ratio`` and ``throughput_bound_bps`` are None; every
    other figure is the same.
    """
    from rollsim.calibrate import p_e_text
    from rollsim.channel.analytic import throughput_bound_bps
    from rollsim.channel.scene_channel import sdu_duration_from_scene
    from rollsim.sweeps.stages import run_row

    scene = load([*overrides, f"frames={frames}"])
    row = run_row(scene, {}, measure_roi=measure_roi)
    bits = scene.link.header_bits + scene.link.payload_bits
    camera = scene.camera
    duration_s = frames * camera.frame_period_s
    bound_bps = None
    if row["roi_ratio"] is not None:
        window_s = row["roi_ratio"] * camera.readout_s + camera.exposure_s
        bound_bps = throughput_bound_bps(camera.frame_period_s, window_s, sdu_duration_from_scene(scene), bits)
    return {
        "roi_ratio": row["roi_ratio"],
        # rlnc has no replay through a repetition schedule: its goodput is the receiver's.
        "goodput_bps": (row["goodput_received_bps"] if scene.link.strategy == "rlnc"
                        else row.get("goodput_replayed_bps") or 0.0),
        "throughput_bps": bits * row["ok"] / duration_s,
        "throughput_bound_bps": bound_bps,
        "p_e": row.get("p_e"),
        "p_e_text": None if row.get("p_e") is None else p_e_text(
            {"p_e": row["p_e"], "p_e_ci95": [row["p_e_ci_low"], row["p_e_ci_high"]],
             "on_emissions": row["on_emissions"], "on_failures": row["on_failures"]}),
        "M": row.get("M"), "N": row.get("N"), "ok": row["ok"], "fully_visible": row["fully_visible"],
        "frames": frames, "seconds": row["render_s"] + row["decode_s"],
    }
