"""Quadric edge collapse of a 2.5-D triangulation (the kernel of :mod:`tinsmith.algorithms.grid.decimate`).

Buffer layout:

- ``x``, ``y``, ``z`` float64 (N,): vertex coordinates (the caller passes
  pixel coordinates for a grid, so that straight borders are exactly
  straight); ``tri`` int64 (M, 3), counter-clockwise, rewritten in place.
- Corner lists: corner ``c = 3 t + k`` is corner ``k`` of triangle ``t``;
  ``head[v]`` is the first corner at vertex ``v`` and ``nxt[c]`` the next
  (-1 ends a list).  A collapse splices the lists; corners of dead
  triangles are unlinked lazily, when a walk meets them.
- ``quad`` float64 (N, 10): the error quadric of every vertex.
- ``bn`` int64 (N, 2): the two neighbours of a border vertex along the
  border (-1 for interior vertices).
- ``locked`` bool (N,): vertices that never move: corners of the outline,
  vertices where the outline touches itself, and what the caller locks.

A collapse is a half-edge collapse ``v -> u``: ``v`` goes, its triangles
take ``u`` instead, the two (one on the border) that held both die.  The
kept vertices are input vertices, so a mesh of a grid keeps exact heights.
"""

import numpy as np

from ._jit import jit, jit_inline, jit_no_refcount
from .heap import HEAP_SIZE, heap_push, heap_remove, heap_update
from .predicates import orient2d


@jit_inline
def _add_plane(quad, v, a, b, c, weight):
    """Add ``weight * (a x + b y + c - z)**2`` (the vertical distance to a plane, squared) to ``quad[v]``."""
    quad[v, 0] += weight * a * a
    quad[v, 1] += weight * a * b
    quad[v, 2] -= weight * a
    quad[v, 3] += weight * a * c
    quad[v, 4] += weight * b * b
    quad[v, 5] -= weight * b
    quad[v, 6] += weight * b * c
    quad[v, 7] += weight
    quad[v, 8] -= weight * c
    quad[v, 9] += weight * c * c


@jit_inline
def _cost(quad, v, u, x, y, z):
    """``(Q_v + Q_u)`` at the position of ``u``: the error of moving ``v`` onto ``u``."""
    px, py, pz = x[u], y[u], z[u]
    q = quad[v]
    r = quad[u]
    return (
        (q[0] + r[0]) * px * px + 2.0 * (q[1] + r[1]) * px * py + 2.0 * (q[2] + r[2]) * px * pz
        + 2.0 * (q[3] + r[3]) * px + (q[4] + r[4]) * py * py + 2.0 * (q[5] + r[5]) * py * pz
        + 2.0 * (q[6] + r[6]) * py + (q[7] + r[7]) * pz * pz + 2.0 * (q[8] + r[8]) * pz + (q[9] + r[9])
    )


@jit
def quadrics(x, y, z, tri):
    """(N, 10) quadrics: each triangle's plane, weighted by its area, added to its three corners."""
    quad = np.zeros((len(x), 10))
    for t in range(tri.shape[0]):
        i, j, k = tri[t, 0], tri[t, 1], tri[t, 2]
        ux, uy, uz = x[j] - x[i], y[j] - y[i], z[j] - z[i]
        vx, vy, vz = x[k] - x[i], y[k] - y[i], z[k] - z[i]
        d = ux * vy - vx * uy
        if d == 0.0:
            continue
        a = (uz * vy - vz * uy) / d
        b = (ux * vz - vx * uz) / d
        c = z[i] - a * x[i] - b * y[i]
        weight = 0.5 * abs(d)
        _add_plane(quad, i, a, b, c, weight)
        _add_plane(quad, j, a, b, c, weight)
        _add_plane(quad, k, a, b, c, weight)
    return quad


@jit
def corner_lists(tri, n):
    head = np.full(n, -1, np.int64)
    nxt = np.full(3 * tri.shape[0], -1, np.int64)
    for c in range(3 * tri.shape[0] - 1, -1, -1):
        v = tri[c // 3, c % 3]
        nxt[c] = head[v]
        head[v] = c
    return head, nxt


@jit
def border(x, y, tri, head, nxt, locked):
    """(N, 2) border neighbours; locks corners of the outline and vertices with more than two border edges."""
    n = len(x)
    bn = np.full((n, 2), -1, np.int64)
    count = np.zeros(n, np.int64)
    for v in range(n):
        c = head[v]
        while c >= 0:
            t, k = c // 3, c % 3
            w = tri[t, (k + 1) % 3]  # directed edge v -> w; a border edge if no triangle has w -> v
            twin = False
            d = head[w]
            while d >= 0:
                if tri[d // 3, (d % 3 + 1) % 3] == v:
                    twin = True
                    break
                d = nxt[d]
            if not twin:
                for a, b in ((v, w), (w, v)):
                    if count[a] < 2:
                        bn[a, count[a]] = b
                    count[a] += 1
            c = nxt[c]
    for v in range(n):
        if count[v] > 2:
            locked[v] = True
        elif count[v] == 2:
            a, b = bn[v, 0], bn[v, 1]
            if orient2d(x[a], y[a], x[v], y[v], x[b], y[b]) != 0.0:
                locked[v] = True
    return bn


@jit_inline
def _ring(v, tri, head, nxt, dead, mark, gen, out):
    """Write the neighbours of ``v`` to ``out`` (marking them ``gen``); return their count.  Unlinks dead corners."""
    count = 0
    prev = -1
    c = head[v]
    while c >= 0:
        t = c // 3
        following = nxt[c]
        if dead[t]:
            if prev < 0:
                head[v] = following
            else:
                nxt[prev] = following
        else:
            k = c % 3
            for w in (tri[t, (k + 1) % 3], tri[t, (k + 2) % 3]):
                if mark[w] != gen:
                    mark[w] = gen
                    out[count] = w
                    count += 1
            prev = c
        c = following
    return count


@jit_inline
def _valid(v, u, x, y, tri, head, nxt, dead, mark_v, gen_v, mark_u, gen_u, scratch):
    """True if ``v -> u`` keeps a valid 2-D triangulation: the link condition and no triangle turned over."""
    n_u = _ring(u, tri, head, nxt, dead, mark_u, gen_u, scratch)
    common = 0
    for i in range(n_u):
        if mark_v[scratch[i]] == gen_v:
            common += 1
    shared = 0
    c = head[v]
    while c >= 0:
        t = c // 3
        if not dead[t]:
            k = c % 3
            a, b = tri[t, (k + 1) % 3], tri[t, (k + 2) % 3]
            if a == u or b == u:
                shared += 1
            elif orient2d(x[u], y[u], x[a], y[a], x[b], y[b]) <= 0.0:
                return False
        c = nxt[c]
    return common == shared


@jit_inline
def _best(v, x, y, z, tri, head, nxt, dead, quad, bn, locked, marks, gens, ring, cost, scratch):
    """The cheapest valid collapse of ``v``: (cost, target), (inf, -1) when there is none.

    The candidates are costed first and validated cheapest first, so that
    most calls validate one.  ``gens[1]`` and ``gens[2]`` are the mark
    generations of the two rings.
    """
    if locked[v]:
        return np.inf, -1
    gens[1] += 1
    n_v = _ring(v, tri, head, nxt, dead, marks[0], gens[1], ring)
    n_c = 0
    for i in range(n_v):
        u = ring[i]
        if bn[v, 0] >= 0 and u != bn[v, 0] and u != bn[v, 1]:
            continue  # a border vertex slides along the border only
        ring[n_c] = u  # the candidates overwrite the ring in place; its marks stay
        cost[n_c] = _cost(quad, v, u, x, y, z)
        n_c += 1
    for j in range(n_c):
        k = j
        for i in range(j + 1, n_c):
            if cost[i] < cost[k]:
                k = i
        u, c = ring[k], cost[k]
        ring[k], cost[k] = ring[j], cost[j]
        gens[2] += 1
        if _valid(v, u, x, y, tri, head, nxt, dead, marks[0], gens[1], marks[1], gens[2], scratch):
            return c, u
    return np.inf, -1


@jit_inline
def _update(v, x, y, z, tri, head, nxt, dead, quad, bn, locked, marks, gens, ring, cost, scratch, goal, q, cnt):
    """Recompute the best collapse of ``v`` and put it in the heap (or take ``v`` out when it has none)."""
    c, g = _best(v, x, y, z, tri, head, nxt, dead, quad, bn, locked, marks, gens, ring, cost, scratch)
    goal[v] = g
    if g < 0:
        heap_remove(v, q, cnt)
    elif q[1][v] >= 0:
        heap_update(v, q, -c, cnt)
    else:
        heap_push(v, q, -c, cnt)


@jit
def collapse(x, y, z, tri, locked, quad, bn, head, nxt, target_vertices):
    """Collapse the cheapest edge until ``target_vertices`` remain or no collapse is valid.

    Returns ``(gone, into, cost, n_triangles)``, one entry per collapse in
    order: the vertex removed, the vertex it went into, the quadric cost
    and the triangle count after it.  ``tri`` holds the final mesh
    (with dead triangles among it).
    """
    n, m = len(x), tri.shape[0]
    alive = np.zeros(n, np.bool_)
    for t in range(m):
        for k in range(3):
            alive[tri[t, k]] = True
    steps = max(np.count_nonzero(alive) - target_vertices, 0)
    out = (np.empty(steps, np.int64), np.empty(steps, np.int64), np.empty(steps, np.float64), np.empty(steps, np.int64))
    work = (
        np.zeros(m, np.bool_),  # dead triangles
        np.zeros((2, n), np.int64),  # marks of two rings
        np.empty(n + 1, np.int64),  # ring buffers
        np.empty(n + 1, np.int64),
        np.empty(n + 1, np.int64),
        np.empty(n, np.float64),  # costs of the candidates
        np.full(n, -1, np.int64),  # goal: the best collapse of each vertex
    )
    q = (np.empty(n, np.int32), np.full(n, -1, np.int32), np.empty(n, np.float64))
    cnt = np.zeros(HEAP_SIZE + 1, np.int64)  # triangles, two mark generations, heap size
    cnt[0] = m
    done = _collapse_loop(x, y, z, tri, alive, locked, quad, bn, head, nxt, work, q, cnt, out)
    return out[0][:done], out[1][:done], out[2][:done], out[3][:done]


@jit_no_refcount
def _collapse_loop(x, y, z, tri, alive, locked, quad, bn, head, nxt, work, q, cnt, out):
    dead, marks, ring, scratch, near, cost, goal = work
    gone, into, costs, n_tris = out
    for v in range(len(x)):
        if alive[v]:
            _update(v, x, y, z, tri, head, nxt, dead, quad, bn, locked, marks, cnt, ring, cost, scratch, goal, q, cnt)
    done = 0
    while done < len(gone) and cnt[HEAP_SIZE] > 0:
        v = q[0][0]
        u = goal[v]
        # the entry is recomputed whenever v's ring or u's quadric changes, but
        # a change of u's ring may break the link condition: check again
        cnt[1] += 1
        n_v = _ring(v, tri, head, nxt, dead, marks[0], cnt[1], near)
        cnt[2] += 1
        if not _valid(v, u, x, y, tri, head, nxt, dead, marks[0], cnt[1], marks[1], cnt[2], scratch):
            _update(v, x, y, z, tri, head, nxt, dead, quad, bn, locked, marks, cnt, ring, cost, scratch, goal, q, cnt)
            continue
        costs[done] = -q[2][0]
        heap_remove(v, q, cnt)
        # v's triangles take u; the ones that held both die
        c = head[v]
        tail = -1
        while c >= 0:
            t = c // 3
            if not dead[t]:
                if tri[t, 0] == u or tri[t, 1] == u or tri[t, 2] == u:
                    dead[t] = True
                    cnt[0] -= 1
                else:
                    tri[t, c % 3] = u
            tail = c
            c = nxt[c]
        if tail >= 0:
            nxt[tail] = head[u]
            head[u] = head[v]
        head[v] = -1
        for i in range(10):
            quad[u, i] += quad[v, i]
        if bn[v, 0] >= 0:  # the border now runs u - other
            other = bn[v, 0] if bn[v, 1] == u else bn[v, 1]
            for a, old, new in ((u, v, other), (other, v, u)):
                for s in range(2):
                    if bn[a, s] == old:
                        bn[a, s] = new
        alive[v] = False
        goal[v] = -1
        gone[done], into[done], n_tris[done] = v, u, cnt[0]
        done += 1
        # v's neighbours have new rings; u's other neighbours only a dearer way into u
        near[n_v] = u
        for i in range(n_v + 1):
            _update(near[i], x, y, z, tri, head, nxt, dead, quad, bn, locked, marks, cnt, ring, cost, scratch, goal, q, cnt)
        cnt[2] += 1
        n_u = _ring(u, tri, head, nxt, dead, marks[1], cnt[2], near)
        for i in range(n_u):
            w = near[i]
            if goal[w] == u:
                _update(w, x, y, z, tri, head, nxt, dead, quad, bn, locked, marks, cnt, ring, cost, scratch, goal, q, cnt)
    return done


@jit
def representatives(n, gone, into, k):
    """The vertex each of ``n`` vertices has become after the first ``k`` collapses."""
    rep = np.arange(n)
    for i in range(k - 1, -1, -1):
        rep[gone[i]] = rep[into[i]]
    return rep
