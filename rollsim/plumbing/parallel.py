"""Worker processes: one pool helper for every command, and an ordered,
memory-bounded map over chunks of work.

Rendering and decoding stream many frames through worker processes. Results
must come back in order (truth lines, decoded records) and only a few chunks
may be in flight at once, so that memory stays flat however long the run.

:func:`default_workers` is the one default worker count. Every pool is
started by :func:`process_pool`, so that its workers leave
SIGINT and SIGTERM to the main process, die with it (even under SIGKILL), and
are killed at once when the command stops early (a signal, an error, a full
disk): no orphan keeps a core busy.

Workers are forked where the process runs one thread (a command's usual
case): they inherit its imports and loaded kernels and start at once. Where
another thread runs (a notebook's kernel, a test runner's, a Dask client's
loop), a fork copies the locks that thread holds, held for ever in the
child, which may then hang on its first import or write; the workers are
then forked from a fresh server process instead (``forkserver``, Python
3.14's default on Linux), at the cost of their own imports
(:func:`pool_context`).
"""

from __future__ import annotations

import contextlib
import itertools
import multiprocessing
import os
import threading
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Iterable, Iterator, Optional, Sequence

from rollsim.plumbing import signals

# How long a killed pool's own thread is awaited (s; it ends within
# milliseconds once it sees its workers gone).
MANAGER_JOIN_S = 5.0


def default_workers(cap: Optional[int] = None) -> int:
    """Worker processes to use by default: one per core, at most ``cap`` if given."""
    cores = max(1, os.cpu_count() or 1)
    return cores if cap is None else min(cap, cores)


def chunked(items: Sequence, size: int) -> Iterator[list]:
    """Consecutive slices of ``items`` of ``size`` (the last may be shorter)."""
    for first in range(0, len(items), size):
        yield list(items[first : first + size])


def pool_context() -> multiprocessing.context.BaseContext:
    """How this process should start workers now: ``fork`` alone on one thread, else ``forkserver``.

    Objects the workers share (a :class:`multiprocessing.Barrier`, a queue)
    must come from the same context as the pool.
    """
    return multiprocessing.get_context("fork" if threading.active_count() == 1 else "forkserver")


def _init_worker(initializer: Optional[Callable], initargs: tuple) -> None:
    signals.init_worker()
    if initializer is not None:
        initializer(*initargs)


def terminate(pool: ProcessPoolExecutor) -> None:
    """Kill a pool's workers now, without waiting for their tasks."""
    # The executor has no public way to stop running tasks before Python
    # 3.14 (terminate_workers); its process table is the only handle.
    processes = list((getattr(pool, "_processes", None) or {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        with contextlib.suppress(Exception):
            process.kill()
    for process in processes:
        with contextlib.suppress(Exception):
            process.join(timeout=1.0)
    # The executor's thread closes its wake-up pipe as it sees the workers
    # gone; were it still doing so at the interpreter's exit, the exit hook
    # would write to the closing pipe and print a traceback (EBADF) after the
    # command's one-line error. Its end is awaited (briefly: the workers are dead).
    if manager is not None:
        manager.join(timeout=MANAGER_JOIN_S)


@contextlib.contextmanager
def process_pool(workers: int, initializer: Optional[Callable] = None, initargs: tuple = (),
                 context: Optional[multiprocessing.context.BaseContext] = None):
    """A :class:`ProcessPoolExecutor` whose workers never outlive the command.

    Its workers start by ``context``, by default :func:`pool_context`'s
    (``initializer`` and ``initargs`` must then pickle where another thread
    runs). On a normal exit the pool waits for its tasks; on any exception
    (including :class:`rollsim.errors.Interrupted` and the closing of a
    generator that uses it) its workers are killed at once.
    """
    if context is None:
        context = pool_context()
    pool = ProcessPoolExecutor(workers, mp_context=context, initializer=_init_worker,
                               initargs=(initializer, initargs))
    try:
        yield pool
    except BaseException:
        terminate(pool)
        raise
    pool.shutdown(wait=True)


def ordered_chunk_map(
    function: Callable,
    chunks: Iterable[list],
    workers: int,
    *args,
    initializer: Optional[Callable] = None,
    initargs: tuple = (),
) -> Iterator:
    """Yield the items of ``function(chunk, *args)`` for every chunk, in order.

    With one worker, or one chunk, everything runs in this process (after
    ``initializer``). With more, one pool of at most as many workers as
    chunks serves every chunk, at most ``2 × workers`` of them in flight at
    a time.

    Parameters
    ----------
    function : callable
        Takes a chunk (and ``args``) and returns a list of results; must be
        picklable (module level) when ``workers > 1``.
    chunks : iterable of list
    workers : int
    initializer, initargs
        Run once in each worker process (or here, when everything runs here).
    """
    # Every worker starts a process and runs the initializer (a render builds
    # its pipeline there): a worker without a chunk would be start-up for nothing.
    chunks = iter(chunks)
    first = list(itertools.islice(chunks, max(workers, 1)))
    workers = min(workers, len(first))
    chunks = itertools.chain(first, chunks)
    if workers <= 1:
        if initializer is not None:
            initializer(*initargs)
        for chunk in chunks:
            yield from function(chunk, *args)
        return
    with process_pool(workers, initializer, initargs) as pool:
        pending = []
        for chunk in chunks:
            pending.append(pool.submit(function, chunk, *args))
            if len(pending) >= 2 * workers:
                yield from pending.pop(0).result()
        for future in pending:
            yield from future.result()
