"""Atomic file output: write to a temporary file beside the target, then rename."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

__all__ = ["atomic_paths"]


@contextlib.contextmanager
def atomic_paths(*targets: Path):
    """Yield a list of temporary paths (same folder, same suffix), one per target.

    When the block ends without an exception every temporary file is renamed
    onto its target with :func:`os.replace`; otherwise every temporary file is
    removed and no target is touched.  Temporary names start with a dot and
    keep the target's suffix, so libraries that pick a format from the suffix
    still do.
    """
    temps = []
    try:
        for target in targets:
            target = Path(target)
            fd, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".tmp{target.suffix}", dir=target.parent)
            os.close(fd)
            os.unlink(name)  # let the writer create it (some refuse to overwrite)
            temps.append(Path(name))
        yield temps
        for temp, target in zip(temps, targets):
            os.replace(temp, target)
    finally:
        for temp in temps:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(temp)
