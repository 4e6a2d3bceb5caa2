"""Where a sweep's cells run: Dask distributed, on this machine or on a cluster.

By default the command starts a local Dask cluster sized to the machine
(processes with one thread each, the memory budget split between them) and
closes it at the end. ``--scheduler tcp://HOST:8786`` submits to a cluster
the user started (``dask scheduler`` and ``dask worker`` processes, which
must import the same rollsim). Either way a cell's result depends only on
the cell, never on the worker that ran it or on the order.

Cheap cells (the analytic stage) go to the workers in batches, so that the
scheduler's per-task overhead does not dominate; every cell of a batch still
gets its own result and error.
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import math
from typing import Callable, Generator, Optional

from distributed.diagnostics.plugin import WorkerPlugin

from rollsim.errors import SystemFailure
from rollsim.parallel import default_workers

SCHEDULER_TIMEOUT_S = 6
# Wall time a task should take (seconds) and the work a stage's cell costs,
# to size batches: the scheduler spends ~1 ms per task.
_TASK_TARGET_S = 0.25
_CELL_COST_S = {"analytic": 0.001, "simulate": 0.2, "run": 1.0, "envelope": 1.0}


# What each stage's cells import, loaded as a worker starts (in parallel with
# the others and with the validation of the cells) rather than by the first
# cell each worker runs. colour-science (2 s) is not among them: only the
# bayer effect's spectra import it.
STAGE_MODULES = {
    "analytic": ("rollsim.channel.prediction", "rollsim.sweeps.stages"),
    "simulate": ("rollsim.channel.scene_channel", "rollsim.channel.eventsim", "rollsim.sweeps.stages"),
    "run": ("rollsim.sweeps.stages", "rollsim.render", "rollsim.calibrate", "rollsim.stream", "decoder"),
    "envelope": ("rollsim.sweeps.stages", "rollsim.render", "rollsim.stream", "rollsim.genie", "decoder"),
}


class _WorkerSetup(WorkerPlugin):
    """Run in every local worker as it starts: leave SIGINT to the command, die with it, import the stage."""

    name = "rollsim-worker-setup"

    def __init__(self, modules: tuple = ()):
        self.modules = tuple(modules)

    def setup(self, worker=None):
        import importlib

        from rollsim import signals

        with contextlib.suppress(ValueError):  # not the main thread: nothing to set
            signals.init_worker()
        for module in self.modules:
            importlib.import_module(module)


def local_cluster(workers: int, **options):
    """A ``LocalCluster`` of ``workers`` processes with one thread each, for rollsim's cells.

    Three of Dask's worker defaults cost CPU-bound cells time, and are off:

    * ``MALLOC_TRIM_THRESHOLD_`` turns off glibc's adaptive mmap threshold,
      so every frame-sized numpy temporary is mapped and page-faulted afresh:
      a 1080p render ran at 107 instead of 68 ms per frame;
    * the statistical profiler samples the running task's stack every 10 ms
      and the event-loop tick monitor wakes every 20 ms, both taking the GIL
      from the cell (the tick now runs every second).
    """
    import dask
    from distributed import LocalCluster

    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
    environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    settings = {"distributed.nanny.pre-spawn-environ": environ, "distributed.worker.profile.enabled": False,
                "distributed.admin.tick.interval": "1s"}
    with dask.config.set(settings):
        # Workers log a heartbeat error when the scheduler closes first; a
        # real failure reaches the command as its task's exception.
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                            silence_logs=logging.CRITICAL, **options)


class DaskEngine:
    """A Dask client on a new local cluster, or on a running scheduler.

    :meth:`start` may run in another thread (the sweep validates its cells
    meanwhile); :meth:`close` stops what :meth:`start` started.

    Parameters
    ----------
    workers : int, optional
        Size of the local cluster (default: one per core).
    scheduler : str, optional
        Address of a running scheduler, instead of a local cluster.
    stage : str
        The sweep's stage, whose modules local workers import as they start.
    """

    def __init__(self, workers: Optional[int] = None, scheduler: Optional[str] = None, stage: str = "analytic"):
        self.workers = workers
        self.scheduler = scheduler
        self.stage = stage
        self.cluster = None
        self.client = None

    def start(self):
        """Connect or start the cluster; returns the client.

        Raises
        ------
        SystemFailure
            The scheduler cannot be reached within :data:`SCHEDULER_TIMEOUT_S`
            seconds (exit 1, one line).
        """
        from distributed import Client

        if self.scheduler:
            try:
                self.client = Client(self.scheduler, timeout=f"{SCHEDULER_TIMEOUT_S}s", set_as_default=False)
            except (OSError, TimeoutError, ValueError) as exc:
                reason = " ".join(str(exc).split()) or type(exc).__name__
                raise SystemFailure(f"--scheduler {self.scheduler}: cannot reach it within {SCHEDULER_TIMEOUT_S} s "
                                    f"({reason[:160]})") from None
            return self.client
        from rollsim.budget import memory_budget_bytes

        workers = self.workers or default_workers()
        # The dashboard needs bokeh; without it, no dashboard and no warning.
        dashboard = ":0" if importlib.util.find_spec("bokeh") is not None else None
        self.cluster = local_cluster(workers, memory_limit=max(2**28, memory_budget_bytes() // workers),
                                     dashboard_address=dashboard)
        self.client = Client(self.cluster, set_as_default=False)
        self.client.register_plugin(_WorkerSetup(STAGE_MODULES[self.stage]))
        return self.client

    def close(self) -> None:
        for part in (self.client, self.cluster):
            if part is not None:
                with contextlib.suppress(Exception):
                    part.close()
        self.client = self.cluster = None


def batch_size(stage: str, cells: int, workers: int) -> int:
    """Cells per task: tasks of about :data:`_TASK_TARGET_S`, at least 4 per worker."""
    by_time = max(1, int(_TASK_TARGET_S / _CELL_COST_S[stage]))
    by_balance = max(1, math.ceil(cells / (4 * max(1, workers))))
    return min(by_time, by_balance)


def run_tasks(client, function: Callable, batches: list, *args) -> Generator[tuple[list, object], None, None]:
    """Submit ``function(batch, *args)`` for every batch now; a generator of
    ``(batch, result or exception)`` as they finish."""
    futures = {client.submit(function, batch, *args, pure=False): batch for batch in batches}
    return _finished(client, futures)


def _finished(client, futures: dict) -> Generator[tuple[list, object], None, None]:
    from distributed import as_completed

    try:
        for future in as_completed(futures, loop=client.loop):
            batch = futures[future]
            try:
                yield batch, future.result()
            except Exception as exc:  # the worker died, or lost the task
                yield batch, exc
    finally:
        # Nothing is left to cancel once the client has closed.
        with contextlib.suppress(Exception):
            client.cancel(list(futures))


def worker_count(client) -> int:
    """Workers the client's cluster has now."""
    with contextlib.suppress(Exception):
        return max(1, len(client.scheduler_info().get("workers", {})))
    return 1

