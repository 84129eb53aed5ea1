"""Names imported on first use, so that ``import tinsmith`` and the command line start at once.

numba, scipy and the format libraries take about a second to import.  Each
package that exports names from heavy modules lists them in its
``__init__.pyi`` stub, as ``from .module import name`` lines and an
``__all__``: type checkers and IDEs read the stub, and at run time
:func:`attach` hands the same lines to ``lazy_loader``, which imports a
name's module when the name is first read (PEP 562).  The command line
calls its heavy functions through :func:`function`.
"""

from __future__ import annotations

import importlib
import os
import sys

import lazy_loader


def attach(package: str, file: str):
    """``(__getattr__, __dir__, __all__)`` of ``package`` from the ``__init__.pyi`` beside ``file``.

    The stub's ``from .module import name`` lines are imported on first use
    (:func:`lazy_loader.attach`, as :func:`lazy_loader.attach_stub` does,
    with the stub read once); its ``__all__`` is the package's ``__all__``,
    so the names the package defines itself (listed in the stub with their
    signatures) are public too.
    """
    submodules, attributes, public = read_stub(os.path.splitext(file)[0] + ".pyi")
    load, _, lazy = lazy_loader.attach(package, submodules, attributes)
    lazy = frozenset(lazy)

    def __getattr__(name: str):
        if name not in lazy:  # Python's own words, as for any module
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return load(name)

    def __dir__():  # what the module holds so far and every public name, loaded or not
        return sorted(set(vars(sys.modules[package])) | set(public))

    return __getattr__, __dir__, public


def read_stub(stub: str) -> tuple[list[str], dict[str, list[str]], list[str]]:
    """``(submodules, {module: names}, __all__)`` of a stub: its ``from . import x`` and ``from .m import x`` lines.

    Any other ``from`` import is refused, as :func:`lazy_loader.attach_stub`
    refuses it (plain ``import`` lines, for annotations, are left alone).
    """
    import ast

    with open(stub, encoding="utf-8") as f:
        tree = ast.parse(f.read())
    submodules, attributes, public = [], {}, None
    for node in tree.body:
        if isinstance(node, ast.ImportFrom):
            if node.level != 1:
                raise ValueError(f"{stub}: only `from .module import name` lines are loaded on first use")
            names = [alias.name for alias in node.names]
            if node.module:
                attributes.setdefault(node.module, []).extend(names)
            else:
                submodules.extend(names)
        elif isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets):
            public = [ast.literal_eval(e) for e in node.value.elts]
    if public is None:
        raise ValueError(f"{stub}: no __all__ list")
    return submodules, attributes, public


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
