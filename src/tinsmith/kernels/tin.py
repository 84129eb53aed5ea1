"""Incremental triangulation on halfedges: point insertion, Lawson flips, constrained edges.

Buffer layout (capacity-sized arrays, the live part given by the counters):

- ``px, py`` float64 (V,): vertex coordinates (pixel space for the grid methods).
- ``tri`` int32 (3T,): vertex ids; triangle ``t`` is ``tri[3t:3t+3]``,
  counter-clockwise, i.e. ``orient2d > 0``.
- ``half`` int32 (3T,): halfedge ``e = 3t + k`` runs from ``tri[e]`` to
  ``tri[next(e)]``; ``half[e]`` is the opposite halfedge or -1 on the hull.
- ``cons`` uint8 (3T,): 1 when the edge of halfedge ``e`` is constrained (both
  halves carry the flag); Lawson flips never cross a constrained edge.
- ``dirty`` int32 (T,) with ``is_dirty`` uint8 (T,): every triangle written
  since the caller last emptied the list (its index in ``cnt[2]``), so callers
  that keep per-triangle data (greedy insertion) can refresh it.
- ``cnt`` int64 (3,): number of vertices, of triangles, of dirty triangles.

Triangle slots are reused: a split or a flip rewrites the triangles it
replaces, so every slot below ``cnt[1]`` is a live triangle.
"""

import numpy as np

from ._jit import jit
from .predicates import incircle, orient2d


@jit
def next_half(e):
    return e - e % 3 + (e + 1) % 3


@jit
def prev_half(e):
    return e - e % 3 + (e + 2) % 3


@jit
def _mark(t, dirty, is_dirty, cnt):
    if not is_dirty[t]:
        is_dirty[t] = 1
        dirty[cnt[2]] = t
        cnt[2] += 1


@jit
def _link(a, b, half):
    half[a] = b
    if b >= 0:
        half[b] = a


@jit
def set_triangle(t, a, b, c, tri, dirty, is_dirty, cnt):
    """Write the vertices of slot t (links are set by the caller) and mark it dirty."""
    tri[3 * t] = a
    tri[3 * t + 1] = b
    tri[3 * t + 2] = c
    _mark(t, dirty, is_dirty, cnt)


@jit
def legalize(a, px, py, tri, half, cons, dirty, is_dirty, cnt, stack):
    """Restore the Delaunay property around halfedge ``a`` by Lawson flips.

    ``a`` must be opposite the newly inserted vertex.  Returns the stack
    (grown when needed).
    """
    top = 0
    stack[top] = a
    top += 1
    while top > 0:
        top -= 1
        a = stack[top]
        b = half[a]
        if b < 0 or cons[a]:
            continue
        al = next_half(a)
        ar = prev_half(a)
        bl = prev_half(b)
        br = next_half(b)
        p0 = tri[ar]
        pr = tri[a]
        pl = tri[al]
        p1 = tri[bl]
        if incircle(px[p0], py[p0], px[pr], py[pr], px[pl], py[pl], px[p1], py[p1]) <= 0.0:
            continue
        # flip: (pr, pl, p0) + (pl, pr, p1) -> (p1, pl, p0) + (p0, pr, p1)
        hbl, har = half[bl], half[ar]
        cbl, car = cons[bl], cons[ar]
        tri[a] = p1
        tri[b] = p0
        _link(a, hbl, half)
        cons[a] = cbl
        _link(b, har, half)
        cons[b] = car
        _link(ar, bl, half)
        cons[ar] = 0
        cons[bl] = 0
        _mark(a // 3, dirty, is_dirty, cnt)
        _mark(b // 3, dirty, is_dirty, cnt)
        if top + 2 > len(stack):
            bigger = np.empty(2 * len(stack), dtype=stack.dtype)
            bigger[:top] = stack[:top]
            stack = bigger
        stack[top] = br
        stack[top + 1] = a
        top += 2
    return stack


@jit
def split_triangle(t, n, px, py, tri, half, cons, dirty, is_dirty, cnt, stack):
    """Insert vertex ``n`` strictly inside triangle ``t`` (3 triangles, 2 new slots)."""
    e0 = 3 * t
    p0, p1, p2 = tri[e0], tri[e0 + 1], tri[e0 + 2]
    h1, h2 = half[e0 + 1], half[e0 + 2]
    c1, c2 = cons[e0 + 1], cons[e0 + 2]
    t1 = cnt[1]
    t2 = t1 + 1
    cnt[1] += 2
    set_triangle(t, p0, p1, n, tri, dirty, is_dirty, cnt)
    set_triangle(t1, p1, p2, n, tri, dirty, is_dirty, cnt)
    set_triangle(t2, p2, p0, n, tri, dirty, is_dirty, cnt)
    # t keeps its edge 0 (p0 -> p1) and its link
    _link(3 * t1, h1, half)
    cons[3 * t1] = c1
    _link(3 * t2, h2, half)
    cons[3 * t2] = c2
    _link(3 * t + 1, 3 * t1 + 2, half)  # p1 -> n  /  n -> p1
    _link(3 * t1 + 1, 3 * t2 + 2, half)  # p2 -> n  /  n -> p2
    _link(3 * t2 + 1, 3 * t + 2, half)  # p0 -> n  /  n -> p0
    for e in (3 * t1 + 1, 3 * t1 + 2, 3 * t2 + 1, 3 * t2 + 2, 3 * t + 1, 3 * t + 2):
        cons[e] = 0
    stack = legalize(3 * t, px, py, tri, half, cons, dirty, is_dirty, cnt, stack)
    stack = legalize(3 * t1, px, py, tri, half, cons, dirty, is_dirty, cnt, stack)
    stack = legalize(3 * t2, px, py, tri, half, cons, dirty, is_dirty, cnt, stack)
    return stack


@jit
def split_edge(a, n, px, py, tri, half, cons, dirty, is_dirty, cnt, stack):
    """Insert vertex ``n`` on the edge of halfedge ``a`` (strictly between its ends).

    Interior edge: 2 triangles become 4 (2 new slots); hull edge: 1 becomes 2.
    A constrained edge stays constrained in both halves.
    """
    b = half[a]
    c = cons[a]
    al = next_half(a)
    ar = prev_half(a)
    pr, pl, p0 = tri[a], tri[al], tri[ar]
    hal, har = half[al], half[ar]
    cal, car = cons[al], cons[ar]
    ta = a // 3
    if b < 0:
        t1 = cnt[1]
        cnt[1] += 1
        # (p0, pr, n) in slot ta, (pl, p0, n) in slot t1
        set_triangle(ta, p0, pr, n, tri, dirty, is_dirty, cnt)
        set_triangle(t1, pl, p0, n, tri, dirty, is_dirty, cnt)
        _link(3 * ta, har, half)
        cons[3 * ta] = car
        _link(3 * t1, hal, half)
        cons[3 * t1] = cal
        half[3 * ta + 1] = -1  # pr -> n on the hull
        cons[3 * ta + 1] = c
        half[3 * t1 + 2] = -1  # n -> pl on the hull
        cons[3 * t1 + 2] = c
        _link(3 * ta + 2, 3 * t1 + 1, half)  # n -> p0 / p0 -> n
        cons[3 * ta + 2] = 0
        cons[3 * t1 + 1] = 0
        stack = legalize(3 * ta, px, py, tri, half, cons, dirty, is_dirty, cnt, stack)
        stack = legalize(3 * t1, px, py, tri, half, cons, dirty, is_dirty, cnt, stack)
        return stack
    bl = prev_half(b)
    br = next_half(b)
    p1 = tri[bl]
    hbl, hbr = half[bl], half[br]
    cbl, cbr = cons[bl], cons[br]
    tb = b // 3
    t2 = cnt[1]
    t3 = t2 + 1
    cnt[1] += 2
    # (p0, pr, n) ta, (pr, p1, n) tb, (p1, pl, n) t2, (pl, p0, n) t3
    set_triangle(ta, p0, pr, n, tri, dirty, is_dirty, cnt)
    set_triangle(tb, pr, p1, n, tri, dirty, is_dirty, cnt)
    set_triangle(t2, p1, pl, n, tri, dirty, is_dirty, cnt)
    set_triangle(t3, pl, p0, n, tri, dirty, is_dirty, cnt)
    _link(3 * ta, har, half)
    cons[3 * ta] = car
    _link(3 * tb, hbr, half)
    cons[3 * tb] = cbr
    _link(3 * t2, hbl, half)
    cons[3 * t2] = cbl
    _link(3 * t3, hal, half)
    cons[3 * t3] = cal
    _link(3 * ta + 1, 3 * tb + 2, half)  # pr -> n / n -> pr   (old edge, first half)
    _link(3 * tb + 1, 3 * t2 + 2, half)  # p1 -> n / n -> p1
    _link(3 * t2 + 1, 3 * t3 + 2, half)  # pl -> n / n -> pl   (old edge, second half)
    _link(3 * t3 + 1, 3 * ta + 2, half)  # p0 -> n / n -> p0
    cons[3 * ta + 1] = c
    cons[3 * tb + 2] = c
    cons[3 * t2 + 1] = c
    cons[3 * t3 + 2] = c
    cons[3 * tb + 1] = 0
    cons[3 * t2 + 2] = 0
    cons[3 * t3 + 1] = 0
    cons[3 * ta + 2] = 0
    for e in (3 * ta, 3 * tb, 3 * t2, 3 * t3):
        stack = legalize(e, px, py, tri, half, cons, dirty, is_dirty, cnt, stack)
    return stack


@jit
def insert_in_triangle(t, n, px, py, tri, half, cons, dirty, is_dirty, cnt, stack):
    """Insert vertex ``n``, known to lie in the closed triangle ``t`` and not on a vertex."""
    x, y = px[n], py[n]
    for k in range(3):
        e = 3 * t + k
        a = tri[e]
        b = tri[next_half(e)]
        if orient2d(px[a], py[a], px[b], py[b], x, y) == 0.0:
            return split_edge(e, n, px, py, tri, half, cons, dirty, is_dirty, cnt, stack)
    return split_triangle(t, n, px, py, tri, half, cons, dirty, is_dirty, cnt, stack)
