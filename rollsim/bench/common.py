"""Shared helpers of the benchmarks."""

from __future__ import annotations

import platform
import time
from typing import Callable

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
