"""Say so when kernels compile: one line before the first compilation of a process, never a silent wait.

numba compiles a kernel on its first call unless its cache (numba's own or
the one shipped with the package, :mod:`.portable`) has it.  On a slow
machine that takes a minute or more, which looks like a hang.
:func:`install` registers a listener on numba's compile events: when a
``tinsmith`` kernel starts compiling for the first time in the process, the
callback receives one sentence (the command line prints it on standard error;
the library logs it on the ``tinsmith`` logger at INFO level).  Loading a
kernel from a cache is no compile event and says nothing.  With the
environment variable ``TINSMITH_COMPILE_NOTICE=0`` the command line keeps
quiet (for scripts that read its standard error line by line).
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable

MESSAGE = (
    "compiling numerical kernels for this machine: once, later runs load them from the cache "
    "(this can take a minute or two; `tinsmith warmup` compiles them all up front)"
)


def _log(message: str) -> None:
    logging.getLogger("tinsmith").info(message)


_callback: Callable[[str], None] = _log
_listener = None


def announce_with(callback: Callable[[str], None] | None) -> None:
    """Send :data:`MESSAGE` to ``callback`` (None: the ``tinsmith`` logger) at the first compilation.

    Cheap (imports nothing); the listener itself is registered by
    :func:`install` when the kernels are imported.  The message is sent at
    most once per process.
    """
    global _callback
    if os.environ.get("TINSMITH_COMPILE_NOTICE") == "0":
        callback = None
    _callback = callback or _log


def install() -> None:
    """Register the compile listener with numba (once per process)."""
    global _listener
    if _listener is not None:
        return
    from numba.core import event

    class _FirstCompile(event.Listener):
        def __init__(self):
            self.said = False
            self.compiled = 0
            self.seconds = 0.0
            self._depth = 0
            self._start = 0.0

        def on_start(self, ev):
            func = getattr(ev.data.get("dispatcher"), "py_func", None)
            if self._depth == 0:
                self._start = time.perf_counter()
            self._depth += 1
            if not self.said and func is not None and func.__module__.startswith("tinsmith"):
                self.said = True
                _callback(MESSAGE)

        def on_end(self, ev):
            self._depth -= 1
            if self._depth == 0:
                self.compiled += 1
                self.seconds += time.perf_counter() - self._start

    _listener = _FirstCompile()
    event.register("numba:compile", _listener)


def compiled() -> tuple[int, float]:
    """(kernels compiled, seconds spent) in this process (top-level compilations, after :func:`install`)."""
    if _listener is None:
        return 0, 0.0
    return _listener.compiled, _listener.seconds
