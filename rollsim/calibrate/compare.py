"""Comparing fitted channel models with the trace they were fitted to.

* Information criteria: AIC = 2k − 2 ln L and BIC = k ln n − 2 ln L, with
  k = 4 for the MMBP (M, N, phase, p_e) and 3 for Gilbert-Elliott (p, q, p_e).
* Run lengths: the distributions of success-run and loss-run lengths in the
  trace, against long traces simulated from each fitted model.
* Whole messages: for r = 1 … 10, the probability that every one of N_p
  packets is received within one round of r·N_p emissions, as each model
  predicts it, against the empirical frequency over every round-long window
  of the trace (the trace read as a channel realisation, each strategy
  replayed over it).
"""

from __future__ import annotations

import math

import numpy as np

from rollsim.channel.analytic import ge_p_message, mmbp_p_message

MMBP_PARAMETERS = 4
GE_PARAMETERS = 3


def information_criteria(loglik: float, parameters: int, n: int) -> dict:
    """AIC and BIC of a fit."""
    return {"aic": 2 * parameters - 2 * loglik, "bic": parameters * math.log(max(n, 1)) - 2 * loglik}


def run_lengths(success) -> dict[str, np.ndarray]:
    """Lengths of the maximal runs of successes and of losses."""
    x = np.asarray(success, dtype=np.int8)
    if x.size == 0:
        return {"success": np.zeros(0, np.int64), "loss": np.zeros(0, np.int64)}
    edges = np.flatnonzero(np.diff(x)) + 1
    starts = np.r_[0, edges]
    lengths = np.diff(np.r_[starts, x.size])
    values = x[starts]
    return {"success": lengths[values == 1], "loss": lengths[values == 0]}


def run_length_distribution(lengths: np.ndarray, max_length: int) -> list[float]:
    """P(run length = 1 … max_length), the last bin holding every longer run."""
    if lengths.size == 0:
        return [0.0] * max_length
    counts = np.bincount(np.minimum(lengths, max_length), minlength=max_length + 1)[1:]
    return (counts / lengths.size).tolist()


def simulate_mmbp_trace(M: int, N: int, p_e: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """A 0/1 trace of n emissions from the MMBP, random phase."""
    cycle = M + N
    on = ((np.arange(n) + rng.integers(cycle)) % cycle) < M
    return on & (rng.random(n) >= p_e)


def simulate_ge_trace(p: float, q: float, p_e: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """A 0/1 trace of n emissions from Gilbert-Elliott, stationary start (states by
    :func:`rollsim.channel.markov.ge_path`: no loop per emission)."""
    from rollsim.channel.markov import ge_path

    path = ge_path(p, q, n, rng, bool(rng.random() < p / (p + q)))
    return path & (rng.random(n) >= p_e)


def empirical_message_probability(success, r: int, n_packets: int, strategy: str) -> float | None:
    """Fraction of round-long windows of the trace in which a whole message gets through.

    For a window starting at emission w, packet k's copies are emissions
    w + k·r + j (RP) or w + k + j·n_packets (RS), j < r. None when the trace
    is shorter than one round.
    """
    x = np.asarray(success, dtype=bool)
    span = r * n_packets
    windows = x.size - span + 1
    if windows < 1:
        return None
    step, stride = (1, r) if strategy == "rp" else (n_packets, 1)
    # got[e]: a success among the r copies starting at emission e, spaced `step`.
    reach = x.size - (r - 1) * step
    got = np.zeros(reach, dtype=bool)
    for j in range(r):
        got |= x[j * step : j * step + reach]
    # A window succeeds when got[w + k·stride] holds for every packet k.
    misses = (~got).astype(np.int64)
    total = np.zeros(windows, dtype=np.int64)
    for k in range(n_packets):
        total += misses[k * stride : k * stride + windows]
    return float(np.mean(total == 0))


def message_curves(success, mmbp, ge, n_packets: int, r_values=range(1, 11)) -> list[dict]:
    """P(whole message in one round), predicted by each model and measured, per r and strategy."""
    rows = []
    for r in r_values:
        for strategy in ("rp", "rs"):
            rows.append(
                {
                    "r": r,
                    "strategy": strategy,
                    "mmbp": mmbp_p_message(mmbp.M, mmbp.N, r, mmbp.p_e, n_packets, strategy),
                    "ge": ge_p_message(ge.p, ge.q, r, ge.p_e, n_packets, strategy),
                    "empirical": empirical_message_probability(success, r, n_packets, strategy),
                }
            )
    return rows
