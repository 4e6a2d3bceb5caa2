"""Shared helpers of the benchmarks."""

from __future__ import annotations

import contextlib
import math
import platform
import shlex
import statistics
import subprocess
import time
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np


def seconds_per_call(function: Callable[[int], object], n: int, warmup: int = 1) -> float:
    """Median seconds per call of ``function(i)`` over ``n`` calls, after warm-up."""
    for i in range(warmup):
        function(i)
    times = []
    for i in range(warmup, warmup + n):
        start = time.perf_counter()
        function(i)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def machine() -> dict:
    """What the figures were measured on."""
    import os

    return {"python": platform.python_version(), "cpus": os.cpu_count(), "machine": platform.machine()}


def spread(values: Sequence[float]) -> dict:
    """``{"median", "min", "max"}`` of ``values``."""
    return {"median": float(statistics.median(values)), "min": float(min(values)), "max": float(max(values))}


def timed_process(argv: Sequence[str], cwd: Optional[Path] = None) -> tuple[float, str]:
    """Wall seconds and standard output of ``argv`` run as a fresh process; raises with its stderr if it fails."""
    start = time.perf_counter()
    done = subprocess.run(list(argv), cwd=cwd, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{shlex.join(argv)}: exit {done.returncode}: {done.stderr.strip()[-300:]}")
    return seconds, done.stdout


def write_bytecode() -> None:
    """Write the bytecode of rollsim's and the decoder's modules, as the first run of an install does.

    The benchmarks time commands as fresh processes, as a user meets them
    after that first run. Where ``PYTHONDONTWRITEBYTECODE`` is set (it
    stops the import system's writing, not its reading), each process would
    otherwise compile every module it imports again: 0.1 to 0.4 s of a
    command's start that a normal install does not pay. A package directory
    that cannot be written (a system-wide install) is left as it is: its
    installer wrote the bytecode.
    """
    import compileall
    import importlib.util

    for package in ("rollsim", "decoder"):
        spec = importlib.util.find_spec(package)  # where it is, without importing it
        for folder in (spec.submodule_search_locations or []) if spec is not None else []:
            compileall.compile_dir(folder, quiet=2)


def strict_floats(value):
    """``value`` with every non-finite float made None (JSON and CSV stay strict)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: strict_floats(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_floats(v) for v in value]
    return value


@contextlib.contextmanager
def one_opencv_thread():
    """OpenCV on one thread inside the block (one-core figures), as it was after."""
    import cv2

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(threads)
