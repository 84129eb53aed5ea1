"""Heightfield reconstruction on a dexel grid (Gopi and Krishnan 2002, section 5.1).

One point per dexel, neighbours from adjacent dexels.

Buffer layout: ``rep`` int64 (ny, nx), the index of each dexel's
representative point or -1; ``x``, ``y`` float64 point coordinates.  Row
``i`` of the grid holds y in [y0 + i d, y0 + (i+1) d), column ``j`` holds
x in [x0 + j d, x0 + (j+1) d).
"""

import numpy as np

from ._jit import jit, jit_inline
from .predicates import incircle, orient2d


@jit_inline
def _orient(x, y, a, b, c):
    return orient2d(x[a], y[a], x[b], y[b], x[c], y[c])


@jit
def dexel_triangles(rep, x, y):
    """(M, 3) counter-clockwise triangles joining the representatives of every 2 x 2 block of dexels.

    The block's corners a (i, j), b (i, j+1), d (i+1, j+1), c (i+1, j) go
    round counter-clockwise.  Opposite sides of the quadrilateral lie in
    disjoint strips of the grid, so it is simple, and blocks in different
    strips cannot overlap: the union is a planar triangulation.  With four
    corners, the diagonal whose two triangles both turn left is taken (the
    Delaunay one when both do); with three, their triangle; triangles of
    zero area, and blocks with no valid diagonal, are left out.
    """
    ny, nx = rep.shape
    out = np.empty((2 * max(ny - 1, 0) * max(nx - 1, 0), 3), np.int64)
    m = 0
    for i in range(ny - 1):
        for j in range(nx - 1):
            a, b, c, d = rep[i, j], rep[i, j + 1], rep[i + 1, j], rep[i + 1, j + 1]
            n = (a >= 0) + (b >= 0) + (c >= 0) + (d >= 0)
            if n < 3:
                continue
            if n == 3:
                # the three present corners in counter-clockwise order a, b, d, c
                if a < 0:
                    p, q, r = b, d, c
                elif b < 0:
                    p, q, r = a, d, c
                elif d < 0:
                    p, q, r = a, b, c
                else:
                    p, q, r = a, b, d
                if _orient(x, y, p, q, r) > 0.0:
                    out[m, 0], out[m, 1], out[m, 2] = p, q, r
                    m += 1
                continue
            ad_ok = _orient(x, y, a, b, d) > 0.0 and _orient(x, y, a, d, c) > 0.0
            bc_ok = _orient(x, y, a, b, c) > 0.0 and _orient(x, y, b, d, c) > 0.0
            if ad_ok and bc_ok:
                # both diagonals work: the Delaunay one (c outside the circle of a, b, d)
                use_ad = incircle(x[a], y[a], x[b], y[b], x[d], y[d], x[c], y[c]) <= 0.0
            elif ad_ok or bc_ok:
                use_ad = ad_ok
            else:  # corners on one line: nothing here, rather than a triangle reaching over a neighbour's
                continue
            if use_ad:
                out[m, 0], out[m, 1], out[m, 2] = a, b, d
                out[m + 1, 0], out[m + 1, 1], out[m + 1, 2] = a, d, c
            else:
                out[m, 0], out[m, 1], out[m, 2] = a, b, c
                out[m + 1, 0], out[m + 1, 1], out[m + 1, 2] = b, d, c
            m += 2
    return out[:m]
