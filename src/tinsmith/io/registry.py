"""Readers and writers, registered by file suffix.

A format module declares its functions with :func:`reader` and :func:`writer`;
:mod:`tinsmith.io` dispatches on the lower-case suffix of the path.

Reader functions take ``(path, **options)`` and return a :class:`Heightfield`,
:class:`PointCloud` or :class:`TerrainMesh`; they receive only the options they
declare in ``options``.  Writer functions take ``(mesh, path, *, grid)`` and
write exactly one file at ``path`` (a temporary name chosen by the dispatcher,
which renames it when the writer returns).  A format made of several files
declares the suffixes of the others (``sidecars=(".cli",)``): its function
also receives ``sidecars``, one temporary path per suffix, and the dispatcher
renames all of them together, or none, onto the target's stem with those
suffixes.

A reader that shares a suffix with another and tells its files by their
content declares ``claims``, a function of the path: :func:`tinsmith.io.reader_for`
asks it first (a UGRID mesh and a NetCDF raster are both ``.nc``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

__all__ = ["Reader", "Writer", "CLAIMS", "READERS", "WRITERS", "READ_OPTIONS", "reader", "writer"]

#: Every option a reader may declare, with its meaning (CLI flags use the same names).
READ_OPTIONS = {
    "nodata": "height that marks missing data, in addition to the file's own (nan for NaN)",
    "band": "raster band to read (1-based)",
    "cell_size": "cell size in world units, for inputs that carry no georeferencing",
    "classes": "point classes to keep (ASPRS codes, e.g. [2] for ground)",
    "encoding": "PNG elevation encoding: 'terrarium', 'mapbox' or 'raw'",
    "tile": "web-mercator tile index (z, x, y) that georeferences a PNG tile",
}


@dataclass(frozen=True)
class Reader:
    suffixes: tuple[str, ...]
    kind: str  # "raster", "points" or "mesh"
    description: str
    function: Callable = field(repr=False)
    options: tuple[str, ...] = ()
    claims: Callable | None = field(default=None, repr=False)  # path -> bool: the file is this reader's


@dataclass(frozen=True)
class Writer:
    suffixes: tuple[str, ...]
    description: str
    function: Callable = field(repr=False)
    carries_crs: bool = False  # False: the dispatcher writes a .prj sidecar
    needs_grid: bool = False  # True: the writer needs the source grid (grid=...)
    named: bool = False  # True: its library needs a real file name (see tinsmith.io._atomic), not /proc/self/fd/N
    solver: bool = False  # True: a 2-D solver's input: the dispatcher warns of sliver triangles (tinsmith.io.slivers)
    sidecars: tuple[str, ...] = ()  # suffixes of further files the writer writes beside the target (sidecars=...)


READERS: dict[str, Reader] = {}
WRITERS: dict[str, Writer] = {}
#: suffix -> the readers that claim some files of that suffix by their content (asked before READERS)
CLAIMS: dict[str, list[Reader]] = {}


def reader(suffixes, *, kind: str, description: str, options=(), claims: Callable | None = None):
    """Register a reader for the given suffixes (lower case, with the dot).

    With ``claims`` (a function of the path), the reader takes only the files
    it claims and the suffix's other reader keeps the rest.
    """
    unknown = set(options) - set(READ_OPTIONS)
    if unknown:
        raise ValueError(f"unknown reader options {sorted(unknown)}")

    def decorate(func):
        record = Reader(tuple(suffixes), kind, description, func, tuple(options), claims)
        for s in record.suffixes:
            if claims is None:
                READERS[s] = record
            else:
                CLAIMS.setdefault(s, []).append(record)
        return func

    return decorate


def writer(suffixes, *, description: str, carries_crs: bool = False, needs_grid: bool = False, named: bool = False,
           solver: bool = False, sidecars=()):
    """Register a writer for the given suffixes (lower case, with the dot).

    ``solver=True`` declares a 2-D solver's input format: :func:`tinsmith.io.write`
    warns (:class:`tinsmith.io.slivers.SliverWarning`, one line) when the mesh
    written has sliver triangles, so that no writer checks them itself.
    """

    def decorate(func):
        record = Writer(tuple(suffixes), description, func, carries_crs, needs_grid, named, solver, tuple(sidecars))
        for s in record.suffixes:
            WRITERS[s] = record
        return func

    return decorate
