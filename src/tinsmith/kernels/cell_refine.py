"""Greedy refinement of a triangulation at given points, in rounds (:mod:`tinsmith.tiles.refine`).

Each candidate point ``i`` has a position ``(cx[i], cy[i])`` where the surface
should have height ``want[i]``, and a vertex for it takes the position and
height the caller gives :func:`insert` (a client's grid of positions and
heights can move it by a hair).  A round locates every live candidate in the current
triangles (:func:`worst_per_triangle`: bucket grid of :mod:`.locate`, the
triangle of the previous candidate tried first), and keeps, per triangle, the
candidate whose ``|mesh - want|`` exceeds the bound the most; :func:`insert`
then inserts those (point location by walking, Lawson flips after each, never
across a constrained edge or the hull: :mod:`.tin`).

A candidate in no triangle, or in one whose ``region`` is not 0, is dropped
for good: splits and flips keep the covered domain and the regions (the
caller constrains every edge between regions).

Layout: ``uv`` float64 (V, 2), ``tri`` int64 (M, 3) counter-clockwise,
``z`` float64 (V,) heights of the vertices, ``region`` uint8 (M,);
``start``/``items`` of :func:`.locate.build`; ``m`` the triangulation tuple of
:mod:`.tin`.
"""

import numpy as np

from . import tin
from ._jit import jit
from .certificate import _weights
from .predicates import orient2d


@jit
def worst_per_triangle(cx, cy, want, alive, uv, tri, region, z, start, items, lo_x, lo_y, cell, nx, ny, eps, bound):
    """(candidate (M,) int64 per triangle or -1, largest error of a live candidate, candidates over the bound).

    Candidates held by no triangle of region 0 get ``alive[i] = 0``.
    """
    m_tri = tri.shape[0]
    best = np.full(m_tri, -1, np.int64)
    best_err = np.zeros(m_tri)
    worst = 0.0
    over = 0
    last = -1
    for i in range(len(cx)):
        if not alive[i]:
            continue
        x, y = cx[i], cy[i]
        found = -1
        w0 = w1 = w2 = 0.0
        if last >= 0:
            a0, a1, a2, ok = _weights(uv, tri, last, x, y)
            if ok and a0 >= 0.0 and a1 >= 0.0 and a2 >= 0.0:
                found, w0, w1, w2 = last, a0, a1, a2
        if found < 0:
            bi = int((x - lo_x) / cell)
            bj = int((y - lo_y) / cell)
            if bi >= 0 and bj >= 0 and bi < nx and bj < ny:
                b = bj * nx + bi
                best_min = -np.inf
                for s in range(start[b], start[b + 1]):
                    k = items[s]
                    a0, a1, a2, ok = _weights(uv, tri, k, x, y)
                    if not ok:
                        continue
                    low = min(a0, a1, a2)
                    if low > best_min:
                        best_min = low
                        found, w0, w1, w2 = k, a0, a1, a2
                        if low >= 0.0:
                            break
                if found >= 0 and best_min < -eps:
                    found = -1
        if found < 0 or region[found] != 0:
            alive[i] = 0
            continue
        last = found
        mesh = z[tri[found, 0]] * w0 + z[tri[found, 1]] * w1 + z[tri[found, 2]] * w2
        e = abs(mesh - want[i])
        if e > worst:
            worst = e
        if e > bound:
            over += 1
            if e > best_err[found]:
                best_err[found] = e
                best[found] = i
    return best, worst, over


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


@jit
def insert(m, z, cx, cy, put, chosen, hosts, origin, stack):
    """Insert candidates ``chosen`` at (``cx``, ``cy``) (walks start at their ``hosts``); return (vertices added,
    stack).

    A new vertex ``n`` takes height ``put[i]`` in ``z`` and ``origin[n] = i``.
    A candidate already a vertex adds nothing.  Capacity for every candidate
    is the caller's.
    """
    px, py, tri, cnt = m[0], m[1], m[2], m[9]
    added = 0
    for k in range(len(chosen)):
        i = chosen[k]
        x, y = cx[i], cy[i]
        t = tin.locate(m, x, y, hosts[k])
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
        added += 1
    return added, stack
