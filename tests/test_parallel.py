"""rollsim.plumbing.parallel: results in order, no worker started without a chunk to run, and
no worker left a lock that another thread held at its start."""

from __future__ import annotations

import os
import subprocess
import sys
import threading

from rollsim.plumbing.parallel import chunked, ordered_chunk_map, pool_context, process_pool

# Held by a thread of the test's process while a pool starts: a forked worker
# would get it held, with no thread to release it.
HELD = threading.Lock()

INITIALIZED: list[str] = []


def _with_pid(chunk: list) -> list:
    return [(item, os.getpid()) for item in chunk]


def _initialize(tag: str) -> None:
    INITIALIZED.append(tag)


def test_one_chunk_runs_here_whatever_the_workers():
    """A one-chunk job (a one-frame render) starts no pool: its initializer runs once, here."""
    INITIALIZED.clear()
    out = list(ordered_chunk_map(_with_pid, chunked(range(3), 4), 4, initializer=_initialize, initargs=("here",)))
    assert out == [(item, os.getpid()) for item in range(3)]
    assert INITIALIZED == ["here"]


def test_chunks_come_back_in_order_from_the_workers():
    out = list(ordered_chunk_map(_with_pid, chunked(range(40), 3), 2))
    assert [item for item, _ in out] == list(range(40))
    assert os.getpid() not in {pid for _, pid in out}


def _take_the_held_lock(chunk: list) -> list:
    with HELD:
        return [os.getpid() for _ in chunk]


def test_a_worker_started_while_another_thread_holds_a_lock_does_not_inherit_it():
    release, taken = threading.Event(), threading.Event()

    def hold() -> None:
        with HELD:
            taken.set()
            release.wait(120)

    holder = threading.Thread(target=hold)
    holder.start()
    try:
        assert taken.wait(10)
        assert pool_context().get_start_method() == "forkserver"
        with process_pool(1) as pool:
            # A forked worker would wait for ever here; the timeout fails the test instead.
            assert pool.submit(_take_the_held_lock, [0]).result(timeout=120) != [os.getpid()]
    finally:
        release.set()
        holder.join()


def test_a_process_on_one_thread_forks_its_workers():
    code = "from rollsim.plumbing.parallel import pool_context; print(pool_context().get_start_method())"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "fork"
