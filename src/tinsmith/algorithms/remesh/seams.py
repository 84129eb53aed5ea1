"""Relaxing the seams of a chart-by-chart remesh: the cut is no feature of the surface (Alliez et al. 2003, section 4.1).

The charts of a closed or higher-genus surface (:mod:`.charts`) are
remeshed with their shared border held as a backbone, so the pieces close
up.  But the border is only where the surface was cut: its samples were
spaced along it in 1-D, the triangles beside it were relaxed on one side
at a time, and where three charts meet a corner stays at an input vertex.
The triangles that touch the cut are the ones that come out worse shaped.

The paper's remedy is to let the relaxation run across the cut once the
surface is whole.  Here, on the merged mesh, a few rounds of the two
operations of isotropic remeshing (Botsch and Kobbelt 2004) around the cut:

- **edge flips** where a flip raises the smaller of the two triangles'
  minimum angles (and neither new triangle folds away from the old ones),
  never across a true feature (a boundary, sharp or breakline backbone);
- **Lloyd steps on the surface**: each vertex of the cut, and each vertex
  next to it, to the area-weighted centroid of its ring of triangles, then
  back onto the input surface (its closest point there); a move that would
  turn a triangle over is not made.

The vertex count does not change.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ...kernels import flips as kf
from ...metrics.surface import closest_points
from ...triangulation.edges import edge_twins

__all__ = ["relax_seams"]


def _normals(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.cross(v[t[..., 1]] - v[t[..., 0]], v[t[..., 2]] - v[t[..., 0]])


def _halfedges(tri: np.ndarray, n: int) -> tuple:
    """(twin (3M,), vedge (N,)) of :mod:`tinsmith.kernels.flips` for a manifold, consistently oriented mesh."""
    first, second, _ = edge_twins(tri, n)
    twin = np.full(3 * len(tri), -1, np.int64)
    twin[first], twin[second] = second, first
    vedge = np.full(n, -1, np.int64)
    vedge[tri.ravel()] = np.arange(3 * len(tri))
    return twin, vedge


def relax_seams(xyz: np.ndarray, triangles: np.ndarray, movable: np.ndarray, locked: np.ndarray,
                source_vertices: np.ndarray, source_triangles: np.ndarray, rounds: int = 8) -> tuple:
    """(vertices, triangles) with the seams relaxed (module docstring).

    ``movable`` (N,) bool: the vertices of the cut; they and their
    neighbours that are not on a true feature move.  ``locked`` (L, 2): edges
    no flip may remove (true feature segments).
    """
    v = xyz.copy()
    tri = np.ascontiguousarray(triangles, np.int64).copy()
    locked = np.asarray(locked, np.int64).reshape(-1, 2)
    keys = np.unique(locked.min(axis=1) * len(v) + locked.max(axis=1))
    on_feature = np.zeros(len(v), bool)
    on_feature[locked.ravel()] = True
    twin, vedge = _halfedges(tri, len(v))
    tree = cKDTree(source_vertices[source_triangles].mean(axis=1))
    for _ in range(rounds):
        # the band: the cut and the ring round it, less what lies on a true feature
        near = movable.copy()
        near[tri[near[tri].any(axis=1)].ravel()] = True
        flips = kf.flip_pass(v, tri, twin, vedge, np.ones(len(v), bool), keys)
        band = near & ~on_feature
        n = _normals(v, tri)
        area = np.linalg.norm(n, axis=1) / 2
        cen = v[tri].mean(axis=1)
        wsum = np.zeros(len(v))
        csum = np.zeros((len(v), 3))
        np.add.at(wsum, tri.ravel(), np.repeat(area, 3))
        np.add.at(csum, tri.ravel(), np.repeat(cen * area[:, None], 3, axis=0))
        ids = np.flatnonzero(band & (wsum > 0))
        target = closest_points(source_vertices, source_triangles, csum[ids] / wsum[ids, None], tree=tree)
        old = v[ids].copy()
        v[ids] = target
        # undo the moves that turn a triangle of their ring over
        turned = (_normals(v, tri) * n).sum(axis=1) <= 0
        if turned.any():
            bad = np.zeros(len(v), bool)
            bad[tri[turned].ravel()] = True
            undo = bad[ids]
            v[ids[undo]] = old[undo]
        if flips == 0 and np.abs(v[ids] - old).max(initial=0.0) == 0:
            break
    return v, tri
