"""Measures of seed 002's Table 1: errors on vertical lines through triangle centroids, and contour distances.

The DEM surface is the full-resolution grid mesh (cell centres, squares cut
by the diagonal rule as :func:`tinsmith.algorithms.grid.grid.grid_mesh` cuts
them), so a height "on the DEM" at any point is that mesh's height there.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..core import Heightfield, TerrainMesh
from ..errors import InvalidInputError, InvalidOptionError
from ..kernels.cvt import covered_points, surface_heights
from .vertical import rasterize, vertical_error_at_points

__all__ = ["contour_distance", "dem_heights", "polyline_distances", "vertical_error_at_centroids"]


def dem_heights(hf: Heightfield, x, y) -> np.ndarray:
    """Heights of the DEM surface (the full-resolution grid mesh) at world points; NaN off the data."""
    from ..algorithms.grid.grid import diagonal_rule

    rows, cols = hf.world_to_pixel(np.asarray(x, np.float64), np.asarray(y, np.float64))
    cols, rows = np.atleast_1d(cols).astype(np.float64), np.atleast_1d(rows).astype(np.float64)
    z = np.where(hf.valid, hf.z, 0.0).astype(np.float64)
    out = surface_heights(cols, rows, z, diagonal_rule(hf.z))
    out[~covered_points(cols, rows, hf.valid)] = np.nan
    return out


def vertical_error_at_centroids(mesh: TerrainMesh, hf: Heightfield, at: TerrainMesh | None = None) -> dict:
    """TIN height minus DEM height on the vertical line through every triangle centroid of ``at`` (default ``mesh``).

    Seed 002 measures both meshes at the centroids of the cCVT's triangles.
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
    for k, (a, d) in enumerate(zip(line[:-1], seg)):
        t = np.clip(((pts - a) @ d) / (d @ d), 0, 1)
        dist = np.linalg.norm(pts - (a + t[:, None] * d), axis=1)
        closer = dist < best
        best[closer], where[closer] = dist[closer], start[k] + t[closer] * np.linalg.norm(d)
    return best, where
