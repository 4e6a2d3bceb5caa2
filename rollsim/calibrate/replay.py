"""Goodput measured by replaying a trace.

Replaying reads the trace as a channel realisation: emission e of a
broadcast that starts at trace position w gets the trace's outcome at
w + e, whatever packet it carries. The trace is read cyclically (position
w + e modulo its length), as one period of a stationary channel: a replay
that needs more emissions than remain after its start goes on at the
trace's start instead of being dropped. Dropping such replays kept only
the fast ones and biased long messages upwards (a 1 kB log at r = 3 on
600 frames: 453 of 500 replays dropped, goodput +44 %). RP(r) is replayed
from up to 500 evenly spaced starts over the whole trace until every
packet has been received, or until ``max_emissions`` PHY-SDUs have been
sent (then the replay is capped and counts with goodput 0, as in the event
simulator and the paper, §6.3.1); goodput = P·N_p / duration.
"""

from __future__ import annotations

import math

import numpy as np

from rollsim.channel.eventsim import DEFAULT_MAX_EMISSIONS
from rollsim.transmitter import Schedule

_NEVER = np.iinfo(np.int64).max


def _first_receptions(hits: np.ndarray, horizon: int, start: int, seq_of, n_packets: int, emissions: int) -> int:
    """Emission index (from ``start``) at which the last packet is first received, or -1 if capped.

    ``hits`` are the trace positions with a success; the trace repeats
    every ``horizon`` positions. Only the first ``emissions`` emissions count.
    """
    laps = math.ceil((start + emissions) / horizon)
    unrolled = (hits[None, :] + horizon * np.arange(laps)[:, None]).ravel()
    offsets = unrolled[(unrolled >= start) & (unrolled < start + emissions)] - start
    first = np.full(n_packets, _NEVER)
    np.minimum.at(first, seq_of(offsets), offsets)
    done = int(first.max())
    return -1 if done == _NEVER else done


# Elements of the (starts × emissions) table the replays are read from at once; beyond it,
# the starts go in blocks (memory stays flat whatever the trace's length).
_TABLE_ELEMENTS = 4_000_000


def _first_receptions_all(x: np.ndarray, starts: np.ndarray, seq: np.ndarray, n_packets: int) -> np.ndarray:
    """:func:`_first_receptions` for every start at once, over the first ``seq.size`` emissions.

    Emission e of the replay from start w reads ``x[(w + e) mod len(x)]`` and carries packet
    ``seq[e]``, the same for every start. Grouping the emissions by packet (a stable sort of
    ``seq``), each packet's first reception is a minimum over its group (``reduceat``), and the
    replay ends at the last packet's. Returns the emission index of that end per start, −1 where
    some packet is not received within ``seq.size`` emissions.
    """
    horizon, emissions = x.size, seq.size
    order = np.argsort(seq, kind="stable")
    counts = np.bincount(seq, minlength=n_packets)
    if np.any(counts == 0):  # a packet never sent within the window: no replay completes
        return np.full(starts.size, -1, dtype=np.int64)
    bounds = np.concatenate([[0], np.cumsum(counts)[:-1]])
    index = order.astype(np.int64)
    block = max(1, _TABLE_ELEMENTS // max(1, emissions))
    done = np.empty(starts.size, dtype=np.int64)
    for lo in range(0, starts.size, block):
        w = starts[lo:lo + block]
        received = x[(w[:, None] + index[None, :]) % horizon]
        # The emission index where received, past the window where not.
        at = np.where(received, index[None, :], emissions)
        last = np.minimum.reduceat(at, bounds, axis=1).max(axis=1)
        done[lo:lo + block] = np.where(last >= emissions, -1, last)
    return done


def replay_goodput_bps(success, r: int, n_packets: int, payload_bits: int, sdu_duration_s: float, max_starts: int = 500,
                       strategy: str = "rp", max_emissions: int = DEFAULT_MAX_EMISSIONS) -> dict:
    """Mean goodput of RP(r) (or RS(r)) replayed over the trace, read cyclically, from up to ``max_starts`` starts.

    Parameters
    ----------
    success : array_like of bool
        Outcome of each emission of the trace, in emission order.
    r : int
        Repeats of the strategy.
    n_packets : int
        Packets of the message.
    payload_bits : int
        P, bits per packet.
    sdu_duration_s : float
        PHY-SDU duration, s.
    max_starts : int, default 500
        Starts, evenly spaced over the trace.
    strategy : {'rp', 'rs'}
    max_emissions : int, default 50000
        Emissions after which a replay is capped (goodput 0).

    Returns
    -------
    dict
        ``goodput_bps`` (mean over the starts, capped replays as 0; None
        for an empty trace), ``ci95`` (its 95 % interval by batch means,
        :func:`batch_means_interval`, batches at least a replay long; None
        for a trace shorter than two replays),
        ``replays`` (starts replayed), ``capped`` (replays that hit
        ``max_emissions``) and ``trace_rounds`` (the trace's length in
        rounds of ``r * n_packets`` emissions: below 1, every replay
        reuses outcomes of the trace).
    """
    x = np.asarray(success, dtype=bool)
    horizon = x.size
    rounds = horizon / (r * n_packets)
    if horizon == 0:
        return {"goodput_bps": None, "ci95": None, "replays": 0, "capped": 0, "trace_rounds": rounds}
    schedule = Schedule(strategy, n_packets, r)
    hits = np.flatnonzero(x)
    starts = np.unique(np.linspace(0, horizon - 1, max_starts).astype(np.int64))
    # Most replays end within a few rounds: every start is read over that window at once, the
    # starts not done over a window one trace longer, and the rest one by one up to the cap.
    few_rounds = 4 * r * n_packets
    windows = sorted({min(max_emissions, few_rounds), min(max_emissions, few_rounds + horizon)})
    first_done = np.full(starts.size, -1, dtype=np.int64)
    for window in windows:
        pending = np.flatnonzero(first_done < 0)
        if pending.size:
            first_done[pending] = _first_receptions_all(x, starts[pending], schedule.sequence_numbers(np.arange(window)),
                                                        n_packets)
    goodputs, lengths, capped = [], [], 0
    for w, done in zip(starts.tolist(), first_done.tolist()):
        if done < 0 and windows[-1] < max_emissions:  # rare: a replay longer than a few rounds and a trace
            done = _first_receptions(hits, horizon, w, schedule.sequence_numbers, n_packets, max_emissions)
        if done < 0:
            capped += 1
            goodputs.append(0.0)
            lengths.append(max_emissions)
            continue
        goodputs.append(payload_bits * n_packets / ((done + 1) * sdu_duration_s))
        lengths.append(done + 1)
    return {"goodput_bps": float(np.mean(goodputs)),
            "ci95": replay_interval(np.array(goodputs), horizon, float(np.mean(lengths))),
            "replays": len(goodputs), "capped": capped, "trace_rounds": rounds}


# Batches of consecutive starts for the replay's interval: at most a tenth
# of the trace each (30 frames of a 300-frame trace, several cycles of the
# frame and emission clocks), and never shorter than a replay's mean length,
# so that replays that share outcomes fall mostly in one batch. A trace
# shorter than two replays has no interval.
REPLAY_BATCHES = 10


def replay_interval(per_start: np.ndarray, horizon: int, mean_length: float) -> tuple[float, float] | None:
    """95 % interval of a replayed goodput from its per-start values (in start order), by batch
    means: :data:`REPLAY_BATCHES` at most, each at least a replay's mean length (``mean_length``
    emissions, of a trace of ``horizon``), since a batch must outlast a replay or neighbouring
    batches share outcomes; None for a trace shorter than two replays."""
    return batch_means_interval(per_start, min(REPLAY_BATCHES, int(horizon // max(1.0, mean_length))))


def batch_means_interval(values: np.ndarray, batches: int = REPLAY_BATCHES) -> tuple[float, float] | None:
    """95 % interval of the mean of a correlated series by batch means.

    The series is cut into ``batches`` contiguous batches; their means are
    treated as independent, and the interval is Student's t on them. None
    with fewer than two batches.
    """
    from scipy.special import stdtrit

    values = np.asarray(values, dtype=np.float64)
    count = min(batches, values.size)
    if count < 2:
        return None
    means = np.array([chunk.mean() for chunk in np.array_split(values, count)])
    half = float(stdtrit(count - 1, 0.975)) * float(means.std(ddof=1)) / count**0.5
    centre = float(values.mean())
    return centre - half, centre + half
