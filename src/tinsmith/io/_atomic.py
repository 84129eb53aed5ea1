"""Atomic file output that leaves nothing behind, even when the process is killed.

A writer gets a path to write to; the target appears, complete, only when the
block ends without an exception.  On Linux the path is an anonymous file
(``O_TMPFILE``) in the target's folder, reached as ``/proc/self/fd/N``: it has
no name until it is linked in, so a run stopped at any moment (Ctrl-C, a
crash, ``kill -9``) leaves neither a half-written output nor a temporary file;
the kernel frees it with the process.  It is linked under a hidden name and
renamed onto the target (the only moment a temporary name exists, microseconds).

Writers whose library cannot write through ``/proc/self/fd/N`` (GDAL's vector
drivers remove and recreate the path; SQLite keeps journals beside it) ask for
``named=True``: a hidden temporary file beside the target, as before, whose name
carries the process id, so that the next atomic write into that folder removes
the leftovers of a process that no longer runs.  So do systems without
``O_TMPFILE``.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import re
import tempfile
from pathlib import Path

__all__ = ["atomic_paths"]

#: Hidden temporary names: ``.NAME.PID.RANDOM.tmp.SUFFIX``.
_TEMP_NAME = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.[a-z0-9_]+\.tmp(?:\.[^.]*)?$")
_AT_FDCWD, _AT_SYMLINK_FOLLOW = -100, 0x400


def _libc():
    try:
        return ctypes.CDLL(None, use_errno=True)
    except OSError:  # pragma: no cover - no C library to call
        return None


_LIBC = _libc() if hasattr(os, "O_TMPFILE") else None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


#: Folders this process has swept already (a pyramid writes thousands of files into a few folders).
_SWEPT: set[str] = set()


def sweep_stale_temporaries(folder: Path) -> None:
    """Remove the hidden temporary files that a killed tinsmith process left in ``folder`` (once per process)."""
    key = os.path.realpath(folder)
    if key in _SWEPT:
        return
    _SWEPT.add(key)
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        match = _TEMP_NAME.match(entry.name)
        if match and int(match.group("pid")) != os.getpid() and not _alive(int(match.group("pid"))):
            with contextlib.suppress(OSError):
                os.unlink(entry.path)


def _hidden_name(target: Path) -> Path:
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}.", suffix=f".tmp{target.suffix}",
                                dir=target.parent)
    os.close(fd)
    os.unlink(name)  # let the writer create it (some refuse to overwrite)
    return Path(name)


def _anonymous(target: Path) -> int | None:
    """A file descriptor of an unnamed file in the target's folder, or None where there is none."""
    if _LIBC is None:
        return None
    mask = os.umask(0)
    os.umask(mask)
    try:
        return os.open(target.parent if str(target.parent) else ".", os.O_TMPFILE | os.O_RDWR, 0o666 & ~mask)
    except OSError:  # the filesystem or kernel has no O_TMPFILE
        return None


def _link(fd: int, name: Path) -> None:
    """Give the anonymous file of ``fd`` the name ``name``."""
    if _LIBC.linkat(_AT_FDCWD, f"/proc/self/fd/{fd}".encode(), _AT_FDCWD, os.fsencode(name), _AT_SYMLINK_FOLLOW):
        err = ctypes.get_errno()
        raise OSError(err, os.strerror(err), str(name))


@contextlib.contextmanager
def atomic_paths(*targets: Path, named: bool = False):
    """Yield one path per target to write to; on success each becomes its target at once.

    When the block ends without an exception every file written is moved onto
    its target (``os.replace``); otherwise nothing of the targets is touched
    and nothing is left behind.  The paths keep no suffix of their own when
    they are anonymous files, so writers must not choose the format from the
    path they are given (tinsmith's writers are chosen from the target's
    suffix); ``named=True`` gives hidden files with the target's suffix, for
    libraries that need a real name beside the target.
    """
    targets = [Path(t) for t in targets]
    for folder in {t.parent for t in targets}:
        sweep_stale_temporaries(folder if str(folder) else Path("."))
    fds: list[int | None] = []
    temps: list[Path] = []
    try:
        for target in targets:
            fd = None if named else _anonymous(target)
            fds.append(fd)
            temps.append(Path(f"/proc/self/fd/{fd}") if fd is not None else _hidden_name(target))
        yield temps
        for fd, temp, target in zip(fds, temps, targets, strict=True):
            if fd is None:
                os.replace(temp, target)
                continue
            hidden = _hidden_name(target)
            _link(fd, hidden)
            os.replace(hidden, target)
    finally:
        # not strict: when naming a hidden temporary failed, fds holds that target's None and temps nothing
        for fd, temp in zip(fds, temps, strict=False):
            if fd is None:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(temp)
            else:
                os.close(fd)
