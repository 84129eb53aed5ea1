"""Incremental constrained Delaunay triangulation on halfedges.

Point insertion (inside a triangle or on an edge), Lawson flips, point
location by walking, and constrained segments inserted by flips (Sloan 1993)
then re-Delaunayed; every decision is made with the robust predicates of
:mod:`.predicates`.

Buffer layout: the triangulation is the tuple ``m`` =
``(px, py, tri, half, cons, vedge, region, dirty, is_dirty, cnt)`` of
capacity-sized arrays, the live part given by the counters:

- ``px, py`` float64 (V,): vertex coordinates (pixel space for grid methods).
- ``tri`` int32 (3T,): vertex ids; triangle ``t`` is ``tri[3t:3t+3]``,
  counter-clockwise (``orient2d > 0``).
- ``half`` int32 (3T,): halfedge ``e = 3t + k`` runs from ``tri[e]`` to
  ``tri[next(e)]``; ``half[e]`` is the opposite halfedge, -1 on the hull.
- ``cons`` uint8 (3T,): 1 on both halves of a constrained edge; no flip ever
  crosses one.
- ``vedge`` int32 (V,): one halfedge leaving each vertex.
- ``region`` uint8 (T,): a label carried by the triangles (1 = outside the
  data); children of a split inherit it, flips never change it.
- ``dirty`` int32 (T,) with ``is_dirty`` uint8 (T,): triangles written since
  the caller last emptied the list (its length is ``cnt[2]``).
- ``cnt`` int64 (>= 3,): number of vertices, of triangles, of dirty triangles.

Triangle slots are reused: a split or a flip rewrites the triangles it
replaces, so every slot below ``cnt[1]`` is a live triangle.
"""

import numpy as np

from ._jit import jit, jit_inline, jit_no_refcount_unchecked
from .predicates import incircle_inline, incircle_perturbed, incircle_small_ints, orient2d, orient2d_small_ints

#: Return codes of :func:`insert_segment`.
SEGMENT_OK, SEGMENT_CROSSES_CONSTRAINT = 0, 1
#: The ``small_ints`` mode of the in-circle tests that breaks their ties by symbolic perturbation
#: (:func:`.predicates.incircle_perturbed`): the Delaunay triangulation becomes unique.
PERTURBED = 2


@jit
def next_half(e):
    return e - e % 3 + (e + 1) % 3


@jit
def prev_half(e):
    return e - e % 3 + (e + 2) % 3


@jit
def _mark(m, t):
    dirty, is_dirty, cnt = m[7], m[8], m[9]
    if not is_dirty[t]:
        is_dirty[t] = 1
        dirty[cnt[2]] = t
        cnt[2] += 1


@jit
def _link(half, a, b):
    half[a] = b
    if b >= 0:
        half[b] = a


@jit
def set_triangle(m, t, a, b, c):
    """Write the vertices of slot t (links are set by the caller) and mark it dirty."""
    tri, vedge = m[2], m[5]
    tri[3 * t] = a
    tri[3 * t + 1] = b
    tri[3 * t + 2] = c
    vedge[a] = 3 * t
    vedge[b] = 3 * t + 1
    vedge[c] = 3 * t + 2
    _mark(m, t)


@jit_inline
def flip(m, a):
    """Flip the edge of halfedge ``a`` (interior, unconstrained).

    (pr, pl, p0) + (pl, pr, p1) become (p1, pl, p0) + (p0, pr, p1); the new
    diagonal p0-p1 is halfedge ``prev(a)`` (and its twin).
    """
    tri, half, cons, vedge = m[2], m[3], m[4], m[5]
    b = half[a]
    al, ar = next_half(a), prev_half(a)
    bl, br = prev_half(b), next_half(b)
    p0, pr, pl, p1 = tri[ar], tri[a], tri[al], tri[bl]
    hbl, har = half[bl], half[ar]
    cbl, car = cons[bl], cons[ar]
    tri[a] = p1
    tri[b] = p0
    _link(half, a, hbl)
    cons[a] = cbl
    _link(half, b, har)
    cons[b] = car
    _link(half, ar, bl)
    cons[ar] = 0
    cons[bl] = 0
    vedge[p1] = a
    vedge[p0] = b
    vedge[pr] = br
    vedge[pl] = al
    _mark(m, a // 3)
    _mark(m, b // 3)


@jit_inline
def _push(stack, top, value):
    if top >= len(stack):
        bigger = np.empty(2 * len(stack), dtype=stack.dtype)
        bigger[:top] = stack[:top]
        stack = bigger
    stack[top] = value
    return stack, top + 1


@jit
def _put(stack, top, value):
    """Push onto a legalisation stack that :func:`reserve` sized (no allocation); return the new top."""
    if top >= len(stack):  # pragma: no cover - reserve's bound holds
        raise IndexError("legalisation stack overflow: call reserve() before inserting")
    stack[top] = value
    return top + 1


@jit
def reserve(stack, n_triangles):
    """A legalisation stack deep enough for one insertion into a triangulation of ``n_triangles``.

    The insertion path allocates nothing (so that greedy insertion can run
    without reference counting): its stack must be sized first.  One
    insertion pushes the halfedges opposite the new vertex (at most one per
    new triangle) and two per flip, popping one per test; a flip replaces an
    edge the new vertex does not touch by one it does, so there are fewer
    flips than edges (3/2 per triangle, plus the hull).  Point insertion
    outside the hull may double the triangles, so 6 per triangle bounds
    every case.
    """
    need = 6 * n_triangles + 64
    if len(stack) >= need:
        return stack
    return np.empty(max(need, 2 * len(stack)), dtype=stack.dtype)


@jit_inline
def _illegal(m, a, small_ints):
    """True when the unconstrained interior edge ``a`` fails the in-circle test.

    ``small_ints`` (a constant at most calls): True (1) when every vertex is a
    grid point of a grid at most 4097 points a side, where the plain in-circle
    evaluation is exact (:func:`.predicates.incircle_small_ints`);
    :data:`PERTURBED` to break the ties of cocircular points by symbolic
    perturbation (:func:`.predicates.incircle_perturbed`); False otherwise
    (a cocircular edge is left as it is).
    """
    px, py, tri, half, cons = m[0], m[1], m[2], m[3], m[4]
    b = half[a]
    if b < 0 or cons[a]:
        return False
    p0, pr, pl, p1 = tri[prev_half(a)], tri[a], tri[next_half(a)], tri[prev_half(b)]
    if small_ints == PERTURBED:
        return incircle_perturbed(px[p0], py[p0], px[pr], py[pr], px[pl], py[pl], px[p1], py[p1]) > 0.0
    if small_ints == 1:
        return incircle_small_ints(px[p0], py[p0], px[pr], py[pr], px[pl], py[pl], px[p1], py[p1]) > 0.0
    return incircle_inline(px[p0], py[p0], px[pr], py[pr], px[pl], py[pl], px[p1], py[p1]) > 0.0


@jit_inline
def legalize(m, stack, top, small_ints):
    """Lawson flips for the halfedges ``stack[:top]``, each opposite a newly inserted vertex.

    The last one pushed is legalised first, with every edge its flips
    uncover, before the next: a caller pushes its edges in reverse order.
    The stack comes from :func:`reserve`; ``small_ints`` as in :func:`_illegal`.
    """
    while top > 0:
        top -= 1
        a = stack[top]
        if not _illegal(m, a, small_ints):
            continue
        br = next_half(m[3][a])
        flip(m, a)
        top = _put(stack, top, br)
        top = _put(stack, top, a)


@jit_inline
def split_triangle(m, t, n, stack):
    """Insert vertex ``n`` strictly inside triangle ``t`` (3 triangles, 2 new slots).

    Returns the top of ``stack``, which holds the edges to legalise (:func:`legalize`).
    """
    tri, half, cons, region, cnt = m[2], m[3], m[4], m[6], m[9]
    e0 = 3 * t
    p0, p1, p2 = tri[e0], tri[e0 + 1], tri[e0 + 2]
    h1, h2 = half[e0 + 1], half[e0 + 2]
    c1, c2 = cons[e0 + 1], cons[e0 + 2]
    t1 = cnt[1]
    t2 = t1 + 1
    cnt[1] += 2
    region[t1] = region[t]
    region[t2] = region[t]
    set_triangle(m, t, p0, p1, n)
    set_triangle(m, t1, p1, p2, n)
    set_triangle(m, t2, p2, p0, n)
    # t keeps its edge p0 -> p1 and its link
    _link(half, 3 * t1, h1)
    cons[3 * t1] = c1
    _link(half, 3 * t2, h2)
    cons[3 * t2] = c2
    _link(half, 3 * t + 1, 3 * t1 + 2)  # p1 -> n  /  n -> p1
    _link(half, 3 * t1 + 1, 3 * t2 + 2)  # p2 -> n  /  n -> p2
    _link(half, 3 * t2 + 1, 3 * t + 2)  # p0 -> n  /  n -> p0
    for e in (3 * t1 + 1, 3 * t1 + 2, 3 * t2 + 1, 3 * t2 + 2, 3 * t + 1, 3 * t + 2):
        cons[e] = 0
    return _put(stack, _put(stack, _put(stack, 0, 3 * t2), 3 * t1), 3 * t)


@jit_inline
def split_edge(m, a, n, stack):
    """Insert vertex ``n`` on the edge of halfedge ``a`` (strictly between its ends).

    Interior edge: 2 triangles become 4 (2 new slots); hull edge: 1 becomes 2.
    A constrained edge stays constrained in both halves; each side keeps its region.
    Returns the top of ``stack``, which holds the edges to legalise (:func:`legalize`).
    """
    tri, half, cons, region, cnt = m[2], m[3], m[4], m[6], m[9]
    b = half[a]
    c = cons[a]
    al, ar = next_half(a), prev_half(a)
    pr, pl, p0 = tri[a], tri[al], tri[ar]
    hal, har = half[al], half[ar]
    cal, car = cons[al], cons[ar]
    ta = a // 3
    if b < 0:
        t1 = cnt[1]
        cnt[1] += 1
        region[t1] = region[ta]
        set_triangle(m, ta, p0, pr, n)
        set_triangle(m, t1, pl, p0, n)
        _link(half, 3 * ta, har)
        cons[3 * ta] = car
        _link(half, 3 * t1, hal)
        cons[3 * t1] = cal
        half[3 * ta + 1] = -1  # pr -> n on the hull
        cons[3 * ta + 1] = c
        half[3 * t1 + 2] = -1  # n -> pl on the hull
        cons[3 * t1 + 2] = c
        _link(half, 3 * ta + 2, 3 * t1 + 1)  # n -> p0 / p0 -> n
        cons[3 * ta + 2] = 0
        cons[3 * t1 + 1] = 0
        return _put(stack, _put(stack, 0, 3 * t1), 3 * ta)
    bl, br = prev_half(b), next_half(b)
    p1 = tri[bl]
    hbl, hbr = half[bl], half[br]
    cbl, cbr = cons[bl], cons[br]
    tb = b // 3
    t2 = cnt[1]
    t3 = t2 + 1
    cnt[1] += 2
    region[t2] = region[tb]
    region[t3] = region[ta]
    # (p0, pr, n) ta, (pr, p1, n) tb, (p1, pl, n) t2, (pl, p0, n) t3
    set_triangle(m, ta, p0, pr, n)
    set_triangle(m, tb, pr, p1, n)
    set_triangle(m, t2, p1, pl, n)
    set_triangle(m, t3, pl, p0, n)
    _link(half, 3 * ta, har)
    cons[3 * ta] = car
    _link(half, 3 * tb, hbr)
    cons[3 * tb] = cbr
    _link(half, 3 * t2, hbl)
    cons[3 * t2] = cbl
    _link(half, 3 * t3, hal)
    cons[3 * t3] = cal
    _link(half, 3 * ta + 1, 3 * tb + 2)  # pr -> n / n -> pr   (old edge, first half)
    _link(half, 3 * tb + 1, 3 * t2 + 2)  # p1 -> n / n -> p1
    _link(half, 3 * t2 + 1, 3 * t3 + 2)  # pl -> n / n -> pl   (old edge, second half)
    _link(half, 3 * t3 + 1, 3 * ta + 2)  # p0 -> n / n -> p0
    cons[3 * ta + 1] = c
    cons[3 * tb + 2] = c
    cons[3 * t2 + 1] = c
    cons[3 * t3 + 2] = c
    cons[3 * tb + 1] = 0
    cons[3 * t2 + 2] = 0
    cons[3 * t3 + 1] = 0
    cons[3 * ta + 2] = 0
    return _put(stack, _put(stack, _put(stack, _put(stack, 0, 3 * t3), 3 * t2), 3 * tb), 3 * ta)


@jit_inline
def insert_in_triangle(m, t, n, stack, small_ints):
    """Insert vertex ``n``, known to lie in the closed triangle ``t`` and not on a vertex.

    ``small_ints`` as in :func:`_illegal` (a constant False but for greedy insertion on a grid).
    """
    px, py, tri = m[0], m[1], m[2]
    x, y = px[n], py[n]
    top = -1
    for k in range(3):
        e = 3 * t + k
        a = tri[e]
        b = tri[next_half(e)]
        if small_ints == 1:
            on_edge = orient2d_small_ints(px[a], py[a], px[b], py[b], x, y) == 0.0
        else:
            on_edge = orient2d(px[a], py[a], px[b], py[b], x, y) == 0.0
        if on_edge:
            top = split_edge(m, e, n, stack)
            break
    if top < 0:
        top = split_triangle(m, t, n, stack)
    # one legalisation loop for every kind of split: inlined once, not three times
    legalize(m, stack, top, small_ints)
    return stack


@jit
def link(m, n_tri):
    """``half`` and ``vedge`` of triangles ``0 .. n_tri - 1`` (``tri`` and ``cnt[0]`` set): each halfedge a -> b
    joined with b -> a, -1 where there is none (the hull)."""
    tri, half, vedge, cnt = m[2], m[3], m[5], m[9]
    n = cnt[0]
    start = np.zeros(n + 1, np.int64)
    for e in range(3 * n_tri):
        start[tri[e] + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    leaving = np.empty(3 * n_tri, np.int64)
    fill = start[:-1].copy()
    for e in range(3 * n_tri):
        a = tri[e]
        leaving[fill[a]] = e
        fill[a] += 1
        vedge[a] = e
    for e in range(3 * n_tri):
        a, b = tri[e], tri[next_half(e)]
        half[e] = -1
        for s in range(start[b], start[b + 1]):
            f = leaving[s]
            if tri[next_half(f)] == a:
                half[e] = f
                break


# -- point location and general insertion ---------------------------------------------------------
@jit
def locate(m, x, y, t, segments=False):
    """A triangle whose closure holds (x, y), walking from triangle ``t``.

    Outside the hull the result is ``-2 - e`` for a hull halfedge ``e`` that
    sees the point; with ``segments`` the walk stops as well at a
    constrained edge in its way (``-2 - e`` for that edge).

    A visibility walk that starts its edge tests at a rotating offset, which
    keeps it from cycling in constrained (non-Delaunay) triangulations.
    """
    px, py, tri, half, cnt = m[0], m[1], m[2], m[3], m[9]
    for turn in range(4 * cnt[1] + 16):
        moved = False
        for j in range(3):
            e = 3 * t + (j + turn) % 3
            a, b = tri[e], tri[next_half(e)]
            if orient2d(px[a], py[a], px[b], py[b], x, y) < 0.0:
                h = half[e]
                if h < 0 or (segments and m[4][e]):
                    return -2 - e
                t = h // 3
                moved = True
                break
        if not moved:
            return t
    return -1  # pragma: no cover - the walk ends on every valid triangulation


@jit
def insert_point(m, x, y, t, stack):
    """Insert (x, y) unless a vertex is already there; return (vertex id, stack).

    ``t`` is where the walk starts.  The caller guarantees vertex capacity and
    two free triangle slots; (x, y) must lie inside the hull (else -1).
    """
    px, py, tri, cnt = m[0], m[1], m[2], m[9]
    t = locate(m, x, y, t)
    if t < 0:
        return -1, stack
    for k in range(3):
        v = tri[3 * t + k]
        if px[v] == x and py[v] == y:
            return v, stack
    n = cnt[0]
    px[n] = x
    py[n] = y
    cnt[0] += 1
    stack = insert_in_triangle(m, t, n, reserve(stack, cnt[1]), False)
    return n, stack


# -- constrained segments ---------------------------------------------------------------------------
@jit
def find_edge(m, a, b):
    """A halfedge between a and b (a -> b, or b -> a on the hull), or -1 when they are not joined."""
    tri, half, vedge = m[2], m[3], m[5]
    start = vedge[a]
    e = start
    # clockwise around a until the hull or back at the start, then counter-clockwise
    while True:
        if tri[next_half(e)] == b:
            return e
        if tri[prev_half(e)] == b:
            return prev_half(e)
        h = half[e]
        if h < 0:
            break
        e = next_half(h)
        if e == start:
            return -1
    e = start
    while True:
        h = half[prev_half(e)]
        if h < 0:
            return -1
        e = h
        if tri[next_half(e)] == b:
            return e
        if tri[prev_half(e)] == b:
            return prev_half(e)
        if e == start:
            return -1


@jit
def _constrain(m, e):
    cons, half = m[4], m[3]
    cons[e] = 1
    if half[e] >= 0:
        cons[half[e]] = 1


@jit
def _first_crossing(m, a, b):
    """Where segment a-b leaves a: (kind, value).

    kind 0: the edge a-b exists (value: halfedge a -> b); kind 1: a vertex on the
    open segment (value: vertex id); kind 2: the segment crosses halfedge ``value``.
    """
    px, py, tri, half, vedge = m[0], m[1], m[2], m[3], m[5]
    ax, ay, bx, by = px[a], py[a], px[b], py[b]
    # rewind clockwise to the hull (or all the way round) so the sweep sees every wedge
    start = vedge[a]
    e = start
    while True:
        h = half[e]
        if h < 0:
            break
        e = next_half(h)
        if e == start:
            break
    first = e
    while True:
        x = tri[next_half(e)]
        y = tri[prev_half(e)]
        if x == b:
            return 0, e
        ox = orient2d(ax, ay, bx, by, px[x], py[x])
        if ox == 0.0 and (px[x] - ax) * (bx - ax) + (py[x] - ay) * (by - ay) > 0.0:
            return 1, x
        oy = orient2d(ax, ay, bx, by, px[y], py[y])
        if ox < 0.0 and oy > 0.0:
            return 2, next_half(e)
        h = half[prev_half(e)]
        if h < 0 or h == first:
            break
        e = h
    # the last wedge's far edge (a -> y) on the hull side
    y = tri[prev_half(e)]
    if y == b:
        return 0, prev_half(e)
    return 1, y


@jit
def insert_segment(m, a, b, stack, work):
    """Make a-b a constrained edge, splitting it at vertices that lie on it.

    Crossed edges are removed by flips (Sloan 1993), then the Delaunay
    property is restored around the new edges.  Returns (code, stack, work):
    ``SEGMENT_CROSSES_CONSTRAINT`` when a-b crosses another constrained edge
    (nothing of that piece is changed).
    """
    px, py, tri, half, cons = m[0], m[1], m[2], m[3], m[4]
    while a != b:
        kind, value = _first_crossing(m, a, b)
        if kind == 0:
            _constrain(m, value)
            return SEGMENT_OK, stack, work
        if kind == 1:
            e = find_edge(m, a, value)
            _constrain(m, e)
            a = value
            continue
        # walk the crossed edges, stopping at b or at a vertex on the segment
        ax, ay, bx, by = px[a], py[a], px[b], py[b]
        top = 0
        e = value
        end = b
        while True:
            if cons[e]:
                return SEGMENT_CROSSES_CONSTRAINT, stack, work
            work, top = _push(work, top, tri[e])
            work, top = _push(work, top, tri[next_half(e)])
            h = half[e]
            v = tri[prev_half(h)]
            if v == b:
                break
            o = orient2d(ax, ay, bx, by, px[v], py[v])
            if o == 0.0:
                end = v
                break
            e = next_half(h) if o > 0.0 else prev_half(h)
        fresh, nf = _flip_out(m, a, end, work, top)
        _constrain(m, find_edge(m, a, end))
        stack = _restore(m, fresh, nf, stack)
        a = end
    return SEGMENT_OK, stack, work


@jit
def _crosses(m, a, b, p, q):
    """True when segment p-q crosses the line through a-b strictly (p, q on opposite sides)."""
    px, py = m[0], m[1]
    op = orient2d(px[a], py[a], px[b], py[b], px[p], py[p])
    oq = orient2d(px[a], py[a], px[b], py[b], px[q], py[q])
    return (op > 0.0 and oq < 0.0) or (op < 0.0 and oq > 0.0)


@jit
def _flip_out(m, a, b, work, n):
    """Flip away the edges (vertex pairs in work[:n]) that cross a-b (Sloan 1993).

    Returns the new edges that do not cross a-b, as vertex pairs (array, length).
    """
    tri, half = m[2], m[3]
    queue = work[:n].copy()
    head = 0
    tail = n
    fresh = np.empty(16, dtype=np.int32)
    nf = 0
    while head < tail:
        p, q = queue[head], queue[head + 1]
        head += 2
        e = find_edge(m, p, q)
        r = tri[prev_half(e)]
        s = tri[prev_half(half[e])]
        convex = _crosses(m, r, s, p, q)
        if convex:
            flip(m, e)
            if _crosses(m, a, b, r, s):
                queue, tail = _append2(queue, tail, r, s)
            else:
                fresh, nf = _push(fresh, nf, r)
                fresh, nf = _push(fresh, nf, s)
        else:
            queue, tail = _append2(queue, tail, p, q)
        if head > 2 * n and head * 2 > tail:  # compact the queue now and then
            queue = queue[head:tail].copy()
            tail -= head
            head = 0
    return fresh, nf


@jit
def _append2(queue, tail, p, q):
    queue, tail = _push(queue, tail, p)
    return _push(queue, tail, q)


@jit
def _restore(m, pairs, n, stack):
    """Lawson flips over the edges given as vertex pairs until all are locally Delaunay."""
    tri, half = m[2], m[3]
    top = 0
    for i in range(n):
        stack, top = _push(stack, top, pairs[i])
    while top >= 2:
        q = stack[top - 1]
        p = stack[top - 2]
        top -= 2
        e = find_edge(m, p, q)
        if e < 0 or not _illegal(m, e, False):
            continue
        b = half[e]
        outer = (tri[next_half(e)], tri[prev_half(e)], tri[prev_half(e)], tri[e],
                 tri[next_half(b)], tri[prev_half(b)], tri[prev_half(b)], tri[b])
        flip(m, e)
        for v in outer:
            stack, top = _push(stack, top, v)
    return stack


@jit
def label_components(m):
    """Label the triangles by the regions that constrained edges (and the hull) enclose.

    Returns an int32 (T,) array of component numbers 0, 1, ... in order of
    their first triangle.
    """
    half, cons, cnt = m[3], m[4], m[9]
    n = cnt[1]
    label = np.full(n, -1, dtype=np.int32)
    queue = np.empty(n, dtype=np.int32)
    count = 0
    for seed in range(n):
        if label[seed] >= 0:
            continue
        label[seed] = count
        head, tail = 0, 1
        queue[0] = seed
        while head < tail:
            t = queue[head]
            head += 1
            for k in range(3):
                e = 3 * t + k
                h = half[e]
                if h >= 0 and not cons[e] and label[h // 3] < 0:
                    label[h // 3] = count
                    queue[tail] = h // 3
                    tail += 1
        count += 1
    return label


# -- points outside the hull ----------------------------------------------------------------------
@jit
def _hull_next(m, e):
    """The hull halfedge that starts where hull halfedge ``e`` ends."""
    half = m[3]
    f = next_half(e)
    while half[f] >= 0:
        f = next_half(half[f])
    return f


@jit
def _hull_prev(m, e):
    """The hull halfedge that ends where hull halfedge ``e`` starts."""
    half = m[3]
    f = prev_half(e)
    while half[f] >= 0:
        f = prev_half(half[f])
    return f


@jit
def _visible(m, e, x, y):
    px, py, tri = m[0], m[1], m[2]
    a, b = tri[e], tri[next_half(e)]
    return orient2d(px[a], py[a], px[b], py[b], x, y) < 0.0


@jit
def insert_outside(m, n, e, stack, ties=False):
    """Insert vertex ``n``, strictly outside the hull, joining it to every visible hull edge.

    ``e`` is a hull halfedge that sees ``n`` (as :func:`locate` reports it);
    ``ties`` is the in-circle mode of :func:`_illegal` (False or :data:`PERTURBED`).
    """
    px, py, tri, half, cons, region, cnt = m[0], m[1], m[2], m[3], m[4], m[6], m[9]
    x, y = px[n], py[n]
    # back to the first edge of the visible chain
    while True:
        p = _hull_prev(m, e)
        if p == e or not _visible(m, p, x, y):
            break
        e = p
    first_new = cnt[1]
    prev_tri = -1
    while True:
        nxt = _hull_next(m, e)
        a, b = tri[e], tri[next_half(e)]
        t = cnt[1]
        cnt[1] += 1
        region[t] = 0
        set_triangle(m, t, b, a, n)  # counter-clockwise: n lies right of a -> b
        _link(half, 3 * t, e)  # b -> a is the twin of a -> b
        cons[3 * t] = cons[e]
        half[3 * t + 1] = -1  # a -> n
        cons[3 * t + 1] = 0
        half[3 * t + 2] = -1  # n -> b
        cons[3 * t + 2] = 0
        if prev_tri >= 0:
            # this triangle's a -> n is the twin of the previous one's n -> b (its b is this a)
            _link(half, 3 * t + 1, 3 * prev_tri + 2)
        prev_tri = t
        if nxt == e or not _visible(m, nxt, x, y):
            break
        e = nxt
    top = 0
    for t in range(cnt[1] - 1, first_new - 1, -1):
        top = _put(stack, top, 3 * t)
    legalize(m, stack, top, ties)
    return stack


@jit
def morton_keys(pts, bits):
    """(N,) uint64 Z-order keys of (N, 2) points on a 2**bits x 2**bits lattice (bits <= 16) over their bounding box."""
    n = len(pts)
    keys = np.empty(n, np.uint64)
    if n == 0:
        return keys
    x0, y0, x1, y1 = pts[0, 0], pts[0, 1], pts[0, 0], pts[0, 1]
    for i in range(n):
        x0, x1 = min(x0, pts[i, 0]), max(x1, pts[i, 0])
        y0, y1 = min(y0, pts[i, 1]), max(y1, pts[i, 1])
    top = float(2**bits - 1)
    sx = top / max(x1 - x0, 1e-300)
    sy = top / max(y1 - y0, 1e-300)
    for i in range(n):
        key = np.uint64(0)
        for axis in range(2):
            v = (pts[i, 0] - x0) * sx if axis == 0 else (pts[i, 1] - y0) * sy
            q = np.uint64(min(max(v, 0.0), top))
            q = (q | (q << np.uint64(8))) & np.uint64(0x00FF00FF)
            q = (q | (q << np.uint64(4))) & np.uint64(0x0F0F0F0F)
            q = (q | (q << np.uint64(2))) & np.uint64(0x33333333)
            q = (q | (q << np.uint64(1))) & np.uint64(0x55555555)
            key |= q << np.uint64(axis)
        keys[i] = key
    return keys


#: numpy's ``np.random.default_rng(0)``: its PCG64 generator's 128-bit state and increment as high and low 64-bit
#: halves (``np.random.PCG64(0).state``, tested), and PCG's 128-bit multiplier.
PCG64_SEED0 = (1919014152682489133, 673392287158723043, 4723672219303484034, 6377435431028945833)
PCG_MULTIPLIER = (2549297995355413924, 4865540595714422341)


@jit_inline
def _mul_high(a, b):
    """The high 64 bits of the 128-bit product of the uint64 ``a`` and ``b`` (from 32-bit halves)."""
    low, s = np.uint64(0xFFFFFFFF), np.uint64(32)
    a0, a1, b0, b1 = a & low, a >> s, b & low, b >> s
    p00, p01, p10 = a0 * b0, a0 * b1, a1 * b0
    middle = (p00 >> s) + (p01 & low) + (p10 & low)
    return a1 * b1 + (p01 >> s) + (p10 >> s) + (middle >> s)


@jit
def seeded_permutation(n):
    """``np.random.default_rng(0).permutation(n)``, the same values, without importing ``numpy.random``.

    That import is 6 ms of a fresh process's first TIN (numba's import made
    it before the TIN was compiled ahead of time).  numpy's algorithm
    (``Generator.shuffle``): a Fisher-Yates shuffle of ``arange(n)`` from the
    top, each index drawn in ``[0, i]`` by masked rejection
    (``random_interval``) from the generator's 32-bit halves (64-bit draws
    above 2**32 - 1); PCG64 steps its 128-bit state by ``state * multiplier +
    increment`` and outputs the xor of its halves rotated by its top 6 bits.
    """
    sh, sl, ih, il = (np.uint64(PCG64_SEED0[0]), np.uint64(PCG64_SEED0[1]), np.uint64(PCG64_SEED0[2]),
                      np.uint64(PCG64_SEED0[3]))
    mh, ml = np.uint64(PCG_MULTIPLIER[0]), np.uint64(PCG_MULTIPLIER[1])
    low32, s32, s58, m63 = np.uint64(0xFFFFFFFF), np.uint64(32), np.uint64(58), np.uint64(63)
    one, zero = np.uint64(1), np.uint64(0)
    out = np.arange(n)
    buffered, has_buffered = zero, False
    for i in range(n - 1, 0, -1):
        top = np.uint64(i)
        mask = top
        for shift in (1, 2, 4, 8, 16, 32):
            mask |= mask >> np.uint64(shift)
        while True:
            if top <= low32 and has_buffered:
                value, has_buffered = buffered, False
            else:
                lo = sl * ml  # the 128-bit step, modulo 2**128
                hi = sh * ml + sl * mh + _mul_high(sl, ml)
                sl = lo + il
                sh = hi + ih + (one if sl < lo else zero)
                x, rot = sh ^ sl, sh >> s58
                value = (x >> rot) | (x << ((np.uint64(64) - rot) & m63))
                if top <= low32:
                    buffered, has_buffered = value >> s32, True
                    value &= low32
            value &= mask
            if value <= top:
                break
        j = np.int64(value)
        out[i], out[j] = out[j], out[i]
    return out


@jit
def brio_order(pts, perm, bounds, bits):
    """The insertion order of :func:`tinsmith.triangulation.delaunay._insertion_order`, in one call (the GIL
    released throughout: strips on threads order their points side by side).

    Point ``perm[i]`` for ``bounds[r] <= i < bounds[r + 1]`` is in round
    ``r``; the points are sorted by round, then by their Z-order key on a
    2**bits x 2**bits lattice (stable: ties keep their index order).
    """
    n = len(pts)
    keys = morton_keys(pts, bits)
    top = np.uint64(2 * bits)
    for r in range(len(bounds) - 1):
        high = np.uint64(r) << top
        for i in range(bounds[r], bounds[r + 1]):
            keys[perm[i]] |= high
    rounds = len(bounds) - 2  # the last round's number, whose bits the sort must cover
    width = 0
    while rounds >> width:
        width += 1
    return radix_argsort(keys, 2 * bits + width) if n else np.empty(0, np.int64)


@jit
def first_in_front(order, first):
    """Move the three vertices ``first`` (each once in ``order``) to its front, the others keeping their order,
    in place: what ``concatenate([first, order[not in first]])`` gives, without its copies."""
    w = len(order) - 1
    for i in range(len(order) - 1, -1, -1):
        v = order[i]
        if v != first[0] and v != first[1] and v != first[2]:
            order[w] = v
            w -= 1
    order[0], order[1], order[2] = first[0], first[1], first[2]


@jit
def radix_argsort(keys, bits):
    """Stable argsort of (N,) uint64 ``keys`` below 2**``bits``: LSD radix, 14 bits a pass (the same order on every machine)."""
    n = len(keys)
    order, other = np.arange(n, dtype=np.int64), np.empty(n, np.int64)
    k, k2 = keys.copy(), np.empty(n, np.uint64)
    count = np.empty(16385, np.int64)
    mask = np.uint64(16383)
    shift = 0
    while shift < bits:
        s = np.uint64(shift)
        count[:] = 0
        for i in range(n):
            count[((k[i] >> s) & mask) + 1] += 1
        for d in range(16384):
            count[d + 1] += count[d]
        for i in range(n):
            d = (k[i] >> s) & mask
            j = count[d]
            count[d] = j + 1
            other[j] = order[i]
            k2[j] = k[i]
        order, other = other, order
        k, k2 = k2, k
        shift += 14
    return order


@jit_no_refcount_unchecked
def triangulate(m, order, stack, same, ties):
    """Delaunay triangulation of the vertices ``order`` (already in px, py; cnt[0] set); returns 0.

    The first three non-collinear vertices of ``order`` start it (the caller
    puts them first); a duplicate of an earlier vertex gets the id of that
    vertex in ``same`` (the caller fills it with 0 .. V-1), every other vertex
    keeps its own.  ``stack`` comes from :func:`tinsmith.triangulation.delaunay.stack_for`; ``ties`` is the
    in-circle mode of :func:`_illegal`: with :data:`PERTURBED` the result is
    the unique Delaunay triangulation of the points, whatever ``order``.

    Compiled without reference counting (it allocates nothing): every array
    a numba function pulls out of the tuple ``m`` otherwise costs two atomic
    operations, which made this loop 2.6 times slower (Delft AHN3's 849k
    points: 1.49 s -> 0.58 s).
    """
    px, py, tri, half, vedge, cnt = m[0], m[1], m[2], m[3], m[5], m[9]
    a, b, c = order[0], order[1], order[2]
    if orient2d(px[a], py[a], px[b], py[b], px[c], py[c]) < 0.0:
        b, c = c, b
    cnt[1] = 1
    set_triangle(m, 0, a, b, c)
    half[0] = half[1] = half[2] = -1
    last = 0
    for i in range(3, len(order)):
        v = order[i]
        x, y = px[v], py[v]
        t = locate(m, x, y, last)
        if t < -1:
            insert_outside(m, v, -2 - t, stack, ties)
            last = vedge[v] // 3
            continue
        dup = -1
        for k in range(3):
            u = tri[3 * t + k]
            if px[u] == x and py[u] == y:
                dup = u
        if dup >= 0:
            same[v] = dup
            last = t
            continue
        insert_in_triangle(m, t, v, stack, ties)
        last = vedge[v] // 3
    return 0


@jit
def insert_points(m, xs, ys, stack):
    """Insert many points, each walk starting at the last insertion; return (ids, stack)."""
    ids = np.empty(len(xs), np.int64)
    start = 0
    for i in range(len(xs)):
        v, stack = insert_point(m, xs[i], ys[i], start, stack)
        ids[i] = v
        if v >= 0:
            start = m[5][v] // 3
    return ids, stack


@jit
def insert_segments(m, a, b, stack, work):
    """Insert the segments a[k]-b[k] in order; return (index of the first that crosses a constraint or -1, stack, work)."""
    for k in range(len(a)):
        code, stack, work = insert_segment(m, a[k], b[k], stack, work)
        if code != SEGMENT_OK:
            return k, stack, work
    return -1, stack, work
