"""Deprecated names: a :class:`DeprecationWarning` at the line that used one.

A name that changes keeps working for one release.  The warning names what
to use instead and points at the caller's line, past the frames of the
plumbing between the caller and the deprecated name (the method registry's
public functions, the command line's lazy stand-ins), so that Python's
default filters show it to a script's author and the test suite can turn
the ones tinsmith's own code triggers into errors (pyproject.toml).
"""

from __future__ import annotations

import sys
import warnings

__all__ = ["warn"]

#: Modules whose frames stand between a caller and a deprecated name.
PLUMBING = frozenset({"tinsmith.algorithms.registry", "tinsmith._lazy"})


def warn(message: str, *, depth: int = 1) -> None:
    """Warn that a name is deprecated, at the line ``depth`` frames above the caller of this function.

    ``depth=1`` (the default) is the line that called the function that
    calls :func:`warn`; frames of :data:`PLUMBING` are skipped.
    """
    frame, level = sys._getframe(1 + depth), 2 + depth
    while frame is not None and frame.f_globals.get("__name__") in PLUMBING:
        frame, level = frame.f_back, level + 1
    warnings.warn(message, DeprecationWarning, stacklevel=level)
