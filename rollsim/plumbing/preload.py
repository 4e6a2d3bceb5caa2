"""Modules imported on a thread while a command waits on its worker processes.

``rollsim run`` spends its render stage waiting on its workers. The modules
its later stages need (SciPy's optimiser for the calibration, matplotlib
for the report: about 0.9 s of imports in a fresh process) are imported
meanwhile, on a thread of the waiting process, where they would otherwise
be imported one after another once the render is done.

The thread must start only after the workers have forked: a fork while
another thread holds an import lock would leave the child that lock held,
for ever. And a stage that needs the modules, or forks again, joins the
thread first (:meth:`Preload.join`; leaving the ``with`` block joins it too).
"""

from __future__ import annotations

import contextlib
import importlib
import threading
from typing import Iterator, Optional, Sequence


class Preload:
    """Import ``modules``, in order, on one background thread once :meth:`start` is called.

    An import that fails stops the thread quietly: the stage that needs the
    module imports it again, and raises the error where it belongs.
    """

    def __init__(self, modules: Sequence[str]):
        self.modules = tuple(modules)
        self._thread: Optional[threading.Thread] = None

    def _import(self) -> None:
        for name in self.modules:
            try:
                importlib.import_module(name)
            except Exception:  # raised again by the stage's own import
                return

    def start(self) -> None:
        """Start the imports (once; later calls do nothing)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._import, name="rollsim-preload", daemon=True)
            self._thread.start()

    def join(self) -> None:
        """Wait for the imports started, if any."""
        if self._thread is not None:
            self._thread.join()


@contextlib.contextmanager
def preloading(modules: Sequence[str]) -> Iterator[Preload]:
    """A :class:`Preload` of ``modules``, joined on leaving the block (an error included)."""
    preload = Preload(modules)
    try:
        yield preload
    finally:
        preload.join()
