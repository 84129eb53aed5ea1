"""Memory: what a step will need, what this process may still use, and a clear refusal.

``tinsmith remesh dem.tif --vertices 1000000000`` used to grow until the kernel
killed it, and a 200,000 x 200,000 GeoTIFF gave numpy's "Unable to allocate
149. GiB".  Every step that allocates in proportion to its input or its options
(reading a raster, gridding a cloud, each method, each tile) first asks
:func:`check_memory` with an estimate from sizes known before any allocation
(the raster's header, the options), and is refused in one line when it cannot
fit: the estimate, what is available, what to do.

The estimates are linear models, bytes per cell and bytes per output vertex,
measured per method on real and synthetic DEMs by
``benchmarks/memory_model.py`` (``benchmarks/RESULTS_memory.md``) with a margin
on top: a refusal must never stop a run that would have fitted comfortably, and
a run that passes must not be the one that takes the machine down.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import re
import resource

from .errors import InvalidOptionError, ResourceError

__all__ = [
    "MEMORY_LIMIT_VARIABLE",
    "PARSE_BYTES_PER_FILE_BYTE",
    "available_memory",
    "check_memory",
    "estimate_method",
    "format_bytes",
    "parse_size",
    "raster_read_bytes",
    "release_free_memory",
]

#: Environment variable that caps the memory tinsmith plans to use (bytes, or 512M, 8G, 1.5T).
MEMORY_LIMIT_VARIABLE = "TINSMITH_MEMORY_LIMIT"

#: Bytes every method run may take on top of its input, whatever its size (buffers, cached kernels).
FIXED = 64 * 2**20
#: Peak bytes of parsing a mesh or a text cloud, per byte of the file: measured on Big Tujunga's
#: full-resolution mesh (1.5 million triangles) 3.1x (VTK) to 7.8x (STL; OBJ 7.4x, LandXML 5.7x),
#: and 6.0x on a 1 million point XYZ file; with a margin.
PARSE_BYTES_PER_FILE_BYTE = 12
#: Peak bytes per grid cell (per input vertex for meshes) of each method beyond its input, in the worst
#: case its options allow (every cell a vertex for the refining methods), measured with
#: benchmarks/memory_model.py on St. Helens, Big Tujunga and a 2048 x 2048 synthetic DEM
#: (benchmarks/RESULTS_memory.md): the largest measured (peak - FIXED) / cells, rounded up.
PER_CELL = {
    "greedy": 310.0,
    # per input point: the full TIN for the outline, the candidate lists, the refined TIN
    "greedy:points": 400.0,
    "grid": 400.0,
    "subsample": 400.0,  # step 1 is the grid
    "features": 280.0,
    "quadtree": 120.0,
    "decimate": 470.0,
    "cvt": 530.0,
    "remesh": 960.0,
}
#: Peak bytes per requested output vertex for the methods whose vertex count is an option (remesh's
#: samples and their Voronoi cells; cvt's sites, at most one per cell).
PER_VERTEX = {"cvt": 1000.0, "remesh": 7000.0}
#: Bytes per cell for the methods not measured (wavelet, urban): above every measured one.
DEFAULT_PER_CELL = 1000.0
#: Factor on the measured coefficients.
MARGIN = 1.5

_SUFFIXES = {"": 1, "B": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def parse_size(text: str, name: str = MEMORY_LIMIT_VARIABLE) -> int:
    """Bytes of ``"8000000"``, ``"512M"``, ``"8G"``, ``"1.5T"`` (binary units, an optional ``B`` or ``iB``)."""
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([KMGT]?)(?:i?B)?\s*", str(text), flags=re.IGNORECASE)
    if not match:
        raise InvalidOptionError(f"{name} must be a size such as 8000000000, 512M or 8G, got {text!r}")
    value = float(match.group(1)) * _SUFFIXES[match.group(2).upper()]
    if value < 1:
        raise InvalidOptionError(f"{name} must be at least 1 byte, got {text!r}")
    return int(value)


def format_bytes(n: float) -> str:
    """``"1.5 GiB"``: binary units, three significant figures."""
    for unit, size in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{int(n)} B"


def _meminfo_available() -> int | None:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _cgroup_headroom() -> int | None:
    """Limit minus usage of this process's cgroup (v2, else v1); None without a limit."""
    try:
        with open("/proc/self/cgroup") as f:
            lines = f.read().splitlines()
    except OSError:
        return None
    for line in lines:
        _, controllers, path = line.split(":", 2)
        if controllers == "":  # v2
            base = "/sys/fs/cgroup" + path
            files = (os.path.join(base, "memory.max"), os.path.join(base, "memory.current"))
        elif "memory" in controllers.split(","):
            base = "/sys/fs/cgroup/memory" + path
            files = (os.path.join(base, "memory.limit_in_bytes"), os.path.join(base, "memory.usage_in_bytes"))
        else:
            continue
        try:
            with open(files[0]) as f:
                limit = f.read().strip()
            with open(files[1]) as f:
                used = int(f.read().strip())
        except (OSError, ValueError):
            continue
        if limit == "max" or not limit.isdigit() or int(limit) >= 2**60:
            return None
        return max(0, int(limit) - used)
    return None


def _rss() -> int:
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def _rlimit_headroom() -> int | None:
    """What the address-space or data-segment limit leaves this process, when one is set."""
    limits = [resource.getrlimit(r)[0] for r in (resource.RLIMIT_AS, getattr(resource, "RLIMIT_DATA", None))
              if r is not None]
    limits = [soft for soft in limits if soft != resource.RLIM_INFINITY]
    if not limits:
        return None
    try:
        with open("/proc/self/statm") as f:
            size = int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")  # the address space in use
    except (OSError, ValueError):
        size = _rss()
    return max(0, min(limits) - size)


def available_memory() -> int:
    """Bytes this process may still allocate: the least of the system's available memory, the
    cgroup's headroom and the address-space limit's; or, when ``TINSMITH_MEMORY_LIMIT`` is set,
    that budget for the whole process less what it already holds (lower it on a shared
    machine; raise it to run a step whose worst-case estimate is refused but which you know fits)."""
    limit = os.environ.get(MEMORY_LIMIT_VARIABLE)
    if limit not in (None, ""):
        return max(0, parse_size(limit) - _rss())
    candidates = [v for v in (_meminfo_available(), _cgroup_headroom(), _rlimit_headroom()) if v is not None]
    return min(candidates) if candidates else 2**62


def check_memory(needed: float, what: str, hint: str = "") -> None:
    """Raise :class:`~tinsmith.errors.ResourceError` when ``needed`` bytes cannot fit.

    Parameters
    ----------
    needed : float
        The estimate, in bytes.
    what : str
        The step, as the message names it: ``"reading 'big.tif' (200,000 x 200,000 cells)"``.
    hint : str
        What to do instead, appended after a colon.
    """
    available = available_memory()
    if needed <= available:
        return
    source = f" ({MEMORY_LIMIT_VARIABLE})" if os.environ.get(MEMORY_LIMIT_VARIABLE) else ""
    raise ResourceError(
        f"{what} needs about {format_bytes(needed)} of memory; {format_bytes(available)} is available{source}"
        + (f": {hint}" if hint else "")
    )


def raster_read_bytes(rows: int, cols: int, itemsize: int) -> float:
    """Peak bytes of reading a raster band into a :class:`~tinsmith.core.Heightfield`.

    The band as stored, its mask (1 byte), the heights (float32 for types it
    holds exactly, else float64) and the nodata mask with one temporary, and
    the fixed cost of GDAL's first read (drivers, caches: about 55 MiB measured).
    """
    height = 4 if itemsize <= 2 else 8
    return FIXED + float(rows) * float(cols) * (itemsize + 1 + height + 2)


def estimate_method(method: str, n_cells: int, n_vertices: int = 0) -> float:
    """Peak bytes a method needs beyond its input, for ``n_cells`` grid cells (or input vertices
    of a mesh) and ``n_vertices`` requested output vertices (``remesh``'s count, ``cvt``'s sites)."""
    per_cell = PER_CELL.get(method, DEFAULT_PER_CELL)
    per_vertex = PER_VERTEX.get(method, 0.0)
    return MARGIN * (FIXED + per_cell * float(n_cells) + per_vertex * float(n_vertices))


def release_free_memory() -> None:
    """Hand the memory this process has freed back to the system, where the C library can (glibc's ``malloc_trim``).

    glibc keeps freed blocks below its mmap threshold (which rises, up to
    32 MB, with every large block freed) for later allocations; a larger
    allocation after them comes on top.  Called between the steps of a large
    job whose temporaries are freed before a larger output is made (the full
    TIN of a cloud: 43 MB less peak on Delft AHN3's 849k points).
    """
    with contextlib.suppress(OSError, AttributeError):  # not glibc: nothing to do
        ctypes.CDLL(None).malloc_trim(0)
