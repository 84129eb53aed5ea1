"""What the benchmark scripts share: paths, the large synthetic DEM, the machine line of a table."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SHARED = ROOT.parent / "shared"
ST_HELENS = ROOT / "src/tinsmith/data/samples/st_helens_30m.tif"


def large_dem(workdir: Path, size: int = 4097, source: Path = ST_HELENS) -> Path:
    """A ``size`` x ``size`` DEM made by ``make_large_dem.py`` from ``source`` (seed 1), once, into ``workdir``.

    The default is the 4097 x 4097 DEM of the issues, from St. Helens.
    """
    name = "big4097.tif" if (size, source) == (4097, ST_HELENS) else f"big{size}_{Path(source).stem}.tif"
    big = Path(workdir) / name
    if not big.exists():
        subprocess.run(
            [sys.executable, str(SHARED / "tools/make_large_dem.py"), str(source), str(big), "--size", str(size),
             "--seed", "1"],
            check=True,
        )
    return big


def machine() -> str:
    """``Machine: x86_64, 2 cores, Python 3.11.7`` for a table's header."""
    return f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"
