"""Relaxing the seams of a chart-by-chart remesh: the cut is no feature of the surface (seed 003, section 4.1).

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

__all__ = ["closest_points", "relax_seams"]


def _closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The closest point to each ``p`` on the triangle ``(a, b, c)`` of its row (Ericson, Real-Time Collision
    Detection, 5.1.5), vectorised."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp = p - b
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    cp = p - c
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    denom = va + vb + vc
    with np.errstate(divide="ignore", invalid="ignore"):
        v = vb / denom
        w = vc / denom
        out = a + ab * v[..., None] + ac * w[..., None]  # inside the face
        # edges
        t_ab = d1 / (d1 - d3)
        e_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
        out = np.where(e_ab[..., None], a + ab * t_ab[..., None], out)
        t_ac = d2 / (d2 - d6)
        e_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
        out = np.where(e_ac[..., None], a + ac * t_ac[..., None], out)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        e_bc = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)
        out = np.where(e_bc[..., None], b + (c - b) * t_bc[..., None], out)
    # corners
    out = np.where(((d1 <= 0) & (d2 <= 0))[..., None], a, out)
    out = np.where(((d3 >= 0) & (d4 <= d3))[..., None], b, out)
    out = np.where(((d6 >= 0) & (d5 <= d6))[..., None], c, out)
    return out


def closest_points(vertices: np.ndarray, triangles: np.ndarray, points: np.ndarray, k: int = 8,
                   tree: cKDTree | None = None) -> np.ndarray:
    """The closest point on the mesh to each of ``points``, exactly.

    The ``k`` triangles with the nearest centroids give a first distance
    ``d``; every triangle that could hold a closer point has its centroid
    within ``d`` plus the largest centroid-to-corner distance, and those are
    all tried.
    """
    if len(points) == 0:
        return np.zeros((0, 3))
    corners = vertices[triangles]
    centroid = corners.mean(axis=1)
    tree = tree if tree is not None else cKDTree(centroid)
    reach = float(np.linalg.norm(corners - centroid[:, None, :], axis=2).max())
    k = min(k, len(triangles))
    _, near = tree.query(points, k=k)
    near = near.reshape(len(points), k)
    q = _closest_on_triangles(points[:, None, :], corners[near, 0], corners[near, 1], corners[near, 2])
    d = np.sqrt(((q - points[:, None, :]) ** 2).sum(-1)).min(axis=1)
    balls = tree.query_ball_point(points, d + reach)
    sizes = np.fromiter((len(x) for x in balls), np.int64, len(points))
    who = np.repeat(np.arange(len(points)), sizes)
    cand = np.fromiter((t for x in balls for t in x), np.int64, int(sizes.sum()))
    q = _closest_on_triangles(points[who], corners[cand, 0], corners[cand, 1], corners[cand, 2])
    dist = ((q - points[who]) ** 2).sum(-1)
    order = np.lexsort((cand, dist, who))  # per point the nearest, ties to the lowest triangle
    first = order[np.searchsorted(who[order], np.arange(len(points)))]
    return q[first]


def _normals(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.cross(v[t[..., 1]] - v[t[..., 0]], v[t[..., 2]] - v[t[..., 0]])


def _halfedges(tri: np.ndarray, n: int) -> tuple:
    """(twin (3M,), vedge (N,)) of :mod:`tinsmith.kernels.flips` for consistently oriented triangles."""
    a = tri.ravel()
    b = tri[:, [1, 2, 0]].ravel()
    key = a * n + b
    order = np.argsort(key)
    back = b * n + a
    at = np.clip(np.searchsorted(key[order], back), 0, len(key) - 1)
    twin = np.where(key[order][at] == back, order[at], -1)
    vedge = np.full(n, -1, np.int64)
    vedge[a] = np.arange(len(a))
    return twin.astype(np.int64), vedge


def relax_seams(xyz: np.ndarray, triangles: np.ndarray, movable: np.ndarray, locked: np.ndarray,
                source_vertices: np.ndarray, source_triangles: np.ndarray, rounds: int = 8) -> tuple:
    """(vertices, triangles) with the seams relaxed (module docstring).

    ``movable`` (N,) bool: the vertices of the cut; they and their
    neighbours that are not on a true feature move.  ``locked`` (L, 2): edges
    no flip may remove (true feature segments).
    """
    from ...kernels import flips as kf

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
