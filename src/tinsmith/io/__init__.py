"""Readers and writers: formats only, chosen by file suffix.

:func:`read` returns whatever the file holds (:class:`Heightfield`,
:class:`PointCloud` or :class:`TerrainMesh`); :func:`read_heightfield` always
returns a heightfield, gridding point clouds; :func:`write` writes a mesh
atomically in the format of the suffix, with a ``.prj`` sidecar when the format
cannot carry the CRS itself.  :func:`read_clouds` reads many point-cloud files
(files, folders, globs: :func:`expand_sources`) as one cloud, in chunks.
"""

from __future__ import annotations

import importlib
import os
import warnings
from pathlib import Path

from .. import _lazy, core
from ..errors import (
    FileError,
    FormatError,
    InputNotFoundError,
    InvalidInputError,
    InvalidOptionError,
    NoDataError,
    TinsmithError,
    TinsmithWarning,
    UnsupportedFormatError,
)
from ..resources import FIXED, PARSE_BYTES_PER_FILE_BYTE, check_memory, format_bytes
from ._atomic import atomic_paths
from ._errors import first_line, format_error
from .crs import GEOGRAPHIC_WARNING, describe, is_geographic, to_esri_wkt
from .registry import CLAIMS as _CLAIMS
from .registry import READ_OPTIONS, Reader, Writer
from .registry import READERS as _READERS
from .registry import WRITERS as _WRITERS


def _formats() -> tuple[dict, dict]:
    """The registries (suffix -> Reader, suffix -> Writer), every format module imported.

    The format modules register themselves when imported; they import numpy
    and their libraries, so they load at the first read or write, not with
    the package.
    """
    for name in ("mesh_formats", "points", "raster", "text_formats", "gis_formats", "cityjson", "adcirc", "selafin",
                 "ugrid"):
        importlib.import_module(f"{__name__}.{name}")
    return _READERS, _WRITERS


# the point-cloud readers' names, imported on first use: see __init__.pyi
_lazy_attribute, __dir__, __all__ = _lazy.attach(__name__, __file__)


def __getattr__(name: str):
    if name in ("READERS", "WRITERS"):
        return _formats()[name == "WRITERS"]
    return _lazy_attribute(name)


#: Registry key of the reader used for suffixes no other reader claims (GDAL via rasterio).
RASTER_FALLBACK = "*"


#: Point clouds read from text (the LAS reader checks its header's point count instead).
TEXT_CLOUDS = (".xyz", ".txt", ".csv")


def reader_for(path) -> Reader:
    """The reader of ``path``'s suffix (one that claims the file by its content first); rasters GDAL can open
    use the fallback reader."""
    readers, _ = _formats()
    suffix = Path(path).suffix.lower()
    for record in _CLAIMS.get(suffix, ()):
        if record.claims(path):
            return record
    return readers.get(suffix) or readers[RASTER_FALLBACK]


def writer_for(path) -> Writer:
    """The writer of ``path``'s suffix; :class:`UnsupportedFormatError` lists the known ones."""
    suffix = Path(path).suffix.lower()
    _, writers = _formats()
    try:
        return writers[suffix]
    except KeyError:
        known = ", ".join(sorted(writers))
        shown = suffix or "(none)"
        raise UnsupportedFormatError(
            f"cannot write {Path(path).name!r}: unsupported output suffix {shown}; use one of {known}"
        ) from None


def _check_input(path: Path) -> None:
    if not path.exists():
        raise InputNotFoundError(f"input file {str(path)!r} does not exist")
    if path.is_dir():
        raise FileError(f"input {str(path)!r} is a folder, expected a file")


_GLOB_CHARACTERS = ("*", "?", "[")


def is_cloud_sources(path) -> bool:
    """Whether ``path`` names several point-cloud files: a list of paths, a folder, or a glob pattern.

    A path that exists as a file is never a pattern (as in :func:`expand_sources`).
    """
    if not isinstance(path, (str, os.PathLike)):
        return True
    given = os.fspath(path)
    if isinstance(given, bytes):
        return False
    if Path(given).is_dir():
        return True
    return not Path(given).exists() and any(c in given for c in _GLOB_CHARACTERS)


def _read_sources(sources, given: dict):
    """Point clouds of ``sources`` (files, folders, globs) read as one: :func:`read_clouds`."""
    from .points import read_clouds

    for name in given:
        if name not in READ_OPTIONS:
            raise InvalidOptionError(f"unknown read option {name!r}; known: {', '.join(READ_OPTIONS)}")
        if name != "classes":
            raise InvalidOptionError(
                f"option {name!r} does not apply to point clouds (several files, a folder or a glob); "
                "they take classes"
            )
    return read_clouds(sources, **given)


def read(path, **options):
    """Read a raster, point cloud or mesh; the suffix picks the reader.

    Parameters
    ----------
    path : str, Path or list of them
        One file; or point clouds read as one cloud (:func:`read_clouds`, as
        the command line reads them): a list of files, folders and glob
        patterns, a folder (its ``.las``, ``.laz``, ``.xyz``, ``.txt`` and
        ``.csv`` files) or a glob pattern such as ``"tiles/*.laz"``.
    **options
        Reader options (``None`` values are ignored): see
        :data:`tinsmith.io.registry.READ_OPTIONS`.  An option the chosen
        reader does not use raises :class:`InvalidOptionError`.

    Returns
    -------
    Heightfield, PointCloud or TerrainMesh

    Raises
    ------
    FormatError
        A damaged file; a LAS/LAZ file that holds fewer points than its header
        announces (naming the file and both counts).
    InvalidInputError
        Point clouds in different CRSs (naming two of them).
    InputNotFoundError, FileError
        A missing file, a glob that matches nothing, an empty folder.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import tinsmith
    >>> dem = tinsmith.read(tinsmith.sample_path("st-helens"))  # a GeoTIFF: a Heightfield
    >>> type(dem).__name__, dem.shape
    ('Heightfield', (468, 327))
    >>> mesh = tinsmith.grid(tinsmith.Heightfield(dem.z[200:220, 100:120], cell_size=30.0))
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = tinsmith.write(mesh, Path(folder) / "window.ply")
    ...     again = tinsmith.read(path)  # a mesh file: a TerrainMesh
    >>> type(again).__name__, again.n_triangles == mesh.n_triangles
    ('TerrainMesh', True)
    """
    given = {k: v for k, v in options.items() if v is not None}
    if is_cloud_sources(path):
        return _read_sources(path, given)
    path = Path(path)
    _check_input(path)
    record = reader_for(path)
    for name in given:
        if name not in READ_OPTIONS:
            raise InvalidOptionError(f"unknown read option {name!r}; known: {', '.join(READ_OPTIONS)}")
        if name not in record.options:
            raise InvalidOptionError(
                f"option {name!r} does not apply to {path.name!r} ({record.description})"
            )
    if record.kind == "mesh" or path.suffix.lower() in TEXT_CLOUDS:
        size = path.stat().st_size
        check_memory(FIXED + PARSE_BYTES_PER_FILE_BYTE * size, f"reading {str(path)!r} ({format_bytes(size)})",
                     "split the file, or write it in a binary format")
    try:
        return record.function(path, **given)
    except (TinsmithError, MemoryError):
        raise
    except Exception as exc:  # a library failed on damaged content
        raise format_error(path, record.description, exc) from exc


def georeferencing(source, cell_size=None) -> tuple[str | None, tuple | None, float | None]:
    """``(crs, bounds, cell)`` of an input from its header alone: no height or point is read.

    A GDAL raster: its CRS (WKT), ``(xmin, ymin, xmax, ymax)`` and cell size.
    Point clouds (a file, or several as :func:`read` takes them): the CRS
    they share, the bounds of their headers, and ``cell_size`` or the cell
    :meth:`PointCloud.default_cell_size` would about choose.  ``(None, None,
    None)`` for other formats (meshes, numpy arrays, PNG tiles): the
    commands check them once read.
    """
    from .points import CLOUD_SUFFIXES, clouds_info

    if is_cloud_sources(source) or Path(source).suffix.lower() in CLOUD_SUFFIXES:
        infos, crs = clouds_info(source)
        boxes = [i.bounds for i in infos if i.count]
        if not boxes:
            return crs, None, cell_size
        xmin, ymin = min(b[0] for b in boxes), min(b[1] for b in boxes)
        xmax, ymax = max(b[3] for b in boxes), max(b[4] for b in boxes)
        count = sum(i.count for i in infos)
        cell = cell_size or 2.0 * ((max(xmax - xmin, 0.0) * max(ymax - ymin, 0.0)) / max(count, 1)) ** 0.5
        return crs, (xmin, ymin, xmax, ymax), cell or None
    path = Path(source)
    _check_input(path)
    if reader_for(path).function.__name__ != "read_gdal":
        return None, None, None
    from .raster import raster_georeferencing  # numpy and rasterio: imported for a raster

    return raster_georeferencing(path)


def read_heightfield(path, *, cell_size=None, statistic: str = "max", **options) -> core.Heightfield:
    """Read a heightfield; point clouds are gridded with :meth:`PointCloud.to_heightfield`.

    Parameters
    ----------
    path : str, Path or list of them
        A raster, or point clouds as :func:`read` takes them (files, folders,
        globs: read as one cloud, then gridded).
    cell_size : float, optional
        For point clouds, the cell size of the grid (default: from the point
        density); for bare arrays (.npy), their georeferencing.
    statistic : {"max", "min", "mean"}
        How the heights of the points in a cell are combined.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> import tinsmith
    >>> dem = tinsmith.read_heightfield(tinsmith.sample_path("st-helens"))
    >>> dem.shape, dem.cell_size
    ((468, 327), (30.0, 30.0))
    >>> x, y = np.meshgrid(np.arange(0.0, 40.0), np.arange(0.0, 30.0))  # points 1 m apart
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "points.xyz"
    ...     np.savetxt(path, np.column_stack([x.ravel(), y.ravel(), (x + y).ravel()]))
    ...     gridded = tinsmith.read_heightfield(path, cell_size=2.0)  # a point cloud, gridded
    >>> gridded.shape, gridded.n_valid == gridded.n_cells
    ((16, 20), True)
    """
    if is_cloud_sources(path):
        data = read(path, **options).to_heightfield(cell_size=cell_size, statistic=statistic)
        name = str(path) if isinstance(path, (str, os.PathLike)) else "the point clouds"
    else:
        path = Path(path)
        _check_input(path)
        if reader_for(path).kind == "points":
            data = read(path, **options).to_heightfield(cell_size=cell_size, statistic=statistic)
        else:
            data = read(path, cell_size=cell_size, **options)
        if not isinstance(data, core.Heightfield):
            raise InvalidInputError(f"{str(path)!r} holds a {type(data).__name__}, expected a raster")
        name = str(path)
    for message in height_warnings(data):
        warnings.warn(f"{name!r}: {message}", TinsmithWarning, stacklevel=2)
    return data


#: Values that stand for missing data in DEMs written by common tools (ArcGIS, GDAL, SRTM, USGS).
COMMON_NODATA = (-9999.0, -99999.0, -32768.0, -32767.0, 32767.0, 65535.0)


def height_warnings(hf: core.Heightfield) -> list[str]:
    """What a GIS user should hear about a raster that is read without complaint.

    * Cells equal to a common nodata value (-9999, -32768, ...) that the file
      does not declare, when that value lies far outside the other heights
      (beyond them by more than their own range): almost surely missing data
      about to be meshed as pits or spikes.
    * A geographic CRS: x and y in degrees against heights in metres, so
      slopes, triangle shapes, areas and every distance option mix units.
    """
    found = []
    z = hf.z[~hf.nodata_mask]
    lo, hi = float(z.min()), float(z.max())
    for value in COMMON_NODATA:
        if not lo <= value <= hi:
            continue
        hits = z == value
        n = int(hits.sum())
        if not n:
            continue
        rest = z[~hits]
        if rest.size:
            r_lo, r_hi = float(rest.min()), float(rest.max())
            if r_lo - (r_hi - r_lo) <= value <= r_hi + (r_hi - r_lo):
                continue  # among the heights: a real elevation
        shown = f"{value:g}"
        found.append(
            f"{n:,} cell(s) hold {shown}, a common nodata value far from the other heights"
            + (f" ({r_lo:g} .. {r_hi:g})" if rest.size else "")
            + f", but no nodata is declared for them: pass --nodata {shown} (nodata={shown}) if they are missing data"
        )
    if is_geographic(hf.crs):
        found.append(GEOGRAPHIC_WARNING.format(crs=describe(hf.crs)))
    return found


def read_mesh(path) -> core.TerrainMesh:
    """Read a triangle mesh; :class:`InvalidInputError` when the file holds something else.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> import tinsmith
    >>> mesh = tinsmith.grid(tinsmith.Heightfield(np.zeros((5, 5)), cell_size=1.0))
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = tinsmith.write(mesh, Path(folder) / "flat.obj")
    ...     again = tinsmith.read_mesh(path)
    >>> again.n_vertices, again.n_triangles
    (25, 32)
    """
    data = read(path)
    if not isinstance(data, core.TerrainMesh):
        raise InvalidInputError(f"{str(path)!r} holds a {type(data).__name__}, expected a triangle mesh")
    return data


def check_output_path(path) -> Writer:
    """Fail early, before any work, when ``path`` cannot be written; return its writer."""
    path = Path(path)
    record = writer_for(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise FileError(f"output folder {str(parent)!r} does not exist (for {path.name!r})")
    if path.is_dir():
        raise FileError(f"output {str(path)!r} is a folder, expected a file name")
    return record


def write(mesh: core.TerrainMesh, path, *, grid: core.Heightfield | None = None) -> Path:
    """Write ``mesh`` in the format of ``path``'s suffix, atomically.

    Parameters
    ----------
    mesh : TerrainMesh
    path : str or Path
    grid : Heightfield, optional
        The grid a raster output is sampled on (needed for GeoTIFF).

    Returns
    -------
    Path
        The written file.  When the format cannot carry a CRS and the mesh has
        one, a ``.prj`` file (ESRI WKT) is written beside it.  A format of
        several files writes the others beside it, together with it (TELEMAC's
        ``.slf`` and its boundary-conditions file ``.cli``).

    Warns
    -----
    SliverWarning
        A solver format (2DM, Gmsh ``.msh``, ADCIRC ``.14``/``.grd``, TELEMAC
        ``.slf``) and a mesh with triangles whose smallest plan-view angle is
        under 10 degrees: one line with their count, their share and the
        smallest angle, naming the method that meshes for a solver (:mod:`tinsmith.io.slivers`).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> mesh = tinsmith.greedy(hf, max_vertices=200)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     written = tinsmith.write(mesh, Path(folder) / "st-helens.obj")
    ...     print(written.name, sorted(p.name for p in Path(folder).iterdir()))  # OBJ has no CRS: a .prj beside it
    ...     raster = tinsmith.write(mesh, Path(folder) / "st-helens.tif", grid=hf)  # the mesh sampled on hf's grid
    ...     print(tinsmith.read_heightfield(raster).shape)
    st-helens.obj ['st-helens.obj', 'st-helens.prj']
    (468, 327)
    """
    path = Path(path)
    record = check_output_path(path)
    if not isinstance(mesh, core.TerrainMesh):
        raise InvalidInputError(f"write needs a TerrainMesh, got {type(mesh).__name__}")
    if mesh.n_triangles == 0:
        method = mesh.info.get("method")
        raise NoDataError(
            f"nothing to write to {str(path)!r}: the mesh has no triangles"
            + (f" (method {method!r} made none from this input with these options)" if method else "")
        )
    if record.needs_grid and not isinstance(grid, core.Heightfield):
        raise InvalidInputError(f"writing {path.name!r} needs grid= (the Heightfield to sample the mesh on)")
    sidecar = path.with_suffix(".prj") if (mesh.crs and not record.carries_crs) else None
    others = [path.with_suffix(s) for s in record.sidecars]  # the format's own further files
    targets = [path, *others] + ([sidecar] if sidecar else [])
    try:
        with atomic_paths(*targets, named=record.named) as temps:
            extra = {"sidecars": temps[1 : 1 + len(others)]} if others else {}
            record.function(mesh, temps[0], grid=grid, **extra)
            if sidecar:
                temps[-1].write_text(to_esri_wkt(mesh.crs))
    except (TinsmithError, MemoryError):
        raise
    except Exception as exc:
        raise FormatError(f"cannot write {str(path)!r}: {first_line(exc)}") from exc
    if record.solver:
        from .slivers import SliverWarning, sliver_warning

        message = sliver_warning(mesh, str(path))
        if message:
            warnings.warn(message, SliverWarning, stacklevel=2)
    return path
