"""Tiled runs on point clouds: a survey of any size meshed tile by tile, with seams that join.

``tile_cloud(sources, max_error=...)`` is the point-cloud side of
:func:`tinsmith.tiles.tile_raster`: greedy insertion on the points
(:mod:`tinsmith.algorithms.greedy.greedy_points`), the error exact at every point
of every tile, in bounded memory, on local processes or a Dask cluster,
resumable from a parts folder.

1. **Layout** by the point bounds of the files' headers: tiles of about
   ``tile_size`` world units a side (by default sized to hold about
   :data:`POINTS_PER_TILE` points).
2. **Buckets**: every file is streamed once, a chunk at a time, files in
   parallel, and the points of the kept classes of each chunk are written to
   one array per tile whose box, widened by ``reach``, holds them
   (``parts/buckets/TILE/FILE.CHUNK.npy``).  A tile then reads only its own
   points, however the survey's files are cut, and no worker holds a whole
   file.
   Before that, **max_edge** is fixed for the whole run ("auto":
   ``AUTO_EDGE_FACTOR`` (12) x the median edge of the TINs of blocks spread
   over the files nearest the survey's centre, :mod:`.point_edge`, as
   :func:`tinsmith.tin` takes it from all the points); ``reach`` is twice it.
3. **Tiles**: each tile's points strictly inside its box, with the vertices of
   its seam sides (:mod:`.point_seams`) as constrained segments, are
   triangulated; triangles along a covered seam segment are kept, along a gap
   removed, and elsewhere cut at ``max_edge`` as in :func:`tinsmith.tin` (an
   edge from a seam vertex counts its point's distance to the seam line, since
   simplified seams have long segments); greedy insertion then refines from
   the outline and the seams until every point of the tile is within the
   bound.  Points exactly on a seam line are seam vertices.
4. **Merge**: seam vertices have the same coordinates in both tiles and are
   joined by them.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import _checks
from .._version import __version__
from ..algorithms.greedy.greedy_points import PointGreedyEngine
from ..core import Heightfield, TerrainMesh
from ..core.pointcloud import class_codes
from ..errors import InvalidInputError, InvalidOptionError, NoDataError, TinsmithWarning
from ..io import atomic_paths
from ..io.gis_formats import write_geotiff
from ..io.points import clouds_info, iter_xyz, read_clouds
from ..kernels import pointtin as kpt
from ..kernels import tin as ktin
from ..resources import check_memory
from ..triangulation.delaunay import triangulate_points
from ..triangulation.pointtin import (
    AUTO_EDGE_FACTOR,
    DUPLICATE_RULES,
    PointTin,
    is_hull,
    max_edge_value,
)
from . import POINTS_PER_TILE
from .cesium import quantized_mesh_pyramid
from .point_edge import survey_max_edge
from .point_seams import Side, SideProfile, corner_height, side_profile
from .run import TileLog, TileSummaries, execute, forget_if_idle, open_parts, weld, write_part

__all__ = ["PointTileResult", "PointTileSpec", "TiledPointRun", "cloud_pyramid", "point_layout", "tile_cloud"]

#: The ASPRS class of water points (``water="class"`` of a pyramid).
WATER_CLASS = 9
#: The grid of water="class": this many times the survey's mean point spacing.
WATER_GRID = 2.0

#: Points read at a time when a file is bucketed: the memory of that stage whatever the files' sizes.
BUCKET_CHUNK = 2_000_000
#: A bucket holds the points within this many times ``reach`` of its tile (a margin: each side of a tile selects
#: the points within reach by its own arithmetic).
BUCKET_MARGIN = 1.05
#: Peak bytes per point of a tile's meshing (the full TIN, the greedy engine, the buckets read).
TILE_BYTES_PER_POINT = 400


@dataclass(frozen=True)
class PointTileSpec:
    """Tile ``(i, j)`` (row ``i`` along y, column ``j`` along x) of a point layout, with the cut lines of the whole layout."""

    i: int
    j: int
    xs: tuple
    ys: tuple

    @property
    def name(self) -> str:
        return f"tile_{self.i:04d}_{self.j:04d}"

    @property
    def box(self) -> tuple[float, float, float, float]:
        return self.xs[self.j], self.ys[self.i], self.xs[self.j + 1], self.ys[self.i + 1]

    def sides(self) -> list[Side]:
        """The tile's sides that are seams (shared with a neighbour), as :class:`.point_seams.Side`."""
        x0, y0, x1, y1 = self.box
        out = []
        if self.j > 0:
            out.append(Side(0, x0, y0, y1))
        if self.j + 2 < len(self.xs):
            out.append(Side(0, x1, y0, y1))
        if self.i > 0:
            out.append(Side(1, y0, x0, x1))
        if self.i + 2 < len(self.ys):
            out.append(Side(1, y1, x0, x1))
        return out

    def owns(self, xyz: np.ndarray) -> np.ndarray:
        """Mask of the points of this tile: strictly inside its box; on the survey's outer sides included."""
        x0, y0, x1, y1 = self.box
        x, y = xyz[:, 0], xyz[:, 1]
        first_j, last_j = self.j == 0, self.j + 2 == len(self.xs)
        first_i, last_i = self.i == 0, self.i + 2 == len(self.ys)
        return (((x >= x0) if first_j else (x > x0)) & ((x <= x1) if last_j else (x < x1))
                & ((y >= y0) if first_i else (y > y0)) & ((y <= y1) if last_i else (y < y1)))


def point_layout(bounds, tile_size: float) -> list[PointTileSpec]:
    """Tiles of about ``tile_size`` a side over ``bounds`` (xmin, ymin, xmax, ymax), row by row.

    Examples
    --------
    >>> from tinsmith.tiles import point_layout
    >>> tiles = point_layout((0.0, 0.0, 1000.0, 480.0), 250.0)
    >>> len(tiles)  # 4 columns and 2 rows of tiles about 250 a side
    8
    >>> tiles[0].xs, tiles[0].ys
    ((0.0, 250.0, 500.0, 750.0, 1000.0), (0.0, 240.0, 480.0))
    """
    tile_size = _checks.number("tile_size", tile_size, minimum=0.0, exclusive_min=True)
    xmin, ymin, xmax, ymax = (float(v) for v in bounds)

    def cuts(lo: float, hi: float) -> tuple:
        n = max(1, int(round((hi - lo) / tile_size)))
        return tuple([lo] + [lo + (hi - lo) * k / n for k in range(1, n)] + [hi])

    xs, ys = cuts(xmin, xmax), cuts(ymin, ymax)
    return [PointTileSpec(i, j, xs, ys) for i in range(len(ys) - 1) for j in range(len(xs) - 1)]


@dataclass(frozen=True)
class PointTileJob:
    """What every task of a run shares."""

    files: tuple
    classes: tuple | None
    duplicates: str
    max_error: float
    reach: float  # points read round each tile (seams and buckets): twice max_edge
    buckets: str  # folder of the buckets
    max_edge: float
    crs: str | None = None


@dataclass
class PointTileResult:
    """A meshed tile: its vertices (world x, y, z), triangles, the seam segments it shares, its figures."""

    vertices: np.ndarray
    triangles: np.ndarray
    seams: np.ndarray  # (S, 5): x0, y0, x1, y1, covered of each seam segment of the tile
    max_error: float
    seconds: float
    points: int
    covered: int

    @property
    def n_triangles(self) -> int:
        return len(self.triangles)

    def summary(self) -> dict:
        """The tile's line in the run's log."""
        return {"max_error": self.max_error, "seconds": self.seconds, "triangles": self.n_triangles,
                "points": self.points, "covered": self.covered}

    def to_dict(self) -> dict:
        return {"vertices": self.vertices, "triangles": self.triangles, "seams": self.seams,
                "max_error": self.max_error, "seconds": self.seconds, "points": self.points, "covered": self.covered}

    @classmethod
    def from_dict(cls, d) -> PointTileResult:
        return cls(np.asarray(d["vertices"]), np.asarray(d["triangles"]), np.asarray(d["seams"]),
                   float(d["max_error"]), float(d["seconds"]), int(d["points"]), int(d["covered"]))


# -- stage 1: buckets ---------------------------------------------------------------------------
def _bucket_dir(job: PointTileJob, spec: PointTileSpec) -> Path:
    return Path(job.buckets) / spec.name


def _bucket_file(task: tuple, job: PointTileJob) -> dict:
    """Stream one file, a chunk of :data:`BUCKET_CHUNK` points at a time, into the buckets of the tiles its points
    reach (``TILE/FILE.CHUNK.npy``: a file of any size in the memory of one chunk); points per tile."""
    k, specs = task
    counts: dict[str, int] = {}
    r = BUCKET_MARGIN * job.reach
    for c, xyz in enumerate(iter_xyz(job.files[k], classes=job.classes, chunk_size=BUCKET_CHUNK)):
        lo, hi = xyz[:, :2].min(axis=0), xyz[:, :2].max(axis=0)
        for spec in specs:
            x0, y0, x1, y1 = spec.box
            if x0 - r > hi[0] or x1 + r < lo[0] or y0 - r > hi[1] or y1 + r < lo[1]:
                continue
            mask = bucket_mask(xyz, spec, job)
            if not mask.any():
                continue
            bucket = xyz[mask]
            folder = _bucket_dir(job, spec)
            folder.mkdir(parents=True, exist_ok=True)
            with atomic_paths(folder / f"{k:05d}.{c:05d}.npy") as (tmp,), open(tmp, "wb") as f:
                np.save(f, bucket)
            counts[spec.name] = counts.get(spec.name, 0) + int(spec.owns(bucket).sum())
    return counts


def bucket_mask(xyz: np.ndarray, spec: PointTileSpec, job: PointTileJob) -> np.ndarray:
    """Mask of the points of a tile's bucket: within :data:`BUCKET_MARGIN` x ``reach`` of its box."""
    x0, y0, x1, y1 = spec.box
    r = BUCKET_MARGIN * job.reach
    x, y = xyz[:, 0], xyz[:, 1]
    return (x >= x0 - r) & (x <= x1 + r) & (y >= y0 - r) & (y <= y1 + r)


def _read_bucket(job: PointTileJob, spec: PointTileSpec) -> np.ndarray:
    """The tile's points: its buckets in the order of the files and of their chunks."""
    folder = _bucket_dir(job, spec)
    parts = [np.load(p) for p in sorted(folder.glob("*.npy"))] if folder.is_dir() else []
    return np.concatenate(parts) if parts else np.empty((0, 3))


# -- stage 2: a tile ----------------------------------------------------------------------------
def _tile_profiles(xyz: np.ndarray, spec: PointTileSpec, job: PointTileJob) -> list[SideProfile]:
    out = []
    heights: dict[tuple[float, float], float | None] = {}  # a corner two of the tile's sides end at, once
    for side in spec.sides():
        ends = [(side.at, side.lo), (side.at, side.hi)] if side.axis == 0 else [(side.lo, side.at), (side.hi, side.at)]
        for end in ends:
            if end not in heights:
                heights[end] = corner_height(xyz, *end, job.reach, job.duplicates)
        corners = tuple(heights[end] for end in ends)
        out.append(side_profile(xyz, side, reach=job.reach, max_edge=job.max_edge, duplicates=job.duplicates,
                                bound=job.max_error, corners=corners))
    return out


def _seam_network(profiles: list[SideProfile]):
    """(V, 3) the distinct seam vertices, (S, 2) segment ends as indices into them, (S,) covered flags."""
    if not any(len(p.xyz) for p in profiles):
        return np.empty((0, 3)), np.empty((0, 2), np.int64), np.empty(0, bool)
    allv = np.concatenate([p.xyz for p in profiles if len(p.xyz)])
    verts, inverse = np.unique(allv[:, :2], axis=0, return_inverse=True)
    z = np.empty(len(verts))
    z[inverse.ravel()] = allv[:, 2]
    segs, cov, offset = [], [], 0
    for p in profiles:
        k = len(p.xyz)
        if k > 1:
            ids = inverse.ravel()[offset:offset + k]
            segs.append(np.column_stack([ids[:-1], ids[1:]]))
            cov.append(p.covered)
        offset += k
    segs = np.concatenate(segs) if segs else np.empty((0, 2), np.int64)
    cov = np.concatenate(cov) if cov else np.empty(0, bool)
    return np.column_stack([verts, z]), segs.astype(np.int64), cov


def _tile_keep(ptin, n_points: int, segs: np.ndarray, covered: np.ndarray, on_x: np.ndarray, on_y: np.ndarray,
               max_edge: float) -> np.ndarray:
    """Triangles kept: along covered seam segments; not along gaps; elsewhere no free edge longer than max_edge.

    A simplified seam has long segments, so the triangles between it and the
    tile's nearest points have long edges the full TIN would not have (there,
    points across the seam split them).  In a triangle with a vertex on a
    covered seam segment, an edge therefore counts its points' distance to
    that side (``on_x`` / ``on_y``: the seam vertices, from ``n_points`` on,
    on a vertical / horizontal side of the tile): it opens only where the
    points themselves are farther than ``max_edge`` from a covered seam.
    """
    m = ptin.m
    p = ptin.xyz
    V = len(p)
    keys, key_covered = np.empty(0, np.int64), np.empty(0, bool)
    if len(segs):
        ends = np.sort(segs, axis=1).astype(np.int64)
        order = np.argsort(ends[:, 0] * V + ends[:, 1])
        keys, key_covered = (ends[:, 0] * V + ends[:, 1])[order], np.asarray(covered, bool)[order]
    # the sides of the covered seam segments each triangle touches
    joined = np.zeros(V, bool)
    joined[segs[covered].ravel()] = True
    line_x = np.full(V, np.nan)
    line_y = np.full(V, np.nan)
    line_x[n_points:] = np.where(on_x & joined[n_points:], p[n_points:, 0], np.nan)
    line_y[n_points:] = np.where(on_y & joined[n_points:], p[n_points:, 1], np.nan)
    return kpt.tile_keep(m[2], m[4], ptin.n_triangles, np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1]),
                         n_points, keys, key_covered, line_x, line_y, float(max_edge))


def tile_tin(xyz: np.ndarray, spec: PointTileSpec, job: PointTileJob):
    """The TIN a tile is refined from: ``(ptin or None, seams (S, 5), points owned)``.

    ``xyz`` is the tile's bucket (its points and those within ``reach``).
    ``ptin`` is None when the tile's points cover no area.
    """
    own = xyz[spec.owns(xyz)]
    sv, segs, covered = _seam_network(_tile_profiles(xyz, spec, job))
    seams = np.empty((0, 5))
    if len(segs):
        seams = np.column_stack([sv[segs[:, 0], :2], sv[segs[:, 1], :2], covered])
    if len(own) + len(sv) < 3:
        return None, seams, len(own)
    pts = np.concatenate([own, sv])
    try:
        m, same, stack = triangulate_points(pts[:, :2])
    except InvalidInputError:  # points on one line or at one place: no area
        return None, seams, len(own)
    merged = int(np.count_nonzero(same != np.arange(len(same))))
    if merged:  # duplicates are among the tile's own points only (seam vertices are on its sides)
        z = np.array(pts[:, 2], np.float64)
        _, kept = kpt.merge_duplicates(m, same, z, DUPLICATE_RULES.index(job.duplicates))
        pts = np.column_stack([m[0][:kept], m[1][:kept], z[:kept]])
    n_points = len(pts) - len(sv)
    local = segs + n_points
    if len(local):
        failed, _, _ = ktin.insert_segments(m, local[:, 0].copy(), local[:, 1].copy(), stack, np.empty(64, np.int32))
        if failed >= 0:  # pragma: no cover - seams lie on the box's sides, points strictly inside
            raise RuntimeError(f"tile {spec.name}: a seam segment crosses another")
    x0, y0, x1, y1 = spec.box
    on_x = (sv[:, 0] == x0) | (sv[:, 0] == x1)
    on_y = (sv[:, 1] == y0) | (sv[:, 1] == y1)
    ptin = PointTin(pts, m, np.ones(0, bool), job.max_edge, merged, constrained=local)
    ptin.keep = _tile_keep(ptin, n_points, local, covered, on_x, on_y, job.max_edge)
    return (ptin if ptin.keep.any() else None), seams, n_points


def mesh_point_tile(spec: PointTileSpec, job: PointTileJob) -> PointTileResult:
    """Mesh one tile of a survey under the seam contract (see the module notes), from its buckets."""
    return mesh_tile_points(_read_bucket(job, spec), spec, job)


def mesh_tile_points(xyz: np.ndarray, spec: PointTileSpec, job: PointTileJob) -> PointTileResult:
    """Mesh one tile from its bucket (:func:`bucket_mask`: its points and those within reach of its box)."""
    start = time.perf_counter()
    ptin, seams, n_points = tile_tin(xyz, spec, job)
    if ptin is None:
        return PointTileResult(np.empty((0, 3)), np.empty((0, 3), np.int64), seams, 0.0,
                               time.perf_counter() - start, n_points, 0)
    engine = PointGreedyEngine(ptin, job.crs)
    engine.refine(max_error=job.max_error)
    mesh = engine.to_mesh()
    covered = len(engine.candidates) + int(np.count_nonzero(engine._fixed < n_points))
    return PointTileResult(mesh.vertices, mesh.triangles, seams, float(engine.max_error),
                           time.perf_counter() - start, n_points, covered)


# -- the run ------------------------------------------------------------------------------------
class TiledPointRun(TileSummaries):
    """The outcome of :func:`tile_cloud`: per-tile results and their merge (``max_error``: at any point of any tile).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from tinsmith.tiles import tile_cloud
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0.0, 200.0, size=(20000, 2))
    >>> z = 10.0 * np.sin(xy[:, 0] / 30.0) + 0.05 * xy[:, 1]  # a rolling surface
    >>> folder = tempfile.TemporaryDirectory()
    >>> np.savetxt(Path(folder.name) / "survey.xyz", np.column_stack([xy, z]))
    >>> run = tile_cloud(Path(folder.name) / "survey.xyz", max_error=0.5, tile_size=100.0, workers=1)
    >>> run.covered <= run.points <= len(xy)  # points inside the outline: each within the bound
    True
    >>> [axis for axis, at, lo, hi in run.seam_lines()]  # one cut along x, one along y
    [0, 1]
    >>> folder.cleanup()
    """

    def __init__(self, specs, results: dict, summaries: dict, parts, reused: int, job: PointTileJob):
        self.specs, self.parts, self.reused, self.job = specs, parts, reused, job
        self._results, self._summaries = results, summaries

    def result(self, spec: PointTileSpec) -> PointTileResult:
        if spec.name in self._results:
            return self._results[spec.name]
        with np.load(Path(self.parts) / f"{spec.name}.npz") as d:
            return PointTileResult.from_dict(d)

    @property
    def max_edge(self) -> float:
        return self.job.max_edge

    @property
    def points(self) -> int:
        """Points of the kept classes owned by the tiles (those on seam lines excluded)."""
        return int(sum(s["points"] for s in self._summaries.values()))

    @property
    def covered(self) -> int:
        """Points inside the meshed outline: every one of them is within the bound."""
        return int(sum(s["covered"] for s in self._summaries.values()))

    def tile_mesh(self, spec: PointTileSpec) -> TerrainMesh:
        r = self.result(spec)
        return TerrainMesh(r.vertices, r.triangles, crs=self.job.crs, info={"tile": [spec.i, spec.j]})

    def seam_lines(self) -> list[tuple[int, float, float, float]]:
        """Every cut of the layout between tiles: ``(axis, at, lo, hi)`` (axis 0: x = at; 1: y = at)."""
        xs, ys = self.specs[0].xs, self.specs[0].ys
        return ([(0, x, ys[0], ys[-1]) for x in xs[1:-1]] + [(1, y, xs[0], xs[-1]) for y in ys[1:-1]])

    def seam_segments(self) -> np.ndarray:
        """(S, 5) every seam segment once: x0, y0, x1, y1, covered."""
        segs = [self.result(s).seams for s in self.specs]
        segs = np.concatenate(segs) if segs else np.empty((0, 5))
        return np.unique(segs, axis=0) if len(segs) else segs

    def merge(self) -> TerrainMesh:
        """All tiles as one mesh, seam vertices joined by their coordinates (the same in both tiles)."""
        xs, ys = self.specs[0].xs[1:-1], self.specs[0].ys[1:-1]
        verts = [self.result(spec).vertices for spec in self.specs]
        sides = [np.isin(v[:, 0], xs) | np.isin(v[:, 1], ys) for v in verts]
        triangles, first = weld(sides, [v[m, :2] for v, m in zip(verts, sides, strict=True)],
                                [self.result(spec).triangles for spec in self.specs])
        on_sides = np.concatenate([v[m] for v, m in zip(verts, sides, strict=True)]) if verts else np.empty((0, 3))
        vertices = np.concatenate([v[~m] for v, m in zip(verts, sides, strict=True)] + [on_sides[first]])
        info = {"error": {"max": self.max_error}, "tiles": len(self.specs), "tile_seconds": self.tile_seconds,
                "max_edge": self.max_edge, "max_error_used": self.job.max_error, "points": self.points,
                "points_covered": self.covered}
        return TerrainMesh(vertices, triangles, crs=self.job.crs, info=info)


def _default_tile_size(bounds, count: int) -> float:
    area = max((bounds[2] - bounds[0]) * (bounds[3] - bounds[1]), 1e-12)
    return math.sqrt(area * POINTS_PER_TILE / max(count, 1))


def tile_cloud(sources, *, max_error: float, classes=None, duplicates: str = "lowest", max_edge="auto",
               tile_size: float | None = None, workers: int | None = None, scheduler: str | None = None,
               parts=None, progress: Callable[[int, int], None] | None = None) -> TiledPointRun:
    """Mesh a point cloud of any size tile by tile, greedy insertion on the points, seams that join.

    Parameters
    ----------
    sources : path, folder, glob or list of them
        LAS/LAZ or XYZ files (see :func:`tinsmith.io.points.expand_sources`).
    max_error : float
        The vertical error bound at every point of every tile (z units).
    classes : iterable of int, optional
        ASPRS classes to keep (``[2]`` for a ground TIN).
    duplicates : {"lowest", "highest", "mean"}
        Height of points at one x-y (as :func:`tinsmith.tin`).
    max_edge : "auto" or float
        The outline's edge length (as :func:`tinsmith.tin`; "auto" from a
        sample of the survey, see the module notes).
    tile_size : float, optional
        Tile side in world units; default: about :data:`POINTS_PER_TILE`
        points a tile.
    workers, scheduler, parts, progress
        As for :func:`tinsmith.tiles.tile_raster` (``progress`` counts the
        files bucketed, then the tiles).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from tinsmith.tiles import tile_cloud
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0.0, 200.0, size=(20000, 2))
    >>> z = 10.0 * np.sin(xy[:, 0] / 30.0) + 0.05 * xy[:, 1]  # a rolling surface
    >>> folder = tempfile.TemporaryDirectory()
    >>> np.savetxt(Path(folder.name) / "survey.xyz", np.column_stack([xy, z]))
    >>> run = tile_cloud(Path(folder.name) / "survey.xyz", max_error=0.5, tile_size=100.0, workers=1)
    >>> len(run.specs), run.max_error <= 0.5
    (4, True)
    >>> mesh = run.merge()
    >>> mesh.n_vertices < len(xy)
    True
    >>> folder.cleanup()
    """
    max_error, duplicates, fixed_edge, workers = run_options(max_error, duplicates, max_edge, workers)
    codes = class_codes(classes)
    infos, crs = clouds_info(sources)
    counted = [i for i in infos if i.count]
    if not counted:
        raise NoDataError(f"no points in {len(infos)} file(s) ({infos[0].path.name}, ...)")
    b = np.array([i.bounds for i in counted])
    bounds = (b[:, 0].min(), b[:, 1].min(), b[:, 3].max(), b[:, 4].max())
    count = sum(i.count for i in counted)
    if tile_size is None:
        tile_size = _default_tile_size(bounds, count)
    specs = point_layout(bounds, tile_size)
    parallel = 1 if (scheduler is not None and scheduler != "local") else (workers or os.cpu_count() or 1)
    per_tile = count / len(specs)
    check_memory(int(parallel * TILE_BYTES_PER_POINT * per_tile * 1.5),
                 f"meshing tiles of about {per_tile:,.0f} points on {parallel} worker(s)",
                 "a smaller tile_size (--tile-size) or fewer workers")

    fingerprint = {"tinsmith": __version__, "kind": "points",
                   "files": [_file_key(i.path) for i in infos], "classes": list(codes) if codes else None,
                   "duplicates": duplicates, "max_edge": str(max_edge), "max_error": float(max_error),
                   "tile_size": float(tile_size)}
    scratch = None
    if parts is None:
        scratch = parts = Path(tempfile.mkdtemp(prefix="tinsmith-tiles-"))
    parts = Path(parts)
    summaries: dict = {}
    opened = hopeless = False

    def nothing_done() -> bool:
        """Nothing to resume from: no file bucketed and no tile meshed (a max_edge is soon sampled again),
        or no point to mesh at all."""
        return opened and (hopeless or not any(n.startswith(("file_", "tile_")) for n in summaries))

    try:
        with forget_if_idle(None if scratch is not None else parts, nothing_done):
            summaries = open_parts(parts, fingerprint)
            opened = True
            log = TileLog(parts / "tiles.jsonl")
            files = tuple(str(i.path) for i in infos)
            edge = fixed_edge
            if edge is None:
                edge = summaries.get("max_edge", {}).get("value")
                if edge is None:
                    edge = survey_max_edge(counted, codes, duplicates, parallel)
                    log.append("max_edge", {"value": edge})
            job = PointTileJob(files, codes, duplicates, float(max_error), 2.0 * float(edge), str(parts / "buckets"),
                               max_edge=float(edge), crs=crs)
            total = len(infos) + len(specs)
            done_files = {k for k in range(len(infos)) if f"file_{k:05d}" in summaries}
            counts = _bucketed_counts(summaries)
            done = len(done_files)
            if progress is not None:
                progress(done, total)
            todo = [(k, specs) for k in range(len(infos)) if k not in done_files]
            for task, c in execute(_bucket_file, todo, job, workers, scheduler):
                for t, n in c.items():
                    counts[t] = counts.get(t, 0) + n
                summaries[f"file_{task[0]:05d}"] = {"counts": c}
                log.append(f"file_{task[0]:05d}", {"counts": c})
                done += 1
                if progress is not None:
                    progress(done, total)
            if not any(counts.values()):
                hopeless = True
                raise NoDataError(f"no points{'' if codes is None else ' of the classes ' + str(list(codes))} "
                                  f"in {len(infos)} file(s) ({infos[0].path.name}, ...)")
            results: dict[str, PointTileResult] = {}
            tiles_todo = [s for s in specs if s.name not in summaries]
            done += len(specs) - len(tiles_todo)
            for spec, result in execute(mesh_point_tile, tiles_todo, job, workers, scheduler):
                results[spec.name] = result
                write_part(parts, spec, result, summaries)
                done += 1
                if progress is not None:
                    progress(done, total)
            reused = len(specs) - len(tiles_todo)
            # a scratch folder is new, so every tile ran in this call and its result is in memory
            return TiledPointRun(specs, results, {s.name: summaries[s.name] for s in specs},
                                 None if scratch is not None else parts, reused, job)
    finally:
        if scratch is not None:
            shutil.rmtree(scratch, ignore_errors=True)


def run_options(max_error, duplicates, max_edge, workers) -> tuple:
    """(max_error, duplicates, the fixed max_edge or None for "auto", workers), checked for a tiled run."""
    max_error = _checks.number("max_error", max_error)
    if not max_error > 0:
        raise InvalidOptionError(f"max_error must be > 0 for tiled runs (the seams are simplified to it), got {max_error}")
    duplicates = _checks.choice("duplicates", duplicates, DUPLICATE_RULES)
    if is_hull(max_edge):
        raise InvalidOptionError("max_edge must be 'auto' or a length > 0 for tiled runs (a convex hull has no tiles)")
    fixed_edge = None if isinstance(max_edge, str) and max_edge.lower() == "auto" else max_edge_value(max_edge, None)
    if workers is not None:
        workers = _checks.integer("workers", workers, minimum=1)
    return max_error, duplicates, fixed_edge, workers


def _bucketed_counts(summaries: dict) -> dict[str, int]:
    """Points per tile in the files bucketed already (a resumed run's ``file_*`` summaries)."""
    counts: dict[str, int] = {}
    for name, s in summaries.items():
        if name.startswith("file_"):
            for t, n in s.get("counts", {}).items():
                counts[t] = counts.get(t, 0) + n
    return counts


def _file_key(path: Path) -> dict:
    stat = Path(path).stat()
    return {"path": str(Path(path).resolve()), "size": stat.st_size, "mtime_ns": stat.st_mtime_ns}


def cloud_pyramid(run: TiledPointRun, out_dir, *, cell_size: float | None = None, scratch=None, **pyramid) -> dict:
    """A quantized-mesh pyramid for CesiumJS of a tiled point run: its TIN as a DEM, then the raster pyramid.

    The merged TIN (within ``max_error`` of every point) is sampled at the
    centres of a grid of ``cell_size`` (default: the median edge of the
    points' TIN, ``max_edge / AUTO_EDGE_FACTOR``) into a GeoTIFF in ``scratch``
    (the run's parts folder by default; kept there, so that a stopped pyramid
    resumes), and :func:`tinsmith.tiles.cesium.quantized_mesh_pyramid` meshes
    it (``pyramid`` are its keyword arguments, ``max_error`` included).  Each
    level's bound holds against that DEM at its sample nodes, so against the
    points the finest level is within about ``max_error`` of the run plus the
    level's bound.
    """
    if run.job.crs is None:
        raise InvalidInputError("the point clouds have no CRS: a quantized-mesh pyramid needs to place them on the globe")
    cell = float(cell_size) if cell_size is not None else run.max_edge / AUTO_EDGE_FACTOR
    folder = Path(scratch if scratch is not None else (run.parts or tempfile.mkdtemp(prefix="tinsmith-pyramid-")))
    tif = folder / f"tin_{cell:.6g}.tif"
    if not tif.exists():
        mesh = run.merge()
        x0, y0 = mesh.vertices[:, :2].min(axis=0)
        x1, y1 = mesh.vertices[:, :2].max(axis=0)
        w, h = int(np.ceil((x1 - x0) / cell)) + 1, int(np.ceil((y1 - y0) / cell)) + 1
        check_memory(12 * w * h, f"a {h:,} x {w:,} grid of the TIN for the pyramid", "a larger cell size")
        grid = Heightfield(np.zeros((h, w), np.float32), transform=(cell, 0.0, x0 - cell / 2, 0.0, -cell, y1 + cell / 2),
                           crs=run.job.crs, nodata=float("nan"))
        folder.mkdir(parents=True, exist_ok=True)
        with atomic_paths(tif) as (tmp,):
            write_geotiff(mesh, tmp, grid=grid)
    if isinstance(pyramid.get("water"), str) and pyramid["water"] == "class":
        pyramid = {**pyramid, "water": _water_points(run)}
    summary = quantized_mesh_pyramid(tif, out_dir, **pyramid)
    summary["cell_size"] = cell
    return summary


def _water_points(run: TiledPointRun):
    """The area of the run's water points (ASPRS class 9), in the clouds' CRS; one warning line when there are none.

    Water returns few pulses, so the water points are sparse: on a grid of
    :data:`WATER_GRID` times the survey's mean spacing, a cell is water where
    most of the returns in its 3 x 3 neighbourhood are water points, and
    cells without returns that water surrounds are water too.
    """
    import shapely
    from scipy import ndimage

    from ..io.geometry import mask_polygons

    try:
        points = read_clouds(list(run.job.files), classes=run.job.classes)
    except NoDataError:
        points = None
    codes = None if points is None else points.classification
    if points is None or codes is None or not (codes == WATER_CLASS).any():
        warnings.warn(f"water='class': the point clouds hold no water points (class {WATER_CLASS}); every tile is "
                      "marked land", TinsmithWarning, stacklevel=3)
        return shapely.Polygon()
    xy = np.asarray(points.xyz)[:, :2]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    step = max(WATER_GRID * math.sqrt(span[0] * span[1] / len(xy)), float(span.max()) / 8192)
    cols = ((xy[:, 0] - lo[0]) / step).astype(np.int64) + 1
    rows = ((hi[1] - xy[:, 1]) / step).astype(np.int64) + 1
    shape = (int(rows.max()) + 2, int(cols.max()) + 2)
    every = np.zeros(shape)
    np.add.at(every, (rows, cols), 1.0)
    wet = np.zeros(shape)
    water = codes == WATER_CLASS
    np.add.at(wet, (rows[water], cols[water]), 1.0)
    every, wet = ndimage.uniform_filter(every, 3), ndimage.uniform_filter(wet, 3)
    mask = (every > 0) & (wet >= 0.5 * every)
    mask = ndimage.binary_fill_holes(mask)
    polys = mask_polygons(mask, (step, 0.0, lo[0] - step, 0.0, -step, hi[1] + step))
    return shapely.union_all(np.asarray(polys, dtype=object)) if polys else shapely.Polygon()
