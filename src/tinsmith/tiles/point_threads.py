"""Greedy insertion on an in-memory point cloud in tiles on threads: one file meshed as a survey is.

``tinsmith.greedy(cloud, max_error=..., workers=2)`` comes here (through the
hook ``tile_points`` of :mod:`tinsmith._hooks`): the points are cut into
tiles of about :data:`TILE_POINTS` points and meshed under the seam contract
of :mod:`.points` (each side a profile of the points' TIN simplified once,
within the bound, shared by both tiles), the tiles on threads (the kernels
release the GIL), each reading its points straight from the cloud.  It is
the survey's run (:func:`.points.tile_cloud`) without the files: the same
buckets, tiles, seams and keep rules, so with a ``max_edge`` given, the same
mesh as that run over the cloud written to a file with the same tile size.
``max_edge="auto"`` is taken as one piece takes it, from the median edge of
the points' TIN, here sampled in blocks spread over the whole cloud
(:func:`spread_max_edge`; a survey samples the one box at its centre).

Against one piece (``workers=1``) the mesh differs along the seams: each
seam is a simplified profile both tiles keep, and by the few per cent
between the sampled median edge and the whole TIN's.  The bound holds at
every point inside the outline either way.  The tiles depend on the points
alone, so the mesh is the same on any number of workers above one.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, as_completed

import numpy as np

from .. import _checks
from ..core import PointCloud, TerrainMesh
from ..core.pointcloud import class_codes
from ..errors import InvalidInputError, NoDataError
from ..kernels import pointtin as kpt
from ..resources import check_memory
from ..triangulation.pointtin import auto_max_edge, auto_max_edge_of, build_point_tin, kept_points
from .points import (
    TILE_BYTES_PER_POINT,
    PointTileJob,
    TiledPointRun,
    bucket_mask,
    mesh_tile_points,
    point_layout,
    run_options,
)

__all__ = ["TILE_POINTS", "point_tiles", "tile_points"]

#: A tile holds about this many points.  Chosen on Delft AHN3's ground (283k points) and CODEM's city
#: (222k, every class) at a 0.1 m bound, two threads: tiles of 50k points cost more seams (0.6% more
#: vertices than one piece on Delft, 0.3% on CODEM) for no gain in time over 100k (0.05% and 0.2%);
#: 200k makes one tile of either.  Figures: benchmarks/RESULTS_points.md.
TILE_POINTS = 100_000
#: "auto" max_edge from the TINs of SPREAD_BLOCKS x SPREAD_BLOCKS blocks of about SPREAD_POINTS points spread over
#: the cloud (:func:`spread_max_edge`).  Against the whole TIN's median: Delft's ground +0.04%, Delft with
#: every class -1.42%, CODEM 0.00%, the 100M survey's first file's ground +0.44%, where the survey's sample of
#: the 200,000 points at the centre was +1.04%, +21.5%, 0.00% and +21.5% (forest at the centre of the file).
#: Clouds the blocks would hold nearly all of (both lidR forests, Autzen) take the whole TIN's.
SPREAD_BLOCKS, SPREAD_POINTS = 8, 2_000


def spread_max_edge(xyz: np.ndarray, bounds, workers: int) -> float:
    """"auto" of a cloud in memory: AUTO_EDGE_FACTOR x the median edge of the TINs of blocks spread over it.

    :data:`SPREAD_BLOCKS` x :data:`SPREAD_BLOCKS` square blocks, one at the
    centre of each cell of that grid over ``bounds``, each about the size
    that holds :data:`SPREAD_POINTS` points at the cloud's mean density, are
    triangulated apart (on ``workers`` threads) and their edges pooled: the
    median edge of the whole cloud's TIN, which one piece takes, sampled
    over all of it rather than at its centre (as a survey must, reading one
    box of its files).  A cloud the blocks would hold nearly all of is
    triangulated whole: its median exactly.
    """
    n = len(xyz)
    g = SPREAD_BLOCKS
    if n <= g * g * SPREAD_POINTS:
        return auto_max_edge_of(xyz, workers=workers)
    x0, y0, x1, y1 = bounds
    wx, wy = (x1 - x0) / g, (y1 - y0) / g
    half = 0.5 * math.sqrt(max(wx * wy * g * g, 1e-24) * SPREAD_POINTS / n)
    hx, hy = min(half, wx / 2), min(half, wy / 2)
    col = np.clip(((xyz[:, 0] - x0) / wx).astype(np.int64), 0, g - 1) if wx > 0 else np.zeros(n, np.int64)
    row = np.clip(((xyz[:, 1] - y0) / wy).astype(np.int64), 0, g - 1) if wy > 0 else np.zeros(n, np.int64)
    inside = ((np.abs(xyz[:, 0] - (x0 + (col + 0.5) * wx)) <= hx)
              & (np.abs(xyz[:, 1] - (y0 + (row + 0.5) * wy)) <= hy))
    ids = np.flatnonzero(inside)
    block = (row * g + col)[ids]
    ids = ids[np.argsort(block, kind="stable")]
    parts = np.split(ids, np.cumsum(np.bincount(block, minlength=g * g))[:-1])

    def lengths(part):
        try:
            return kpt.edge_lengths(build_point_tin(xyz[part], max_edge=None).m)
        except (InvalidInputError, NoDataError):  # a block of fewer than 3 points, or of points on one line
            return np.empty(0)

    with ThreadPoolExecutor(max_workers=workers) as pool:
        pooled = np.concatenate(list(pool.map(lengths, parts)))
    if not len(pooled):  # the blocks missed every area of points
        return auto_max_edge_of(xyz, workers=workers)
    return auto_max_edge(float(np.median(pooled)))


def point_tiles(xyz: np.ndarray, tile_size: float | None = None) -> list:
    """The layout of the tiles over (N, 3) points: about :data:`TILE_POINTS` points a tile by default."""
    bounds = (float(xyz[:, 0].min()), float(xyz[:, 1].min()), float(xyz[:, 0].max()), float(xyz[:, 1].max()))
    if tile_size is None:
        area = max((bounds[2] - bounds[0]) * (bounds[3] - bounds[1]), 1e-12)
        tile_size = math.sqrt(area * TILE_POINTS / len(xyz))
    return point_layout(bounds, tile_size)


def tile_points(cloud: PointCloud, *, max_error: float, classes=None, duplicates: str = "lowest", max_edge="auto",
                workers: int | None = None, tile_size: float | None = None,
                progress: Callable[[float], None] | None = None) -> TerrainMesh | None:
    """Greedy insertion on the points of ``cloud`` in tiles on ``workers`` threads (None: every core), seams shared.

    Returns the merged mesh (``info``: ``tiles``, ``workers``, ``max_edge``,
    ``points``, ``points_covered``, ``error``), or None when the points make
    one tile (the caller then meshes them in one piece).  ``tile_size``
    (world units) defaults to about :data:`TILE_POINTS` points a tile.
    """
    max_error, duplicates, fixed_edge, workers = run_options(max_error, duplicates, max_edge, workers)
    workers = _checks.workers(workers)
    xyz = kept_points(cloud, classes)
    if len(xyz) < 3:
        raise NoDataError(f"a TIN needs at least 3 points with distinct x-y, got {len(xyz)}")
    specs = point_tiles(xyz, tile_size)
    if len(specs) == 1:
        return None
    per_tile = len(xyz) / len(specs)
    check_memory(int(workers * TILE_BYTES_PER_POINT * per_tile * 1.5),
                 f"meshing tiles of about {per_tile:,.0f} points on {workers} thread(s)", "fewer workers")
    bounds = (specs[0].xs[0], specs[0].ys[0], specs[0].xs[-1], specs[0].ys[-1])
    edge = spread_max_edge(xyz, bounds, workers) if fixed_edge is None else fixed_edge
    codes = class_codes(classes)
    job = PointTileJob((), codes, duplicates, float(max_error), 2.0 * float(edge), "", max_edge=float(edge),
                       crs=cloud.crs)
    results = {}
    with ThreadPoolExecutor(max_workers=workers) as pool:
        futures = {pool.submit(lambda s: mesh_tile_points(xyz[bucket_mask(xyz, s, job)], s, job), spec): spec
                   for spec in specs}
        for future in as_completed(futures):
            results[futures[future].name] = future.result()
            if progress is not None:
                progress(len(results) / len(specs))
    summaries = {name: r.summary() for name, r in results.items()}
    mesh = TiledPointRun(specs, results, summaries, None, 0, job).merge()
    mesh.info["workers"] = workers
    return mesh
