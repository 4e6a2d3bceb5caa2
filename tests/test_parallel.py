"""rollsim.plumbing.parallel: results in order, and no worker started without a chunk to run."""

from __future__ import annotations

import os

from rollsim.plumbing.parallel import chunked, ordered_chunk_map

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
