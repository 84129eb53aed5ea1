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
triangle); the lattice nodes of :func:`refine` are measured in those
triangles only, found from each triangle's bounding box.  A candidate in no
triangle, or in one whose ``region`` is not 0, is dropped for good: splits
and flips keep the covered domain and the regions (the caller constrains
every edge between regions).

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


@jit_inline
def _nodes_in(px, py, tri, z, region, t, node_h, bound, node_best, node_err):
    """Measure the lattice nodes (``node_h``: (N + 1, N + 1) heights, rows from the north, NaN where none is a
    candidate) inside triangle ``t``; keep the furthest beyond ``bound`` in ``node_best[t]`` (row * (N + 1) + col)."""
    if region[t] != 0:
        return
    n = node_h.shape[0] - 1
    a, b, c = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    x0, x1 = min(px[a], px[b], px[c]), max(px[a], px[b], px[c])
    y0, y1 = min(py[a], py[b], py[c]), max(py[a], py[b], py[c])
    d = (px[b] - px[a]) * (py[c] - py[a]) - (px[c] - px[a]) * (py[b] - py[a])
    for col in range(max(int(np.ceil(x0)), 0), min(int(np.floor(x1)), n) + 1):
        for y in range(max(int(np.ceil(y0)), 0), min(int(np.floor(y1)), n) + 1):
            h = node_h[n - y, col]
            if not np.isfinite(h):
                continue
            w1 = ((col - px[a]) * (py[c] - py[a]) - (px[c] - px[a]) * (y - py[a])) / d
            w2 = ((px[b] - px[a]) * (y - py[a]) - (col - px[a]) * (py[b] - py[a])) / d
            w0 = 1.0 - w1 - w2
            if w0 < -1e-12 or w1 < -1e-12 or w2 < -1e-12:
                continue
            e = abs(z[a] * w0 + z[b] * w1 + z[c] * w2 - h)
            if e > bound and e > node_err[t]:
                node_err[t] = e
                node_best[t] = (n - y) * (n + 1) + col


@jit
def refine(m, z, cx, cy, want, qx, qy, put, node_h, node_put, bound, max_rounds, origin, stack):
    """Refine until every live candidate is within ``bound`` or ``max_rounds`` pass; return (rounds, stack).

    Candidates: the points ``cx, cy`` (see the module notes), and the lattice
    nodes of ``node_h`` (heights; a node takes ``node_put``), measured only
    in the triangles a round rewrote: the mesher left every node within the
    bound.  A new vertex ``n`` takes ``origin[n] = i`` for point ``i`` and
    ``-2 - (row * (N + 1) + col)`` for a node.  Capacity for every candidate
    is the caller's.
    """
    px, py, tri, half, region, is_dirty, dirty, cnt = m[0], m[1], m[2], m[3], m[6], m[8], m[7], m[9]
    p = len(cx)
    n_side = node_h.shape[0] - 1
    host = np.full(p, -1, np.int64)
    err = np.zeros(p)
    alive = np.ones(p, np.bool_)
    cap_t = len(region)
    best = np.full(cap_t, -1, np.int64)
    node_best = np.full(cap_t, -1, np.int64)
    node_err = np.zeros(cap_t)
    rounds = 0
    first = True
    last = 0
    while rounds < max_rounds:
        # measure the candidates whose triangle changed (every point the first time)
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
        for k in range(cnt[2]):  # the nodes in the rewritten triangles; the dirty list emptied for the next round
            t = dirty[k]
            is_dirty[t] = 0
            _nodes_in(px, py, tri, z, region, t, node_h, bound, node_best, node_err)
        cnt[2] = 0
        # in every triangle, its candidate furthest beyond the bound
        for i in range(p):
            if alive[i] and err[i] > bound:
                t = host[i]
                if best[t] < 0 or err[i] > err[best[t]]:
                    best[t] = i
        chosen = 0
        for t in range(cnt[1]):
            if best[t] >= 0 or node_best[t] >= 0:
                chosen += 1
        if chosen == 0:
            break
        rounds += 1
        picks = np.empty(chosen, np.int64)  # a point i, or -2 - a node
        hosts = np.empty(chosen, np.int64)
        k = 0
        for t in range(cnt[1]):
            if best[t] < 0 and node_best[t] < 0:
                continue
            if node_best[t] >= 0 and (best[t] < 0 or node_err[t] > err[best[t]]):
                picks[k] = -2 - node_best[t]
            else:
                picks[k] = best[t]
            hosts[k] = t
            best[t] = -1
            node_best[t] = -1
            node_err[t] = 0.0
            k += 1
        for k in range(chosen):
            i = picks[k]
            if i >= 0:
                alive[i] = False  # each candidate is inserted once
                x, y, h = qx[i], qy[i], put[i]
            else:
                r, c = (-2 - i) // (n_side + 1), (-2 - i) % (n_side + 1)
                node_h[r, c] = np.nan
                x, y, h = float(c), float(n_side - r), node_put[r, c]
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
            z[n] = h
            origin[n] = i
            cnt[0] += 1
            stack = tin.insert_in_triangle(m, t, n, tin.reserve(stack, cnt[1]), False)
    return rounds, stack
