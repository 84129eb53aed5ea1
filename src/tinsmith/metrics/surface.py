"""Measures of Duan et al. (2016)'s Table 1: errors on vertical lines through triangle centroids, and contour distances.

The DEM surface is the full-resolution grid mesh (cell centres, squares cut
by the diagonal rule as :func:`tinsmith.triangulation.grid.grid_mesh` cuts
them), so a height "on the DEM" at any point is that mesh's height there.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..core import Heightfield, TerrainMesh
from ..errors import InvalidInputError, InvalidOptionError
from ..kernels.cvt import covered_points, surface_heights
from ..triangulation.grid import diagonal_rule
from .vertical import rasterize, vertical_error_at_points

__all__ = ["closest_points", "contour_distance", "dem_heights", "polyline_distances", "vertical_error_at_centroids"]


def dem_heights(hf: Heightfield, x, y) -> np.ndarray:
    """Heights of the DEM surface (the full-resolution grid mesh) at world points; NaN off the data."""
    rows, cols = hf.world_to_pixel(np.asarray(x, np.float64), np.asarray(y, np.float64))
    cols, rows = np.atleast_1d(cols).astype(np.float64), np.atleast_1d(rows).astype(np.float64)
    z = np.where(hf.valid, hf.z, 0.0).astype(np.float64)
    out = surface_heights(cols, rows, z, diagonal_rule(hf.z))
    out[~covered_points(cols, rows, hf.valid)] = np.nan
    return out


def vertical_error_at_centroids(mesh: TerrainMesh, hf: Heightfield, at: TerrainMesh | None = None) -> dict:
    """TIN height minus DEM height on the vertical line through every triangle centroid of ``at`` (default ``mesh``).

    Duan et al. (2016) measures both meshes at the centroids of the cCVT's triangles.
    Returns the dict of :func:`~tinsmith.metrics.vertical_error`, ``n_valid``
    counting the centroids on the data.
    """
    at = mesh if at is None else at
    g = at.vertices[at.triangles].mean(axis=1)
    z = dem_heights(hf, g[:, 0], g[:, 1])
    on_data = ~np.isnan(z)
    return vertical_error_at_points(mesh, np.column_stack([g[on_data, :2], z[on_data]]))


def _levels(z: np.ndarray, interval: float) -> np.ndarray:
    lo, hi = np.nanmin(z), np.nanmax(z)
    return np.arange(np.ceil(lo / interval) * interval, hi, interval)


def _lines(gen, level: float, step: float) -> np.ndarray:
    """(K, 2) points every ``step`` pixels along the contour lines of ``level`` (x = col, y = row)."""
    parts = []
    for line in gen.lines(level):
        if len(line) < 2:
            continue
        d = np.hypot(*np.diff(line, axis=0).T)
        cum = np.r_[0.0, np.cumsum(d)]
        t = np.arange(0.0, cum[-1] + step / 2, step)
        parts.append(np.column_stack([np.interp(t, cum, line[:, 0]), np.interp(t, cum, line[:, 1])]))
    return np.concatenate(parts) if parts else np.empty((0, 2))


def contour_distance(mesh: TerrainMesh, hf: Heightfield, interval: float) -> dict:
    """Distance between the contours of ``mesh`` and of the DEM, every ``interval`` z units (world units).

    Both surfaces are contoured on the DEM's grid (the mesh rasterised at
    the cell centres, the cells it leaves uncovered masked in both), each
    contour line sampled every quarter cell; for every point of one set, the
    distance to the nearest point of the other set at the same level.

    Returns
    -------
    dict
        ``mean`` (symmetric mean distance), ``hausdorff`` (largest distance
        either way), ``levels`` (how many levels have lines), ``points``.
    """
    try:
        import contourpy
    except ImportError as err:  # pragma: no cover - contourpy comes with matplotlib
        raise InvalidInputError("contour_distance needs contourpy: pip install 'tinsmith[viz]'") from err
    if not (np.isfinite(interval) and interval > 0):
        raise InvalidOptionError(f"interval must be a positive number of z units, got {interval!r}")
    tin = rasterize(mesh, hf)
    mask = ~hf.valid | np.isnan(tin)
    dem = np.ma.array(np.where(mask, 0.0, hf.z), mask=mask)
    tin = np.ma.array(np.where(mask, 0.0, tin), mask=mask)
    sx, sy = hf.cell_size
    gen_d = contourpy.contour_generator(z=dem, name="serial")
    gen_t = contourpy.contour_generator(z=tin, name="serial")
    distances = []
    levels = 0
    for level in _levels(np.where(mask, np.nan, hf.z), interval):
        a, b = _lines(gen_d, level, 0.25), _lines(gen_t, level, 0.25)
        if not len(a) or not len(b):
            continue
        levels += 1
        a, b = a * [sx, sy], b * [sx, sy]
        distances += [cKDTree(b).query(a)[0], cKDTree(a).query(b)[0]]
    if not distances:
        return {"mean": np.nan, "hausdorff": np.nan, "levels": 0, "points": 0}
    d = np.concatenate(distances)
    return {"mean": float(d.mean()), "hausdorff": float(d.max()), "levels": levels, "points": int(d.size)}



def polyline_distances(points, line) -> tuple[np.ndarray, np.ndarray]:
    """Distance in x-y of each point to the polyline ``line``, and the arc length along it of its nearest point.

    For judging breaklines: which output vertices lie on a line, and in what
    order along it.  ``points`` is (N, 2+), ``line`` (K, 2+); only x and y count.
    """
    pts = np.asarray(points, dtype=np.float64)[:, :2]
    line = np.asarray(line, dtype=np.float64)[:, :2]
    seg = np.diff(line, axis=0)
    start = np.concatenate([[0.0], np.cumsum(np.linalg.norm(seg, axis=1))])
    best, where = np.full(len(pts), np.inf), np.zeros(len(pts))
    for k, (a, d) in enumerate(zip(line[:-1], seg, strict=True)):
        t = np.clip(((pts - a) @ d) / (d @ d), 0, 1)
        dist = np.linalg.norm(pts - (a + t[:, None] * d), axis=1)
        closer = dist < best
        best[closer], where[closer] = dist[closer], start[k] + t[closer] * np.linalg.norm(d)
    return best, where


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
