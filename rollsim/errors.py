"""The project's error types.

Every error a user can cause by what they give rollsim (a scene file, a
command-line value, a frame on disk) is a :class:`RollsimError`. The CLI prints
its message as one line per problem on stderr and exits with code 2; a bug is
anything else, and keeps its traceback.
"""

from __future__ import annotations


class RollsimError(Exception):
    """Bad input: a clear message, no traceback by default.

    Parameters
    ----------
    lines : str or sequence of str
        One line per problem. Each line names the field, file or parameter
        at fault.
    """

    def __init__(self, lines):
        if isinstance(lines, str):
            lines = [lines]
        self.lines = [str(line) for line in lines]
        super().__init__("\n".join(self.lines))


class SceneError(RollsimError):
    """A scene file, preset or override is invalid."""


class OutputError(RollsimError):
    """An output location cannot be used (exists, not writable, ...)."""
