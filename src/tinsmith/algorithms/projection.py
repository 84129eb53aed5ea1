"""General mode of the projection-based reconstruction (seed 001, section 4; Gopi and Krishnan 2002).

The points are bucketed in the dexel array (:func:`dexel_buckets`); a
breadth-first front then takes one reference point R at a time
(:func:`tinsmith.kernels.projection.greedy_projection`):

1. **Distance pruning**: the L-infinity box about R (a few dexels, each
   searched by height), then the sphere of influence of radius ``mu * m``,
   ``m`` the distance from R to its nearest connected neighbour (its nearest
   point for a fresh seed).  Completed points are never candidates.
2. **Projection plane**: the mean normal of the triangles already at R; for
   a fresh seed, the direction of least spread of R and its candidates
   (PCA), turned upwards.
3. **Visibility pruning** in that plane: candidates between R's consecutive
   border edges (inside its fans) are dropped (rule 1); so are those that
   have R inside one of their own fans (rule 2), and those hidden behind a
   border edge of a candidate or of R's neighbours (rule 3: only border
   edges can hide a point, the paper's theorem).
4. **Angle pruning** (``min_angle``): a point that makes too small an angle
   with the one before it is dropped, only where the triangle that skips it
   does not cover it (no point is trapped).
5. **Connection** in angular order within each free range of R; neighbours
   more than ``max_angle`` apart leave a gap.  A triangle is added only if
   each of its directed edges is new, so every edge has at most two
   triangles walked in opposite directions: the mesh is manifold and
   consistently oriented by construction.  New neighbours become fringe
   points at the back of the queue; R becomes completed when its fan
   closes, a boundary point otherwise.  An empty queue re-seeds at the next
   free point (one seed per component).

Each component is then turned so that its normals point outwards (closed)
or upwards (open).
"""

from __future__ import annotations

import numpy as np

from ..core import PointCloud, TerrainMesh
from ..errors import InvalidOptionError
from ..kernels import cloud as cloud_kernel
from ..kernels import projection as kernel
from ..kernels.projection import COMPLETED

__all__ = ["dexel_buckets", "dexel_grid", "general_mesh"]

MAX_CANDIDATES = 64
"""At most this many points, the nearest, are candidates of one reference point."""


def dexel_grid(xy: np.ndarray, size: float):
    """(row, col) of every point's dexel, the grid shape (ny, nx) and its corner; rows go up in y.

    A grid far larger than the cloud (a dexel size far below the spacing) is refused.
    """
    lo = xy.min(axis=0)
    idx = np.floor((xy - lo) / size).astype(np.int64)
    nx, ny = int(idx[:, 0].max()) + 1, int(idx[:, 1].max()) + 1
    if nx * ny > 4 * len(xy) + 1_000_000:
        raise InvalidOptionError(
            f"dexel_size {size:g} makes a {ny} x {nx} dexel grid for {len(xy)} points; choose a larger dexel_size"
        )
    return idx[:, 1], idx[:, 0], (ny, nx), lo


def dexel_buckets(xyz: np.ndarray, size: float):
    """(cstart, cidx, x0, y0, nx, ny): the points of dexel k are ``cidx[cstart[k]:cstart[k+1]]``, sorted by z."""
    rows, cols, (ny, nx), lo = dexel_grid(xyz[:, :2], size)
    cstart, cidx = cloud_kernel.bucket(rows * nx + cols, np.ascontiguousarray(xyz[:, 2]), nx * ny)
    return cstart, cidx, float(lo[0]), float(lo[1]), nx, ny


def _front(p, nnd, dexels, mu, max_angle, min_angle):
    """(triangles, state): the kernel's front with every buffer it needs, enlarged and run again when one is full."""
    n = len(p)
    cstart, cidx, x0, y0, h, nx, ny = dexels
    size = {"triangles": 2 * n + 64, "entries": 4 * (2 * n + 64), "neighbours": 256, "edges": 1024}
    full = {kernel.MORE_TRIANGLES: "triangles", kernel.MORE_ENTRIES: "entries",
            kernel.MORE_NEIGHBOURS: "neighbours", kernel.MORE_EDGES: "edges"}
    k = MAX_CANDIDATES
    i32 = np.int32  # indices of points, triangles and entries: half the memory traffic of int64
    cidx = cidx.astype(i32)
    while True:
        tri = np.empty((size["triangles"], 3), i32)
        nxt = np.empty(3 * len(tri), i32)
        head = np.full(n, -1, i32)
        state = np.zeros(n, np.int8)
        status, nt = kernel.greedy_projection(
            p, nnd, cstart, cidx, x0, y0, h, nx, ny, mu, max_angle, min_angle, True,
            tri, nxt, head, np.empty((len(tri), 6), np.float32), state, np.empty(n, i32),
            np.full(nx * ny, -1, i32), np.empty((size["entries"], 2), i32), np.full(len(tri), -1, np.int64),
            np.full(n, -1, np.int64), np.empty(k, i32), np.empty(k), np.empty(k), np.empty(k, np.bool_),
            np.empty(k, i32), np.empty(k + 2, i32), np.empty(k + 2, i32),
            np.empty(size["neighbours"], i32), np.empty((2, size["neighbours"]), i32),
            np.empty((size["edges"], 2), i32),
            np.empty((size["edges"], 4)), np.empty((2, kernel.MAX_FANS), i32))
        if status == kernel.DONE:
            return tri[:nt], nxt, head, state
        size[full[status]] *= 2


def general_mesh(cloud: PointCloud, *, mu: float, max_angle: float, min_angle: float, dexel_size: float) -> TerrainMesh:
    """The general mode of :func:`tinsmith.reconstruct` (see the module docstring)."""
    xyz = np.ascontiguousarray(cloud.xyz, dtype=np.float64) + 0.0  # -0.0 becomes 0.0: equal values, equal bits
    xyz = xyz[cloud_kernel.first_occurrences(xyz.view(np.int64))]  # duplicates dropped, input order kept
    centre = xyz.mean(axis=0)
    p = np.ascontiguousarray(xyz - centre)  # local coordinates: no cancellation at world offsets
    cstart, cidx, x0, y0, nx, ny = dexel_buckets(p, dexel_size)
    nnd = cloud_kernel.nearest_distances(p, cstart, cidx, x0, y0, dexel_size, nx, ny)
    tri, nxt, head, state = _front(p, nnd, (cstart, cidx, x0, y0, dexel_size, nx, ny), mu, max_angle, min_angle)
    label, flip, loops = kernel.surface_summary(p, tri, nxt, head, state)
    turn = flip[label[tri[:, 0]]]  # each component outwards (closed) or upwards (open)
    tri[turn] = tri[turn][:, [0, 2, 1]]
    used = head >= 0
    index = np.cumsum(used) - 1  # new vertex numbers
    vertices, tri = xyz[used], index[tri]
    components = len(np.unique(label[used]))
    mesh = TerrainMesh(vertices, tri, crs=cloud.crs)
    mesh.info["reconstruct"] = {
        "mode": "general", "dexel_size": dexel_size, "points_in": len(cloud), "duplicates": len(cloud) - len(xyz),
        "points_unused": int(len(xyz) - np.count_nonzero(used)), "completed": int(np.count_nonzero(state == COMPLETED)),
        "components": components, "border_loops": loops,
    }
    return mesh
