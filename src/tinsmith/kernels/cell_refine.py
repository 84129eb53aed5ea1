"""Greedy refinement of a triangulation at given points, in rounds (:mod:`tinsmith.tiles.refine`).

Each candidate point ``i`` has a position ``(cx[i], cy[i])`` where the surface
should have height ``want[i]``, and a position ``(qx[i], qy[i])`` and height
``put[i]`` a vertex for it takes (a client's grid of positions and heights
can move it by a hair).  A round measures every live candidate in its
triangle and inserts, in every triangle, the candidate whose ``|mesh -
want|`` exceeds the bound the most (point location by walking, Lawson flips
after each insertion, never across a constrained edge or the hull:
:mod:`.tin`); rounds repeat until no candidate exceeds the bound.

Only candidates whose triangle a round rewrote are located and measured
again (the triangulation's dirty list: a slot not rewritten holds the same
triangle).  A candidate in no triangle, or in one whose ``region`` is not 0,
is dropped for good: splits and flips keep the covered domain and the
regions (the caller constrains every edge between regions).

Layout: ``m`` the triangulation tuple of :mod:`.tin` (``px, py`` the vertex
positions), ``z`` float64 (capacity,) the vertices' heights; candidates
float64 (P,).
"""

import numpy as np

from . import tin
from ._jit import jit, jit_inline
from .predicates import orient2d


@jit
def _holding(m, x, y):
    """A triangle whose closure holds (x, y), by testing every one (-1 for none): where a walk meets a hole."""
    px, py, tri, cnt = m[0], m[1], m[2], m[9]
    for t in range(cnt[1]):
        a, b, c = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
        if (orient2d(px[a], py[a], px[b], py[b], x, y) >= 0.0 and orient2d(px[b], py[b], px[c], py[c], x, y) >= 0.0
                and orient2d(px[c], py[c], px[a], py[a], x, y) >= 0.0):
            return t
    return -1


@jit_inline
def _walk(px, py, tri, half, x, y, t):
    """The triangle holding (x, y) by a visibility walk from ``t`` in floating point (each step tries the edges from
    a rotating offset, so that it does not cycle); -1 at the hull or after too many steps.  For measuring: a point
    within rounding of an edge may be given either side."""
    for step in range(1 << 20):
        moved = False
        for j in range(3):
            e = 3 * t + (j + step) % 3
            a, b = tri[e], tri[3 * t + (j + step + 1) % 3]
            if (px[b] - px[a]) * (y - py[a]) - (py[b] - py[a]) * (x - px[a]) < 0.0:
                h = half[e]
                if h < 0:
                    return -1
                t = h // 3
                moved = True
                break
        if not moved:
            return t
    return -1


@jit_inline
def _height(px, py, tri, z, t, x, y):
    """The triangle's plane at (x, y)."""
    a, b, c = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    d = (px[b] - px[a]) * (py[c] - py[a]) - (px[c] - px[a]) * (py[b] - py[a])
    w1 = ((x - px[a]) * (py[c] - py[a]) - (px[c] - px[a]) * (y - py[a])) / d
    w2 = ((px[b] - px[a]) * (y - py[a]) - (x - px[a]) * (py[b] - py[a])) / d
    return z[a] * (1.0 - w1 - w2) + z[b] * w1 + z[c] * w2


@jit
def refine(m, z, cx, cy, want, qx, qy, put, bound, max_rounds, origin, stack):
    """Refine until every live candidate is within ``bound`` or ``max_rounds`` pass; return (rounds, stack).

    A new vertex ``n`` takes ``origin[n] = i`` (its candidate).  Capacity for
    every candidate is the caller's.
    """
    px, py, tri, half, region, is_dirty, dirty, cnt = m[0], m[1], m[2], m[3], m[6], m[8], m[7], m[9]
    p = len(cx)
    host = np.full(p, -1, np.int64)
    err = np.zeros(p)
    alive = np.ones(p, np.bool_)
    cap_t = len(region)
    best = np.full(cap_t, -1, np.int64)
    rounds = 0
    first = True
    last = 0
    while rounds < max_rounds:
        # measure the candidates whose triangle changed (all of them the first time)
        for i in range(p):
            if not alive[i]:
                continue
            if not first and not is_dirty[host[i]]:
                continue
            t = _walk(px, py, tri, half, cx[i], cy[i], last if host[i] < 0 else host[i])
            if t < 0:
                t = _holding(m, cx[i], cy[i])
            if t < 0 or region[t] != 0:
                alive[i] = False
                continue
            host[i] = t
            last = t
            err[i] = abs(_height(px, py, tri, z, t, cx[i], cy[i]) - want[i])
        first = False
        for k in range(cnt[2]):  # the dirty list, emptied for the next round's insertions
            is_dirty[dirty[k]] = 0
        cnt[2] = 0
        # in every triangle, its candidate furthest beyond the bound
        chosen = 0
        for i in range(p):
            if alive[i] and err[i] > bound:
                t = host[i]
                if best[t] < 0:
                    chosen += 1
                    best[t] = i
                elif err[i] > err[best[t]]:
                    best[t] = i
        if chosen == 0:
            break
        rounds += 1
        picks = np.empty(chosen, np.int64)
        k = 0
        for t in range(cnt[1]):
            if best[t] >= 0:
                picks[k] = best[t]
                best[t] = -1
                k += 1
        for i in picks:
            alive[i] = False  # each candidate is inserted once
            x, y = qx[i], qy[i]
            t = tin.locate(m, x, y, host[i])
            if t < 0:
                t = _holding(m, x, y)
                if t < 0:
                    continue
            dup = False
            for j in range(3):
                v = tri[3 * t + j]
                if px[v] == x and py[v] == y:
                    dup = True
            if dup:
                continue
            n = cnt[0]
            px[n] = x
            py[n] = y
            z[n] = put[i]
            origin[n] = i
            cnt[0] += 1
            stack = tin.insert_in_triangle(m, t, n, tin.reserve(stack, cnt[1]), False)
    return rounds, stack
