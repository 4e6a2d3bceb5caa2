"""Goodput measured by replaying a trace, and predicted by the MMBP simulator.

Replaying reads the trace as a channel realisation: emission e of a
broadcast that starts at trace position w gets the trace's outcome at
w + e, whatever packet it carries. RP(r) is replayed from up to 500
evenly spaced starts in the first half of the trace (the second half is the
runway), until every packet has been received; goodput = P·N_p / duration.
"""

from __future__ import annotations

import numpy as np

from rollsim.channel.channels import MmbpChannel
from rollsim.channel.eventsim import simulate_broadcast
from rollsim.transmitter import Schedule


def replay_goodput_bps(success, r: int, n_packets: int, payload_bits: int, sdu_duration_s: float, max_starts: int = 500,
                       strategy: str = "rp") -> dict:
    """Mean goodput of RP(r) (or RS(r)) replayed over the trace from starts in its first half.

    Returns ``{"goodput_bps", "replays", "completed"}``; a replay that does
    not complete before the trace ends is left out (and counted).
    """
    x = np.asarray(success, dtype=bool)
    schedule = Schedule(strategy, n_packets, r)
    horizon = x.size
    seq = schedule.sequence_numbers(np.arange(horizon))
    goodputs, incomplete = [], 0
    starts = np.unique(np.linspace(0, max(0, horizon // 2 - 1), max_starts).astype(np.int64))
    for w in starts.tolist():
        got = x[w:]
        # First emission index at which each packet is received.
        hits = np.flatnonzero(got)
        if hits.size == 0:
            incomplete += 1
            continue
        first = np.full(n_packets, np.iinfo(np.int64).max)
        np.minimum.at(first, seq[hits], hits)
        done = first.max()
        if done == np.iinfo(np.int64).max:
            incomplete += 1
            continue
        goodputs.append(payload_bits * n_packets / ((done + 1) * sdu_duration_s))
    return {
        "goodput_bps": float(np.mean(goodputs)) if goodputs else None,
        "replays": len(goodputs),
        "incomplete": incomplete,
    }


def mmbp_goodput_bps(M: int, N: int, p_e: float, r: int, n_packets: int, payload_bits: int, header_bits: int,
                     sdu_duration_s: float, runs: int = 2000, seed: int = 1) -> float:
    """Mean goodput of RP(r) that the ``mmbp`` event simulator predicts.

    A channel with no ON slot, or p_e = 1, never delivers: 0 without
    simulating runs that could only hit the emission cap.
    """
    if M == 0 or p_e >= 1.0:
        return 0.0
    result = simulate_broadcast(
        MmbpChannel(M, N, p_e, sdu_duration_s), Schedule("rp", n_packets, r),
        header_bits=header_bits, payload_bits=payload_bits, runs=runs, seed=seed, workers=1,
    )
    return float(result.summary()["metrics"]["goodput_bps"]["mean"])
