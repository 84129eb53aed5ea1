"""Process pools whose workers end with the process that started them.

Every process pool tinsmith starts comes from :func:`process_pool`.  Its
workers must not outlive their parent: a parent stopped by SIGKILL (the OOM
killer, ``kill -9``, a container's stop after its grace period) runs no
cleanup, and a worker of a ``ProcessPoolExecutor`` left behind would go on
meshing its tile for nobody, holding its memory, and wait for work forever.
So each worker, when it starts (:func:`_init_worker`):

* on Linux asks the kernel for SIGKILL when its parent ends
  (``prctl(PR_SET_PDEATHSIG)``); the signal comes when the *thread* that
  started the worker ends, which for a pool is the thread that submitted the
  first tasks (the main thread of the command line);
* elsewhere on POSIX (or if prctl fails) watches its parent's pid from a
  daemon thread, once a second, and exits when it changes (the orphan is
  re-parented);
* ignores SIGINT: Ctrl-C in a terminal reaches the whole process group, and
  the parent, which gets it too, stops the pool (:func:`stop_pool`), so the
  workers need not each print a traceback;
* takes SIGTERM by default again (a forked worker inherits the command line's
  SIGTERM handler, which raises KeyboardInterrupt and would keep it alive).

The parent holds SIGINT and SIGTERM while the pool forks (:func:`_stops_held`),
so that a stop that comes just then is not lost in Python's at-fork hooks.

A parent that is stopped by an exception (Ctrl-C, SIGTERM through the command
line's handler, a failed task) calls :func:`stop_pool`: the tasks that wait are
cancelled and the running ones are not waited for.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor

__all__ = ["process_pool", "stop_pool"]

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
#: Seconds between two looks at the parent's pid where the kernel does not signal its death.
WATCH_INTERVAL = 1.0


#: The signals that stop a run: held while a pool starts its workers and its threads.
_STOPS = {signal.SIGINT, signal.SIGTERM}


@contextlib.contextmanager
def _stops_held():
    """Hold Ctrl-C and SIGTERM (delivered when the block ends) where Python would lose them.

    A pool forks its workers inside ``submit``, and an exception a signal handler
    raises while Python runs its at-fork hooks is printed and dropped ("Exception
    ignored in: _releaseLock"): a SIGTERM then would not stop the run.  The
    threads the pool starts meanwhile keep the signals blocked, so they always
    reach the main thread, and the workers unblock them (:func:`_init_worker`).
    """
    held = threading.current_thread() is threading.main_thread() and hasattr(signal, "pthread_sigmask")
    if held:
        before = signal.pthread_sigmask(signal.SIG_BLOCK, _STOPS)
    try:
        yield
    finally:
        if held:
            signal.pthread_sigmask(signal.SIG_SETMASK, before)


class _Pool(ProcessPoolExecutor):
    """A ``ProcessPoolExecutor`` that starts its workers with the stop signals held."""

    def submit(self, fn, /, *args, **kwargs):
        with _stops_held():
            return super().submit(fn, *args, **kwargs)


def process_pool(max_workers: int, initializer: Callable[[], None] | None = None) -> ProcessPoolExecutor:
    """A ``ProcessPoolExecutor`` of ``max_workers`` whose workers die with this process.

    Fork where there is one: the workers inherit the imported, compiled kernels,
    and a caller's script needs no ``if __name__ == "__main__"`` guard (spawn
    elsewhere: it does).  ``initializer`` then runs in each worker.
    """
    import multiprocessing

    method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
    return _Pool(max_workers=max_workers, mp_context=multiprocessing.get_context(method),
                 initializer=_init_worker, initargs=(os.getpid(), initializer))


def stop_pool(pool: ProcessPoolExecutor, patience: float = 10.0) -> None:
    """End a pool now: cancel the waiting tasks, end the running workers (SIGTERM, then SIGKILL), reap them."""
    # what shutdown drops, taken first
    processes = list((getattr(pool, "_processes", None) or {}).values())
    results, manager = getattr(pool, "_result_queue", None), getattr(pool, "_executor_manager_thread", None)
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes:
        with contextlib.suppress(Exception):
            p.terminate()
    for p in processes:
        with contextlib.suppress(Exception):
            p.join(patience)
            if p.is_alive():
                p.kill()
                p.join(patience)
    # A worker ended while it sent a result (a tile's arrays, megabytes) leaves the pool's manager thread
    # reading the rest of that message for ever, and the interpreter joins that thread at exit: with the
    # workers gone this process holds the last write end of the results pipe, and closing it ends the read.
    if results is not None:
        with contextlib.suppress(Exception):
            results._writer.close()
    if manager is not None:
        manager.join(patience)


def _init_worker(parent: int, then: Callable[[], None] | None) -> None:
    """In each pool worker: die with ``parent``, leave Ctrl-C to it, take SIGTERM; then ``then()``."""
    with contextlib.suppress(ValueError, OSError):  # not the main thread: nothing to set
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):  # held while the parent forked this worker
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOPS)
    die_with_parent(parent)
    if then is not None:
        then()


def die_with_parent(parent: int) -> None:
    """Make this process end when the process ``parent`` (its parent) ends."""
    if not _death_signal():
        if os.name != "posix":  # no re-parenting to watch for (Windows)
            return
        threading.Thread(target=_watch, args=(parent,), name="tinsmith-parent-watch", daemon=True).start()
    if os.getppid() != parent:  # the parent ended before the signal was asked for
        os._exit(1)


def _death_signal() -> bool:
    """Ask Linux for SIGKILL when the parent ends; whether it was granted."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch(parent: int) -> None:
    import time

    while os.getppid() == parent:
        time.sleep(WATCH_INTERVAL)
    os._exit(1)
