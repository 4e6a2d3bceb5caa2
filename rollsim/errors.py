"""The project's error types, and the helpers that keep error lines short.

Every error a user can cause by what they give rollsim (a scene file, a
command-line value, a frame on disk) is a :class:`RollsimError`. The CLI prints
its message as one line per problem on stderr and exits with the error's
``exit_code``: 2 for bad input, 1 for an operating-system failure (a full disk,
a read-only target) or an output that could not be committed. A bug is
anything else, and keeps its traceback.

Error lines quote at most about :data:`VALUE_CHARS` characters of any value,
so that a hostile input (a YAML alias bomb, a megabyte-long ``--set``) costs
nothing to report.
"""

from __future__ import annotations

import reprlib

EXIT_BAD_INPUT = 2
EXIT_FAILURE = 1
# The most characters of a user's value that an error line quotes.
VALUE_CHARS = 80

_REPR = reprlib.Repr()
_REPR.maxlevel = 3
_REPR.maxstring = VALUE_CHARS
_REPR.maxother = VALUE_CHARS
_REPR.maxlong = VALUE_CHARS
for _name in ("maxlist", "maxtuple", "maxdict", "maxset", "maxfrozenset", "maxdeque", "maxarray"):
    setattr(_REPR, _name, 6)


def short_repr(value, limit: int = VALUE_CHARS) -> str:
    """``repr(value)`` cut to about ``limit`` characters, in bounded time.

    :mod:`reprlib` stops descending into containers after a few items and
    levels, so a value expanded from a YAML alias bomb, or an integer of
    thousands of digits, is summarised without being formatted whole.
    """
    try:
        text = _REPR.repr(value)
    except Exception:  # a value whose own repr fails still gets a line
        text = f"<{type(value).__name__}>"
    return clip(text, limit)


def clip(text: str, limit: int = VALUE_CHARS) -> str:
    """``text`` cut to ``limit`` characters, with ``...`` where it was cut."""
    text = str(text)
    return text if len(text) <= limit else text[: max(0, limit - 3)] + "..."


class RollsimError(Exception):
    """Bad input: a clear message, no traceback by default.

    Parameters
    ----------
    lines : str or sequence of str
        One line per problem. Each line names the field, file or parameter
        at fault.

    Attributes
    ----------
    exit_code : int
        The command's exit status for this error: 2 (bad input).
    """

    exit_code = EXIT_BAD_INPUT

    def __init__(self, lines):
        if isinstance(lines, str):
            lines = [lines]
        # One problem, one line: a newline inside a message (an OS message,
        # a quoted value) would read as two problems.
        self.lines = [" ".join(str(line).split("\n")) for line in lines]
        super().__init__("\n".join(self.lines))


class SceneError(RollsimError):
    """A scene file, preset or override is invalid."""


class OutputError(RollsimError):
    """An output location cannot be used (exists, not writable, ...)."""


class BudgetError(RollsimError):
    """An input would need more memory than the budget allows.

    Raised before the allocation, naming the field and the estimate (see
    :mod:`rollsim.plumbing.budget`).
    """


class ApiArgumentError(RollsimError):
    """A Python API function (:mod:`rollsim.api`) was given an argument it cannot take.

    The message is one line: ``rollsim.FUNCTION: ARGUMENT: expected ..., got
    ...``. Catch this class for either kind below.
    """


class ApiTypeError(ApiArgumentError, TypeError):
    """An API argument of the wrong type (``None`` for a scene, ``True`` for a count)."""


class ApiValueError(ApiArgumentError, ValueError):
    """An API argument of the right type and a wrong value (a negative count, an unknown name)."""


class SystemFailure(RollsimError):
    """The operating system refused (full disk, read-only target, ...).

    Exit code 1: the input was fine; the machine could not do the work.
    """

    exit_code = EXIT_FAILURE


class CommitError(SystemFailure):
    """A finished result could not be put in place (its target changed meanwhile).

    The message names where the result was kept.
    """


class Interrupted(BaseException):
    """SIGINT or SIGTERM reached the command (see :mod:`rollsim.plumbing.signals`).

    A :class:`BaseException`, like :class:`KeyboardInterrupt`, so that
    ``except Exception`` blocks do not swallow it and every ``finally`` and
    context manager on the way out cleans up.

    Attributes
    ----------
    signum : int
        The signal's number; the command exits with ``128 + signum``.
    note : str
        What the command leaves behind, for its last line.
    """

    def __init__(self, signum: int, note: str = "nothing was written"):
        self.signum = int(signum)
        self.note = note
        super().__init__(signum)
