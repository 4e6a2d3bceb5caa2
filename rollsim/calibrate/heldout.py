"""Held-out likelihood: each fold of frames predicted by a model fitted to the other frames.

The information criteria count parameters; the held-out likelihood asks
the question a user has of a channel model directly: does it predict
frames it was not fitted to? The frames are cut into contiguous folds
(:func:`frame_folds`); each fold's emissions are scored under the model
fitted to the rest, and the scores are summed. Rates are estimated for
prediction with the Krichevsky–Trofimov rule, (s + ½) / (n + 1), so that a
rate with no failure in training does not give a held-out failure
probability of 0.
"""

from __future__ import annotations

import math

import numpy as np

FOLDS = 5
KT = 0.5


def frame_folds(frame: np.ndarray, folds: int = FOLDS) -> list[np.ndarray]:
    """Masks of the emissions of each fold: the frames cut into ``folds`` contiguous blocks."""
    frames = np.unique(frame)
    blocks = np.array_split(frames, min(folds, frames.size))
    return [np.isin(frame, block) for block in blocks if block.size]


def kt_rate(successes, trials) -> np.ndarray:
    """The Krichevsky–Trofimov success probability, (s + ½) / (n + 1)."""
    return (np.asarray(successes, dtype=np.float64) + KT) / (np.asarray(trials, dtype=np.float64) + 2 * KT)


def bernoulli_score(success: np.ndarray, q: np.ndarray) -> float:
    """Log-probability of outcomes ``success`` under success probabilities ``q`` (each in (0, 1))."""
    return float(np.sum(np.log(np.where(success, q, 1.0 - q))))


def mmbp_heldout(success: np.ndarray, start_s, frame_starts_s, frame: np.ndarray, frame_period_s: float,
                 sdu_duration_s: float) -> float | None:
    """Held-out log-likelihood of the MMBP as it predicts: a cycle of M + N slots.

    The MMBP's goodput and message probabilities come from its cycle
    (emission k in slot (k + φ) mod (M + N), slots 0 … M − 1 ON), so that
    is the model scored: M and N from the aligned fit to the training
    frames, the phase φ of greatest training likelihood, and the ON and OFF
    slots' success rates from the training emissions. Where T_f / T_p is
    not the whole number M + N, the cycle drifts against the frames, and
    the held-out frames say so. None when a training fold has no success.
    """
    from rollsim.calibrate.mmbp import fit_mmbp_aligned

    total = 0.0
    start_s = np.asarray(start_s, dtype=np.float64)
    for test in frame_folds(frame):
        train = ~test
        if not success[train].any():
            return None
        fit = fit_mmbp_aligned(success[train], start_s[train], frame_starts_s, frame_period_s, sdu_duration_s)
        cycle = fit.M + fit.N
        slot = np.arange(success.size) % cycle
        counts = {name: np.bincount(slot[mask], minlength=cycle).astype(np.float64) for name, mask in
                  (("n", train), ("s", train & success), ("n_test", test), ("s_test", test & success))}
        # on[φ, j]: slot j is ON at phase φ.
        on = ((np.arange(cycle)[None, :] + np.arange(cycle)[:, None]) % cycle) < fit.M
        q_on = kt_rate(on @ counts["s"], on @ counts["n"])[:, None]
        q_off = kt_rate(~on @ counts["s"], ~on @ counts["n"])[:, None]
        log_q = np.where(on, np.log(q_on), np.log(q_off))
        log_1mq = np.where(on, np.log1p(-q_on), np.log1p(-q_off))

        train_score = log_q @ counts["s"] + log_1mq @ (counts["n"] - counts["s"])
        test_score = log_q @ counts["s_test"] + log_1mq @ (counts["n_test"] - counts["s_test"])
        total += float(test_score[int(np.argmax(train_score))])
    return total


def ge_heldout(success: np.ndarray, frame: np.ndarray, whole=None) -> float | None:
    """Held-out log-likelihood of Gilbert-Elliott: each fold's emissions (contiguous) scored from a
    stationary start under the parameters fitted to the other folds' emissions, joined in order.

    ``whole``, the fit to the whole trace, starts each fold's optimisation (one start, not five).
    """
    from rollsim.calibrate.ge import fit_ge, ge_loglik

    total = 0.0
    for test in frame_folds(frame):
        train = success[~test]
        if not train.any():
            return None
        fit = fit_ge(train, start=whole)
        value = ge_loglik(success[test], fit.p, fit.q, fit.p_e)
        if not math.isfinite(value):
            return -math.inf
        total += value
    return total
