"""Feature points: rank the cells by importance, keep the top ones, Delaunay-triangulate.

After the Salt Lake City thesis, sections 2.3 and 3.1.1.

The one-pass feature method the Salt Lake City thesis reviews (section 2.3) with the
importance measure of its section 3.1.1: the magnitude of the Sobel gradient,
``sqrt(hx**2 + hy**2)`` with the two 3 x 3 Sobel kernels (here divided by
8 times the cell size, so that it is the slope in z units per world unit).
``measure="curvature"`` ranks by the largest absolute eigenvalue of the
Hessian of the heights (central second differences), which picks ridges,
valleys and breaks of slope rather than steep even slopes.

The kept cells are the corners of the data, a border sampled at the mean
spacing of the budget (so the border triangles are not slivers), and the most
important cells up to the vertex budget; they are triangulated by the
constrained Delaunay kernel of greedy insertion, which cuts out the holes
of the data along their outline (:class:`GreedyEngine` with ``nodes``).
Near the edge of the grid the 3 x 3 neighbourhood repeats the edge
cells; next to a hole, a missing neighbour takes the mean of its valid
neighbours.  A baseline: it is blind to the
error it makes (the Salt Lake City thesis found it noisy and poor at building edges).
"""

from __future__ import annotations

import numpy as np

from ...core import Heightfield, StopCriteria, TerrainMesh
from ...errors import InvalidInputError
from ..greedy.engine import GreedyEngine
from ..registry import register

__all__ = ["features", "importance"]


def _completed(hf: Heightfield) -> np.ndarray:
    """Heights padded by one cell (edge repeated), nodata next to data filled with the mean of its valid neighbours."""
    z = np.pad(hf.z.astype(np.float64), 1, mode="edge")
    valid = np.pad(hf.valid, 1, mode="edge")
    if valid.all():
        return z
    vals = np.where(valid, z, 0.0)
    total = np.zeros_like(z)
    count = np.zeros_like(z)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            total += np.roll(np.roll(vals, dr, 0), dc, 1)
            count += np.roll(np.roll(valid, dr, 0), dc, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        fill = np.where(count > 0, total / np.maximum(count, 1), 0.0)
    return np.where(valid, z, fill)


def importance(hf: Heightfield, measure: str = "sobel") -> np.ndarray:
    """(H, W) importance of every cell (NaN on nodata): Sobel gradient magnitude or Hessian curvature.

    ``"sobel"``: ``sqrt(hx**2 + hy**2)`` with the 3 x 3 Sobel kernels over
    8 times the cell size (a slope, z units per world unit), as the Salt Lake City thesis
    section 3.1.1.  ``"curvature"``: the largest absolute eigenvalue of the
    Hessian ``[[zxx, zxy], [zxy, zyy]]`` from central second differences
    (z units per world unit squared).
    """
    z = _completed(hf)
    dx, dy = hf.cell_size
    c = z[1:-1, 1:-1]
    n, s_, w, e = z[:-2, 1:-1], z[2:, 1:-1], z[1:-1, :-2], z[1:-1, 2:]
    nw, ne, sw, se = z[:-2, :-2], z[:-2, 2:], z[2:, :-2], z[2:, 2:]
    if measure == "sobel":
        hx = ((ne + 2 * e + se) - (nw + 2 * w + sw)) / (8.0 * dx)
        hy = ((sw + 2 * s_ + se) - (nw + 2 * n + ne)) / (8.0 * dy)
        value = np.hypot(hx, hy)
    elif measure == "curvature":
        zxx = (w - 2 * c + e) / (dx * dx)
        zyy = (n - 2 * c + s_) / (dy * dy)
        zxy = (se - sw - ne + nw) / (4.0 * dx * dy)
        half_trace, det = (zxx + zyy) / 2.0, zxx * zyy - zxy * zxy
        root = np.sqrt(np.maximum(half_trace * half_trace - det, 0.0))
        value = np.maximum(abs(half_trace + root), abs(half_trace - root))
    else:
        raise InvalidInputError(f"measure must be 'sobel' or 'curvature', got {measure!r}")
    return np.where(hf.valid, value, np.nan)


def _border(hf: Heightfield, spacing: int) -> np.ndarray:
    """(K, 2) valid cells on the edges of the grid every ``spacing`` cells, with the last of each edge."""
    h, w = hf.shape
    rows = np.unique(np.r_[np.arange(0, h, spacing), h - 1])
    cols = np.unique(np.r_[np.arange(0, w, spacing), w - 1])
    rc = np.concatenate([
        np.column_stack([np.zeros_like(cols), cols]), np.column_stack([np.full_like(cols, h - 1), cols]),
        np.column_stack([rows, np.zeros_like(rows)]), np.column_stack([rows, np.full_like(rows, w - 1)]),
    ])
    rc = np.unique(rc, axis=0)
    return rc[hf.valid[rc[:, 0], rc[:, 1]]]


def feature_mesh(hf: Heightfield, n_points: int, measure: str = "sobel", rank=None) -> TerrainMesh:
    """The Delaunay mesh of the border and the ``n_points`` most important cells (ties: row order)."""
    if rank is None:
        rank = _ranking(hf, measure)
    spacing = max(1, int(np.sqrt(hf.n_valid / max(n_points, 1))))
    border = _border(hf, spacing)
    taken = np.zeros(hf.shape, bool)
    taken[border[:, 0], border[:, 1]] = True
    w = hf.shape[1]
    top = rank[~taken.ravel()[rank]][: max(n_points - len(border), 0)]
    nodes = np.concatenate([border, np.column_stack([top // w, top % w])])
    engine = GreedyEngine(hf, nodes=nodes)
    mesh = engine.to_mesh()
    mesh.info["error"] = {"max": engine.max_error}
    mesh.info["n_points"] = n_points
    return mesh


def _ranking(hf: Heightfield, measure: str) -> np.ndarray:
    """Flat indices of the valid cells, most important first (a stable sort: ties keep row order)."""
    value = importance(hf, measure).ravel()
    valid = np.flatnonzero(~np.isnan(value))
    return valid[np.argsort(-value[valid], kind="stable")]


def _largest_within_counts(build, n: int, stop: StopCriteria) -> TerrainMesh:
    """The mesh of the largest budget <= n within the count rules (bisection; counts grow with the budget)."""
    mesh = build(n)
    if stop.counts_fit(mesh.n_vertices, mesh.n_triangles):
        return mesh
    lo, hi, best = 0, n - 1, None
    while lo <= hi:
        mid = (lo + hi) // 2
        m = build(mid)
        if stop.counts_fit(m.n_vertices, m.n_triangles):
            lo, best = mid + 1, m
        else:
            hi = mid - 1
    if best is None:
        raise InvalidInputError(
            f"max_vertices={stop.max_vertices} / max_triangles={stop.max_triangles} leave no room: "
            f"the border and the outline of the data alone need {build(0).n_vertices} vertices"
        )
    return best


def _smallest_within_error(build, mesh: TerrainMesh, max_error: float) -> TerrainMesh:
    """The mesh of the smallest budget below ``mesh``'s whose measured error meets ``max_error`` (bisection)."""
    lo, hi, best = 0, mesh.info["n_points"], mesh
    while lo < hi:
        mid = (lo + hi) // 2
        m = build(mid)
        if m.info["error"]["max"] <= max_error:
            hi, best = mid, m
        else:
            lo = mid + 1
    return best


@register("features")
def features(hf: Heightfield, *, measure, stop: StopCriteria, progress=None) -> TerrainMesh:
    """Keep the most important cells and the border, and triangulate them (Delaunay, holes cut out).

    Without a stop rule 1% of the valid cells are kept.  The count rules
    bound the output mesh (the outline of holes included): the largest
    budget that fits is taken.  ``max_error`` takes the smallest budget
    whose measured error meets it (a bisection; the error of the feature
    method need not fall steadily as points are added, so the result meets
    the bound but may not be the very smallest such mesh).

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> mesh = tinsmith.features(dem, max_vertices=300)
    >>> mesh.n_vertices <= 300
    True
    >>> edge = tinsmith.features(dem, measure="curvature", max_error=25.0)
    >>> tinsmith.vertical_error(edge, dem)["max"] <= 25.0
    True
    """
    rank = _ranking(hf, measure)

    def build(n):
        return feature_mesh(hf, n, measure, rank)

    if not stop.is_set:
        return build(max(4, hf.n_valid // 100))
    n = len(rank) if stop.max_vertices is None else min(len(rank), stop.max_vertices)
    mesh = _largest_within_counts(build, n, stop)
    if stop.max_error is not None and mesh.info["error"]["max"] <= stop.max_error:
        mesh = _smallest_within_error(build, mesh, stop.max_error)
    return mesh
