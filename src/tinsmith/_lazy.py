"""Names imported on first use, so that ``import tinsmith`` and the command line start at once.

numba, scipy and the format libraries take about a second to import; the
packages ``tinsmith``, ``tinsmith.algorithms`` and ``tinsmith.metrics`` name
their public functions here and import a function's module when the name is
first read (PEP 562), and the command line calls its heavy functions through
:func:`function`.
"""

from __future__ import annotations

import importlib
import sys


def attributes(package: str, names: dict[str, str]):
    """A module ``__getattr__`` for ``package``: ``names`` maps a public name to the submodule defining it."""

    def __getattr__(name: str):
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        setattr(sys.modules[package], name, value)
        return value

    return __getattr__


def function(module: str, name: str):
    """A stand-in for the function ``module.name`` that imports ``module`` on its first call."""
    target = None

    def call(*args, **kwargs):
        nonlocal target
        if target is None:
            target = getattr(importlib.import_module(module), name)
        return target(*args, **kwargs)

    call.__name__ = call.__qualname__ = name
    call.__doc__ = f"``{module}.{name}``, imported on first call."
    return call
