"""Calibration: fit the MMBP and Gilbert-Elliott models to an outcome trace.

``calibrate(trace)`` fits both models, compares them (log-likelihood, AIC,
BIC, run-length distributions, whole-message probabilities against the
trace), and, when the trace carries its scene, predicts (M, N) from the
physics alone.
"""

from __future__ import annotations

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
from rollsim.calibrate.mmbp import MmbpFit, clopper_pearson, fit_mmbp_aligned, fit_mmbp_cycle
from rollsim.calibrate.trace import Trace, load_trace
from rollsim.errors import RollsimError

RUN_LENGTH_BINS = 12


def _fit_mmbp(trace: Trace, scene) -> MmbpFit:
    if scene is not None and trace.start_s is not None and trace.frame_starts_s is not None and trace.frame_starts_s.size:
        from rollsim.channel.scene_channel import sdu_duration_from_scene

        return fit_mmbp_aligned(
            trace.success, trace.start_s, trace.frame_starts_s, scene.camera.frame_period_s, sdu_duration_from_scene(scene)
        )
    return fit_mmbp_cycle(trace.success)


def physics_prediction(scene) -> dict:
    """(M, N) from the scene alone: frame period, LED rows × row time + exposure, PHY-SDU duration."""
    from rollsim.channel.scene_channel import capture_window_from_scene, mmbp_slots_from_scene, sdu_duration_from_scene

    slots = mmbp_slots_from_scene(scene)
    return {
        "M": slots.M,
        "N": slots.N,
        "mean_whole_sdus_per_frame": slots.mean_whole_sdus_per_frame,
        "capture_window_s": capture_window_from_scene(scene),
        "sdu_duration_s": sdu_duration_from_scene(scene),
        "frame_period_s": scene.camera.frame_period_s,
    }


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
        mmbp = _fit_mmbp(trace, scene)
        ge = fit_ge(success)
        ge_moments = ge_method_of_moments(success) if success.size >= 3 else None
    except ValueError as exc:
        raise RollsimError(f"{trace.source}: {exc}") from None
    if n_packets is None:
        n_packets = _scene_packets(scene) if scene is not None else 50
    n = success.size
    criteria = {
        "mmbp": information_criteria(mmbp.loglik, MMBP_PARAMETERS, n),
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
    }
    return result


def _scene_packets(scene) -> int:
    from rollsim.protocol import n_packets

    return n_packets(scene.link.message_bytes, scene.link.payload_bits)


__all__ = [
    "GeFit",
    "MmbpFit",
    "Trace",
    "calibrate",
    "clopper_pearson",
    "fit_ge",
    "fit_mmbp_aligned",
    "fit_mmbp_cycle",
    "ge_method_of_moments",
    "load_trace",
    "physics_prediction",
]
