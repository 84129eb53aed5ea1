"""Mesh optimisation after Delaunay refinement: vertices removed and moved while both bounds keep holding.

Delaunay refinement (:mod:`.quality`) puts a point wherever a triangle is
bad and never takes one back: around every small feature the error asks
for, it grades out from tiny triangles in rings, and many of its points end
up where a better-placed neighbour would have done their work.  Mesh
improvement after refinement takes them back, with two classic local
operations: vertex removal, the cavity filled by the rule of Devillers
1999, and Laplacian smoothing kept only where every bound still holds (a
constrained form of the "smart" Laplacian smoothing of mesh improvement,
Freitag and Ollivier-Gooch 1997, "Tetrahedral mesh improvement using
swapping and smoothing").  Every step is a local change that is kept only when
every triangle it makes passes the refinement's own tests:

- **removal** of a vertex: its star (the triangles round it) is
  re-triangulated by Delaunay ears (Devillers 1999, "On deletion in
  Delaunay triangulations": the ear whose circumcircle holds no other
  vertex of the star's outline is a Delaunay triangle of what remains);
- **smoothing** of a vertex: it moves to the centroid of its neighbours
  (Laplacian), or half way there, with the DEM's bilinear height at its
  new place (as every Steiner point).

The tests are the refinement's: the exact vertical error over the valid
cells each new triangle covers (:func:`.quality._scan`, the metrics'
expression), the size rules (largest area, regions, grading; for grading
the triangles across the star's outline as well), and the plan-view angle
bound, here with no exemption (a new triangle below the bound is refused,
whatever its size).  Every new edge must also be locally Delaunay, so the
triangulation stays a constrained Delaunay one.  Vertices on a segment
(outline, breakline, region boundary), on the hull, next to a triangle
outside the data, or ``fixed`` (control points) are never touched.

Passes run over the vertices in index order (so the result is
deterministic) until a pass removes no vertex or ``passes`` are done.
A removal frees two triangle slots, filled by the last triangles so that
every slot below ``cnt[1]`` stays live; the removed vertex keeps its slot
(``vedge`` -1) and is left out of the output.
"""

import numpy as np

from ._jit import jit, jit_inline
from .predicates import incircle, orient2d
from .quality import _assess, bilinear, smallest_angle
from .tin import _illegal, next_half, prev_half

#: The most neighbours a vertex may have to be moved or removed.
MAX_RING = 48
#: A move shorter than this share of the vertex's mean distance to its neighbours is not made, squared.
MIN_STEP2 = 0.02**2


@jit_inline
def _star(m, v, fixed, ring, spokes):
    """The neighbours of vertex ``v`` counter-clockwise into ``ring`` and the halfedges leaving ``v`` into
    ``spokes`` (``spokes[j]`` runs from ``v`` to ``ring[j]``; its triangle is ``v, ring[j], ring[j + 1]``).
    Returns their number, or -1 when ``v`` must stay (see the module notes)."""
    tri, half, cons, vedge, region = m[2], m[3], m[4], m[5], m[6]
    if fixed[v] or vedge[v] < 0:
        return -1
    start = vedge[v]
    e = start
    k = 0
    while True:
        if region[e // 3] or half[e] < 0 or cons[e] or k >= len(ring):
            return -1
        ring[k] = tri[next_half(e)]
        spokes[k] = e
        k += 1
        f = prev_half(e)  # ring[k] -> v; its twin leaves v towards the next neighbour
        if half[f] < 0 or cons[f]:
            return -1
        e = half[f]
        if e == start:
            return k


@jit_inline
def _triangles_ok(m, pz, g, prm, amap, fmap, lin, slots, n, segq):
    """True when the triangles ``slots[:n]`` pass every test of the module notes."""
    half, region = m[3], m[6]
    for i in range(n):
        t = slots[i]
        if smallest_angle(m, lin, t)[0] > prm[1]:  # no exemption, whatever the triangle's size
            return False
        if _assess(m, pz, g, prm, amap, fmap, lin, t, segq, len(segq))[0] > 0.0:
            return False
        for k in range(3):
            if _illegal(m, 3 * t + k, False):
                return False
    if prm[3] > 0.0:  # grading: the neighbours across the outline compare their area with the new triangles
        for i in range(n):
            t = slots[i]
            for k in range(3):
                o = half[3 * t + k]
                if o >= 0 and not region[o // 3] and _assess(m, pz, g, prm, amap, fmap, lin, o // 3, segq, len(segq))[0] > 0.0:
                    return False
    return True


@jit_inline
def _try_move(m, pz, g, prm, amap, fmap, lin, v, ring, spokes, k, slots, segq, share):
    """Move ``v`` ``share`` of the way to the centroid of its neighbours if the star stays good; True if moved."""
    px, py = m[0], m[1]
    zf, vf, all_valid, h, w = g
    cx = cy = 0.0
    for j in range(k):
        cx += px[ring[j]]
        cy += py[ring[j]]
    x0, y0, z0 = px[v], py[v], pz[v]
    x = x0 + share * (cx / k - x0)
    y = y0 + share * (cy / k - y0)
    spread = 0.0
    for j in range(k):
        spread += (px[ring[j]] - x0) ** 2 + (py[ring[j]] - y0) ** 2
    if (x - x0) ** 2 + (y - y0) ** 2 <= MIN_STEP2 * spread / k:
        return False
    for j in range(k):
        a, b = ring[j], ring[(j + 1) % k]
        if orient2d(x, y, px[a], py[a], px[b], py[b]) <= 0.0:
            return False
    z = bilinear(zf, vf, all_valid, h, w, x, y, np.nan)
    if not np.isfinite(z):
        return False
    px[v], py[v], pz[v] = x, y, z
    for j in range(k):
        slots[j] = spokes[j] // 3
    if _triangles_ok(m, pz, g, prm, amap, fmap, lin, slots, k, segq):
        return True
    px[v], py[v], pz[v] = x0, y0, z0
    return False


@jit_inline
def _ears(m, ring, k, poly, out):
    """Delaunay ears of the polygon ``ring[:k]`` (counter-clockwise) into ``out`` (k - 2 rows of three vertices);
    False when no ear is found (the polygon is not the star of a Delaunay vertex)."""
    px, py = m[0], m[1]
    for i in range(k):
        poly[i] = ring[i]
    n = k
    row = 0
    while n > 3:
        found = -1
        for i in range(n):
            a, b, c = poly[(i + n - 1) % n], poly[i], poly[(i + 1) % n]
            if orient2d(px[a], py[a], px[b], py[b], px[c], py[c]) <= 0.0:
                continue
            empty = True
            for j in range(n):
                d = poly[j]
                if d in (a, b, c):
                    continue
                if incircle(px[a], py[a], px[b], py[b], px[c], py[c], px[d], py[d]) > 0.0:
                    empty = False
                    break
            if empty:
                found = i
                break
        if found < 0:
            return False
        out[row, 0], out[row, 1], out[row, 2] = poly[(found + n - 1) % n], poly[found], poly[(found + 1) % n]
        row += 1
        for j in range(found, n - 1):
            poly[j] = poly[j + 1]
        n -= 1
    a, b, c = poly[0], poly[1], poly[2]
    if orient2d(px[a], py[a], px[b], py[b], px[c], py[c]) <= 0.0:
        return False
    out[row, 0], out[row, 1], out[row, 2] = a, b, c
    return True


@jit_inline
def _write_star(m, ring, k, outer, ocons, slots, rows, n_rows):
    """Write triangles ``rows[:n_rows]`` into ``slots``: each edge of the star's outline is linked to its saved
    outer twin ``outer`` (with its constraint flag ``ocons``), every other edge to its twin among the rows."""
    tri, half, cons, vedge, region = m[2], m[3], m[4], m[5], m[6]
    for i in range(n_rows):
        t = slots[i]
        region[t] = 0
        for c in range(3):
            tri[3 * t + c] = rows[i, c]
    for i in range(n_rows):
        t = slots[i]
        for c in range(3):
            e = 3 * t + c
            p, q = tri[e], tri[next_half(e)]
            vedge[p] = e
            linked = False
            for j in range(k):
                if ring[j] == p and ring[(j + 1) % k] == q:
                    half[e] = outer[j]
                    cons[e] = ocons[j]
                    if outer[j] >= 0:
                        half[outer[j]] = e
                    linked = True
                    break
            if linked:
                continue
            cons[e] = 0
            for i2 in range(n_rows):
                t2 = slots[i2]
                for c2 in range(3):
                    f = 3 * t2 + c2
                    if tri[f] == q and tri[next_half(f)] == p:
                        half[e] = f
                        half[f] = e


@jit_inline
def _move_slot(m, s, d):
    """Move triangle ``s`` into the free slot ``d``."""
    tri, half, cons, vedge, region = m[2], m[3], m[4], m[5], m[6]
    for c in range(3):
        tri[3 * d + c] = tri[3 * s + c]
        cons[3 * d + c] = cons[3 * s + c]
        o = half[3 * s + c]
        half[3 * d + c] = o
        if o >= 0:
            half[o] = 3 * d + c
        vedge[tri[3 * d + c]] = 3 * d + c
    region[d] = region[s]


@jit_inline
def _try_remove(m, pz, g, prm, amap, fmap, lin, v, ring, spokes, k, slots, segq, poly, rows, saved, outer, ocons):
    """Remove ``v`` if the re-triangulated star is good; True if removed."""
    tri, half, cons, vedge, cnt = m[2], m[3], m[4], m[5], m[9]
    if not _ears(m, ring, k, poly, rows):
        return False
    for j in range(k):
        t = spokes[j] // 3
        slots[j] = t
        for c in range(3):
            saved[j, c] = tri[3 * t + c]
            saved[j, 3 + c] = half[3 * t + c]
            saved[j, 6 + c] = cons[3 * t + c]
        f = next_half(spokes[j])  # ring[j] -> ring[j + 1], the star's outline
        outer[j] = half[f]
        ocons[j] = cons[f]
    _write_star(m, ring, k, outer, ocons, slots, rows, k - 2)
    if _triangles_ok(m, pz, g, prm, amap, fmap, lin, slots, k - 2, segq):
        vedge[v] = -1
        # free the last two slots of the star: the last live triangles fill them
        a, b = slots[k - 2], slots[k - 1]
        for f in (max(a, b), min(a, b)):
            last = cnt[1] - 1
            if f != last:
                _move_slot(m, last, f)
            cnt[1] = last
        return True
    for j in range(k):  # put the star back
        t = slots[j]
        for c in range(3):
            e = 3 * t + c
            tri[e] = saved[j, c]
            half[e] = saved[j, 3 + c]
            cons[e] = saved[j, 6 + c]
            vedge[tri[e]] = e
            if half[e] >= 0:
                half[half[e]] = e
    return False


@jit
def optimise(m, pz, g, prm, amap, fmap, lin, fixed, passes):
    """Remove and move vertices of the refined triangulation ``m`` while every bound holds (module notes).

    ``prm``, ``amap`` and ``fmap`` are those of :func:`.quality.refine_quality`;
    ``fixed`` uint8 (V,): vertices never touched.  Returns (vertices
    removed, vertex moves kept, passes run).

    A vertex is tried again only once something its tests read has changed:
    a change at ``v`` wakes its neighbours and the apexes of the triangles
    across its star's outline (``v`` is in their stars, or across their
    outlines); the triangles' own neighbours, which only the grading test
    reads, do not wake anyone.
    """
    tri, half = m[2], m[3]
    ring = np.empty(MAX_RING, np.int64)
    spokes = np.empty(MAX_RING, np.int64)
    apex = np.empty(MAX_RING, np.int64)
    slots = np.empty(MAX_RING, np.int64)
    poly = np.empty(MAX_RING, np.int64)
    rows = np.empty((MAX_RING, 3), np.int64)
    saved = np.empty((MAX_RING, 9), np.int64)
    outer = np.empty(MAX_RING, np.int64)
    ocons = np.empty(MAX_RING, np.uint8)
    segq = np.empty(1, np.int64)
    n = m[9][0]
    awake = np.ones(n, np.uint8)
    removed = moved = 0
    done = 0
    for _ in range(passes):
        done += 1
        removed_now = 0
        for v in range(n):
            if not awake[v]:
                continue
            awake[v] = 0
            k = _star(m, v, fixed, ring, spokes)
            if k < 0:
                continue
            for j in range(k):  # before the change: a removal may move the triangles across the outline
                o = half[next_half(spokes[j])]
                apex[j] = tri[prev_half(o)] if o >= 0 else -1
            if _try_remove(m, pz, g, prm, amap, fmap, lin, v, ring, spokes, k, slots, segq, poly, rows, saved, outer,
                           ocons):
                removed_now += 1
            elif _try_move(m, pz, g, prm, amap, fmap, lin, v, ring, spokes, k, slots, segq, 1.0) or _try_move(
                    m, pz, g, prm, amap, fmap, lin, v, ring, spokes, k, slots, segq, 0.5):
                moved += 1
                awake[v] = 1
            else:
                continue
            for j in range(k):
                awake[ring[j]] = 1
                if apex[j] >= 0:
                    awake[apex[j]] = 1
        removed += removed_now
        if removed_now == 0:
            break
    return removed, moved, done
