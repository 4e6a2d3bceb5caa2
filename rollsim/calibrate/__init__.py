"""Calibration: fit the MMBP and Gilbert-Elliott models to an outcome trace.

``calibrate(trace)`` fits both models, compares them (log-likelihood, AIC,
BIC, run-length distributions, whole-message probabilities against the
trace), and, when the trace carries its scene, predicts (M, N) from the
physics alone.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rollsim.calibrate.compare import (
    GE_PARAMETERS,
    MMBP_PARAMETERS,
    information_criteria,
    message_curves,
    run_length_distribution,
    run_lengths,
    simulate_ge_trace,
    simulate_mmbp_trace,
)
from rollsim.calibrate.ge import GeFit, fit_ge, ge_method_of_moments
from rollsim.calibrate.goodput import agreement_summary, goodput_table
from rollsim.calibrate.mmbp import (
    MmbpFit,
    clopper_pearson,
    fit_mmbp_aligned,
    fit_mmbp_cycle,
    p_e_text,
    wilson_interval,
    zero_failure_bound,
)
from rollsim.calibrate.heldout import ge_heldout, mmbp_heldout
from rollsim.calibrate.position import PositionFit, fit_position, frame_offsets
from rollsim.calibrate.trace import Trace, load_trace
from rollsim.errors import RollsimError

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

RUN_LENGTH_BINS = 12


def _aligned(trace: Trace) -> bool:
    return (trace.scene is not None and trace.start_s is not None and trace.frame_starts_s is not None
            and trace.frame_starts_s.size > 0)


def _frame_clock(trace: Trace) -> tuple[float, float]:
    from rollsim.channel.scene_channel import sdu_duration_from_scene

    assert trace.scene is not None
    return trace.scene.camera.frame_period_s, sdu_duration_from_scene(trace.scene)


def fit_mmbp(trace: Trace) -> MmbpFit:
    """The MMBP fit of a trace: aligned to its frames when it carries them and
    its scene, else by the best cycle.

    Raises
    ------
    ValueError
        For a trace the model cannot be fitted to (empty, no success).
    """
    if _aligned(trace):
        return fit_mmbp_aligned(trace.success, trace.start_s, trace.frame_starts_s, *_frame_clock(trace))
    return fit_mmbp_cycle(trace.success)


def physics_prediction(scene: Scene) -> dict:
    """(M, N) from the scene alone: frame period, LED rows × row time + exposure, PHY-SDU duration.

    Always from the physics, even when the scene's ``channel`` gives M and N
    for the MMBP layer.
    """
    from rollsim.channel.analytic import mmbp_slots_from_physics
    from rollsim.channel.scene_channel import capture_window_from_scene, sdu_duration_from_scene

    window_s, sdu_s = capture_window_from_scene(scene), sdu_duration_from_scene(scene)
    slots = mmbp_slots_from_physics(scene.camera.frame_period_s, window_s, sdu_s)
    return {
        "M": slots.M,
        "N": slots.N,
        "mean_whole_sdus_per_frame": slots.mean_whole_sdus_per_frame,
        "capture_window_s": window_s,
        "sdu_duration_s": sdu_s,
        "frame_period_s": scene.camera.frame_period_s,
    }


def goodput_consistency(table: list[dict], model: str = "mmbp", strategy: str = "rp") -> list[dict]:
    """One model's rows of :func:`rollsim.calibrate.goodput.goodput_table` for one strategy.

    Rows: ``r``, ``predicted_bps``, ``replayed_bps`` (None for an empty
    trace), ``interval``, ``relative_difference`` (predicted / replayed − 1), ``agrees``.
    """
    keys = ("r", "predicted_bps", "replayed_bps", "interval", "relative_difference", "agrees")
    return [{k: row[k] for k in keys} for row in table if row["model"] == model and row["strategy"] == strategy]


def fit_position_model(trace: Trace):
    """The position model (:mod:`rollsim.calibrate.position`) of a trace with its frames, else None."""
    if not _aligned(trace):
        return None
    frame_period_s, sdu_s = _frame_clock(trace)
    return fit_position(trace.success, trace.start_s, trace.frame_starts_s, frame_period_s, sdu_s)


def heldout_logliks(trace: Trace, position, ge: GeFit | None = None) -> dict:
    """Held-out log-likelihood of each model over folds of frames (:mod:`rollsim.calibrate.heldout`);
    empty without frame times."""
    if not _aligned(trace) or position is None:
        return {}
    frame_period_s, sdu_s = _frame_clock(trace)
    frame, _ = frame_offsets(trace.start_s, trace.frame_starts_s, frame_period_s)
    success = np.asarray(trace.success, dtype=bool)
    return {
        "mmbp": mmbp_heldout(success, trace.start_s, trace.frame_starts_s, frame, frame_period_s, sdu_s),
        "ge": ge_heldout(success, frame, ge),
        "position": position.cv_loglik.get(position.segments),
    }


def model_profiles(mmbp: MmbpFit, position, frame_period_s: float, sdu_duration_s: float) -> dict:
    """Each periodic model as slot profiles for the exact goodput (:mod:`rollsim.channel.periodic`)."""
    from rollsim.calibrate.goodput import mmbp_profile
    from rollsim.channel.position import slot_profiles

    profiles = {"mmbp": mmbp_profile(mmbp.M, mmbp.N, mmbp.p_e)}
    if position is not None:
        slots = slot_profiles(frame_period_s, sdu_duration_s, position.edges_s, position.success)
        profiles["position"] = (slots.success, slots.weights)
    return profiles


def _run_length_comparison(success, mmbp: MmbpFit, ge: GeFit, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    n = max(100_000, 20 * success.size)
    models = {
        "empirical": success,
        "mmbp": simulate_mmbp_trace(mmbp.M, mmbp.N, mmbp.p_e, n, rng),
        "ge": simulate_ge_trace(ge.p, ge.q, ge.p_e, n, rng),
    }
    out = {}
    for kind in ("success", "loss"):
        out[kind] = {name: run_length_distribution(run_lengths(x)[kind], RUN_LENGTH_BINS) for name, x in models.items()}
    return out


def calibrate(trace: Trace, n_packets: int | None = None, seed: int = 1) -> dict:
    """Fit, compare and predict (see the module docstring); a JSON-ready dict.

    Parameters
    ----------
    trace : Trace
    n_packets : int, optional
        N_p for the whole-message curves; default the scene's, else 50.
    seed : int
        Seed of the model simulations behind the run-length distributions.

    Raises
    ------
    RollsimError
        For a trace the models cannot be fitted to (empty, no success).
    """
    success = np.asarray(trace.success, dtype=bool)
    scene = trace.scene
    try:
        mmbp = fit_mmbp(trace)
        ge = fit_ge(success)
        ge_moments = ge_method_of_moments(success) if success.size >= 3 else None
        position = fit_position_model(trace)
    except ValueError as exc:
        raise RollsimError(f"{trace.source}: {exc}") from None
    if n_packets is None:
        n_packets = _scene_packets(scene) if scene is not None else 50
    n = success.size
    criteria = {
        # A leak past the aligned window's edge is one more fitted rate.
        "mmbp": information_criteria(mmbp.loglik, MMBP_PARAMETERS + int(mmbp.off_successes > 0), n),
        "ge": information_criteria(ge.loglik, GE_PARAMETERS, n),
    }
    if position is not None:
        criteria["position"] = information_criteria(position.loglik, position.parameters, n)
    heldout = heldout_logliks(trace, position, ge)
    scored = {k: v for k, v in heldout.items() if v is not None}
    table = None
    if scene is not None:
        frame_period_s, sdu_s = _frame_clock(trace)
        table = goodput_table(success, scene.link, sdu_s, _scene_packets(scene),
                              model_profiles(mmbp, position, frame_period_s, sdu_s), ge=ge, seed=seed,
                              rlnc=rlnc_allowed(scene))
    result = {
        "source": trace.source,
        "emissions": int(n),
        "successes": int(success.sum()),
        "mmbp": mmbp.as_dict(),
        "ge": ge.as_dict(),
        "ge_moments": ge_moments.as_dict() if ge_moments is not None else None,
        "position": position.as_dict() if position is not None else None,
        "criteria": criteria,
        "heldout_loglik": heldout,
        "selected_by_aic": min(criteria, key=lambda k: criteria[k]["aic"]),
        "selected_by_bic": min(criteria, key=lambda k: criteria[k]["bic"]),
        "selected_by_heldout": max(scored, key=lambda k: scored[k]) if scored else None,
        "run_lengths": _run_length_comparison(success, mmbp, ge, seed),
        "message": {"n_packets": n_packets, "curves": message_curves(success, mmbp, ge, n_packets)},
        "prediction": physics_prediction(scene) if scene is not None else None,
        "goodput": table,
        "goodput_agreement": agreement_summary(table) if table is not None else None,
        "goodput_rp": goodput_consistency(table) if table is not None else None,
    }
    return result


def rlnc_allowed(scene: Scene) -> bool:
    """Whether the scene's header can carry rlnc's seeds (as the scene's own rlnc rule asks)."""
    from rollsim.protocol.rlnc import seed_space

    header = scene.link.header_bits
    return header >= 1 and seed_space(header) >= _scene_packets(scene)


def _scene_packets(scene: Scene) -> int:
    from rollsim.protocol import n_packets

    return n_packets(scene.link.message_bytes, scene.link.payload_bits)


__all__ = [
    "GeFit",
    "MmbpFit",
    "PositionFit",
    "Trace",
    "calibrate",
    "clopper_pearson",
    "p_e_text",
    "wilson_interval",
    "zero_failure_bound",
    "fit_ge",
    "fit_mmbp",
    "fit_mmbp_aligned",
    "fit_mmbp_cycle",
    "fit_position",
    "fit_position_model",
    "format_calibration",
    "ge_method_of_moments",
    "goodput_consistency",
    "load_trace",
    "physics_prediction",
]


def format_calibration(result: dict) -> str:
    """The fitted parameters and the model comparison as plain text."""
    from rollsim.plumbing.text_tables import format_number as _number
    from rollsim.plumbing.text_tables import format_table

    m, ge, mom = result["mmbp"], result["ge"], result["ge_moments"]
    lines = [
        f"calibration of {result['source']}: {result['emissions']} emissions, {result['successes']} successes",
        f"MMBP ({m['method']}): M = {m['M']}, N = {m['N']}, {p_e_text(m, _number)}, "
        f"mean ON slots per frame {m['mean_on_per_frame']:.3f}"
        + (f"; {m['off_successes']} read past the window's edge" if m.get("off_successes") else ""),
        f"Gilbert-Elliott (maximum likelihood): p = {_number(ge['p'])}, q = {_number(ge['q'])}, p_e = {_number(ge['p_e'])}",
    ]
    if mom is not None:
        lines.append(f"Gilbert-Elliott (moments): p = {_number(mom['p'])}, q = {_number(mom['q'])}, p_e = {_number(mom['p_e'])}")
    prediction = result.get("prediction")
    if prediction is not None:
        lines.append(
            f"physics prediction: M = {prediction['M']}, N = {prediction['N']} "
            f"({prediction['mean_whole_sdus_per_frame']:.3f} whole PHY-SDUs per frame)"
        )
    position = result.get("position")
    if position is not None:
        lines.append(position_text(position, _number))
    criteria, heldout = result["criteria"], result.get("heldout_loglik") or {}
    fits = {"mmbp": m, "ge": ge, "position": position}
    rows = [(name, _number(fits[name]["loglik"], 6), _number(criteria[name]["aic"], 6), _number(criteria[name]["bic"], 6),
             "n/a" if heldout.get(name) is None else _number(heldout[name], 6)) for name in criteria]
    lines += ["", format_table(rows, ("model", "log L", "AIC", "BIC", "held-out log L")),
              f"selected by AIC: {result['selected_by_aic']}, by BIC: {result['selected_by_bic']}"
              + (f", by held-out likelihood: {result['selected_by_heldout']}" if result.get("selected_by_heldout") else ""),
              ""]
    curves = result["message"]["curves"]
    curve_rows = [(c["r"], c["strategy"], _number(c["mmbp"]), _number(c["ge"]), _number(c["empirical"]))
                  for c in curves]
    lines += [f"P(whole message of {result['message']['n_packets']} packets in one round)",
              format_table(curve_rows, ("r", "strategy", "MMBP", "GE", "empirical"))]
    if result.get("goodput"):
        lines += ["", goodput_text(result["goodput"], _number)]
    return "\n".join(lines)


def position_text(position: dict, number) -> str:
    """The position model in one line: its steps (offsets in PHY-SDUs from the first edge) and rates."""
    steps = ", ".join(f"{a:.3f}–{b:.3f}: {number(q)}" for a, b, q in
                      zip(position["edges_sdu"][:-1], position["edges_sdu"][1:], position["success"]))
    return f"position model ({position['segments']} steps, by held-out likelihood): success by start offset [T_p] {steps}"


def goodput_text(table: list[dict], number) -> str:
    """Predicted against replayed goodput, a row per strategy and r, a column per model."""
    from rollsim.plumbing.text_tables import format_table

    models = list(dict.fromkeys(row["model"] for row in table))
    keyed = {(row["strategy"], row["r"], row["model"]): row for row in table}
    rows = []
    for strategy, r in dict.fromkeys((row["strategy"], row["r"]) for row in table):
        first = keyed[(strategy, r, models[0])]
        low_high = first["interval"]
        cells = []
        for model in models:
            row = keyed[(strategy, r, model)]
            diff = "n/a" if row["relative_difference"] is None else f"{100 * row['relative_difference']:+.1f} %"
            diff = "not computed" if row["predicted_bps"] is None else diff
            cells.append(diff + {True: "", False: " ✗", None: " ?"}[row["agrees"]])
        rows.append((strategy.upper(), r, number(first["replayed_bps"], 5) if first["replayed_bps"] is not None else "n/a",
                     "n/a" if low_high is None else f"{number(low_high[0], 4)}–{number(low_high[1], 4)}", *cells))
    return ("goodput (bit/s) replayed over the trace, and each model's prediction against it "
            "(✗: outside 3 % and the replay's 95 % interval; ?: outside 3 % of a trace too short for an interval)\n"
            + format_table(rows, ("strategy", "r", "replayed", "95 % interval", *models)))


# rollsim.calibrate(...) is the Python API's function (rollsim.api).
from rollsim.plumbing.callable_module import make_callable  # noqa: E402

make_callable(__name__)
