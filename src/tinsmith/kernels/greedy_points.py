"""Greedy insertion on scattered points: every triangle holds the input points inside it; insert the worst.

The grid kernel (:mod:`.greedy`) finds a triangle's worst cell by scanning
the cells under it; scattered points have no such order, so each triangle
keeps a list of the points that fall in it (Garland & Heckbert 1995, section
4.2, "greedy insertion" with candidate lists).  After an insertion every
triangle the insertion rewrote is dirty (:mod:`.tin` marks them); the
points of their old lists are exactly the points of the rewritten area,
which the new dirty triangles tile, so each point goes to the dirty triangle
that holds it (exact orientation tests) and only those triangles are
scanned again.

Buffer layout, on top of the triangulation ``m`` of :mod:`.tin` (vertex
coordinates in world units):

- ``P`` = ``(X, Y, Z, nxt, head, used, vz, gather, lost)``: the candidate
  points ``X, Y, Z`` float64 (N,); ``nxt`` int32 (N,), the next point of the
  same triangle's list (-1 ends it); ``head`` int32 (T,), each triangle's
  first point (-1: none); ``used`` uint8 (N,), 1 once a point is a vertex;
  ``vz`` float64 (V,), the height of each vertex; ``gather`` int32 (N,),
  scratch; ``lost`` int64 (1,), points no triangle took (always 0 on a
  valid triangulation; the caller checks).
- ``cand``, ``q`` and ``cnt`` as in :mod:`.greedy`: each triangle's worst
  point (-1: none), the indexed max-heap keyed on that point's error, and
  the counters (vertices, triangles, dirty triangles, heap size).

The mesh height at a point is :func:`plane_height`, the expression
:func:`tinsmith.metrics.points_error` evaluates too.
"""

from ._jit import jit, jit_inline, jit_no_refcount, jit_no_refcount_unchecked
from .greedy import stop_code
from .heap import heap_remove, heap_requeue
from .predicates import orient2d
from .tin import insert_in_triangle, locate


@jit_inline
def plane_height(x0, y0, z0, x1, y1, z1, x2, y2, z2, x, y):
    """Height at (x, y) of the plane through three points (linear interpolation in a triangle)."""
    d = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    w1 = (x - x0) * (y2 - y0) - (x2 - x0) * (y - y0)
    w2 = (x1 - x0) * (y - y0) - (x - x0) * (y1 - y0)
    return z0 + (w1 * (z1 - z0) + w2 * (z2 - z0)) / d


@jit_inline
def _holds(px, py, a, b, c, x, y):
    """Is (x, y) in the closed triangle (a, b, c) (counter-clockwise)?  Exact."""
    return (
        orient2d(px[a], py[a], px[b], py[b], x, y) >= 0.0
        and orient2d(px[b], py[b], px[c], py[c], x, y) >= 0.0
        and orient2d(px[c], py[c], px[a], py[a], x, y) >= 0.0
    )


@jit_no_refcount
def distribute(m, P, ids):
    """Put the points ``ids`` (in walk-friendly order) into the lists of the triangles that hold them.

    Points that fall outside the data (``region`` != 0) or outside the hull
    are counted in ``lost``.  Without reference counting (it allocates
    nothing), as :func:`refine`.
    """
    X, Y, nxt, head, lost = P[0], P[1], P[3], P[4], P[8]
    region = m[6]
    t = 0
    for i in range(len(ids)):
        p = ids[i]
        s = locate(m, X[p], Y[p], t)
        if s < 0 or region[s]:
            lost[0] += 1
            continue
        t = s
        nxt[p] = head[t]
        head[t] = p


@jit_inline
def _scan(m, P, t, cand):
    """The point of triangle ``t``'s list with the largest |mesh - z| (ties: the lower point id); its error."""
    px, py, tri = m[0], m[1], m[2]
    X, Y, Z, nxt, head, vz = P[0], P[1], P[2], P[3], P[4], P[6]
    a, b, c = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    x0, y0, z0 = px[a], py[a], vz[a]
    x1, y1, z1 = px[b], py[b], vz[b]
    x2, y2, z2 = px[c], py[c], vz[c]
    best, best_at = -1.0, -1
    p = head[t]
    while p >= 0:
        e = abs(plane_height(x0, y0, z0, x1, y1, z1, x2, y2, z2, X[p], Y[p]) - Z[p])
        if e > best or (e == best and p < best_at):
            best, best_at = e, p
        p = nxt[p]
    cand[t] = best_at
    return best


@jit_inline
def _flush(m, P, cand, q, redistribute):
    """Rescan every dirty triangle and (re)queue it; first move the points of the rewritten area (``redistribute``)."""
    px, py, tri, region, dirty, is_dirty, cnt = m[0], m[1], m[2], m[6], m[7], m[8], m[9]
    X, Y, nxt, head, used, gather, lost = P[0], P[1], P[3], P[4], P[5], P[7], P[8]
    nd = cnt[2]
    if redistribute:
        k = 0
        for i in range(nd):
            t = dirty[i]
            p = head[t]
            while p >= 0:
                if not used[p]:
                    gather[k] = p
                    k += 1
                p = nxt[p]
            head[t] = -1
        last = 0
        for j in range(k):
            p = gather[j]
            x, y = X[p], Y[p]
            placed = False
            for s in range(nd):
                i = (last + s) % nd
                t = dirty[i]
                if region[t]:
                    continue
                if _holds(px, py, tri[3 * t], tri[3 * t + 1], tri[3 * t + 2], x, y):
                    nxt[p] = head[t]
                    head[t] = p
                    last = i
                    placed = True
                    break
            if not placed:
                lost[0] += 1
    for i in range(nd):
        t = dirty[i]
        is_dirty[t] = 0
        if region[t]:
            e = 0.0
            cand[t] = -1
        else:
            e = _scan(m, P, t, cand)
        heap_requeue(t, q, e, cand[t] >= 0, cnt)
    cnt[2] = 0


@jit
def flush(m, P, cand, q, redistribute):
    """:func:`_flush`, called from Python (the engine's first scan); :func:`refine` inlines it (an out-of-line call
    passes every array of its tuples on the stack, once an insertion)."""
    _flush(m, P, cand, q, redistribute)


@jit_no_refcount_unchecked
def refine(m, P, cand, q, stack, max_error, max_vertices, max_triangles, slack):
    """Insert worst points until a stop rule holds or the buffers are full.

    Compiled as the grid kernel's :func:`tinsmith.kernels.greedy.refine` is:
    without reference counting (it allocates nothing: every array a numba
    function pulls out of a tuple otherwise costs two atomic operations) and
    with numpy's error model (its divisors, twice a triangle's area, are never
    zero).

    Stops on ``max_error`` when the worst error plus ``slack`` (a bound on
    the rounding of another evaluation of the same plane) is at most it, so
    that no evaluation of the result exceeds the bound.  Returns (code,
    stack) as :func:`tinsmith.kernels.greedy.refine` does, with its codes.
    """
    px, py, cnt = m[0], m[1], m[9]
    X, Y, Z, used, vz = P[0], P[1], P[2], P[5], P[6]
    cap_v = len(px)
    cap_t = len(cand)
    while True:
        _flush(m, P, cand, q, True)
        code = stop_code(cnt, q, max_error, max_vertices, max_triangles, cap_v, cap_t, slack)
        if code >= 0:
            return code, stack
        t = q[0][0]
        heap_remove(t, q, cnt)
        p = cand[t]
        n = cnt[0]
        cnt[0] += 1
        px[n] = X[p]
        py[n] = Y[p]
        vz[n] = Z[p]
        used[p] = 1
        stack = insert_in_triangle(m, t, n, stack, False)
