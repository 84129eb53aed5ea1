"""Kernels of the Delaunay triangulation made in strips (:mod:`tinsmith.triangulation.strips`).

Each strip's triangulation is split into the triangles that are final (their
circumscribed disk lies strictly inside the strip, so no point of another
strip can be in it) and the rest; the vertices of the rest, with every hull
vertex of the strip, make the border set, whose own triangulation fills the
space the final triangles leave.  See the orchestrating module for why the
result is the Delaunay triangulation of all the points.
"""

import numpy as np

from ._jit import jit
from .predicates import orient2d
from .tin import find_edge, next_half

#: A disk counts as inside a strip only this far (relative to its radius) from the strip's sides, which
#: covers the rounding of its centre and radius for every triangle that :func:`final_triangles` does not
#: already treat as flat.
RADIUS_MARGIN = 1e-3
#: Triangles whose doubled area is below this share of the squared length of their two edges from the
#: first corner are flat enough that their circumscribed disk cannot be trusted to float precision.
FLAT = 1e-12


@jit
def final_triangles(m, lo, hi, axis):
    """(T,) uint8: 1 where triangle t's closed circumscribed disk lies strictly between ``lo`` and ``hi``.

    ``axis`` 0 measures x, 1 measures y.  The test is conservative: a disk
    within :data:`RADIUS_MARGIN` of a side, or the disk of a triangle flatter
    than :data:`FLAT`, counts as crossing.
    """
    px, py, tri, n = m[0], m[1], m[2], m[9][1]
    final = np.zeros(n, np.uint8)
    for t in range(n):
        a, b, c = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
        bx, by = px[b] - px[a], py[b] - py[a]
        cx, cy = px[c] - px[a], py[c] - py[a]
        b2, c2 = bx * bx + by * by, cx * cx + cy * cy
        d = 2.0 * (bx * cy - by * cx)
        if d <= FLAT * (b2 + c2):
            continue
        ux = (cy * b2 - by * c2) / d
        uy = (bx * c2 - cx * b2) / d
        r = np.sqrt(ux * ux + uy * uy)
        centre = (px[a] + ux) if axis == 0 else (py[a] + uy)
        slack = RADIUS_MARGIN * r + 1e-12 * abs(centre)
        if centre - r - slack > lo and centre + r + slack < hi:
            final[t] = 1
    return final


@jit
def gather(m, final, members, tri_out, half_out, start, border):
    """Copy the final triangles of a strip's triangulation ``m`` to ``tri_out[3*start:]`` in global vertex ids.

    ``members`` maps the strip's vertex ids to global ones; the twins, when
    ``half_out`` is not empty, are as :func:`copy_kept` writes them (-1
    across the frontier, joined later).  Marks in ``border`` (global vertex
    ids) the vertices of every triangle that is not final and of every hull
    edge.  Returns the number of triangles copied and the (F, 2) frontier:
    the halfedges of final triangles with no final triangle on their other
    side (global ids, in the final triangle's direction).
    """
    tri, half, n = m[2], m[3], m[9][1]
    count = 0
    for e in range(3 * n):
        if not final[e // 3] or half[e] < 0:
            border[members[tri[e]]] = 1
        if half[e] < 0:
            border[members[tri[next_half(e)]]] = 1
        if final[e // 3] and (half[e] < 0 or not final[half[e] // 3]):
            count += 1
    frontier = np.empty((count, 2), np.int64)
    count = 0
    for e in range(3 * n):
        if final[e // 3] and (half[e] < 0 or not final[half[e] // 3]):
            frontier[count, 0], frontier[count, 1] = members[tri[e]], members[tri[next_half(e)]]
            count += 1
    return copy_kept(m, final, members, tri_out, half_out, start), frontier


@jit
def close_up(tri, half, starts, counts):
    """Move each strip's triangles (``counts[s]`` of them from slot ``starts[s]``, strips in order) down to
    follow the previous strip's, their twins (when ``half`` is not empty) renumbered; returns the number of
    triangles."""
    twins = len(half) > 0
    to = 0
    for s in range(len(starts)):
        shift = 3 * (starts[s] - to)
        for e in range(3 * starts[s], 3 * (starts[s] + counts[s])):
            tri[e - shift] = tri[e]
            if twins:
                h = half[e]
                half[e - shift] = h - shift if h >= 0 else -1
        to += counts[s]
    return to


@jit
def frontier_walls(mb, frontier_a, frontier_b, seeds):
    """Make the frontier edges walls (constrained) of the border triangulation ``mb``, a scratch one.

    ``frontier_a -> frontier_b`` (border vertex ids) are the edges of final
    triangles whose other side is not final, in the direction of the final
    triangle.  ``seeds[i]`` gets the border triangle on the other side of
    edge i (``b -> a``), -1 where that side is outside the hull: the regions
    of :func:`.tin.label_components` that hold a seed are the ones the final
    triangles leave.  Returns 0, or -1 when a frontier edge is not an edge of
    ``mb`` (which the construction rules out).
    """
    tri, half, cons = mb[2], mb[3], mb[4]
    for i in range(len(frontier_a)):
        a, b = frontier_a[i], frontier_b[i]
        e = find_edge(mb, b, a)
        if e < 0:
            return -1
        if tri[e] != b:  # a -> b (find_edge gives either way): the border side is its twin
            e = half[e] if half[e] >= 0 else e
        seeds[i] = e // 3 if tri[e] == b else -1  # none when a -> b is on the hull
        cons[e] = 1
        if half[e] >= 0:
            cons[half[e]] = 1
    return 0


@jit
def copy_kept(mb, keep, ids, tri_out, half_out, start):
    """Append the kept triangles of ``mb`` (vertex ids mapped by ``ids``) at ``tri_out[3*start:]``, their twins at
    ``half_out`` unless it is empty (halfedge ids there; -1 where the twin is not kept or on the hull).  Returns
    the number copied."""
    tri, half, n = mb[2], mb[3], mb[9][1]
    twins = len(half_out) > 0
    slot = np.full(n, -1, np.int64)
    count = 0
    for t in range(n):
        if keep[t]:
            slot[t] = start + count
            count += 1
    for t in range(n):
        s = slot[t]
        if s < 0:
            continue
        for k in range(3):
            e = 3 * t + k
            h = half[e]
            tri_out[3 * s + k] = ids[tri[e]]
            if twins:
                half_out[3 * s + k] = -1 if h < 0 or slot[h // 3] < 0 else 3 * slot[h // 3] + h % 3
    return count


@jit
def join_frontier(tri, half, n_tri, n_vertices):
    """Join the halfedges with no twin yet (the frontier between the parts) to their opposites, in place.

    Those left without one are the hull.  Returns the number of hull
    halfedges, or -1 when two halfedges run the same way between two
    vertices (not a triangulation).
    """
    open_ = np.flatnonzero(half[: 3 * n_tri] < 0)
    keys = np.empty(len(open_), np.int64)
    for i in range(len(open_)):
        e = open_[i]
        keys[i] = np.int64(tri[e]) * n_vertices + tri[next_half(e)]
    order = np.argsort(keys)
    sorted_keys = keys[order]
    for i in range(1, len(sorted_keys)):
        if sorted_keys[i] == sorted_keys[i - 1]:
            return -1
    hull = 0
    for i in range(len(open_)):
        e = open_[i]
        want = np.int64(tri[next_half(e)]) * n_vertices + tri[e]
        j = np.searchsorted(sorted_keys, want)
        if j < len(sorted_keys) and sorted_keys[j] == want:
            half[e] = open_[order[j]]
        else:
            hull += 1
    return hull


@jit
def vertex_edges(tri, n_tri, vedge):
    """``vedge[v]``: one halfedge leaving each vertex (the last one written)."""
    for e in range(3 * n_tri):
        vedge[tri[e]] = e


@jit
def hull_turns_left(tri, half, n_tri, px, py):
    """True when every hull vertex of the triangles turns left or goes straight (the hull is convex)."""
    for e in range(3 * n_tri):
        if half[e] >= 0:
            continue
        f = next_half(e)  # the hull halfedge that starts where e ends
        while half[f] >= 0:
            f = next_half(half[f])
        a, b, c = tri[e], tri[next_half(e)], tri[next_half(f)]
        if orient2d(px[a], py[a], px[b], py[b], px[c], py[c]) < 0.0:
            return False
    return True


#: :func:`ranked` counts the values in this many bins.
_RANK_BINS = 1 << 16


@jit
def ranked(values, ranks):
    """``np.partition(values, ranks)[ranks]`` of (N,) finite values, without copying or reordering them.

    The values are counted in :data:`_RANK_BINS` even bins between the least
    and the greatest; for each rank, the values of its bin alone are
    gathered and sorted.
    """
    n = len(values)
    low = high = values[0]
    for i in range(n):
        low, high = min(low, values[i]), max(high, values[i])
    top = _RANK_BINS - 1
    scale = top / (high - low) if high > low else 0.0
    bins = np.zeros(_RANK_BINS, np.int64)
    for i in range(n):
        bins[min(int((values[i] - low) * scale), top)] += 1
    out = np.empty(len(ranks))
    for j in range(len(ranks)):
        below = 0
        b = 0
        while below + bins[b] <= ranks[j]:
            below += bins[b]
            b += 1
        middle = np.empty(bins[b])
        size = 0
        for i in range(n):
            if min(int((values[i] - low) * scale), top) == b:
                middle[size] = values[i]
                size += 1
        middle.sort()
        out[j] = middle[ranks[j] - below]
    return out


@jit
def strip_starts(values, cuts):
    """Where each strip starts in the points taken strip after strip: (S + 1,) int64.

    Point i is in strip s when ``cuts[s-1] <= values[i] < cuts[s]``.
    """
    k = len(cuts) + 1
    starts = np.zeros(k + 1, np.int64)
    for i in range(len(values)):
        starts[np.searchsorted(cuts, values[i], side="right") + 1] += 1
    for s in range(k):
        starts[s + 1] += starts[s]
    return starts


@jit
def strip_ids(values, low, high, count):
    """The ``count`` points with ``low <= values[i] < high``, ascending: (count,) int32.

    One strip's members, found by a pass over all the values on the strip's
    own thread, so that no array of every point's strip is held.
    """
    ids = np.empty(count, np.int32)
    size = 0
    for i in range(len(values)):
        if low <= values[i] < high:
            ids[size] = i
            size += 1
    return ids


@jit
def merged_count(same):
    """How many points ``same`` maps to another point (those merged into a vertex at their place)."""
    count = 0
    for i in range(len(same)):
        count += same[i] != i
    return count


@jit
def lowest_duplicates(tri, n_tri, vedge, same):
    """Make the lowest-indexed point of each group at one place the group's vertex, in place; returns 0.

    ``same`` maps each point to the vertex at its place (the first inserted
    there, which depends on the order of insertion); afterwards it maps to the
    lowest index of the group whatever the order, and the ``n_tri`` triangles
    of ``tri`` and ``vedge`` (unless empty) use that vertex.
    """
    n = len(same)
    moved = False
    for i in range(n):
        if i < same[i]:  # a point below its group's vertex: the group's lowest index is not its vertex
            moved = True
            break
    if not moved:
        return 0
    low = np.empty(n, same.dtype)  # of the same width as same, filled here: no int64 range held beside it
    for i in range(n):
        low[i] = i
    for i in range(n):
        r = same[i]
        if i < low[r]:
            low[r] = i
    for e in range(3 * n_tri):
        tri[e] = low[tri[e]]
    if len(vedge):
        for i in range(n):
            if low[i] != i:
                vedge[low[i]] = vedge[i]
    for i in range(n):
        same[i] = low[same[i]]
    return 0
