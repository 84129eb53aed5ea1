"""One tile: read its window, fix its seams, mesh it, return its cells and triangles.

This is the task every executor runs (in the process, in a process pool, or
on a Dask worker): it takes plain data (:class:`TileSpec`, :class:`TileJob`)
and returns plain arrays, so it pickles anywhere.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from ..algorithms.catalogue import TILE_METHODS
from ..algorithms.greedy.engine import GreedyEngine
from ..algorithms.registry import simplify
from ..algorithms.wavelet.wavelet import wavelet_filter
from ..core import Heightfield
from ..errors import NoDataError
from ..io.raster import RasterInfo, read_window
from .seams import seam_sides

__all__ = ["TILE_METHODS", "TileJob", "TileResult", "TileSpec", "mesh_tile", "mesh_window"]



@dataclass(frozen=True)
class TileSpec:
    """Tile ``(i, j)`` of the layout: rows ``r0..r1`` and columns ``c0..c1`` of the raster (inclusive).

    Examples
    --------
    >>> from tinsmith.tiles import TileSpec, layout
    >>> spec = layout((468, 327), 128)[5]
    >>> spec == TileSpec(i=1, j=2, r0=128, r1=256, c0=256, c1=326)
    True
    >>> spec.name
    'tile_0001_0002'
    """

    i: int
    j: int
    r0: int
    r1: int
    c0: int
    c1: int

    @property
    def name(self) -> str:
        return f"tile_{self.i:04d}_{self.j:04d}"


@dataclass(frozen=True)
class TileJob:
    """What every tile of a run shares: the raster, the method and its options, the bound.

    Examples
    --------
    >>> import tinsmith
    >>> from tinsmith.io.raster import raster_info
    >>> from tinsmith.tiles import TileJob, layout, mesh_tile
    >>> raster = raster_info(tinsmith.sample_path("st-helens"))  # its shape and georeferencing, no cell read
    >>> job = TileJob(raster, "greedy", max_error=20.0)
    >>> spec = layout(raster.shape, 128)[5]
    >>> job.method, job.max_error, job.halo
    ('greedy', 20.0, 1)
    >>> mesh_tile(spec, job).max_error <= job.max_error
    True
    """

    raster: RasterInfo
    method: str
    max_error: float
    options: dict = field(default_factory=dict)
    halo: int = 1
    prefilter: dict | None = None  # keyword arguments of wavelet_filter (landuse: a path)


@dataclass
class TileResult:
    """A meshed tile: raster rows and columns of its vertices, their heights, its triangles.

    Examples
    --------
    >>> import tinsmith
    >>> from tinsmith.io.raster import raster_info
    >>> from tinsmith.tiles import TileJob, layout, mesh_tile
    >>> raster = raster_info(tinsmith.sample_path("st-helens"))  # its shape and georeferencing, no cell read
    >>> job = TileJob(raster, "greedy", max_error=20.0)
    >>> spec = layout(raster.shape, 128)[5]
    >>> result = mesh_tile(spec, job)
    >>> len(result.rows) == len(result.cols) == len(result.z)
    True
    >>> sorted(result.summary())
    ['max_error', 'seconds', 'triangles']
    """

    rows: np.ndarray
    cols: np.ndarray
    z: np.ndarray
    triangles: np.ndarray
    max_error: float
    seconds: float
    n_valid: int

    @property
    def n_triangles(self) -> int:
        return len(self.triangles)

    def summary(self) -> dict:
        """The tile's line in the run's log."""
        return {"max_error": self.max_error, "seconds": self.seconds, "triangles": self.n_triangles}

    def to_dict(self) -> dict:
        return {"rows": self.rows, "cols": self.cols, "z": self.z, "triangles": self.triangles,
                "max_error": self.max_error, "seconds": self.seconds, "n_valid": self.n_valid}

    @classmethod
    def from_dict(cls, d) -> TileResult:
        return cls(np.asarray(d["rows"]), np.asarray(d["cols"]), np.asarray(d["z"]), np.asarray(d["triangles"]),
                   float(d["max_error"]), float(d["seconds"]), int(d["n_valid"]))


def _empty(seconds: float) -> TileResult:
    e = np.empty(0, np.int64)
    return TileResult(e, e, np.empty(0), np.empty((0, 3), np.int64), 0.0, seconds, 0)


def mesh_tile(spec: TileSpec, job: TileJob, read=None) -> TileResult:
    """Mesh one tile of a raster under the seam contract (see :mod:`.seams`).

    ``read(rows, cols)`` gives the heights (float64, NaN where there is no
    data) and the valid mask of an inclusive window; default
    :func:`~tinsmith.io.raster.read_window` of ``job.raster``.

    Examples
    --------
    >>> import tinsmith
    >>> from tinsmith.io.raster import raster_info
    >>> from tinsmith.tiles import TileJob, layout, mesh_tile
    >>> raster = raster_info(tinsmith.sample_path("st-helens"))  # its shape and georeferencing, no cell read
    >>> job = TileJob(raster, "greedy", max_error=20.0)
    >>> spec = layout(raster.shape, 128)[5]
    >>> result = mesh_tile(spec, job)
    >>> bool(result.rows.min() >= spec.r0 and result.rows.max() <= spec.r1)  # raster rows of its vertices
    True
    >>> result.max_error <= 20.0
    True
    """
    start = time.perf_counter()
    H, W = job.raster.shape
    halo = max(1, job.halo)
    wr0, wr1 = max(0, spec.r0 - halo), min(H - 1, spec.r1 + halo)
    wc0, wc1 = max(0, spec.c0 - halo), min(W - 1, spec.c1 + halo)
    z, valid = (read or partial(read_window, job.raster))((wr0, wr1), (wc0, wc1))
    rows, cols = (spec.r0 - wr0, spec.r1 - wr0), (spec.c0 - wc0, spec.c1 - wc0)
    filtered = None
    if job.prefilter is not None and valid[rows[0]:rows[1] + 1, cols[0]:cols[1] + 1].any():
        filtered = _prefiltered(z, job.raster.window_transform(wr0, wc0), job)
    out = mesh_window(z, valid, rows, cols, job.raster.window_transform(spec.r0, spec.c0), job.raster.crs,
                      job.method, job.max_error, job.options, heights=filtered)
    if out is None:
        return _empty(time.perf_counter() - start)
    r, c, zz, triangles, error, n_valid = out
    return TileResult(r + spec.r0, c + spec.c0, zz, triangles, error, time.perf_counter() - start, n_valid)


def mesh_window(z, valid, rows, cols, transform, crs, method: str, max_error: float, options: dict, heights=None):
    """Mesh the tile ``rows`` x ``cols`` (inclusive) of a window read with a halo, its sides fixed by the seams.

    ``heights`` (the window's pre-filtered heights) replaces ``z`` inside the
    tile; the sides always follow ``z``.  Returns ``(rows, cols, z,
    triangles, max_error, n_valid)`` in tile cells, or None when the tile's
    data covers no area.
    """
    tile_valid = valid[rows[0]:rows[1] + 1, cols[0]:cols[1] + 1]
    n_valid = int(tile_valid.sum())
    if n_valid == 0:
        return None
    seams = seam_sides(z, valid, rows, cols, max_error)
    tile_z = seams.z
    if heights is not None:
        tile_z = np.array(heights[rows[0]:rows[1] + 1, cols[0]:cols[1] + 1], dtype=np.float64)
        tile_z[~tile_valid] = np.nan
        s = seams.z
        tile_z[0, :], tile_z[-1, :], tile_z[:, 0], tile_z[:, -1] = s[0, :], s[-1, :], s[:, 0], s[:, -1]
    hf = Heightfield(tile_z, transform=transform, crs=crs, nodata=float("nan"))
    nodes = seams.nodes
    if method != "greedy":
        nodes = np.unique(np.concatenate([nodes, _interior_nodes(hf, method, max_error, options)]), axis=0)
    try:
        engine = GreedyEngine(hf, nodes=nodes)
    except NoDataError:  # data in lines or points only: no area of this tile to cover
        return None
    engine.refine(max_error=max_error)
    r, c, triangles, _ = engine.output_cells()
    return r, c, hf.z[r, c].astype(np.float64), triangles, max(engine.max_error, seams.max_error), n_valid


def _interior_nodes(hf: Heightfield, method: str, max_error: float, options: dict) -> np.ndarray:
    """The cells the tile's method picks as vertices, off the tile's sides ((0, 2) when it picks none)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            chosen = simplify(hf, method, max_error=None if method == "cvt" else max_error, **options)
    except NoDataError:  # no triangle of the method's own holds data (a sliver of data): the seams suffice
        return np.empty((0, 2), np.int64)
    r, c = hf.world_to_pixel(chosen.vertices[:, 0], chosen.vertices[:, 1])
    rc = np.column_stack([np.rint(r), np.rint(c)]).astype(np.int64)
    h, w = hf.shape
    inner = (rc[:, 0] > 0) & (rc[:, 0] < h - 1) & (rc[:, 1] > 0) & (rc[:, 1] < w - 1)
    rc = rc[inner]
    return rc[hf.valid[rc[:, 0], rc[:, 1]]]


def _prefiltered(z, transform, job: TileJob) -> np.ndarray:
    """The wavelet pre-filter (Goebbels and Pohle-Fröhlich 2015) of the whole halo window.

    The tile's sides keep their seam lines.
    """
    window = Heightfield(z, transform=transform, crs=job.raster.crs, nodata=float("nan"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # land-use features outside this window
        return wavelet_filter(window, max_error=job.max_error, **job.prefilter).heightfield.z
