"""Modules that are also the API function of their name.

``rollsim.render`` and ``rollsim.calibrate`` are packages of the pipeline
and, at the top level, the Python API's functions (:mod:`rollsim.api`):
``rs.render(scene)``.
Python binds a package's attribute to a submodule once the submodule is
imported, which would hide the function; so each of these modules is made
callable, and calling it calls the API function of the same name.

The call reaches up to :mod:`rollsim.api` by name, when it is made: the
modules never import the API, so the pipeline's layers still run one way
at import (``tests/test_layers.py``).
"""

from __future__ import annotations

import importlib
import sys
import types

API_MODULE = "rollsim.api"


class _CallableModule(types.ModuleType):
    """A module whose call is :mod:`rollsim.api`'s function of the module's last name."""

    def __call__(self, *args, **kwargs):
        function = getattr(importlib.import_module(API_MODULE), self.__name__.rsplit(".", 1)[-1])
        return function(*args, **kwargs)


def make_callable(module_name: str) -> None:
    """Make ``sys.modules[module_name]`` call the API function of its name."""
    sys.modules[module_name].__class__ = _CallableModule
