"""The documented examples run as written: docs/python-api.md's, and every API docstring's.

The docstrings of :mod:`rollsim.api` and :mod:`rollsim` run in
tests/test_api.py (``doctest.testmod``); here the page runs, and every public
function is checked to have examples for that run to run.
"""

from __future__ import annotations

import doctest
import inspect
from pathlib import Path

import rollsim
from rollsim import api

PAGE = Path(__file__).resolve().parents[1] / "docs" / "python-api.md"


def test_the_python_api_page_runs_as_written(capsys):
    failed, attempted = doctest.testfile(str(PAGE), module_relative=False, optionflags=doctest.ELLIPSIS,
                                         globs={}, report=True)
    assert attempted >= 20 and failed == 0, capsys.readouterr().out


def test_every_public_function_shows_an_example():
    functions = [name for name in api.__all__ if inspect.isfunction(getattr(api, name))]
    assert functions
    for name in functions:
        assert "Examples\n    --------\n    >>> " in getattr(api, name).__doc__, name
    assert ">>> " in rollsim.__doc__
