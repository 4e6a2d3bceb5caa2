"""Ordered, memory-bounded parallel map over chunks of work.

Rendering and decoding stream many frames through worker processes. Results
must come back in order (truth lines, decoded records) and only a few chunks
may be in flight at once, so that memory stays flat however long the run.
"""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Iterable, Iterator, Optional, Sequence


def chunked(items: Sequence, size: int) -> Iterator[list]:
    """Consecutive slices of ``items`` of ``size`` (the last may be shorter)."""
    for first in range(0, len(items), size):
        yield list(items[first : first + size])


def ordered_chunk_map(
    function: Callable,
    chunks: Iterable[list],
    workers: int,
    *args,
    initializer: Optional[Callable] = None,
    initargs: tuple = (),
) -> Iterator:
    """Yield the items of ``function(chunk, *args)`` for every chunk, in order.

    With one worker everything runs in this process (after ``initializer``).
    With more, at most ``2 × workers`` chunks are in flight at a time.

    Parameters
    ----------
    function : callable
        Takes a chunk (and ``args``) and returns a list of results; must be
        picklable (module level) when ``workers > 1``.
    chunks : iterable of list
    workers : int
    initializer, initargs
        Run once in each worker process (and here, with one worker).
    """
    if workers <= 1:
        if initializer is not None:
            initializer(*initargs)
        for chunk in chunks:
            yield from function(chunk, *args)
        return
    with ProcessPoolExecutor(workers, initializer=initializer, initargs=initargs) as pool:
        pending = []
        for chunk in chunks:
            pending.append(pool.submit(function, chunk, *args))
            if len(pending) >= 2 * workers:
                yield from pending.pop(0).result()
        for future in pending:
            yield from future.result()
