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
from rollsim.calibrate.mmbp import (
    MmbpFit,
    clopper_pearson,
    fit_mmbp_aligned,
    fit_mmbp_cycle,
    p_e_text,
    wilson_interval,
    zero_failure_bound,
)
from rollsim.calibrate.replay import mmbp_goodput_bps, replay_goodput_bps
from rollsim.calibrate.trace import Trace, load_trace
from rollsim.errors import RollsimError

if TYPE_CHECKING:
    from rollsim.scene.model import Scene

RUN_LENGTH_BINS = 12


def fit_mmbp(trace: Trace) -> MmbpFit:
    """The MMBP fit of a trace: aligned to its frames when it carries them and
    its scene, else by the best cycle.

    Raises
    ------
    ValueError
        For a trace the model cannot be fitted to (empty, no success).
    """
    scene = trace.scene
    if scene is not None and trace.start_s is not None and trace.frame_starts_s is not None and trace.frame_starts_s.size:
        from rollsim.channel.scene_channel import sdu_duration_from_scene

        return fit_mmbp_aligned(
            trace.success, trace.start_s, trace.frame_starts_s, scene.camera.frame_period_s, sdu_duration_from_scene(scene)
        )
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


def goodput_consistency(success, mmbp: MmbpFit, scene: Scene, r_values=range(1, 7), seed: int = 1) -> list[dict]:
    """RP(r) goodput the fitted MMBP predicts (event simulator) against the trace replayed.

    The paper's "within 10 % of the testbed", with the rendered trace as the
    testbed. Rows: ``r``, ``predicted_bps``, ``replayed_bps`` (capped replays
    count as 0; None for an empty trace), ``relative_difference`` (predicted / replayed − 1).
    """
    from rollsim.channel.scene_channel import sdu_duration_from_scene

    link = scene.link
    sdu_s, packets = sdu_duration_from_scene(scene), _scene_packets(scene)
    rows = []
    for r in r_values:
        predicted = mmbp_goodput_bps(
            mmbp.M, mmbp.N, mmbp.p_e, r, packets, link.payload_bits, link.header_bits, sdu_s, seed=seed
        )
        replayed = replay_goodput_bps(success, r, packets, link.payload_bits, sdu_s)["goodput_bps"]
        difference = predicted / replayed - 1.0 if replayed else None
        rows.append({"r": r, "predicted_bps": predicted, "replayed_bps": replayed, "relative_difference": difference})
    return rows


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
    result = {
        "source": trace.source,
        "emissions": int(n),
        "successes": int(success.sum()),
        "mmbp": mmbp.as_dict(),
        "ge": ge.as_dict(),
        "ge_moments": ge_moments.as_dict() if ge_moments is not None else None,
        "criteria": criteria,
        "selected_by_aic": min(criteria, key=lambda k: criteria[k]["aic"]),
        "selected_by_bic": min(criteria, key=lambda k: criteria[k]["bic"]),
        "run_lengths": _run_length_comparison(success, mmbp, ge, seed),
        "message": {"n_packets": n_packets, "curves": message_curves(success, mmbp, ge, n_packets)},
        "prediction": physics_prediction(scene) if scene is not None else None,
        "goodput_rp": goodput_consistency(success, mmbp, scene, seed=seed) if scene is not None else None,
    }
    return result


def _scene_packets(scene: Scene) -> int:
    from rollsim.protocol import n_packets

    return n_packets(scene.link.message_bytes, scene.link.payload_bits)


__all__ = [
    "GeFit",
    "MmbpFit",
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
    criteria = result["criteria"]
    rows = [(name, _number(fit["loglik"], 6), _number(criteria[name]["aic"], 6), _number(criteria[name]["bic"], 6))
            for name, fit in (("mmbp", m), ("ge", ge))]
    lines += ["", format_table(rows, ("model", "log L", "AIC", "BIC")),
              f"selected by AIC: {result['selected_by_aic']}, by BIC: {result['selected_by_bic']}", ""]
    curves = result["message"]["curves"]
    curve_rows = [(c["r"], c["strategy"], _number(c["mmbp"]), _number(c["ge"]), _number(c["empirical"]))
                  for c in curves]
    lines += [f"P(whole message of {result['message']['n_packets']} packets in one round)",
              format_table(curve_rows, ("r", "strategy", "MMBP", "GE", "empirical"))]
    goodput = result.get("goodput_rp")
    if goodput:
        rows = [(g["r"], _number(g["predicted_bps"], 5), _number(g["replayed_bps"], 5),
                 "n/a" if g["relative_difference"] is None else f"{100 * g['relative_difference']:+.1f} %") for g in goodput]
        lines += ["", "RP goodput (bit/s): fitted MMBP (event simulator) against the trace replayed",
                  format_table(rows, ("r", "MMBP", "replayed", "difference"))]
    return "\n".join(lines)


# rollsim.calibrate(...) is the Python API's function (rollsim.api).
from rollsim.plumbing.callable_module import make_callable  # noqa: E402

make_callable(__name__)
