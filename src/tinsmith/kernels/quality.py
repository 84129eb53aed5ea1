"""Delaunay refinement with an error bound: Ruppert's algorithm with Üngör's off-centres, plus the vertical error.

Works on the constrained triangulation ``m`` of :mod:`.tin` in pixel
coordinates (``px`` column, ``py`` row, floats: Steiner points lie off the
grid), with ``pz`` (V,) the height of every vertex.  A triangle inside the
data (``region`` 0) is *bad* when

- its vertical error exceeds ``max_error``: the largest |mesh - DEM| over
  the valid cell centres it covers (edges included, the test and the height
  expression of :func:`.raster.rasterize_triangles`, which the metrics use),
  unless its inradius (world units) is below ``FLOOR_SPLIT`` times the
  largest floor ``fmap`` sets at a cell it covers or holds its centroid (the
  flood method's time-step floor; a one-element ``fmap``: no floor);
- its smallest plan-view angle (world units: ``lin`` maps pixel steps to
  world steps) is below the bound;
- its plan-view area exceeds ``max_area`` (or the smallest limit ``amap``
  sets at a cell it covers or holds its centroid: the regions' sizes), or
  exceeds ``grading**2`` times the area of a neighbour.

Segments are the constrained edges (nodata outline, breaklines) and the
hull.  A segment is *encroached* when a vertex lies inside its diametral
circle; it is split at its midpoint (exact: every segment starts between
grid points, so its pieces' ends are dyadic fractions of it).  Bad
triangles are taken error before angle before size; error-bad ones largest
first, skinny ones skinniest first.  A bad triangle gets its circumcentre,
or the off-centre on the bisector of its shortest edge where that is closer
(Üngör 2004), unless the point would encroach a segment (then the segment
is split instead, Ruppert 1995, Shewchuk 2002).  Steiner points take the
DEM's bilinear height.  Error-bad triangles are refined the same way, so
the points the error asks for are as well spaced as the others, and fewer
are needed than when the worst cell itself is inserted (docs/design.md
has the figures); only a triangle whose shortest edge is below
``cell_edge`` pixels gets its worst cell, with the cell's own height, which
ends the refinement where Steiner points would only creep up on the cell.

Termination near small input angles (Shewchuk 2002, section 5): a skinny
triangle whose smallest angle lies between two segments (an input angle),
or whose shortest edge joins two segments that meet below 60 degrees at a
vertex as far from both ends (a "seditious" edge), is left as it is; so is a triangle whose shortest edge is
below ``min_edge`` pixels.  The caller reports them.
"""

import math

import numpy as np

from ._jit import jit, jit_inline
from .heap import heap_remove, heap_requeue
from .predicates import incircle, orient2d
from .raster import INSIDE_EPS, _cell_box, _inside, scan_triangle
from .tin import insert_point, legalize, locate, next_half, prev_half, split_edge

#: Return codes of :func:`refine_quality`.
DONE, STOP_VERTICES, STOP_TRIANGLES, NEED_SPACE, STOP_BUDGET, STOP_STALLED = 0, 1, 2, 3, 4, 5

#: A triangle over the error bound is refined only while its inradius is at least this many times the largest floor
#: over its cells: refining it roughly halves its inradius, so its pieces stay at or above the floor (on St. Helens
#: at 60 m cells, 2 left 90 and 197 triangles below the target step at max_error 20 and 10 m, 3 left 80 and 146).
FLOOR_SPLIT = 3.0
#: Under a floor, a segment shorter than this many times the floor at its midpoint is not split: its halves would
#: make triangles below the floor (an equilateral triangle's side is 2 sqrt(3) times its inradius; twice that).
SEGMENT_FLOOR = 4.0 * math.sqrt(3.0)

#: Kinds of badness, in the order they are treated (larger first).
_ERROR, _ANGLE, _SIZE = 3.0, 2.0, 1.0


# -- geometry ------------------------------------------------------------------------------------
@jit_inline
def _world(lin, dx, dy):
    """A pixel step (dx, dy) as a world step."""
    return lin[0] * dx + lin[1] * dy, lin[2] * dx + lin[3] * dy


@jit_inline
def _pixel(inv, ux, uy):
    """A world step as a pixel step."""
    return inv[0] * ux + inv[1] * uy, inv[2] * ux + inv[3] * uy


@jit
def bilinear(zf, vf, all_valid, h, w, x, y, fallback):
    """The DEM's bilinear height at pixel (x, y) over the valid cells of its 2 x 2 block (weights renormalised)."""
    c0 = min(max(int(math.floor(x)), 0), w - 1)
    r0 = min(max(int(math.floor(y)), 0), h - 1)
    fx, fy = x - c0, y - r0
    total = 0.0
    acc = 0.0
    for dr in range(2):
        r = min(r0 + dr, h - 1)
        wy = fy if dr else 1.0 - fy
        for dc in range(2):
            c = min(c0 + dc, w - 1)
            wx = fx if dc else 1.0 - fx
            k = wx * wy
            if k > 0.0 and (all_valid or vf[r * w + c]):
                acc += k * np.float64(zf[r * w + c])
                total += k
    if total <= 0.0:
        return fallback
    if total == 1.0:
        return acc
    return acc / total


@jit_inline
def _scan(m, pz, zf, vf, all_valid, h, w, t):
    """(largest |mesh - DEM| over the valid cells triangle ``t`` covers, flat index of the first such cell or -1)."""
    px, py, tri = m[0], m[1], m[2]
    i0, i1, i2 = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    return scan_triangle(px[i0], py[i0], pz[i0], px[i1], py[i1], pz[i1], px[i2], py[i2], pz[i2], zf, vf, all_valid,
                         h, w)


@jit_inline
def _cell_extreme(m, cells, h, w, t, sign):
    """The smallest (``sign`` 1) or largest (``sign`` -1) value of ``cells`` (flat, one per cell) over the cells
    triangle ``t`` covers and the cell of its centroid."""
    px, py, tri = m[0], m[1], m[2]
    i0, i1, i2 = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    x0, y0, x1, y1, x2, y2 = px[i0], py[i0], px[i1], py[i1], px[i2], py[i2]
    cc = min(max(int(round((x0 + x1 + x2) / 3.0)), 0), w - 1)
    cr = min(max(int(round((y0 + y1 + y2) / 3.0)), 0), h - 1)
    best = cells[cr * w + cc]
    d = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    if d == 0.0:
        return best
    tol = INSIDE_EPS * abs(d)
    r_lo, r_hi, c_lo, c_hi = _cell_box(x0, y0, x1, y1, x2, y2, h, w)
    for r in range(r_lo, r_hi + 1):
        fy = float(r)
        for c in range(c_lo, c_hi + 1):
            a = cells[r * w + c]
            if sign * a >= sign * best:
                continue
            fx = float(c)
            w1 = (fx - x0) * (y2 - y0) - (x2 - x0) * (fy - y0)
            w2 = (x1 - x0) * (fy - y0) - (fx - x0) * (y1 - y0)
            if _inside(w1, w2, d, tol):
                best = a
    return best


@jit_inline
def inradius(m, lin, t):
    """The plan-view inradius of triangle ``t`` in world units: twice its area over its perimeter."""
    px, py, tri = m[0], m[1], m[2]
    v0, v1, v2 = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    ax, ay = _world(lin, px[v1] - px[v0], py[v1] - py[v0])
    bx, by = _world(lin, px[v2] - px[v1], py[v2] - py[v1])
    cx, cy = _world(lin, px[v0] - px[v2], py[v0] - py[v2])
    perimeter = math.sqrt(ax * ax + ay * ay) + math.sqrt(bx * bx + by * by) + math.sqrt(cx * cx + cy * cy)
    twice = abs(ax * (-cy) - ay * (-cx))
    return twice / perimeter if perimeter > 0.0 else 0.0


@jit_inline
def _floored(m, lin, fmap, h, w, t):
    """True when triangle ``t`` is too small to refine for its error: its inradius is below ``FLOOR_SPLIT`` times
    the largest floor of ``fmap`` (world units, flat, one per cell; one element: no floor) over the cells it covers
    and the cell of its centroid (a triangle across a channel takes the channel's floor, wherever its worst cell)."""
    if len(fmap) == 1:
        return False
    return inradius(m, lin, t) < FLOOR_SPLIT * _cell_extreme(m, fmap, h, w, t, -1.0)


@jit_inline
def _is_segment(m, e):
    return m[3][e] < 0 or m[4][e] != 0


@jit_inline
def _encroaches(m, e, x, y):
    """True when (x, y) lies strictly inside the diametral circle of the edge of halfedge ``e``."""
    px, py, tri = m[0], m[1], m[2]
    a, b = tri[e], tri[next_half(e)]
    return (px[a] - x) * (px[b] - x) + (py[a] - y) * (py[b] - y) < 0.0


@jit_inline
def _segment_ends(m, p, out):
    """The vertices joined to ``p`` by a segment, into ``out``; return how many (at most len(out))."""
    tri, half, cons, vedge = m[2], m[3], m[4], m[5]
    # rewind clockwise to the hull (or all the way round), then sweep counter-clockwise
    start = vedge[p]
    e = start
    while half[e] >= 0:
        e = next_half(half[e])
        if e == start:
            break
    first = e
    n = 0
    while n < len(out) - 1:
        if half[e] < 0 or cons[e]:  # p -> tri[next(e)]
            out[n] = tri[next_half(e)]
            n += 1
        f = prev_half(e)  # tri[f] -> p
        h = half[f]
        if h < 0 or cons[f]:
            out[n] = tri[f]
            n += 1
        if h < 0 or h == first:
            break
        e = h
    return n


@jit_inline
def _shared_apex(m, lin, p, q):
    """True when a segment at p and one at q meet at a vertex at an angle below 60 degrees, p and q as far
    from it (p-q is then a seditious edge, Shewchuk 2002: splitting it would only cut the small input angle
    again and again)."""
    px, py = m[0], m[1]
    ends_p = np.empty(16, np.int64)
    ends_q = np.empty(16, np.int64)
    n_p = _segment_ends(m, p, ends_p)
    n_q = _segment_ends(m, q, ends_q)
    for i in range(n_p):
        a = ends_p[i]
        if a == q:
            continue
        for j in range(n_q):
            if ends_q[j] != a:
                continue
            ux, uy = _world(lin, px[p] - px[a], py[p] - py[a])
            vx, vy = _world(lin, px[q] - px[a], py[q] - py[a])
            lu, lv = ux * ux + uy * uy, vx * vx + vy * vy
            # below 60 degrees, with p and q on one shell round the apex (as splitting leaves them)
            if ux * vx + uy * vy > 0.5 * math.sqrt(lu * lv) and abs(lu - lv) <= 0.002 * max(lu, lv):
                return True
    return False


@jit_inline
def smallest_angle(m, lin, t):
    """(cos of the smallest plan-view angle of triangle ``t``, 0-2: its shortest edge, the halfedge ``3 t + s``
    opposite that angle, plan-view area); the cos is 1.0 for a degenerate triangle."""
    px, py, tri = m[0], m[1], m[2]
    e0 = 3 * t
    # plan-view (world) edges: a = v0 -> v1 (halfedge e0), b = v1 -> v2, c = v2 -> v0
    v0, v1, v2 = tri[e0], tri[e0 + 1], tri[e0 + 2]
    ax, ay = _world(lin, px[v1] - px[v0], py[v1] - py[v0])  # edge v0 -> v1
    bx, by = _world(lin, px[v2] - px[v1], py[v2] - py[v1])  # edge v1 -> v2
    cx, cy = _world(lin, px[v0] - px[v2], py[v0] - py[v2])  # edge v2 -> v0
    la, lb, lc = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    area = 0.5 * abs(ax * (-cy) - ay * (-cx))
    # the shortest edge and the angle opposite it (the smallest)
    s = 0
    ls, l1, l2 = la, lb, lc
    if lb < ls:
        s, ls, l1, l2 = 1, lb, la, lc
    if lc < ls:
        s, ls, l1, l2 = 2, lc, la, lb
    cos_min = (l1 + l2 - ls) / (2.0 * math.sqrt(l1 * l2)) if l1 > 0.0 and l2 > 0.0 else 1.0
    return cos_min, s, area


@jit_inline
def _assess(m, pz, g, prm, amap, fmap, lin, t, segq, nseg):
    """(key, worst cell, nseg): how bad triangle ``t`` is (0: fine), and its encroached segments pushed on ``segq``."""
    px, py, tri, half, region = m[0], m[1], m[2], m[3], m[6]
    zf, vf, all_valid, h, w = g
    max_error, cos_bound, max_area, grading2, min_edge2 = prm[0], prm[1], prm[2], prm[3], prm[4]
    if region[t]:
        return 0.0, np.int64(-1), nseg
    e0 = 3 * t
    for k in range(3):
        e = e0 + k
        if _is_segment(m, e):
            o = tri[prev_half(e)]
            if _encroaches(m, e, px[o], py[o]) and nseg < len(segq):
                segq[nseg] = e
                nseg += 1
    err, at = _scan(m, pz, zf, vf, all_valid, h, w, t)
    if err > max_error and not _floored(m, lin, fmap, h, w, t):  # largest first (twice the pixel area is below 2 h w)
        v0, v1, v2 = tri[e0], tri[e0 + 1], tri[e0 + 2]
        twice = abs((px[v1] - px[v0]) * (py[v2] - py[v0]) - (px[v2] - px[v0]) * (py[v1] - py[v0]))
        return _ERROR + 0.999 * min(twice / (2.0 * h * w), 1.0), at, nseg
    cos_min, s, area = smallest_angle(m, lin, t)
    # the shortest edge in pixels: below min_edge, a triangle is not refined for its shape or size
    es = e0 + s
    p, q = tri[es], tri[next_half(es)]
    spx, spy = px[q] - px[p], py[q] - py[p]
    if spx * spx + spy * spy < min_edge2:
        return 0.0, np.int64(-1), nseg
    if cos_min > cos_bound:
        # the smallest angle is at the vertex opposite the shortest edge (halfedge es): an input angle when both
        # edges there are segments, and a seditious edge when segments at p and q meet at a third vertex
        small_input = _is_segment(m, next_half(es)) and _is_segment(m, prev_half(es))
        if not small_input and not _shared_apex(m, lin, p, q):
            return _ANGLE + min(cos_min - cos_bound, 0.999), np.int64(-1), nseg
    limit = max_area
    if len(amap) > 1:  # the regions' sizes
        limit = min(limit, _cell_extreme(m, amap, h, w, t, 1.0))
    if area > limit:
        return _SIZE + 0.5 * min(limit / area, 1.0), np.int64(-1), nseg
    if grading2 > 0.0:
        for k in range(3):
            o = half[e0 + k]
            if o < 0 or region[o // 3]:
                continue
            u = o - o % 3
            w0, w1, w2 = tri[u], tri[u + 1], tri[u + 2]
            ux, uy = _world(lin, px[w1] - px[w0], py[w1] - py[w0])
            vx, vy = _world(lin, px[w2] - px[w0], py[w2] - py[w0])
            other = 0.5 * abs(ux * vy - uy * vx)
            if area > grading2 * other:
                return _SIZE + 0.5 * min(grading2 * other / area, 1.0), np.int64(-1), nseg
    return 0.0, np.int64(-1), nseg


@jit_inline
def _steiner(m, lin, inv, t, cos_bound):
    """The point refining skinny or large triangle ``t``: its circumcentre, or Üngör's off-centre where closer."""
    px, py, tri = m[0], m[1], m[2]
    e0 = 3 * t
    v0, v1, v2 = tri[e0], tri[e0 + 1], tri[e0 + 2]
    # world steps from v0
    bx, by = _world(lin, px[v1] - px[v0], py[v1] - py[v0])
    cx, cy = _world(lin, px[v2] - px[v0], py[v2] - py[v0])
    d = 2.0 * (bx * cy - by * cx)
    b2, c2 = bx * bx + by * by, cx * cx + cy * cy
    ox = (cy * b2 - by * c2) / d
    oy = (bx * c2 - cx * b2) / d
    # the shortest edge, as world points relative to v0
    l0 = b2
    l1 = (cx - bx) * (cx - bx) + (cy - by) * (cy - by)
    l2 = c2
    if l0 <= l1 and l0 <= l2:
        sx0, sy0, sx1, sy1, ls = 0.0, 0.0, bx, by, l0
    elif l1 <= l2:
        sx0, sy0, sx1, sy1, ls = bx, by, cx, cy, l1
    else:
        sx0, sy0, sx1, sy1, ls = cx, cy, 0.0, 0.0, l2
    mx, my = 0.5 * (sx0 + sx1), 0.5 * (sy0 + sy1)
    dist = math.sqrt((ox - mx) ** 2 + (oy - my) ** 2)
    # the off-centre: on the bisector, where the shortest edge subtends the bound angle
    sin_b = math.sqrt(max(0.0, 1.0 - cos_bound * cos_bound))
    tan_half = sin_b / (1.0 + cos_bound)
    reach = 0.5 * math.sqrt(ls) / max(tan_half, 1e-12)
    if dist > reach and dist > 0.0:
        ox = mx + (ox - mx) * (reach / dist)
        oy = my + (oy - my) * (reach / dist)
    qx, qy = _pixel(inv, ox, oy)
    return px[v0] + qx, py[v0] + qy


@jit_inline
def _cell_circumcentre(x0, y0, x1, y1, x2, y2):
    """The circumcentre of a triangle in its own (cell) coordinates."""
    bx, by, cx, cy = x1 - x0, y1 - y0, x2 - x0, y2 - y0
    d = 2.0 * (bx * cy - by * cx)
    b2, c2 = bx * bx + by * by, cx * cx + cy * cy
    return x0 + (cy * b2 - by * c2) / d, y0 + (bx * c2 - cx * b2) / d


@jit_inline
def _shortest2(m, t):
    """The squared length (pixels) of the shortest edge of triangle ``t``."""
    px, py, tri = m[0], m[1], m[2]
    v0, v1, v2 = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    a = (px[v1] - px[v0]) ** 2 + (py[v1] - py[v0]) ** 2
    b = (px[v2] - px[v1]) ** 2 + (py[v2] - py[v1]) ** 2
    c = (px[v0] - px[v2]) ** 2 + (py[v0] - py[v2]) ** 2
    return min(a, min(b, c))


@jit_inline
def _insert_cell(m, pz, zf, w, t, at, stack):
    """Insert the centre of cell ``at`` (flat index; in or on triangle ``t``) with its own height."""
    n = m[9][0]
    v, stack = insert_point(m, float(at % w), float(at // w), t, stack)
    if v == n:  # a new vertex (a cell centre already a vertex has no error)
        pz[n] = np.float64(zf[at])
    return stack


@jit_inline
def _cavity_segment(m, t, x, y, marks, stamp, work):
    """A segment bounding the Delaunay cavity of (x, y) (found from triangle ``t``) that the point encroaches, or -1."""
    px, py, tri, half = m[0], m[1], m[2], m[3]
    marks[t] = stamp
    work[0] = t
    top = 1
    while top > 0:
        top -= 1
        u = work[top]
        for k in range(3):
            e = 3 * u + k
            if _is_segment(m, e):
                if _encroaches(m, e, x, y):
                    return e
                continue
            o = half[e] // 3
            if marks[o] == stamp:
                continue
            a, b, c = tri[3 * o], tri[3 * o + 1], tri[3 * o + 2]
            if incircle(px[a], py[a], px[b], py[b], px[c], py[c], x, y) > 0.0 and top < len(work):
                marks[o] = stamp
                work[top] = o
                top += 1
    return -1


@jit_inline
def _split_segment(m, pz, g, fmap, lin, e, stack, min_edge2):
    """Split the segment of halfedge ``e`` at its midpoint; False when it cannot be split (too short or inexact, or
    shorter than ``SEGMENT_FLOOR`` times the floor of ``fmap`` at its midpoint: pass a one-element ``fmap`` for a
    split the angle bound asks for)."""
    px, py, tri, cnt = m[0], m[1], m[2], m[9]
    zf, vf, all_valid, h, w = g
    a, b = tri[e], tri[next_half(e)]
    dx, dy = px[b] - px[a], py[b] - py[a]
    if dx * dx + dy * dy < 4.0 * min_edge2:
        return False
    x, y = 0.5 * (px[a] + px[b]), 0.5 * (py[a] + py[b])
    if len(fmap) > 1:
        ux, uy = _world(lin, dx, dy)
        at = min(max(int(round(y)), 0), h - 1) * w + min(max(int(round(x)), 0), w - 1)
        if ux * ux + uy * uy < (SEGMENT_FLOOR * fmap[at]) ** 2:
            return False
    if orient2d(px[a], py[a], px[b], py[b], x, y) != 0.0 or (x == px[a] and y == py[a]) or (x == px[b] and y == py[b]):
        return False
    n = cnt[0]
    cnt[0] += 1
    px[n], py[n] = x, y
    pz[n] = bilinear(zf, vf, all_valid, h, w, x, y, 0.5 * (pz[a] + pz[b]))
    top = split_edge(m, e, n, stack)
    legalize(m, stack, top, False)
    return True


@jit
def refine_quality(m, pz, g, prm, amap, fmap, lin, inv, q, cand, stack, segq, marks, work, limits, stats):
    """Refine until no triangle is bad and no segment encroached, or a limit holds.

    ``prm`` = (max_error, cos of the angle bound, max_area, grading**2,
    min_edge**2 and cell_edge**2 in pixels); ``amap``: the largest area (world units) at each
    cell, flat, or a one-element array (no regions); ``fmap``: the time-step floor, the smallest
    inradius (world units) a triangle over the error bound is refined to at each cell, flat, or a
    one-element array (no floor); ``limits`` = (max_vertices, max_triangles) of
    the triangulation, then the two guards against a refinement that does not converge: the vertex
    budget and the most Steiner points (for shape or size) allowed in triangles whose shortest edge
    is below ``cell_edge``.  ``stats`` (int64, 2; carried across calls): the Steiner points placed for
    shape or size, and those below ``cell_edge``.  Returns one of DONE, STOP_VERTICES,
    STOP_TRIANGLES, STOP_BUDGET, STOP_STALLED, NEED_SPACE (grow the buffers and call again).  ``stack`` comes from
    :func:`.tin.reserve` for the capacity of the buffers.
    """
    px, py, tri, region, dirty, is_dirty, cnt = m[0], m[1], m[2], m[6], m[7], m[8], m[9]
    zf, vf, all_valid, h, w = g
    min_edge2 = prm[4]
    no_floor = np.zeros(1)
    cap_v, cap_t = len(px), len(cand)
    stamp = 0
    while True:
        if cnt[0] + 1 > cap_v or cnt[1] + 4 > cap_t:
            return NEED_SPACE
        # assess every triangle written since the last look
        nseg = 0
        for k in range(cnt[2]):
            t = dirty[k]
            is_dirty[t] = 0
            key, at, nseg = _assess(m, pz, g, prm, amap, fmap, lin, t, segq, nseg)
            cand[t] = at
            heap_requeue(t, q, key, key > 0.0, cnt)
        cnt[2] = 0
        if nseg > 0:
            # split one encroached segment (still a segment, still encroached), then look again
            split = False
            for i in range(nseg):
                e = segq[i]
                if not _is_segment(m, e):
                    continue
                o = tri[prev_half(e)]
                if region[e // 3] == 0 and _encroaches(m, e, px[o], py[o]):
                    if cnt[0] + 1 > limits[0]:
                        return STOP_VERTICES
                    if cnt[0] + 1 > limits[2]:
                        return STOP_BUDGET
                    if cnt[1] + 2 > limits[1]:
                        return STOP_TRIANGLES
                    if _split_segment(m, pz, g, fmap, lin, e, stack, min_edge2):
                        split = True
                        break
            if split:
                continue
        if cnt[3] == 0:
            return DONE
        if cnt[0] + 1 > limits[0]:
            return STOP_VERTICES
        if cnt[1] + 2 > limits[1]:
            return STOP_TRIANGLES
        if cnt[0] + 1 > limits[2]:
            return STOP_BUDGET
        t = q[0][0]
        key = q[2][0]
        heap_remove(t, q, cnt)
        over = key >= _ERROR
        if over and _shortest2(m, t) < prm[5]:  # a tiny triangle over the bound: its worst cell
            stack = _insert_cell(m, pz, zf, w, t, cand[t], stack)
            continue
        if not over:  # a Steiner point for the shape or size: below the cell floor, count it (the stall guard)
            stats[0] += 1
            if _shortest2(m, t) < prm[5]:
                stats[1] += 1
                if stats[1] > limits[3]:
                    return STOP_STALLED
        x, y = _steiner(m, lin, inv, t, prm[1])
        v0, v1, v2 = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
        if not incircle(px[v0], py[v0], px[v1], py[v1], px[v2], py[v2], x, y) > 0.0:
            # cells not quite square: the point, placed in world units, misses t's circumcircle in cell units (the
            # triangulation's metric), so t would survive; its circumcentre in cell units does not
            x, y = _cell_circumcentre(px[v0], py[v0], px[v1], py[v1], px[v2], py[v2])
        tc = locate(m, x, y, t, True)  # stops at a segment in the way
        blocked = -2 - tc if tc < -1 else -1
        if blocked < 0 and tc >= 0 and region[tc] == 0:
            stamp += 1
            if stamp >= 2**31 - 1:
                marks[:] = 0
                stamp = 1
            blocked = _cavity_segment(m, tc, x, y, marks, stamp, work)
        if blocked >= 0:
            # the error bound yields to the floor; the angle bound does not (slivers break a solver)
            if _split_segment(m, pz, g, fmap if over else no_floor, lin, blocked, stack, min_edge2):
                if not is_dirty[t]:  # look at t again after the split
                    is_dirty[t] = 1
                    dirty[cnt[2]] = t
                    cnt[2] += 1
            elif over:  # an unsplittable segment in the way: the error still gets its cell
                stack = _insert_cell(m, pz, zf, w, t, cand[t], stack)
            continue  # (a skinny triangle stays as it is: reported by the caller)
        if tc < 0 or region[tc] != 0:  # pragma: no cover - a walk that ends outside the data meets a segment
            if over:
                stack = _insert_cell(m, pz, zf, w, t, cand[t], stack)
            continue
        # fallback: the mean height of the triangle holding the point (never needed inside valid data)
        z = bilinear(zf, vf, all_valid, h, w, x, y, (pz[tri[3 * tc]] + pz[tri[3 * tc + 1]] + pz[tri[3 * tc + 2]]) / 3.0)
        n = cnt[0]
        v, stack = insert_point(m, x, y, tc, stack)
        if v == n:  # not a vertex already
            pz[n] = z
        elif over:  # the point is a vertex already: the error still gets its cell
            stack = _insert_cell(m, pz, zf, w, t, cand[t], stack)
