"""Goodput each fitted channel model predicts, against the trace replayed.

For every model, for RP and RS at r = 1 … 6 and for rlnc where the
scene's header can carry its seeds, the mean goodput of a
broadcast of the scene's message (capped broadcasts counting 0, as the
event simulator and the paper count them) is predicted and set beside the
same figure replayed over the trace (:func:`rollsim.calibrate.replay.replay_goodput_bps`,
with its 95 % interval by batch means). A prediction *agrees* when it lies
within :data:`AGREEMENT` of the replay or inside the replay's interval,
whichever is wider.

How each model predicts:

* MMBP and position model: exactly (:mod:`rollsim.channel.periodic`), the
  MMBP as a cycle of M slots of success 1 − p_e and N of 0, the position
  model as the slot profiles of its step function
  (:mod:`rollsim.channel.position`);
* Gilbert-Elliott: by replaying a trace simulated from the fit,
  :data:`GE_TRACE_LENGTHS` times as long as the measured one, from
  :data:`GE_STARTS` starts (a Markov chain has no finite cycle to sum
  over); the figure carries that simulation's spread.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from rollsim.calibrate.replay import replay_goodput_bps

R_VALUES = tuple(range(1, 7))
STRATEGIES = ("rp", "rs")
# A prediction within 3 % of the replay agrees (the wider of this and the replay's interval).
AGREEMENT = 0.03
# Replay starts, evenly spaced over the trace (as replay_goodput_bps).
REPLAY_STARTS = 500
GE_TRACE_LENGTHS = 20
GE_STARTS = 1000


def mmbp_profile(M: int, N: int, p_e: float) -> tuple[np.ndarray, np.ndarray]:
    """The MMBP as one periodic slot profile: M slots of success 1 − p_e, then N of 0."""
    return np.array([[1.0 - p_e] * M + [0.0] * N]), np.ones(1)


def agrees(predicted: float, replayed: float | None, interval) -> bool | None:
    """Whether a prediction agrees with the replay (see the module docstring).

    None when it cannot be told: no replay, or a prediction more than
    :data:`AGREEMENT` away from a replay that has no interval (a trace
    shorter than two replays).
    """
    if replayed is None:
        return None
    if replayed == 0.0:
        if predicted == 0.0:
            return True
        return None if interval is None else bool(predicted <= interval[1])
    if abs(predicted / replayed - 1.0) <= AGREEMENT:
        return True
    if interval is None:
        return None
    return bool(interval[0] <= predicted <= interval[1])


def _row(model, strategy, r, predicted, replay, method) -> dict:
    replayed = replay["goodput_bps"]
    difference = predicted / replayed - 1.0 if replayed and predicted is not None else None
    return {"model": model, "strategy": strategy, "r": r, "predicted_bps": predicted, "method": method,
            "replayed_bps": replayed, "interval": None if replay["ci95"] is None else list(replay["ci95"]),
            "relative_difference": difference,
            "agrees": None if predicted is None else agrees(predicted, replayed, replay["ci95"])}


def goodput_table(success, link, sdu_duration_s: float, n_packets: int, profiles: dict, ge=None,
                  r_values: Sequence[int] = R_VALUES, seed: int = 1, rlnc: bool = False) -> list[dict]:
    """Predicted against replayed goodput for every model, strategy and r.

    Parameters
    ----------
    success : array_like of bool
        The trace, in emission order.
    link : LinkSection
        The scene's link (``payload_bits``).
    sdu_duration_s : float
        T_p, seconds.
    n_packets : int
        Packets of the message.
    profiles : dict
        Model name -> (success (P, C), weights (P,)): the periodic models.
    ge : GeFit, optional
        The Gilbert-Elliott fit, predicted by simulation.
    r_values : sequence of int
    seed : int
        Seed of the Gilbert-Elliott simulation.
    rlnc : bool
        Also the rateless broadcast (strategy ``rlnc``, r = 1), exact for
        the periodic models (:mod:`rollsim.channel.periodic_rlnc`) and
        replayed over the trace as RP and RS are.

    Returns
    -------
    list of dict
        ``model``, ``strategy``, ``r``, ``predicted_bps`` (None when the
        exact sum is too costly), ``method`` (``exact``, ``simulated``, or
        ``not computed: <why>``), ``replayed_bps``, ``interval`` (the
        replay's 95 % interval; None for a trace shorter than two replays),
        ``relative_difference`` (predicted / replayed − 1, None without a
        replay) and ``agrees``.
    """
    from rollsim.calibrate.compare import simulate_ge_trace
    from rollsim.channel.analytic import ExactSumTooCostly
    from rollsim.calibrate.replay import replay_interval
    from rollsim.channel.periodic import goodput_bps
    from rollsim.channel.periodic_rlnc import rlnc_periodic_figures, rlnc_replay_goodput_bps

    success = np.asarray(success, dtype=bool)
    payload = link.payload_bits
    ge_trace = None
    if ge is not None:
        ge_trace = simulate_ge_trace(ge.p, ge.q, ge.p_e, GE_TRACE_LENGTHS * success.size, np.random.default_rng(seed))
    def rows_for(strategy: str, r: int) -> list[dict]:
        replay = replay_goodput_bps(success, r, n_packets, payload, sdu_duration_s, strategy=strategy,
                                    max_starts=REPLAY_STARTS)
        out = []
        for model, (q, weights) in profiles.items():
            try:
                predicted = goodput_bps(q, weights, r, n_packets, strategy, payload, sdu_duration_s)["mean_goodput_bps"]
            except ExactSumTooCostly as exc:
                # A channel that completes a message once in many thousand emissions: no figure, and why.
                out.append(_row(model, strategy, r, None, replay, f"not computed: {exc}"))
                continue
            out.append(_row(model, strategy, r, predicted, replay, "exact"))
        if ge_trace is not None:
            simulated = replay_goodput_bps(ge_trace, r, n_packets, payload, sdu_duration_s, strategy=strategy,
                                           max_starts=GE_STARTS)["goodput_bps"]
            out.append(_row("ge", strategy, r, simulated, replay, "simulated"))
        return out

    def rlnc_rows() -> list[dict]:
        measured = rlnc_replay_goodput_bps(success, n_packets, payload, sdu_duration_s, max_starts=REPLAY_STARTS)
        replay = {"goodput_bps": measured["goodput_bps"],
                  "ci95": replay_interval(measured["per_start"], success.size, measured["mean_length"] or 1.0)
                  if measured["goodput_bps"] is not None else None}
        out = []
        for model, (q, weights) in profiles.items():
            try:
                predicted = rlnc_periodic_figures(q, weights, n_packets, payload, sdu_duration_s)["mean_goodput_bps"]
            except ExactSumTooCostly as exc:
                out.append(_row(model, "rlnc", 1, None, replay, f"not computed: {exc}"))
                continue
            out.append(_row(model, "rlnc", 1, predicted, replay, "exact"))
        if ge_trace is not None:
            simulated = rlnc_replay_goodput_bps(ge_trace, n_packets, payload, sdu_duration_s,
                                                max_starts=GE_STARTS)["goodput_bps"]
            out.append(_row("ge", "rlnc", 1, simulated, replay, "simulated"))
        return out

    rows: list[dict] = []
    for strategy in STRATEGIES:
        # RS emits the sequence of packets over and over whatever r is (r counts the
        # sequences of a round, and a broadcast repeats rounds): one r stands for all.
        shared = rows_for(strategy, r_values[0]) if strategy == "rs" and r_values else None
        for r in r_values:
            rows += [{**row, "r": r} for row in shared] if shared is not None else rows_for(strategy, r)
    if rlnc:
        rows += rlnc_rows()
    return rows


def agreement_summary(rows: Sequence[dict]) -> dict:
    """Model -> how many of its rows agree, disagree and cannot be told, and the largest |relative difference|."""
    out: dict[str, dict] = {}
    for row in rows:
        entry = out.setdefault(row["model"], {"agree": 0, "disagree": 0, "untold": 0, "rows": 0, "worst": 0.0})
        entry["rows"] += 1
        entry[{True: "agree", False: "disagree", None: "untold"}[row["agrees"]]] += 1
        if row["relative_difference"] is not None and math.isfinite(row["relative_difference"]):
            entry["worst"] = max(entry["worst"], abs(row["relative_difference"]))
    return out
