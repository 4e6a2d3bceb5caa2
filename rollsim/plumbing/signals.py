"""SIGINT and SIGTERM: stop every worker, clean up, exit with 128 + the signal.

The command's main process turns both signals into
:class:`rollsim.errors.Interrupted`, an exception that unwinds the stack like
:class:`KeyboardInterrupt`: worker pools kill their processes
(:mod:`rollsim.plumbing.parallel`), staging areas are removed (:mod:`rollsim.plumbing.outputs`),
and the CLI exits with ``128 + signum``. A second signal during that
clean-up ends the process at once with the same status: a clean-up that
hangs (a scheduler that never answers, a network file system) never makes
SIGKILL the only way out. What it leaves (a staging area) carries its
owner's process id, so the next run into the same place removes it.

Python runs a signal's handler between two bytecodes of the main thread,
which may be inside a weak reference's callback or a ``__del__`` that the
garbage collector runs: an exception raised there cannot propagate, and
Python drops it with an "Exception ignored" traceback. The command's
:func:`sys.unraisablehook` catches such an :class:`Interrupted` and sends
the signal again from a helper thread, so that it is raised where it
unwinds the command, with no traceback.

Worker processes leave both signals to the main process (a terminal's
Ctrl-C reaches the whole process group) and die with it, even when it is
killed with SIGKILL, through Linux's parent-death signal.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time

from rollsim.errors import Interrupted

HANDLED = (signal.SIGINT, signal.SIGTERM)
_PR_SET_PDEATHSIG = 1


def _exit_now(signum, frame):
    # The user asked twice: the clean-up the first signal started is given up.
    message = f"rollsim: stopped by {signal.Signals(signum).name} again during clean-up; exiting now\n"
    with contextlib.suppress(OSError):
        os.write(2, message.encode())
    os._exit(128 + signum)


def _raise_interrupted(signum, frame):
    # A later signal must not raise inside the clean-up this one starts
    # (half a clean-up is worse than none); it ends the process instead.
    for sig in HANDLED:
        signal.signal(sig, _exit_now)
    raise Interrupted(signum)


# How long the helper thread waits before sending a dropped signal again: long
# enough for the hook to return (a signal handled inside the hook would be
# dropped there too), short beside any clean-up.
REDELIVER_DELAY_S = 0.05


def _redeliver(signum: int) -> None:
    time.sleep(REDELIVER_DELAY_S)
    os.kill(os.getpid(), signum)


def _unraisable_hook(previous):
    """A :data:`sys.unraisablehook` that sends a dropped :class:`Interrupted`'s signal again (see the module)."""

    def hook(unraisable) -> None:
        exc = unraisable.exc_value
        if not isinstance(exc, Interrupted):
            previous(unraisable)
            return
        # Raised inside a callback that cannot propagate it: the command must still stop, cleaning up,
        # so the first signal's handler is put back and the signal sent again, after the callback (sent
        # while it still runs, it is dropped again and comes back here, until it lands outside).
        for sig in HANDLED:
            signal.signal(sig, _raise_interrupted)
        threading.Thread(target=_redeliver, args=(exc.signum,), daemon=True).start()

    return hook


def install_handlers() -> dict:
    """Make SIGINT and SIGTERM raise :class:`Interrupted` in the main thread.

    Also installs the :data:`sys.unraisablehook` that re-sends a signal
    whose exception Python had to drop (see the module).

    Returns
    -------
    dict
        The handlers replaced, for :func:`restore_handlers` (empty outside
        the main thread, where Python cannot set handlers).
    """
    if threading.current_thread() is not threading.main_thread():
        return {}
    saved: dict = {sig: signal.getsignal(sig) for sig in HANDLED}
    saved["unraisablehook"] = sys.unraisablehook
    sys.unraisablehook = _unraisable_hook(sys.unraisablehook)
    for sig in HANDLED:
        signal.signal(sig, _raise_interrupted)
    return saved


def restore_handlers(saved: dict) -> None:
    """Put back the handlers :func:`install_handlers` replaced."""
    for sig, handler in saved.items():
        if sig == "unraisablehook":
            sys.unraisablehook = handler
        elif handler is not None:
            signal.signal(sig, handler)


@contextlib.contextmanager
def deferred():
    """Hold SIGINT and SIGTERM back while the block runs.

    For the few system calls that put a result in place: a signal between
    them would leave neither the old output nor the new. A signal that
    arrives meanwhile is delivered when the block ends.
    """
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - not POSIX
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, HANDLED)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def die_with_parent() -> None:
    """Ask Linux to SIGKILL this process when its parent dies (no orphans)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover - no prctl
        pass


def init_worker() -> None:
    """Signal set-up of a worker process: the main process owns SIGINT and SIGTERM."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    # Blocked signals are inherited across fork: a worker forked while the
    # main process was committing an output must still die on SIGTERM.
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HANDLED)
    die_with_parent()
