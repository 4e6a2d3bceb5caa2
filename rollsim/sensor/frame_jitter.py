"""Frame start jitter: frame k starts at t_k = k·T_f + ε_k.

Two laws for ε_k, with σ = ``std_us``:

``independent``
    ε_k ~ Normal(0, σ), independent per frame (a frame clock that does not
    drift), truncated to ±margin/2.
``random_walk``
    ε_0 = 0 and ε_{k+1} = ε_k + δ_k, δ_k ~ Normal(0, σ) truncated to
    ±margin: the frame clock drifts, and ε_k is a sum of k steps.

Frames never overlap: the margin is T_f − (H·t_row + t_exp), the time
between the end of one frame's capture (readout plus the last row's
exposure, a row time to spare) and the next frame's start, so the truncation
keeps t_{k+1} − t_k ≥ H·t_row + t_exp. A σ whose truncation would cut more
than the tails beyond ``TRUNCATION_SIGMAS`` standard deviations is refused
(:func:`max_std_s`, which the ``frame_jitter`` effect checks): the law
would no longer be the normal it claims to be.

The draws come from one per-scene stream (:mod:`rollsim.numerics.frame_sequence`), so
ε_k depends only on the seed and k.
"""

from __future__ import annotations

from rollsim.numerics.frame_sequence import FrameSequence

STREAM = "frame_jitter"
TRUNCATION_SIGMAS = 4.0


def frame_margin_s(frame_period_s: float, readout_s: float, exposure_s: float) -> float:
    """T_f − (H·t_row + t_exp): how far two frame starts may come closer, in seconds."""
    return frame_period_s - readout_s - exposure_s


def jitter_bound_s(margin_s: float, mode: str) -> float:
    """Truncation of ε_k (``independent``) or of each step (``random_walk``), in seconds."""
    return 0.5 * margin_s if mode == "independent" else margin_s


def max_std_s(margin_s: float, mode: str) -> float:
    """Largest σ allowed for a margin: the bound is at least :data:`TRUNCATION_SIGMAS` σ, in seconds."""
    return max(0.0, jitter_bound_s(margin_s, mode) / TRUNCATION_SIGMAS)


class FrameJitter:
    """ε_k of a scene, in seconds.

    Parameters
    ----------
    seed : int
        Scene seed.
    std_s : float
        σ in seconds (≥ 0; 0 gives ε_k = 0).
    mode : {"independent", "random_walk"}
    margin_s : float
        :func:`frame_margin_s` of the camera.
    """

    def __init__(self, seed: int, std_s: float, mode: str, margin_s: float):
        if mode not in ("independent", "random_walk"):
            raise ValueError(f"unknown frame jitter mode {mode!r}")
        self.std_s, self.mode = std_s, mode
        self._draws = None
        if std_s > 0:
            self._draws = FrameSequence(seed, STREAM, 1, jitter_bound_s(margin_s, mode) / std_s)

    def offset_s(self, frame: int) -> float:
        """ε_k of frame ``frame`` (≥ 0), in seconds."""
        if self._draws is None:
            return 0.0
        values = self._draws.draws(frame) if self.mode == "independent" else self._draws.walk(frame)
        return float(values[0, 0]) * self.std_s
