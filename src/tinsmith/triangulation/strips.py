"""The Delaunay triangulation of many points on every core: strips triangulated apart, merged exactly.

The points are cut into strips along the longer side of their bounding box
(the same cut for any number of workers), each strip is triangulated on a
thread (the kernel releases the GIL), and the strips are merged in the way
of Funke and Sanders (2017, "Parallel d-D Delaunay triangulations for
shared and distributed memory", section 3):

- a triangle of a strip whose closed circumscribed disk lies strictly inside
  the strip is *final*: no point of another strip lies in that disk, so it
  is a triangle of the Delaunay triangulation of all the points;
- the vertices of every other triangle, with the hull vertices of each strip,
  make the *border* set; its own triangulation, cut to the parts that the
  final triangles leave (its regions between the frontier edges that hold
  the far side of one), fills them.

Every in-circle tie is broken by the same symbolic perturbation
(:func:`tinsmith.kernels.predicates.incircle_perturbed`), so the Delaunay
triangulation of a set is unique: that of the border set holds every
triangle of the whole one among border vertices, and the frontier edges.
The result is therefore the triangulation the sequential kernel makes of
all the points at once, triangle for triangle (tested, cocircular grids
included).  The strips depend on the number of points only, so the arrays
are the same, in the same order, on any number of workers.

Should a check fail (a frontier edge missing from the border triangulation,
the count of triangles not that of a triangulation of the points, a hull
that is not convex), the points are triangulated in one piece instead: the
same triangles.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .. import _checks
from .._threads import thread_map
from ..errors import InvalidInputError
from ..kernels import ahead
from .delaunay import buffers, triangulate_points

ks = ahead.load("tinsmith.kernels.strips")
tin = ahead.load("tinsmith.kernels.tin")

__all__ = [
    "LARGE_STRIP", "MAX_STRIPS", "MOST_STRIPS", "STRIP_POINTS", "Triangles", "n_strips", "triangles_of",
    "triangulate_unique",
]

#: About this many points a strip at least ...
STRIP_POINTS = 16_384
#: ... and this many strips (enough for the cores of one machine; each adds a border) ...
MAX_STRIPS = 8
#: ... unless a strip would then hold more than this many points: a strip's triangulation takes about 130
#: bytes a point while it is made, one a worker at a time, so larger clouds are cut into more strips ...
LARGE_STRIP = 262_144
#: ... up to this many (thinner strips have more of their points on a border, triangulated twice).
MOST_STRIPS = 32


class Triangles(NamedTuple):
    """A Delaunay triangulation as its triangles alone (what :func:`triangulate_unique` gives without twins).

    ``tri`` int32 holds the ``n`` triangles' vertex ids in its first ``3 n``
    slots (counter-clockwise, triangle ``t`` at ``3t:3t+3``); ``hull`` (H, 2)
    the hull's edges, each in the direction of its triangle.
    """

    tri: np.ndarray
    n: int
    hull: np.ndarray


def n_strips(n_points: int) -> int:
    """How many strips ``n_points`` points are cut into (1: one piece), from their number alone."""
    most = min(MOST_STRIPS, max(MAX_STRIPS, -(-n_points // LARGE_STRIP)))
    return int(max(1, min(most, n_points // STRIP_POINTS)))


def triangulate_unique(pts: np.ndarray, workers: int | None = 1, *, twins: bool = True):
    """The Delaunay triangulation of (N, 2) points, ties broken by perturbation; returns ``(m, same, info)``.

    ``m`` and ``same`` as :func:`.delaunay.triangulate_points` gives them with
    ``unique=True`` (the same triangles), but for points at one place: the
    lowest-indexed one is their vertex, whatever the order of insertion.
    ``workers`` threads (None: every core) triangulate the strips.  ``info``
    holds ``strips`` (1 when the points were triangulated in one piece) and
    ``border_points``.  With ``twins=False``, ``m`` is a :class:`Triangles`
    (the same triangles in the same order): no twins, vertex edges nor copy
    of the coordinates, so ``pts`` may be a strided view.
    """
    workers = _checks.workers(workers)
    k = n_strips(len(pts))
    result = _in_strips(pts, k, workers, twins) if k > 1 else None
    if result is None:
        m, same, _ = triangulate_points(np.ascontiguousarray(pts), unique=True)
        result = (m if twins else triangles_of(m)), same, {"strips": 1, "border_points": 0}
    m, same, _ = result
    if twins:
        ks.lowest_duplicates(m[2], m[9][1], m[5], same)
    else:
        ks.lowest_duplicates(m.tri, m.n, np.empty(0, np.int32), same)
        result = m._replace(hull=same[m.hull].astype(np.int64)), same, result[2]  # hull vertices stand for groups
    return result


def triangles_of(m) -> Triangles:
    """The :class:`Triangles` of a kernel triangulation ``m``."""
    n = int(m[9][1])
    tri, half = m[2][: 3 * n], m[3][: 3 * n]
    e = np.flatnonzero(half < 0)
    nxt = e - e % 3 + (e + 1) % 3
    return Triangles(m[2], n, np.column_stack([tri[e], tri[nxt]]).astype(np.int64))


def _cuts(pts: np.ndarray, k: int) -> tuple[int, np.ndarray]:
    """The axis (0: x, 1: y, the longer side) and the values between strips (strip s: cuts[s-1] <= v < cuts[s])."""
    x, y = pts[:, 0], pts[:, 1]  # column by column: numpy reduces an (N, 2) view along axis 0 25x slower
    x0, x1, y0, y1 = x.min(), x.max(), y.min(), y.max()
    axis = 0 if x1 - x0 >= y1 - y0 else 1
    ranks = (np.arange(1, k) * len(pts)) // k
    values = np.sort(ks.ranked(pts[:, axis], ranks))
    # np.unique's values, without its first call's import of numpy.ma (15 ms of a fresh process)
    cuts = values[np.concatenate(([True], values[1:] != values[:-1]))]
    return axis, cuts[cuts > (x0, y0)[axis]]


def _in_strips(pts: np.ndarray, k: int, workers: int, twins: bool):
    """``(m, same, info)`` of :func:`triangulate_unique` made in ``k`` strips, or None when a check fails."""
    n = len(pts)
    axis, cuts = _cuts(pts, k)
    if not len(cuts):
        return None
    parts = _final_triangles(pts, axis, cuts, workers, twins)
    if parts is None:
        return None
    tri, half, n_final, border, same, frontier = parts
    b_ids = np.flatnonzero(border)
    del border
    try:
        m_b, _, _ = triangulate_points(pts[b_ids], unique=True)
    except InvalidInputError:  # pragma: no cover - the strips' hull vertices span an area
        return None
    seeds = np.empty(len(frontier), np.int64)
    walls = np.searchsorted(b_ids, frontier.T)
    if ks.frontier_walls(m_b, walls[0], walls[1], seeds) < 0:
        return None
    labels = tin.label_components(m_b)
    keep = np.isin(labels, labels[seeds[seeds >= 0]]).astype(np.uint8)
    n_tri = n_final + ks.copy_kept(m_b, keep, b_ids, tri, half, n_final)
    distinct = n - int(ks.merged_count(same))
    info = {"strips": len(cuts) + 1, "border_points": len(b_ids)}
    if not twins:
        # every hull vertex of the points is one of a strip: the border set's hull is theirs
        n_b = int(m_b[9][1])
        hull = triangles_of(m_b).hull
        if n_tri != 2 * distinct - 2 - len(hull) or not ks.hull_turns_left(m_b[2], m_b[3], n_b, m_b[0], m_b[1]):
            return None
        return Triangles(tri, n_tri, b_ids[hull]), same, info
    hull = ks.join_frontier(tri, half, n_tri, n)
    if hull < 0 or n_tri != 2 * distinct - 2 - hull:
        return None
    m = buffers(n, tri=tri, half=half)
    m[0][:], m[1][:] = pts[:, 0], pts[:, 1]
    if not ks.hull_turns_left(tri, half, n_tri, m[0], m[1]):
        return None
    m[9][0], m[9][1] = n, n_tri
    tri[3 * n_tri:], half[3 * n_tri:] = 0, -1
    ks.vertex_edges(tri, n_tri, m[5])
    return m, same, info


def _final_triangles(pts: np.ndarray, axis: int, cuts: np.ndarray, workers: int, twins: bool):
    """Each strip triangulated on a thread and its final triangles kept, in global ids, strip after strip.

    Returns ``(tri, half, count, border, same, frontier)``: the triangle and
    twin arrays (room for a triangulation of all the points; ``half`` empty
    without ``twins``), the number of final triangles at their start, the
    (N,) border marks, the duplicates map and the (F, 2) frontier edges of
    :func:`.kernels.strips.gather`; None when a strip cannot be triangulated
    (collinear points).
    """
    n = len(pts)
    k = len(cuts) + 1
    values = pts[:, axis]
    starts = ks.strip_starts(values, cuts)
    bounds = np.r_[-np.inf, cuts, np.inf]
    same = np.arange(n, dtype=np.int32)
    capacity = 2 * n + 8
    tri = np.zeros(3 * capacity, np.int32)
    half = np.full(3 * capacity if twins else 0, -1, np.int32)
    border = np.zeros(n, np.uint8)

    def triangulate(s):
        """Strip s triangulated, its final triangles copied from slot 2 starts[s] on; (their count, frontier) or None."""
        ids = ks.strip_ids(values, bounds[s], bounds[s + 1], starts[s + 1] - starts[s])
        try:
            m, sub_same, _ = triangulate_points(pts, unique=True, ids=ids)
        except InvalidInputError:  # a strip of collinear points
            return None
        same[ids] = ids[sub_same]
        final = ks.final_triangles(m, bounds[s], bounds[s + 1], axis)
        return ks.gather(m, final, ids, tri, half, 2 * starts[s], border)

    # fewer than 2 n_s triangles a strip: each writes its own slots, then they close up
    made = thread_map(triangulate, range(k), workers)
    if any(c is None for c in made):
        return None
    n_final = ks.close_up(tri, half, 2 * starts[:-1], np.array([c for c, _ in made], np.int64))
    return tri, half, n_final, border, same, np.concatenate([f for _, f in made])
