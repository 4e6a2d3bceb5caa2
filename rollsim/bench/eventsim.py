"""Benchmark of the event simulator: emissions per second on CamComSim's workload.

Workload (the paper's §6.4 use case, in CamComSim's units): the ``camcomsim``
channel, G = 1000 packets, RP with r = 1, d = 5 cm, P = 19, H = 5, IFG ratio
0.1, p_e = 0.001, f = 8 kHz, T_f = 33.3 ms, 1000 runs.

Memory is reported two ways, because the runs happen in worker processes:

* ``peak_traced_mb_per_worker``: the peak of Python-level allocations
  (``tracemalloc``, numpy buffers included) while one process simulates
  ``memory_runs`` runs of the same workload: what each worker needs on top
  of the interpreter and libraries. Measured in a separate pass, because
  tracing slows the simulation down.
* ``peak_rss_children_mb``: ``ru_maxrss`` of ``RUSAGE_CHILDREN``, the
  largest resident set of any child process that has ended (the workers of
  the timed pass, when ``workers > 1``): an absolute figure that includes
  the interpreter, numpy and scipy.
"""

from __future__ import annotations

from typing import Any

import json
import os
import resource
import time
import tracemalloc

from rollsim.channel.channels import CamcomsimChannel
from rollsim.channel.eventsim import default_event_workers, simulate_broadcast
from rollsim.plumbing.outputs import write_file
from rollsim.transmitter.schedule import Schedule

WORKLOAD: dict[str, Any] = {
    "channel": "camcomsim",
    "n_packets": 1000,
    "strategy": "rp",
    "repeats": 1,
    "distance_cm": 5.0,
    "payload_bits": 19,
    "header_bits": 5,
    "ifg_ratio": 0.1,
    "p_e": 0.001,
    "clock_hz": 8000.0,
    "frame_period_ms": 33.3,
}


def _workload_channel() -> CamcomsimChannel:
    w = WORKLOAD
    return CamcomsimChannel.from_parameters(
        frame_period_ms=w["frame_period_ms"],
        ifg_ratio=w["ifg_ratio"],
        distance_cm=w["distance_cm"],
        p_e=w["p_e"],
        header_bits=w["header_bits"],
        payload_bits=w["payload_bits"],
        clock_hz=w["clock_hz"],
    )


def _simulate(runs: int, seed: int, workers: int):
    w = WORKLOAD
    return simulate_broadcast(
        _workload_channel(),
        Schedule(w["strategy"], w["n_packets"], w["repeats"]),
        header_bits=w["header_bits"],
        payload_bits=w["payload_bits"],
        runs=runs,
        seed=seed,
        workers=workers,
    )


def _children_maxrss_mb() -> float:
    # Linux reports ru_maxrss in KiB.
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0


def bench_eventsim(runs: int = 1000, workers: int | None = None, seed: int = 1, memory_runs: int = 100) -> dict:
    """Time the event simulator on CamComSim's workload; returns a JSON-ready dict.

    Parameters
    ----------
    runs : int, default 1000
        Runs of the timed pass.
    workers : int, optional
        Processes of the timed pass; default ``min(2, os.cpu_count())``.
    seed : int, default 1
    memory_runs : int, default 100
        Runs of the traced (one-process) memory pass.

    Returns
    -------
    dict
        ``emissions`` (total), ``wall_s``, ``emissions_per_s``,
        ``runs_per_s``, ``workers``, ``completed_fraction``,
        ``mean_goodput_bps``, ``peak_traced_mb_per_worker``,
        ``peak_rss_children_mb``, the ``workload`` and ``cpus``.
    """
    workers = default_event_workers() if workers is None else workers
    start = time.perf_counter()
    result = _simulate(runs, seed, workers)
    wall = time.perf_counter() - start
    rss_children = _children_maxrss_mb()

    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        _simulate(memory_runs, seed, 1)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()

    emissions = int(result.emissions.sum())
    return {
        "workload": dict(WORKLOAD, runs=runs),
        "workers": workers,
        "cpus": os.cpu_count(),
        "emissions": emissions,
        "wall_s": wall,
        "emissions_per_s": emissions / wall,
        "runs_per_s": runs / wall,
        "completed_fraction": float(result.completed.mean()),
        "mean_emissions": float(result.emissions.mean()),
        "mean_goodput_bps": float(result.goodput_bps.mean()),
        "peak_traced_mb_per_worker": peak / 2**20,
        "memory_runs": memory_runs,
        "peak_rss_children_mb": rss_children if workers > 1 else None,
    }


def format_eventsim(result: dict) -> str:
    """A few lines for the terminal."""
    w = result["workload"]
    rss = result["peak_rss_children_mb"]
    lines = [
        f"rollsim bench eventsim: camcomsim channel, G = {w['n_packets']} packets, RP r = {w['repeats']}, "
        f"d = {w['distance_cm']:g} cm, {w['runs']} runs",
        f"  {result['emissions']:,} emissions in {result['wall_s']:.3f} s with {result['workers']} workers: "
        f"{result['emissions_per_s']:.3g} emissions/s ({result['runs_per_s']:.0f} runs/s)",
        f"  completed {100 * result['completed_fraction']:.1f}%, mean goodput {result['mean_goodput_bps']:.0f} bit/s",
        f"  peak traced memory of one worker (tracemalloc, {result['memory_runs']} runs): "
        f"{result['peak_traced_mb_per_worker']:.2f} MB",
    ]
    if rss is not None:
        lines.append(f"  peak RSS of a worker process (ru_maxrss, absolute): {rss:.1f} MB")
    return "\n".join(lines)


def main(args) -> int:
    """Entry point for ``rollsim bench eventsim`` (``args``: runs, workers, json)."""
    result = bench_eventsim(runs=getattr(args, "runs", 1000), workers=getattr(args, "workers", None))
    print(format_eventsim(result))
    path = getattr(args, "json", None)
    if path:
        write_file(path, json.dumps(result, indent=2) + "\n", force=getattr(args, "force", False))
    return 0

