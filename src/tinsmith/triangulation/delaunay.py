"""Constrained Delaunay triangulation of points in the plane, on the kernel every method uses.

``tinsmith.delaunay(points_xy, constraints=...)`` is the stand-alone entry to
:mod:`tinsmith.kernels.tin`: incremental insertion with robust predicates
(exact signs, so collinear and cocircular inputs such as DEM grids never
break it), Lawson flips, and constrained segments inserted by flips (Sloan
1993) and kept through every later step.  It depends on nothing with a
non-commercial licence (unlike Shewchuk's Triangle).

The methods work on the kernel's triangulation tuple itself (``m``, see
:func:`buffers`): :func:`triangulate_points` builds one, :func:`constrain_all`
inserts segments, :func:`component_centroids` finds the regions between
constrained edges and :func:`inside_part` extracts the triangles inside the data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInputError
from ..kernels import ahead

# compiled ahead of time where the build could (the point-cloud TIN's path loads no numba), else the jit kernels
kg = ahead.load("tinsmith.kernels.greedy")
tin = ahead.load("tinsmith.kernels.tin")
_predicates = ahead.load("tinsmith.kernels.predicates")

__all__ = [
    "Triangulation", "buffers", "buffers_of", "component_centroids", "constrain_all", "delaunay", "inside_part", "morton",
    "triangulate_points", "unique_edges",
]


@dataclass(frozen=True)
class Triangulation:
    """The result of :func:`delaunay`.

    Attributes
    ----------
    points : (N, 2) ndarray of float64
        The input points (duplicates included, as given).
    triangles : (M, 3) ndarray of int64
        Counter-clockwise triangles over ``points`` indices; duplicates are
        represented by their first occurrence.
    constrained : (K, 2) ndarray of int64
        The constrained edges (smaller index first), constraints split where
        points lie on them.
    duplicate_of : (N,) ndarray of int64
        For each point, the index of the first point at the same place.

    Examples
    --------
    >>> import tinsmith
    >>> points = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [1.0, 1.0]]  # the last point repeats the third
    >>> result = tinsmith.delaunay(points)
    >>> result.triangles.shape, result.duplicate_of.tolist()
    ((2, 3), [0, 1, 2, 3, 2])
    >>> int(result.triangles.max()) <= 3  # a duplicate is represented by its first occurrence
    True
    """

    points: np.ndarray
    triangles: np.ndarray
    constrained: np.ndarray
    duplicate_of: np.ndarray


def buffers(n_points: int, capacity: int | None = None, *, tri=None, half=None):
    """The triangulation tuple of :mod:`tinsmith.kernels.tin` for ``capacity`` (default ``n_points``) vertices.

    ``tri`` and ``half``, when given, are its triangle and twin arrays (of
    3 (2 capacity + 8) int32 each), already filled.
    """
    cap_v = max(n_points, capacity or 0)
    cap_t = 2 * cap_v + 8
    tri = np.zeros(3 * cap_t, np.int32) if tri is None else tri
    half = np.full(3 * cap_t, -1, np.int32) if half is None else half
    return (
        np.zeros(cap_v), np.zeros(cap_v), tri, half,
        np.zeros(3 * cap_t, np.uint8), np.full(cap_v, -1, np.int32), np.zeros(cap_t, np.uint8),
        np.zeros(cap_t, np.int32), np.zeros(cap_t, np.uint8), np.zeros(4, np.int64),
    )


def buffers_of(points: np.ndarray, triangles: np.ndarray, capacity: int | None = None):
    """The triangulation tuple of :mod:`tinsmith.kernels.tin` holding an existing triangulation.

    ``points`` (V, 2), ``triangles`` (T, 3) counter-clockwise, each edge shared
    by at most two triangles (edges of one are the hull); room for
    ``capacity`` vertices in all (default V).  Regions 0, nothing constrained.
    """
    n, t = len(points), len(triangles)
    m = buffers(n, capacity)
    m[0][:n], m[1][:n] = points[:, 0], points[:, 1]
    m[2][:3 * t] = np.asarray(triangles).ravel()
    m[9][0], m[9][1] = n, t
    tin.link(m, t)
    return m


def triangulate_points(pts: np.ndarray, capacity: int | None = None, unique: bool = False, ids=None):
    """Delaunay triangulation of (N, 2) finite points on the kernel; returns ``(m, same, stack)``.

    ``m`` is the triangulation tuple (vertex ``i`` is point ``i``), with room
    for ``capacity`` vertices in all; ``same`` maps each point to the first
    inserted point at the same place.  ``unique`` breaks the ties of
    cocircular points by symbolic perturbation, so the triangulation is the
    one Delaunay triangulation of the points whatever the order of insertion
    (else a cocircular edge is left as the insertions made it).  ``ids``:
    triangulate the points ``pts[ids]`` (vertex ``i`` is point ``ids[i]``),
    whose gathered copy is let go once the triangulation holds their
    coordinates.  Raises :class:`InvalidInputError` when the points span no
    area.
    """
    if ids is not None:
        pts = pts[ids]
    n = len(pts)
    order = _insertion_order(pts)
    first = _first_triangle(pts, order)
    m = buffers(n, capacity)
    m[0][:n] = pts[:, 0]
    m[1][:n] = pts[:, 1]
    del pts  # a gathered copy is not held while the points are inserted
    m[9][0] = n
    tin.first_in_front(order, first)
    same = np.arange(len(m[0]), dtype=np.int64)
    stack = stack_for(len(m[0]))
    tin.triangulate(m, order, stack, same, tin.PERTURBED if unique else False)
    return m, same[:n], stack


def delaunay(points_xy, *, constraints=None) -> Triangulation:
    """Delaunay triangulation of 2-D points, optionally with constrained segments.

    Parameters
    ----------
    points_xy : (N, 2) array_like of float
        At least three points, not all on one line.
    constraints : (K, 2) array_like of int, optional
        Index pairs of segments that must be edges of the result.  Segments
        may share end points, overlap collinearly, repeat, or pass through
        other points (they are split there); two segments that cross at a
        point that is not an input point are an error.

    Returns
    -------
    Triangulation

    Raises
    ------
    InvalidInputError
        For a wrong shape, non-finite coordinates, fewer than three distinct
        non-collinear points, bad constraint indices, or crossing constraints.

    Examples
    --------
    >>> import tinsmith
    >>> square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]]
    >>> tinsmith.delaunay(square).triangles.shape
    (4, 3)
    >>> kite = [[0.0, 0.0], [2.0, -1.0], [4.0, 0.0], [2.0, 1.0]]
    >>> tinsmith.delaunay(kite).triangles.tolist()  # the short diagonal, 1-3
    [[1, 3, 0], [1, 2, 3]]
    >>> forced = tinsmith.delaunay(kite, constraints=[[0, 2]])  # the long one, kept as an edge
    >>> forced.constrained.tolist()
    [[0, 2]]
    """
    pts = np.array(points_xy, dtype=np.float64, copy=True)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise InvalidInputError(f"points_xy must have shape (N, 2), got {pts.shape}")
    if not np.isfinite(pts).all():
        raise InvalidInputError("points_xy must be finite; found NaN or infinite coordinates")
    n = len(pts)
    if n < 3:
        raise InvalidInputError(f"points_xy needs at least 3 points, got {n}")
    m, same, stack = triangulate_points(pts)
    if constraints is not None:
        stack = constrain_all(m, constraints, same, n, stack)
    count = int(m[9][1])
    # duplicates are named by their first occurrence, whichever of them was inserted
    _, first_index, inverse = np.unique(pts, axis=0, return_index=True, return_inverse=True)
    canon = first_index[inverse.ravel()].astype(np.int64)
    triangles = canon[m[2][: 3 * count].reshape(-1, 3)]
    e = np.flatnonzero(m[4][: 3 * count])
    src = canon[m[2][e]]
    dst = canon[m[2][e - e % 3 + (e + 1) % 3]]
    constrained = np.unique(np.sort(np.column_stack([src, dst]), axis=1), axis=0).astype(np.int64)
    return Triangulation(pts, triangles, constrained.reshape(-1, 2), canon)


def stack_for(n_vertices: int) -> np.ndarray:
    """A legalisation stack that :func:`.kernels.tin.triangulate` never outgrows on ``n_vertices`` vertices.

    The edges waiting for the in-circle test after an insertion are distinct
    edges of the new vertex's link (a flip replaces the one it pops by two
    of them), so there are never more than its degree, below the number of
    vertices.
    """
    return np.empty(n_vertices + 64, np.int32)


def morton(pts: np.ndarray, bits: int = 16) -> np.ndarray:
    """Z-order key of each point on a 2**bits x 2**bits lattice over their bounding box."""
    return tin.morton_keys(np.ascontiguousarray(pts, np.float64), bits)


def _insertion_order(pts: np.ndarray) -> np.ndarray:
    """Biased randomised insertion order (Amenta, Choi, Rote 2003), Z-ordered within rounds.

    Rounds of doubling size in a seeded random order keep the triangulation
    balanced; the Z-order within a round keeps each point-location walk short.
    The seed is fixed, so the same points always give the same triangulation.
    One sort of the 64-bit keys (round above, Z-order below) orders them all.
    """
    n = len(pts)
    perm = tin.seeded_permutation(n)  # np.random.default_rng(0).permutation(n), without importing numpy.random
    bounds = [0]
    size = n
    while size > 16:
        bounds.append(size)
        size //= 2
    bounds = np.array(sorted(set(bounds + [min(16, n), n])), np.int64)
    # about four lattice cells a point: finer buys no shorter walks, coarser sorts fewer bits
    bits = int(min(16, max(4, np.ceil(np.log2(max(n, 2)) / 2) + 1)))
    return tin.brio_order(np.ascontiguousarray(pts, np.float64), perm, bounds, bits)


def _first_triangle(pts: np.ndarray, order: np.ndarray) -> np.ndarray:
    """Three point indices that are distinct and not collinear, taken early in ``order``."""
    a = order[0]
    for rest in (order[1:64], order[1:]):  # almost always found among the first points
        found = _third_point(pts, a, rest)
        if found is not None:
            return found
    if (pts == pts[a]).all():
        raise InvalidInputError("points_xy holds a single distinct point; nothing to triangulate")
    raise InvalidInputError("all points of points_xy lie on one line; nothing to triangulate")


def _third_point(pts: np.ndarray, a: int, rest: np.ndarray):
    """``[a, b, c]`` with b, c of ``rest`` and a, b, c not collinear, or None."""
    differs = np.any(pts[rest] != pts[a], axis=1)
    if not differs.any():
        return None
    b = rest[np.argmax(differs)]
    d = pts[b] - pts[a]
    cross = d[0] * (pts[rest, 1] - pts[a, 1]) - d[1] * (pts[rest, 0] - pts[a, 0])
    for c in rest[np.argsort(-np.abs(cross), kind="stable")[:8]]:
        if _predicates.orient2d(*pts[a], *pts[b], *pts[c]) != 0.0:
            return np.array([a, b, c], np.int64)
    # the float cross products may all be zero although a point is off the line: test exactly
    for c in rest:
        if _predicates.orient2d(*pts[a], *pts[b], *pts[c]) != 0.0:
            return np.array([a, b, c], np.int64)
    return None


def constrain_all(m, constraints, same, n: int, stack):
    """Insert (K, 2) point-index segments into triangulation ``m`` as constrained edges; returns the kernel's stack.

    ``same`` maps each of the ``n`` points to its vertex (duplicates to the first);
    :class:`InvalidInputError` for bad indices or a segment that crosses an earlier one.
    """
    segs = np.asarray(constraints)
    if segs.size == 0:
        return stack
    if segs.ndim != 2 or segs.shape[1] != 2 or not np.issubdtype(segs.dtype, np.integer):
        raise InvalidInputError(f"constraints must be (K, 2) integer point indices, got shape {segs.shape}")
    if segs.min() < 0 or segs.max() >= n:
        raise InvalidInputError(f"constraints index points 0..{n - 1}, got {segs.min()}..{segs.max()}")
    work = np.empty(64, np.int32)
    for k, (a, b) in enumerate(segs.tolist()):
        a, b = int(same[a]), int(same[b])
        if a == b:
            continue
        code, stack, work = tin.insert_segment(m, a, b, stack, work)
        if code == tin.SEGMENT_CROSSES_CONSTRAINT:
            raise InvalidInputError(
                f"constraint {k} (points {segs[k, 0]}-{segs[k, 1]}) crosses an earlier constraint away from "
                "any input point; add the crossing point and split both segments there"
            )
    return stack


def unique_edges(ends: np.ndarray) -> np.ndarray:
    """Each constrained edge once, from the (E, 2) low-index-first sides of the kernels' output."""
    return np.unique(ends, axis=0) if len(ends) else ends


def inside_part(m, swap: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The triangles inside the data (region 0) of triangulation ``m``, renumbered.

    Returns ``used`` (the vertex ids they use, sorted), the triangles as
    indices into ``used`` (int64; each in reverse order with ``swap``) and
    their constrained edges as (E, 2) index pairs, low index first.
    """
    used, triangles, ends = kg.inside_part(m, swap)
    return used, triangles, unique_edges(ends)


def component_centroids(m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The regions of a triangulation between its constrained edges: each triangle's label, and the
    centroid (x, y) of the first triangle of each region, whose side of the constraints decides for all."""
    labels = tin.label_components(m)
    n = int(m[9][1])
    first = np.unique(labels, return_index=True)[1]
    corners = m[2][: 3 * n].reshape(-1, 3)[first]
    return labels, m[0][corners].mean(axis=1), m[1][corners].mean(axis=1)
