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
(:func:`.point_edge.spread_max_edge`; a survey, over the files nearest its
centre).

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
from ..errors import NoDataError
from ..resources import check_memory
from ..triangulation.pointtin import kept_points
from .point_edge import spread_max_edge
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
