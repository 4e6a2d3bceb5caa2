"""How much a scene's frame starts may jitter: the limits the scene loader checks.

The jitter ε_k is truncated so that consecutive frames never overlap (see
:mod:`rollsim.sensor.frame_jitter`, which draws it): the margin is
T_f − (H·t_row + t_exp), and a σ whose truncation would cut more than the
tails beyond :data:`TRUNCATION_SIGMAS` standard deviations is refused. This
is configuration, so it lives with the scene and depends on no physics.
"""

from __future__ import annotations

TRUNCATION_SIGMAS = 4.0


def frame_margin_s(frame_period_s: float, readout_s: float, exposure_s: float) -> float:
    """T_f − (H·t_row + t_exp): how far two frame starts may come closer, in seconds."""
    return frame_period_s - readout_s - exposure_s


def jitter_bound_s(margin_s: float, mode: str) -> float:
    """Truncation of ε_k (``independent``) or of each step (``random_walk``), in seconds."""
    return 0.5 * margin_s if mode == "independent" else margin_s


def max_std_s(margin_s: float, mode: str) -> float:
    """Largest σ allowed for a margin: the bound is at least :data:`TRUNCATION_SIGMAS` σ."""
    return max(0.0, jitter_bound_s(margin_s, mode) / TRUNCATION_SIGMAS)


def frame_jitter_error(camera, params) -> str | None:
    """Why ``params`` cannot jitter frames of ``camera`` without overlap, or None.

    Parameters
    ----------
    camera : rollsim.scene.model.Camera
    params : rollsim.scene.effects.FrameJitter
    """
    if params.std_us == 0:
        return None
    margin = frame_margin_s(camera.frame_period_s, camera.readout_s, camera.exposure_s)
    limit = max_std_s(margin, params.mode)
    if params.std_us * 1e-6 <= limit:
        return None
    return (
        f"effects.frame_jitter.std_us = {params.std_us:g}: out of range for this camera, allowed [0, {limit * 1e6:.6g}] "
        f"(mode {params.mode}: frames must not overlap; the margin T_f - H*t_row - t_exp is {margin * 1e6:.6g} us "
        f"and the jitter is truncated at {TRUNCATION_SIGMAS:g} std)"
    )
