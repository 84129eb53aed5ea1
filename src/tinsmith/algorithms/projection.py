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
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..core import PointCloud, TerrainMesh
from ..errors import InvalidOptionError
from ..kernels.projection import COMPLETED, greedy_projection
from ..metrics.topology import border_edges, border_loops

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
    cell = rows * nx + cols
    cidx = np.lexsort((xyz[:, 2], cell)).astype(np.int64)
    cstart = np.searchsorted(cell[cidx], np.arange(nx * ny + 1)).astype(np.int64)
    return cstart, cidx, float(lo[0]), float(lo[1]), nx, ny


def _orient_components(v: np.ndarray, tri: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Triangles with each component turned outwards (closed) or upwards (open); (tri, components, border loops)."""
    n = len(v)
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    comp = label[tri[:, 0]]
    bedges = border_edges(tri, n)
    loops = border_loops(tri, n)
    open_comp = np.zeros(label.max() + 1, bool)
    open_comp[label[bedges[:, 0]]] = True
    a, b, c = v[tri[:, 0]], v[tri[:, 1]], v[tri[:, 2]]
    cross = np.cross(b - a, c - a)
    volume = np.einsum("ij,ij->i", a, cross)  # six times the signed volume of the cone from the origin
    k = label.max() + 1
    flip = np.where(open_comp, np.bincount(comp, cross[:, 2], k) < 0.0, np.bincount(comp, volume, k) < 0.0)
    out = tri.copy()
    turn = flip[comp]
    out[turn] = out[turn][:, [0, 2, 1]]
    return out, int(len(np.unique(comp))), loops


def general_mesh(cloud: PointCloud, *, mu: float, max_angle: float, min_angle: float, dexel_size: float) -> TerrainMesh:
    """The general mode of :func:`tinsmith.reconstruct` (see the module docstring)."""
    xyz, first = np.unique(cloud.xyz, axis=0, return_index=True)
    xyz = np.ascontiguousarray(xyz[np.argsort(first)])  # duplicates dropped, input order kept
    centre = xyz.mean(axis=0)
    p = np.ascontiguousarray(xyz - centre)  # local coordinates: no cancellation at world offsets
    cstart, cidx, x0, y0, nx, ny = dexel_buckets(p, dexel_size)
    nnd = np.ascontiguousarray(cKDTree(p).query(p, k=2, workers=-1)[0][:, 1])
    tri, state = greedy_projection(p, nnd, cstart, cidx, x0, y0, dexel_size, nx, ny, mu, max_angle, min_angle,
                                   MAX_CANDIDATES, True)
    used, tri = np.unique(tri, return_inverse=True)
    tri = tri.reshape(-1, 3)
    vertices = xyz[used]
    tri, components, loops = _orient_components(vertices - centre, tri) if len(tri) else (tri, 0, 0)
    mesh = TerrainMesh(vertices, tri, crs=cloud.crs)
    mesh.info["reconstruct"] = {
        "mode": "general", "dexel_size": dexel_size, "points_in": len(cloud), "duplicates": len(cloud) - len(xyz),
        "points_unused": int(len(xyz) - len(used)), "completed": int(np.count_nonzero(state == COMPLETED)),
        "components": components, "border_loops": loops,
    }
    return mesh
