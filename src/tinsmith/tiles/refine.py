"""The deepest level's tiles refined at the DEM's cells: the bound held at every cell, not only at the nodes.

A tile is meshed on its nodes, bilinear samples of the DEM on the geographic
lattice.  Between the nodes a cell's centre can stand far beyond the bound
from the mesh: on St. Helens (30 m cells, zoom 13, about 1.6 nodes a cell)
every node was within 2 m and a cell 12.97 m off, since the bilinear surface
has a kink at each cell centre that no node off the centres reproduces.

So at the deepest level, where the nodes sample the cells themselves (no block
average), the mesh is refined by greedy insertion (Garland and Heckbert 1995,
in rounds) from the triangulation the mesher left.  Its candidates are the
centres of the DEM's cells in the tile, with their heights
(:func:`.certificate.tile_cells`: the cells and heights the certificate
checks), each placed where a client decodes it: on the tile's 15-bit ``u,
v`` grid, with the height on the pyramid's step; and the tile's interior
nodes, with their samples, measured only in the triangles a round rewrites
(the mesher left every node within the bound).
Each round inserts, in every triangle, the candidate furthest beyond the
bound (:mod:`tinsmith.kernels.cell_refine`), until none is.  Candidates lie
strictly inside the tile, so the seam vertices stay as they are and
neighbours still share their edges; triangles that reach a node filled for
lack of data are neither refined nor flipped into.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io.quantized_mesh import QUANT
from ..kernels import cell_refine
from ..triangulation.delaunay import buffers_of
from .certificate import tile_cells

__all__ = ["MAX_ROUNDS", "Refined", "refine_at_cells"]

#: Rounds of insertion at most (each inserts one candidate in every triangle over the bound).
MAX_ROUNDS = 200


@dataclass(frozen=True)
class Refined:
    """What refinement added to a tile: the new vertices (node units, rows from the north; ``u, v`` on the
    15-bit grid; heights), every triangle, and the rounds it took."""

    rows: np.ndarray
    cols: np.ndarray
    u: np.ndarray
    v: np.ndarray
    height: np.ndarray
    triangles: np.ndarray
    rounds: int


def _decoded(job, h: np.ndarray) -> np.ndarray:
    return job.h_min + np.rint((h - job.h_min) / job.h_step) * job.h_step


def _nodes(job, samples: np.ndarray, missing: np.ndarray, rows, cols) -> np.ndarray:
    """The interior nodes that are not vertices, as an (N + 1, N + 1) grid of their samples (NaN elsewhere)."""
    N = job.tile_cells
    inner = samples[1:N + 2, 1:N + 2]
    free = np.isfinite(inner) & ~missing[1:N + 2, 1:N + 2]
    free[rows, cols] = False
    free[[0, -1], :] = free[:, [0, -1]] = False
    return np.where(free, inner, np.nan)


def _cells(job, bounds):
    """(x, y, qx, qy, want, u, v) of the DEM's cells strictly inside the tile, in node units north up: (x, y) where
    a cell is checked, (qx, qy) where a vertex for it goes, its ``u, v`` on the client's grid."""
    N = job.tile_cells
    west, _, east, north = bounds
    scale = (east - west) / N
    lon, lat, h = tile_cells(job, bounds)
    x, y = (lon - west) / scale, N - (north - lat) / scale
    u = np.rint(x * QUANT / N).astype(np.int64)
    v = np.rint(y * QUANT / N).astype(np.int64)
    keep = (u > 0) & (u < QUANT) & (v > 0) & (v < QUANT)
    u, v = u[keep], v[keep]
    return x[keep], y[keep], u * (N / QUANT), v * (N / QUANT), h[keep], u, v


def refine_at_cells(job, bounds, samples: np.ndarray, missing: np.ndarray, rows: np.ndarray, cols: np.ndarray,
                    h: np.ndarray, triangles: np.ndarray, filled: np.ndarray, bound: float) -> Refined:
    """Refine a tile's mesh until every candidate (see the module notes) is within ``bound`` of it.

    ``bounds`` is the tile's (west, south, east, north) in degrees,
    ``samples`` its node heights with their halo (NaN: no data),
    ``missing`` the nodes given a height not of the DEM; ``rows, cols, h,
    triangles, filled`` the mesh :func:`.pyramid.tile_geometry` made.
    """
    N = job.tile_cells
    x, y, qx, qy, want, cu, cv = _cells(job, bounds)
    node_h = _nodes(job, samples, missing, rows, cols)
    tri = np.asarray(triangles, np.int64)
    pts = np.column_stack([cols, N - rows]).astype(np.float64)
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    ccw = float(np.sum((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))) > 0
    if not ccw:
        tri = tri[:, [0, 2, 1]]
    V0 = len(pts)
    capacity = V0 + len(x) + int(np.isfinite(node_h).sum())
    m = buffers_of(pts, tri, capacity)
    z = np.zeros(capacity)
    z[:V0] = _decoded(job, h)
    origin = np.full(capacity, -1, np.int64)
    T0 = len(tri)
    m[6][:T0] = filled[tri].any(axis=1)
    border = m[6][:T0][np.maximum(m[3][:3 * T0], 0) // 3] != np.repeat(m[6][:T0], 3)
    m[4][:3 * T0] = (m[3][:3 * T0] >= 0) & border  # no flip across the line between filled and data triangles
    rounds, _ = cell_refine.refine(m, z, x, y, want, qx, qy, _decoded(job, want), node_h.copy(),
                                   _decoded(job, np.nan_to_num(node_h)), float(bound), MAX_ROUNDS, origin,
                                   np.empty(64, np.int32))
    n_v, n_t = int(m[9][0]), int(m[9][1])
    out = m[2][:3 * n_t].reshape(-1, 3).astype(np.int64)
    if not ccw:
        out = out[:, [0, 2, 1]]
    new = origin[V0:n_v]
    cell, node = new[new >= 0], -2 - new[new < 0]
    nr, nc = node // (N + 1), node % (N + 1)
    # the vertices in the order the kernel added them: cells and nodes interleaved
    rows_new, cols_new = np.empty(len(new)), np.empty(len(new))
    u_new, v_new, h_new = np.empty(len(new), np.int64), np.empty(len(new), np.int64), np.empty(len(new))
    is_cell = new >= 0
    rows_new[is_cell], cols_new[is_cell] = N - qy[cell], qx[cell]
    u_new[is_cell], v_new[is_cell], h_new[is_cell] = cu[cell], cv[cell], want[cell]
    rows_new[~is_cell], cols_new[~is_cell] = nr, nc
    u_new[~is_cell], v_new[~is_cell] = (nc * QUANT + N // 2) // N, ((N - nr) * QUANT + N // 2) // N
    h_new[~is_cell] = node_h[nr, nc]
    return Refined(rows=rows_new, cols=cols_new, u=u_new, v=v_new, height=h_new, triangles=out, rounds=rounds)
