"""Event simulator: broadcast a message over a channel until it is received whole.

This is CamComSim's job (paper §6.2.3), vectorised and reproducible. A
transmitter cycles endlessly through the emission order of a strategy
(:class:`rollsim.transmitter.Schedule`: RP or RS, every run starting at
tx 0); a channel (:mod:`rollsim.channel.channels`) decides the outcome of
each emission. A run stops when every packet has been received at least
once (the message is complete) or when ``max_emissions`` PHY-SDUs have been
sent (then the run is *capped*: ``completed = False`` and goodput 0).
``n_r`` independent runs give the distribution of each metric.

Per run
-------
``emissions``
    PHY-SDUs sent, the completing one included (``max_emissions`` if capped).
``receptions``
    Emissions received (duplicates included).
``unique_receptions``
    Distinct packets received (``n_packets`` when completed).
``gap_losses``
    Emissions not wholly inside a capture window (IFG or OFF slot).
``decode_errors``
    Emissions inside a window but wrongly decoded (probability ``p_e``).
``duration_s``
    ``emissions x`` the channel's emission duration, seconds.
``goodput_bps``
    ``P * unique_receptions / duration_s`` if completed, else 0 (CamComSim).
``throughput_bps``
    ``(H + P) * receptions / duration_s`` (CamComSim), capped runs included.
``loss_streaks`` (only with ``record_loss_streaks=True``)
    Lengths of the runs of consecutive losses (gap or decode) that a
    reception ended, in order; a run's trailing losses, which no reception
    ended, are left out (CamComSim's ``nbConsecutiveDrop``).

A capped run counts with goodput 0, as the paper does (§6.3.1: "we stop the
simulation when 50000 PHY-SDU are sent [...] we consider the goodput is 0").

Reproducibility
---------------
One seed drives everything: run ``k`` uses child ``k`` of
``numpy.random.SeedSequence(seed)`` (``SeedSequence(seed).spawn(runs)[k]``),
whatever the number of runs, workers or chunks; nothing is seeded from the
clock. Each run draws its emissions in blocks of a size schedule that depends
only on the round length ``r * n_packets``, never on ``max_emissions``, so a
run capped at ``K`` emissions sees exactly the first ``K`` outcomes of the
same run uncapped.

Speed
-----
No Python loop per emission: each block of emissions is one set of array
operations (outcomes, sequence numbers of the received ones, first reception
of each new packet through ``np.unique``), and a run stops at the block in
which the message completes. Runs are split into chunks over a process pool.
"""

from __future__ import annotations

import math
from concurrent.futures import as_completed
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from rollsim.plumbing.budget import check_memory
from rollsim.channel.channels import DECODE_ERROR, GAP_LOSS, RECEIVED, ChannelModel, _as_count
from rollsim.plumbing.parallel import default_workers, process_pool
from rollsim.plumbing.text_tables import Shown, quantity
from rollsim.transmitter.schedule import RlncSchedule, Schedule

__all__ = [
    "CAMCOMSIM_FIELDS",
    "CAMCOMSIM_RUN_FIELDS",
    "DEFAULT_MAX_EMISSIONS",
    "METRICS",
    "BroadcastResult",
    "run_seed_sequence",
    "simulate_broadcast",
    "summarize",
    "summary_statistics",
    "to_camcomsim",
]

# The paper's cap (§6.3.1): "we stop the simulation when 50000 PHY-SDU are sent".
DEFAULT_MAX_EMISSIONS = 50_000
METRICS = (
    "emissions",
    "receptions",
    "unique_receptions",
    "gap_losses",
    "decode_errors",
    "duration_s",
    "goodput_bps",
    "throughput_bps",
)
# rollsim metric -> CamComSim's JSON field (SimulationResult.java), spelling kept.
CAMCOMSIM_FIELDS = {
    "emissions": "nbTxPhysdu",
    "unique_receptions": "nbRxUniquePhysdu",
    "receptions": "nbRxPhysdu",
    "gap_losses": "nbInterFgError",
    "decode_errors": "nbIntraFError",
    "duration_100us": "duration100Us",
    "goodput_bps": "goodputBps",
    "throughput_bps": "througputBps",
}
# Every field of one run in CamComSim's result file, in its order
# (SimulationResult.java, the fields it exposes to its JSON writer).
CAMCOMSIM_RUN_FIELDS = (
    "physduTxDurationMs",
    "nbConsecutiveDrop",
    "nbTxGeneration",
    "nbTxPhysdu",
    "nbRxUniquePhysdu",
    "nbRxPhysdu",
    "nbInterFgError",
    "nbIntraFError",
    "duration100Us",
    "isGenerationRx",
    "goodputBps",
    "througputBps",
    "simuParams",
)

# Block sizes: the first block covers about one round (small messages do not
# draw thousands of unused outcomes), later ones double up to _MAX_BLOCK
# (long runs amortise the per-block overhead, memory stays bounded).
_MIN_BLOCK = 256
_MAX_BLOCK = 4096
# Bytes a run's results take: six int64 counts, then ten float64 or int64
# metric arrays and their summaries.
_BYTES_PER_RUN = 160
# Bytes per recorded loss streak (int64); a run holds at most one streak per
# two emissions (each streak is ended by a reception).
_BYTES_PER_STREAK = 8
# Spawn key of the stream that draws where a rateless receiver joins.
_JOIN_STREAM = 0x726C6E63
# Columns of the per-chunk integer table.
_COUNTS = ("emissions", "receptions", "unique_receptions", "gap_losses", "decode_errors", "completed")


def run_seed_sequence(seed: int, run: int) -> np.random.SeedSequence:
    """Seed sequence of run ``run``: child ``run`` of ``SeedSequence(seed)``.

    Equal to ``np.random.SeedSequence(seed).spawn(n)[run]`` for any
    ``n > run``, built directly so that a worker needs no other child.
    """
    return np.random.SeedSequence(seed, spawn_key=(run,))


def _block_sizes(emissions_per_round: int):
    """Endless block-size schedule of one run (depends on the round only)."""
    size = min(_MAX_BLOCK, max(_MIN_BLOCK, 1 << max(0, emissions_per_round - 1).bit_length()))
    while True:
        yield size
        size = min(2 * size, _MAX_BLOCK)


def _emission_blocks(run, emissions_per_round: int, max_emissions: int):
    """``(start, codes, received)`` of each block of a run: the block's first
    emission, its outcome codes (the last block cut at ``max_emissions``) and
    the indices of its receptions. Ends after the block that reaches the cap."""
    start = 0
    for size in _block_sizes(emissions_per_round):
        codes = run.next_block(size)
        if start + size > max_emissions:
            codes = codes[: max_emissions - start]
        yield start, codes, np.flatnonzero(codes == RECEIVED)
        start += codes.size
        if start >= max_emissions:
            return


def _add_loss_streaks(received: np.ndarray, open_streak: int, length: int, streaks: list) -> int:
    """Append the loss streaks that the receptions of a block end; return the streak left open.

    ``received`` holds the sorted indices of the receptions among the
    block's ``length`` emissions; ``open_streak`` counts the losses since
    the last reception before the block.
    """
    if received.size == 0:
        return open_streak + length
    # A virtual reception open_streak + 1 emissions before the block's start.
    gaps = np.diff(received, prepend=-1 - open_streak) - 1
    streaks.append(gaps[gaps > 0])
    return length - 1 - int(received[-1])


def _simulate_run(channel, schedule: Schedule, max_emissions: int, seed_sequence, streaks: Optional[list] = None):
    """One broadcast: ``(emissions, receptions, unique, gaps, errors, completed)``.

    With a ``streaks`` list, the run's loss streaks are appended to it as
    int64 arrays (their concatenation is the run's ``loss_streaks``).
    """
    run = channel.open_run(seed_sequence)
    n = schedule.n_packets
    have = np.zeros(n, dtype=bool)
    n_have = 0
    counts = np.zeros(3, dtype=np.int64)  # per outcome code, emissions so far
    open_streak = 0  # losses since the last reception
    for start, codes, got in _emission_blocks(run, schedule.emissions_per_round, max_emissions):
        if got.size:
            seq = schedule.sequence_numbers(got + start)
            fresh = ~have[seq]
            if fresh.any():
                # First reception in this block of each packet not held yet;
                # np.unique returns the index of each value's first occurrence.
                new_packets, first = np.unique(seq[fresh], return_index=True)
                have[new_packets] = True
                n_have += new_packets.size
                if n_have == n:
                    end = int(got[fresh][first].max()) + 1
                    counts += np.bincount(codes[:end], minlength=3)
                    if streaks is not None:
                        _add_loss_streaks(got[got < end], open_streak, end, streaks)
                    return (start + end, int(counts[RECEIVED]), n, int(counts[GAP_LOSS]), int(counts[DECODE_ERROR]), 1)
        counts += np.bincount(codes, minlength=3)
        if streaks is not None:
            open_streak = _add_loss_streaks(got, open_streak, codes.size, streaks)
    return (max_emissions, int(counts[RECEIVED]), n_have, int(counts[GAP_LOSS]), int(counts[DECODE_ERROR]), 0)


def _simulate_rlnc_run(channel, schedule: RlncSchedule, max_emissions: int, seed_sequence,
                       streaks: Optional[list] = None):
    """One rateless broadcast: as :func:`_simulate_run`, complete when the received
    combinations reach rank K (``unique`` counts the receptions that raised the rank).
    The receiver joins at a random seed, drawn from the run's own seed sequence.

    Each block's receptions are stacked under the basis held so far and
    eliminated at once; in the block that reaches rank K, a binary search
    over its receptions (:func:`rollsim.protocol.gf2.first_full_rank`) finds
    the one that completed it.
    """
    from rollsim.protocol.gf2 import first_full_rank, row_basis
    from rollsim.protocol.rlnc import combinations

    run = channel.open_run(seed_sequence)
    k = schedule.n_packets
    # The receiver joins the broadcast at a uniformly random coded PHY-SDU:
    # the seeds it sees start there. (Every run from seed 0 would replay one
    # code realisation.) A stream of its own, apart from the channel's.
    joined = np.random.default_rng(np.random.SeedSequence(
        seed_sequence.entropy, spawn_key=(*seed_sequence.spawn_key, _JOIN_STREAM))).integers(schedule.seed_space)
    basis = np.zeros((0, k), dtype=bool)
    counts = np.zeros(3, dtype=np.int64)
    open_streak = 0
    for start, codes, got in _emission_blocks(run, schedule.emissions_per_round, max_emissions):
        if got.size:
            stacked = np.concatenate([basis, combinations(schedule.sequence_numbers(got + start + joined), k)])
            needed = first_full_rank(stacked)
            if needed is not None:
                end = int(got[needed - basis.shape[0] - 1]) + 1
                counts += np.bincount(codes[:end], minlength=3)
                if streaks is not None:
                    _add_loss_streaks(got[got < end], open_streak, end, streaks)
                return (start + end, int(counts[RECEIVED]), k, int(counts[GAP_LOSS]), int(counts[DECODE_ERROR]), 1)
            basis = row_basis(stacked)
        counts += np.bincount(codes, minlength=3)
        if streaks is not None:
            open_streak = _add_loss_streaks(got, open_streak, codes.size, streaks)
    return (max_emissions, int(counts[RECEIVED]), basis.shape[0], int(counts[GAP_LOSS]), int(counts[DECODE_ERROR]), 0)


def _simulate_chunk(
    channel, schedule: Schedule | RlncSchedule, max_emissions: int, seed: int, first_run: int, stop_run: int,
    record_loss_streaks: bool = False,
) -> tuple[np.ndarray, Optional[list]]:
    """Runs ``first_run .. stop_run - 1``: an int64 table, one row per run,
    and (if recorded) each run's loss streaks as one int64 array."""
    table = np.empty((stop_run - first_run, len(_COUNTS)), dtype=np.int64)
    per_run: Optional[list] = [] if record_loss_streaks else None
    for row, k in enumerate(range(first_run, stop_run)):
        parts: Optional[list] = [] if record_loss_streaks else None
        seeds = run_seed_sequence(seed, k)
        if isinstance(schedule, RlncSchedule):
            table[row] = _simulate_rlnc_run(channel, schedule, max_emissions, seeds, parts)
        else:
            table[row] = _simulate_run(channel, schedule, max_emissions, seeds, parts)
        if per_run is not None:
            per_run.append(np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64))
    return table, per_run


@dataclass(frozen=True, repr=False)
class BroadcastResult(Shown):
    """Per-run metrics of a simulated broadcast (see the module docstring).

    Attributes
    ----------
    channel : dict
        The channel's parameters (``kind`` and its own fields).
    strategy : str
    n_packets : int
    repeats : int
    header_bits, payload_bits : int
        ``H`` and ``P`` in bits, for throughput and goodput.
    seed : int
    max_emissions : int
    emission_duration_s : float
        Clock advance per emission, seconds.
    emission_duration_100us : float
        The same in CamComSim's unit of 100 us (an integer for ``camcomsim``).
    emissions, receptions, unique_receptions, gap_losses, decode_errors : ndarray of int64
    duration_s, goodput_bps, throughput_bps : ndarray of float64
    completed : ndarray of bool
    notes : tuple of str
        Caveats of the channel (e.g. CamComSim's units).
    loss_streaks : tuple of ndarray of int64, optional
        Per run, the lengths of its runs of consecutive losses that a
        reception ended (see the module docstring); ``None`` unless
        simulated with ``record_loss_streaks=True``.
    """

    channel: dict
    strategy: str
    n_packets: int
    repeats: int
    header_bits: int
    payload_bits: int
    seed: int
    max_emissions: int
    emission_duration_s: float
    emission_duration_100us: float
    emissions: np.ndarray
    receptions: np.ndarray
    unique_receptions: np.ndarray
    gap_losses: np.ndarray
    decode_errors: np.ndarray
    duration_s: np.ndarray
    goodput_bps: np.ndarray
    throughput_bps: np.ndarray
    completed: np.ndarray
    notes: tuple = field(default=())
    loss_streaks: Optional[tuple] = None

    @property
    def runs(self) -> int:
        return int(self.emissions.size)

    def _figures(self):
        strategy = self.strategy.upper() + ("" if self.strategy == "rlnc" else f" r={self.repeats}")
        goodput = float(np.mean(self.goodput_bps)) if self.runs else None
        return "", [("channel", self.channel.get("kind", "?")), ("strategy", strategy), ("N_p", self.n_packets),
                    ("runs", f"{self.runs} ({int(self.completed.sum())} completed)"),
                    ("mean goodput", quantity(goodput, "bit/s")), ("seed", self.seed)]

    @property
    def rounds_started(self) -> np.ndarray:
        """Rounds of the message begun per run: ``ceil(emissions / (r N_p))``."""
        per_round = self.repeats * self.n_packets
        return -(-self.emissions // per_round)

    @property
    def duration_100us(self) -> np.ndarray:
        """Duration in 100 us units, ``emissions x emission_duration_100us``."""
        return self.emissions * self.emission_duration_100us

    def completed_within(self, emissions: int) -> np.ndarray:
        """Per run: was the message complete within the first ``emissions``?

        Exact for any ``emissions <= max_emissions``: a capped run is a
        prefix of the same run uncapped (see the module docstring), so
        ``simulate_broadcast(..., max_emissions=K).completed`` equals
        ``result.completed_within(K)`` for the same seed.
        """
        k = _as_count(emissions, "emissions", 0)
        if k > self.max_emissions:
            raise ValueError(f"emissions must be <= max_emissions = {self.max_emissions}, got {k}")
        return self.completed & (self.emissions <= k)

    def metrics(self) -> dict[str, np.ndarray]:
        """``{name: per-run array}`` for every name of :data:`METRICS`."""
        return {name: getattr(self, name) for name in METRICS}

    def summary(self) -> dict:
        """JSON-ready summary; see :func:`summarize`."""
        return summarize(self)


def _check_seed(seed) -> int:
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed}")
    return int(seed)


def _check_channel(channel) -> None:
    if not isinstance(channel, ChannelModel):
        raise ValueError(f"channel must be one of the rollsim.channel.channels models, got {channel!r}")


def default_event_workers() -> int:
    """Processes of a broadcast simulation by default: one per core, at most two."""
    return default_workers(cap=2)


def check_broadcast_memory(runs: int, n_packets: int, workers: int, max_emissions: int = DEFAULT_MAX_EMISSIONS,
                           record_loss_streaks: bool = False) -> None:
    """Refuse a broadcast simulation whose arrays exceed the memory budget.

    Per run: its row of counts and the result's metric arrays (and, if
    recorded, at most one loss streak per two emissions); per worker: a
    run's received-packet flags and one block of outcomes. Callers may check
    before any other work (e.g. before a scene's channel is built).

    Raises
    ------
    rollsim.plumbing.budget.BudgetError
        Naming ``runs``.
    """
    streak_bytes = runs * (max_emissions // 2) * _BYTES_PER_STREAK if record_loss_streaks else 0
    check_memory(f"runs = {runs} of {n_packets} packets",
                 runs * _BYTES_PER_RUN + streak_bytes + min(workers, runs) * (n_packets + 64 * _MAX_BLOCK))


def simulate_broadcast(
    channel,
    schedule: Schedule | RlncSchedule,
    *,
    header_bits: int,
    payload_bits: int,
    runs: int = 1000,
    seed: int = 0,
    max_emissions: int = DEFAULT_MAX_EMISSIONS,
    workers: Optional[int] = None,
    chunk_runs: Optional[int] = None,
    progress: Optional[Callable[[int], object]] = None,
    record_loss_streaks: bool = False,
) -> BroadcastResult:
    """Broadcast a message over ``channel`` until it is complete, ``runs`` times.

    Parameters
    ----------
    channel : MmbpChannel, TimedChannel or CamcomsimChannel
        The channel model (:mod:`rollsim.channel.channels`).
    schedule : rollsim.transmitter.Schedule or rollsim.transmitter.schedule.RlncSchedule
        Strategy, packets and repeats: the endless emission order; or
        random linear coding, complete at rank K.
    header_bits, payload_bits : int
        ``H`` and ``P`` in bits: throughput counts ``H + P`` per reception,
        goodput ``P`` per distinct packet.
    runs : int, default 1000
        Independent runs ``n_r``, >= 1.
    seed : int, default 0
        Non-negative seed; run ``k`` uses ``SeedSequence(seed).spawn(runs)[k]``.
    max_emissions : int, default 50000
        Cap on emissions per run, >= 1. A capped run has ``completed =
        False`` and goodput 0.
    workers : int, optional
        Processes; default ``min(2, os.cpu_count())``. ``1`` runs in this
        process. Results are identical for any value.
    chunk_runs : int, optional
        Runs per task of the pool (and per progress call); default
        ``ceil(runs / (8 * workers))``. Results do not depend on it.
    progress : callable, optional
        Called as ``progress(n)`` with the number of runs of each finished
        chunk, e.g. ``tqdm(total=runs).update``.
    record_loss_streaks : bool, default False
        Also keep each run's loss streaks (``result.loss_streaks``, what
        :func:`to_camcomsim` writes as ``nbConsecutiveDrop``): up to 8 bytes
        per two emissions. The other results do not depend on it.

    Returns
    -------
    BroadcastResult

    Raises
    ------
    ValueError
        For invalid parameters, naming the parameter.
    """
    _check_channel(channel)
    if not isinstance(schedule, (Schedule, RlncSchedule)):
        raise ValueError(f"schedule must be a rollsim.transmitter.Schedule or RlncSchedule, got {schedule!r}")
    header_bits = _as_count(header_bits, "header_bits", 0)
    payload_bits = _as_count(payload_bits, "payload_bits", 1)
    runs = _as_count(runs, "runs", 1)
    seed = _check_seed(seed)
    max_emissions = _as_count(max_emissions, "max_emissions", 1)
    workers = default_event_workers() if workers is None else _as_count(workers, "workers", 1)
    chunk = max(1, math.ceil(runs / (8 * workers))) if chunk_runs is None else _as_count(chunk_runs, "chunk_runs", 1)
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be callable, got {progress!r}")

    record_loss_streaks = bool(record_loss_streaks)
    check_broadcast_memory(runs, schedule.n_packets, workers, max_emissions, record_loss_streaks)
    bounds = [(lo, min(lo + chunk, runs)) for lo in range(0, runs, chunk)]
    chunks: list = [None] * len(bounds)
    args = (channel, schedule, max_emissions, seed)
    if workers == 1 or len(bounds) == 1:
        for i, (lo, hi) in enumerate(bounds):
            chunks[i] = _simulate_chunk(*args, lo, hi, record_loss_streaks)
            if progress is not None:
                progress(hi - lo)
    else:
        with process_pool(min(workers, len(bounds))) as pool:
            futures = {pool.submit(_simulate_chunk, *args, lo, hi, record_loss_streaks): i
                       for i, (lo, hi) in enumerate(bounds)}
            for future in as_completed(futures):
                i = futures[future]
                chunks[i] = future.result()
                if progress is not None:
                    progress(bounds[i][1] - bounds[i][0])
    table = np.concatenate([chunk_table for chunk_table, _ in chunks], axis=0)
    streaks = tuple(a for _, per_run in chunks for a in per_run) if record_loss_streaks else None
    return _result_from_table(table, channel, schedule, header_bits, payload_bits, seed, max_emissions, streaks)


def _result_from_table(table, channel, schedule, header_bits, payload_bits, seed, max_emissions,
                       loss_streaks=None) -> BroadcastResult:
    columns = {name: table[:, j].copy() for j, name in enumerate(_COUNTS)}
    completed = columns.pop("completed").astype(bool)
    duration_s = columns["emissions"] * channel.emission_duration_s  # emissions >= 1: duration > 0
    goodput = np.where(completed, payload_bits * columns["unique_receptions"] / duration_s, 0.0)
    throughput = (header_bits + payload_bits) * columns["receptions"] / duration_s
    return BroadcastResult(
        channel=channel.parameters(),
        strategy=schedule.strategy,
        n_packets=schedule.n_packets,
        repeats=schedule.repeats,
        header_bits=header_bits,
        payload_bits=payload_bits,
        seed=seed,
        max_emissions=max_emissions,
        emission_duration_s=float(channel.emission_duration_s),
        emission_duration_100us=float(channel.emission_duration_100us),
        duration_s=duration_s,
        goodput_bps=goodput,
        throughput_bps=throughput,
        completed=completed,
        notes=tuple(channel.notes),
        loss_streaks=loss_streaks,
        **columns,
    )


# ----------------------------------------------------------------------------
# Summaries
# ----------------------------------------------------------------------------
def summary_statistics(values, confidence: float = 0.95) -> dict:
    """Mean, sample standard deviation and Student-t confidence interval.

    Parameters
    ----------
    values : array_like
        One value per run.
    confidence : float, default 0.95
        Two-sided level of the interval, in (0, 1).

    Returns
    -------
    dict
        ``{"mean", "std", "ci95": [low, high]}`` (key ``ci<level>``) as
        Python floats. ``std`` uses ``ddof = 1``; with a single value
        ``std`` and the interval are ``None`` (undefined, not NaN).
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    x = np.asarray(values, dtype=float)
    if x.ndim != 1 or x.size == 0:
        raise ValueError(f"values must be a non-empty 1-D array, got shape {x.shape}")
    key = f"ci{round(100 * confidence):d}"
    mean = float(x.mean())
    if x.size == 1:
        return {"mean": mean, "std": None, key: None}
    std = float(x.std(ddof=1))
    # stdtrit: the Student-t quantile, without importing scipy.stats (0.6 s);
    # imported here, as scipy.special alone costs 0.3 s of every command's start-up.
    from scipy.special import stdtrit

    half = float(stdtrit(x.size - 1, 0.5 + confidence / 2.0)) * std / math.sqrt(x.size)
    return {"mean": mean, "std": std, key: [mean - half, mean + half]}


def summarize(result: BroadcastResult) -> dict:
    """JSON-ready summary of a :class:`BroadcastResult`.

    Returns
    -------
    dict
        The set-up (channel parameters, strategy, packets, repeats, ``H``,
        ``P``, runs, seed, cap), ``completed_runs`` and
        ``completed_fraction``, ``metrics``: ``{name: summary_statistics}``
        over all runs (capped ones included, with goodput 0), and ``notes``.
    """
    completed = int(result.completed.sum())
    return {
        "channel": dict(result.channel),
        "strategy": result.strategy,
        "n_packets": result.n_packets,
        "repeats": result.repeats,
        "header_bits": result.header_bits,
        "payload_bits": result.payload_bits,
        "runs": result.runs,
        "seed": result.seed,
        "max_emissions": result.max_emissions,
        "completed_runs": completed,
        "completed_fraction": completed / result.runs,
        "metrics": {name: summary_statistics(values) for name, values in result.metrics().items()},
        "notes": list(result.notes),
    }


def to_camcomsim(result: BroadcastResult, simu_params: dict) -> list:
    """The result in CamComSim's layout: a bare list with one object per run.

    What CamComSim's result file holds (``SimulationResult.java``, written
    by its JSON writer), so that its own post-processing (``json.load``
    then ``pandas.json_normalize``) reads it. Each object has
    :data:`CAMCOMSIM_RUN_FIELDS`, in that order:

    ``physduTxDurationMs`` : float
        Clock advance per emission, ms (the PHY-SDU duration).
    ``nbConsecutiveDrop`` : list of int
        The run's loss streaks (``result.loss_streaks``).
    ``nbTxGeneration`` : int
        Rounds of the message begun, ``ceil(emissions / (r N_p))``
        (CamComSim declares the field but never sets it: always 0 there).
    ``nbTxPhysdu``, ``nbRxUniquePhysdu``, ``nbRxPhysdu`` : int
        Emissions, distinct packets received, receptions.
    ``nbInterFgError``, ``nbIntraFError`` : int
        Gap losses, decode errors.
    ``duration100Us`` : float
        Duration in units of 100 us.
    ``isGenerationRx`` : bool
        Whether the message was complete before the cap.
    ``goodputBps``, ``througputBps`` : float
        Goodput and throughput, bit/s (CamComSim's spelling); the goodput
        of a capped run is 0, as in the paper.
    ``simuParams`` : object
        ``simu_params``, the same in every run (see
        :func:`rollsim.channel.scene_channel.camcomsim_parameters`).

    Parameters
    ----------
    result : BroadcastResult
        Simulated with ``record_loss_streaks=True``.
    simu_params : dict
        CamComSim's ``simuParams`` object, JSON-ready.

    Returns
    -------
    list of dict
        JSON-ready.

    Raises
    ------
    ValueError
        If ``result`` has no loss streaks.
    """
    if result.loss_streaks is None:
        raise ValueError("result has no loss streaks (nbConsecutiveDrop): simulate with record_loss_streaks=True")
    emission_ms = float(result.emission_duration_100us) / 10.0
    columns = {
        "nbTxGeneration": result.rounds_started.tolist(),
        **{camcomsim: getattr(result, name).tolist() for name, camcomsim in CAMCOMSIM_FIELDS.items()},
        "isGenerationRx": result.completed.tolist(),
    }
    # CamComSim's float fields stay floats (1300.0, not 1300) whatever the channel.
    for name in ("duration100Us", "goodputBps", "througputBps"):
        columns[name] = [float(v) for v in columns[name]]
    rows = []
    for i in range(result.runs):
        row = {"physduTxDurationMs": emission_ms, "nbConsecutiveDrop": result.loss_streaks[i].tolist()}
        row.update((name, columns[name][i]) for name in CAMCOMSIM_RUN_FIELDS[2:-1])
        row["simuParams"] = simu_params
        rows.append(row)
    return rows
