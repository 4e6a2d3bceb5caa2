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
import logging
import math
import threading
from typing import Callable, Generator, Optional

from distributed.diagnostics.plugin import WorkerPlugin

from rollsim.errors import SystemFailure
from rollsim.plumbing.parallel import default_workers

# Seconds each of a client's and a cluster's close may take.
CLOSE_TIMEOUT_S = 5
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
    "run": ("rollsim.sweeps.stages", "rollsim.render", "rollsim.calibrate", "rollsim.sweeps.stream", "decoder"),
    "envelope": ("rollsim.sweeps.stages", "rollsim.render", "rollsim.sweeps.stream", "rollsim.stages.genie", "decoder"),
}


class _WorkerSetup(WorkerPlugin):
    """Run in every local worker as it starts: leave SIGINT to the command, die with it, import the stage."""

    name = "rollsim-worker-setup"

    def __init__(self, modules: tuple = ()):
        self.modules = tuple(modules)

    def setup(self, worker=None):
        import importlib

        from rollsim.plumbing import signals

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
    connect_timeout_s : float, optional
        Deadline of the connection to ``scheduler`` in seconds (default:
        :func:`rollsim.sweeps.scheduler.connect_timeout_s`).
    """

    def __init__(self, workers: Optional[int] = None, scheduler: Optional[str] = None, stage: str = "analytic",
                 connect_timeout_s: Optional[float] = None):
        from rollsim.sweeps.scheduler import connect_timeout_s as resolve_timeout, parse_scheduler_address

        self.workers = workers
        # Checked here, before any work: a mistyped address is refused at once.
        self.address = parse_scheduler_address(scheduler) if scheduler else None
        self.scheduler = self.address.url if self.address is not None else None
        self.timeout_s = resolve_timeout(connect_timeout_s)
        self.stage = stage
        self.cluster = None
        self.client = None

    def start(self):
        """Connect or start the cluster; returns the client.

        Raises
        ------
        SystemFailure
            The scheduler does not greet as Dask does, or has no worker,
            within the deadline (exit 1, one line naming the address and
            what answered).
        """
        if self.address is not None:
            self.client = self._connect()
            return self.client
        from distributed import Client

        from rollsim.plumbing.budget import memory_budget_bytes

        workers = self.workers or default_workers()
        # A free port, never 8787: another cluster on the machine may hold it
        # (Dask then warns on stderr), and without bokeh it serves no page.
        self.cluster = local_cluster(workers, memory_limit=max(2**28, memory_budget_bytes() // workers),
                                     dashboard_address=":0")
        self.client = Client(self.cluster, set_as_default=False)
        self.client.register_plugin(_WorkerSetup(STAGE_MODULES[self.stage]))
        return self.client

    @contextlib.contextmanager
    def running(self):
        """:meth:`start`, then :meth:`close` on the way out (at once, workers killed, when stopped)."""
        try:
            yield self.start()
        except BaseException:
            self.close(stopping=True)
            raise
        self.close()

    def _connect(self):
        """A client of the user's scheduler, probed first and made within the deadline."""
        from distributed import Client

        from rollsim.sweeps.scheduler import probe_scheduler

        assert self.address is not None
        probe_scheduler(self.address, self.timeout_s)
        url = self.address.url
        try:
            client = within(lambda: Client(url, timeout=f"{self.timeout_s}s", set_as_default=False), self.timeout_s,
                            f"--scheduler {url}: no Dask handshake within {self.timeout_s:g} s (--connect-timeout)")
        except (OSError, TimeoutError, ValueError) as exc:
            reason = " ".join(str(exc).split()) or type(exc).__name__
            raise SystemFailure(f"--scheduler {url}: Dask could not connect ({reason[:160]})") from None
        # A scheduler without workers would hold every cell for ever.
        try:
            client.wait_for_workers(1, timeout=self.timeout_s)
        except Exception:  # Dask's TimeoutError, or the scheduler gone meanwhile
            self.client = client
            self.close()
            raise SystemFailure(f"--scheduler {url}: no worker joined it within {self.timeout_s:g} s "
                                f"(--connect-timeout); start some with `dask worker {url}`") from None
        return client

    def close(self, stopping: bool = False) -> None:
        """Close what :meth:`start` made, within :data:`CLOSE_TIMEOUT_S` each, Dask's teardown noise kept quiet.

        ``stopping`` (a signal or an error stops the command): the local
        workers are killed first, since a worker busy with a cell answers
        a polite close only when the cell ends.
        """
        parts = [part for part in (self.client, self.cluster) if part is not None]
        if stopping and self.cluster is not None:
            _kill_workers(self.cluster)
        self.client = self.cluster = None
        # A closing cluster logs every worker it loses; the command has its
        # own line for why it stops.
        previous = logging.root.manager.disable
        logging.disable(logging.CRITICAL)
        try:
            for part in parts:
                with contextlib.suppress(Exception):
                    within(lambda part=part: part.close(timeout=CLOSE_TIMEOUT_S), CLOSE_TIMEOUT_S + 1, "")
        finally:
            logging.disable(previous)


def _kill_workers(cluster) -> None:
    """SIGKILL the worker processes of a local cluster (its nannies name them)."""
    import os
    import signal

    for nanny in list(getattr(cluster, "workers", {}).values()):
        with contextlib.suppress(Exception):
            pid = nanny.pid
            if pid:
                os.kill(pid, signal.SIGKILL)


class _DaemonCall:
    """``function()`` on a daemon thread, its result or exception waited for with signals working.

    A daemon thread, not an executor's: Python joins an executor's threads
    at exit, so a call that never returns would hold the process after the
    command had finished.
    """

    def __init__(self, function: Callable, name: str):
        self._outcome: dict = {}
        self._done = threading.Event()
        threading.Thread(target=self._run, args=(function,), name=name, daemon=True).start()

    def _run(self, function: Callable) -> None:
        try:
            self._outcome["value"] = function()
        except BaseException as exc:  # handed to the waiting thread
            self._outcome["error"] = exc
        finally:
            self._done.set()

    def wait(self, timeout_s: Optional[float] = None) -> bool:
        """Whether the call has ended, within ``timeout_s`` seconds (None: for as long as it takes)."""
        return self._done.wait(timeout_s)

    def result(self):
        """The call's value, or its exception raised here (waits for the end)."""
        self._done.wait()
        if "error" in self._outcome:
            raise self._outcome["error"]
        return self._outcome.get("value")


class BackgroundStart:
    """:meth:`DaskEngine.start` on a daemon thread (:class:`_DaemonCall`), waited for with signals working."""

    def __init__(self, engine: DaskEngine):
        self.engine = engine
        self._abandoned = threading.Event()
        self._call = _DaemonCall(self._start, "rollsim-cluster-start")

    def _start(self):
        try:
            return self.engine.start()
        finally:
            if self._abandoned.is_set():  # nobody waits for it any more: close what came up late
                self.engine.close(stopping=True)

    def result(self):
        """The client, once started (waits; a signal interrupts the wait)."""
        return self._call.result()

    def abandon(self) -> None:
        """Stop waiting: close what has started, giving a local cluster under way a moment to finish starting.

        A connection to a user's scheduler is not waited for: until it
        is made there is nothing to close. A start still under way closes
        what it made itself when it ends.
        """
        self._abandoned.set()
        if self._call.wait(CLOSE_TIMEOUT_S if self.engine.address is None else 0.0):
            self.engine.close(stopping=True)


def within(function: Callable, timeout_s: float, message: str):
    """``function()`` on a daemon thread, given ``timeout_s`` seconds; its result or its exception.

    Raises
    ------
    SystemFailure
        ``message`` when the time is up (the thread is left to finish or not).
    """
    call = _DaemonCall(function, "rollsim-deadline")
    if not call.wait(timeout_s):
        raise SystemFailure(message)
    return call.result()


def dashboard_link(client, timeout_s: float = 2.0) -> Optional[str]:
    """The address of the client's dashboard when it serves its status page, else None.

    Dask gives a link whether or not a dashboard runs (without bokeh on the
    scheduler the address answers with a page asking for it), so the page
    is asked for, within ``timeout_s`` seconds.
    """
    import urllib.request

    link = getattr(client, "dashboard_link", None)
    if not link or not str(link).startswith(("http://", "https://")):
        return None
    try:
        with urllib.request.urlopen(link, timeout=timeout_s) as response:  # noqa: S310 - the scheduler's own page
            page = response.read(4096) if response.status == 200 else b""
    except (OSError, ValueError):  # 404 (HTTPError is an OSError), refused, timed out
        return None
    # Without bokeh the scheduler answers with a page that says so.
    return link if page and b"needs bokeh" not in page else None


def batch_size(stage: str, cells: int, workers: int) -> int:
    """Cells per task: tasks of about :data:`_TASK_TARGET_S`, at least 4 per worker."""
    by_time = max(1, int(_TASK_TARGET_S / _CELL_COST_S[stage]))
    by_balance = max(1, math.ceil(cells / (4 * max(1, workers))))
    return min(by_time, by_balance)


def run_tasks(client, function: Callable, batches: list, *args) -> Generator[tuple[list, object], None, None]:
    """Submit ``function(batch, *args)`` for every batch now; a generator of
    ``(batch, result or exception)`` as they finish.

    Raises
    ------
    SystemFailure
        (from the generator) The cluster has had no worker for the
        connection deadline: its tasks would wait for ever.
    """
    from rollsim.sweeps.scheduler import connect_timeout_s

    futures = {client.submit(function, batch, *args, pure=False): batch for batch in batches}
    return _finished(client, futures, connect_timeout_s())


# How often a wait for tasks looks whether the cluster still has workers, s.
_POLL_S = 1.0


def _finished(client, futures: dict, workerless_s: float) -> Generator[tuple[list, object], None, None]:
    from distributed import wait

    pending = list(futures)
    since: Optional[float] = None  # monotonic time the cluster was first seen without workers
    try:
        while pending:
            try:
                with client.as_current():  # wait() asks for the current client; rollsim's is not the default
                    done, not_done = wait(pending, timeout=_POLL_S, return_when="FIRST_COMPLETED")
            except TimeoutError:  # nothing finished meanwhile: are there workers to finish anything?
                since = _check_workers(client, since, workerless_s, len(futures) - len(pending), len(futures))
                continue
            since = None
            pending = list(not_done)
            for future in done:
                try:
                    yield futures[future], future.result()
                except Exception as exc:  # the worker died, or lost the task
                    yield futures[future], exc
    finally:
        # Nothing is left to cancel once the client has closed.
        with contextlib.suppress(Exception):
            client.cancel(list(futures))


def _check_workers(client, since: Optional[float], workerless_s: float, finished: int, total: int) -> Optional[float]:
    """When the cluster was first seen without workers (None while it has some); a
    :class:`SystemFailure` once that has lasted ``workerless_s`` seconds."""
    import time

    if _workers_now(client) != 0:  # some, or unknown (the scheduler gone too: Dask's error comes with the tasks)
        return None
    now = time.monotonic()
    if since is None:
        return now
    if now - since >= workerless_s:
        raise SystemFailure(f"the cluster has had no worker for {workerless_s:g} s (--connect-timeout): its workers "
                            f"left after {finished} of {total} tasks")
    return since


def _workers_now(client) -> Optional[int]:
    """Workers the client's scheduler lists now; None when it cannot be asked."""
    with contextlib.suppress(Exception):
        return len(client.scheduler_info().get("workers", {}))
    return None


def worker_count(client) -> int:
    """Workers the client's cluster has now (at least 1, for sizing batches)."""
    return max(1, _workers_now(client) or 1)

