"""``rollsim bench sweep``: what a sweep costs, stage by stage, on this machine.

* analytic stage, 10,000 cells (100 distances x 100 exposures), the whole
  ``rollsim sweep`` command as a user runs it: wall seconds;
* simulate stage, 100 cells (distances) x 1,000 runs of paper-geometric, the
  whole command: wall seconds;
* run stage, 8 distances x 100 frames of paper-geometric on running clusters
  of 1 and 2 workers: the compute phase's speed-up, and the per-cell
  overhead beyond the work itself (the workers' time outside the cells'
  own computation, per cell), with the fixed start-up and finishing apart;
* peak resident memory of a worker (run stage).

On ``paper-geometric``, the paper's set-up with its LED's geometric image: the
figures measure the sweep engine, not the glare of ``paper-default`` (whose
LED rows need one FFT set-up per distinct emitter and exposure).
"""

from __future__ import annotations

from typing import Any

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rollsim.bench.common import machine
from rollsim.plumbing.text_tables import format_table

SCENE = "paper-geometric"
ANALYTIC_GRID = ["link.distance_cm=5:54.5:0.5", "camera.exposure_us=10:1000:10"]
SIMULATE_GRID = ["link.distance_cm=5:14.9:0.1"]
RUN_GRID = ["link.distance_cm=5,6,7,8,9,10,11,12"]


def command_seconds(grid: list, stage: str, options: list, out: Path) -> float:
    """Wall seconds of a whole ``rollsim sweep`` command (a fresh process, its own cluster)."""
    args = [sys.executable, "-m", "rollsim", "sweep", SCENE, "--stage", stage, "--out", str(out), "--quiet"]
    for item in grid:
        args += ["--grid", item]
    start = time.perf_counter()
    subprocess.run(args + options, check=True, capture_output=True)
    return time.perf_counter() - start


def _worker_peak_rss_mb(client) -> float:
    import resource

    peaks = client.run(lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
    return max(peaks.values()) / 1024.0


def run_stage_phases(workers: int, frames: int, out: Path) -> dict:
    """The run stage on a running cluster of ``workers``: phase times, cell work, worker memory."""
    from distributed import Client

    from rollsim.sweeps import run_sweep, spec_from_arguments
    from rollsim.sweeps.engine import STAGE_MODULES, _WorkerSetup, local_cluster

    spec = spec_from_arguments(SCENE, grid=RUN_GRID, stage="run", options={"frames": frames})
    marks = {}
    with local_cluster(workers, dashboard_address=":0") as cluster, Client(cluster, set_as_default=False) as client:
        client.register_plugin(_WorkerSetup(STAGE_MODULES["run"]))
        done = [0]

        def progress(n):
            done[0] += n
            if done[0] == len(spec.cells()):
                marks["computed"] = time.perf_counter()

        start = time.perf_counter()
        result = run_sweep(spec, out, client=client, progress=progress,
                           on_start=lambda *_: marks.setdefault("submitted", time.perf_counter()))
        end = time.perf_counter()
        rss = _worker_peak_rss_mb(client)
    work = sum(row["seconds"] for row in result.rows)
    compute = marks["computed"] - marks["submitted"]
    return {
        "workers": workers, "cells": len(result.rows), "frames": frames, "failed": result.failed,
        "start_s": marks["submitted"] - start, "compute_s": compute, "finish_s": end - marks["computed"],
        "work_s": work, "overhead_per_cell_s": (compute * workers - work) / len(result.rows),
        "worker_peak_rss_mb": rss,
    }


def _median_run(runs: list[dict]) -> dict:
    """The run whose compute phase is the median one (the machine's speed drifts)."""
    return sorted(runs, key=lambda run: run["compute_s"])[len(runs) // 2]


def bench_sweep(frames: int = 100, repeats: int = 3) -> dict:
    """Run the sweep benchmark; a JSON-ready dict.

    The run stage alternates 1 and 2 workers ``repeats`` times, so that a
    drift of the machine's speed hits both alike; the median of each counts.
    """
    result: dict[str, Any] = {"machine": machine(), "repeats": repeats}
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        result["analytic_10000_cells_s"] = command_seconds(ANALYTIC_GRID, "analytic", [], tmp / "analytic")
        result["simulate_100_cells_1000_runs_s"] = command_seconds(SIMULATE_GRID, "simulate", ["--runs", "1000"],
                                                                   tmp / "simulate")
        runs: dict[int, list] = {1: [], 2: []}
        for repeat in range(repeats):
            for workers in (1, 2):
                runs[workers].append(run_stage_phases(workers, frames, tmp / f"run{workers}-{repeat}"))
    one, two = _median_run(runs[1]), _median_run(runs[2])
    result["run_stage"] = {"one_worker": one, "two_workers": two,
                           "compute_s_runs": {str(w): [round(r["compute_s"], 2) for r in rs] for w, rs in runs.items()},
                           "compute_speedup": one["compute_s"] / two["compute_s"],
                           "total_speedup": (one["start_s"] + one["compute_s"] + one["finish_s"])
                           / (two["start_s"] + two["compute_s"] + two["finish_s"])}
    return result


def format_sweep(result: dict) -> str:
    run = result["run_stage"]
    one, two = run["one_worker"], run["two_workers"]
    rows = [
        ("analytic stage, 10,000 cells (whole command)", f"{result['analytic_10000_cells_s']:.1f} s", "<= 10 s"),
        ("simulate stage, 100 cells x 1,000 runs (whole command)", f"{result['simulate_100_cells_1000_runs_s']:.1f} s",
         "<= 30 s"),
        (f"run stage, 8 cells x {one['frames']} frames, compute phase: 1 worker / 2 workers",
         f"{one['compute_s']:.1f} s / {two['compute_s']:.1f} s", ""),
        ("run stage speed-up from 1 to 2 workers (compute phase; whole sweep)",
         f"{run['compute_speedup']:.2f}x; {run['total_speedup']:.2f}x", ">= 1.7x"),
        ("run stage compute phase of every repeat, 1 / 2 workers",
         " ".join(map(str, run["compute_s_runs"]["1"])) + " / " + " ".join(map(str, run["compute_s_runs"]["2"])), ""),
        ("run stage overhead per cell beyond its work (1 worker)", f"{one['overhead_per_cell_s']:.3f} s", "<= 0.3 s"),
        ("run stage idle worker time per cell, 2 workers (overhead and the last cells' tail)",
         f"{two['overhead_per_cell_s']:.3f} s", ""),
        ("run stage fixed start-up and finish (2 workers, cluster running)",
         f"{two['start_s']:.1f} s + {two['finish_s']:.1f} s", ""),
        ("peak resident memory of a worker (run stage)", f"{two['worker_peak_rss_mb']:.0f} MB", ""),
    ]
    return "rollsim bench sweep\n" + format_table(rows, ("what", "measured", "target"))


def main(args) -> int:
    from rollsim.plumbing.outputs import write_file

    result = bench_sweep(frames=args.frames, repeats=args.repeats)
    print(format_sweep(result))
    if args.json:
        write_file(args.json, json.dumps(result, indent=2) + "\n", force=args.force)
    return 0
