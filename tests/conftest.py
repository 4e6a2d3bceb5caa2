"""The suite's one pytest hook: benchmarks run in one process.

The default run spreads the tests over two processes (pytest-xdist,
``addopts`` in pyproject.toml). A benchmark's figures are the machine's only
when nothing else runs beside it, so a run that selects benchmarks
(``-m benchmark``) runs them one after another.
"""

import re

import pytest


def selects_benchmarks(markexpr: str) -> bool:
    """Whether a ``-m`` expression can select tests marked ``benchmark`` (it names them, not negated)."""
    return re.search(r"(?<!not )\bbenchmark\b", markexpr or "") is not None


@pytest.hookimpl(tryfirst=True)
def pytest_cmdline_main(config):
    # Before pytest-xdist reads the option (its own hook is tryfirst too; a
    # conftest's runs first, being registered after the plugin).
    if selects_benchmarks(config.getoption("markexpr", "")) and hasattr(config.option, "numprocesses"):
        config.option.numprocesses = None
        config.option.dist = "no"
