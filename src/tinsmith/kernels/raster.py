"""Scan-convert triangles onto a grid of cell centres.

Buffer layout: vertex coordinates come as three float64 arrays ``px`` (column),
``py`` (row) and ``pz`` (height) in *pixel* space, where the centre of cell
``(row, col)`` is the integer point ``(col, row)``.  ``triangles`` is an
``(M, 3)`` int64 array.  The output is an ``(H, W)`` float64 grid holding the
linear interpolation of the triangle that covers each cell centre, NaN where
none does.

Barycentric weights are ``orient(p, v1, v2) / orient(v0, v1, v2)`` and its
cyclic variants, written so that a cell centre exactly on a vertex gets the
weights (1, 0, 0) bit for bit: a mesh whose vertices sit on cell centres
reproduces their heights exactly.  Points on a shared edge are written by both
triangles, with the same value up to rounding.
"""

import math

import numpy as np

from ._jit import jit

#: Tolerance on barycentric weights for "inside" (edges and vertices count as inside).
INSIDE_EPS = 1e-9


@jit
def rasterize_triangles(px, py, pz, triangles, h, w):
    out = np.full((h, w), np.nan)
    for t in range(triangles.shape[0]):
        i0, i1, i2 = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        x0, y0, z0 = px[i0], py[i0], pz[i0]
        x1, y1, z1 = px[i1], py[i1], pz[i1]
        x2, y2, z2 = px[i2], py[i2], pz[i2]
        d = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if d == 0.0:
            continue
        c_lo = max(0, int(math.ceil(min(x0, x1, x2) - 1e-7)))
        c_hi = min(w - 1, int(math.floor(max(x0, x1, x2) + 1e-7)))
        r_lo = max(0, int(math.ceil(min(y0, y1, y2) - 1e-7)))
        r_hi = min(h - 1, int(math.floor(max(y0, y1, y2) + 1e-7)))
        for r in range(r_lo, r_hi + 1):
            fy = float(r)
            for c in range(c_lo, c_hi + 1):
                fx = float(c)
                w0 = ((x1 - fx) * (y2 - fy) - (x2 - fx) * (y1 - fy)) / d
                w1 = ((fx - x0) * (y2 - y0) - (x2 - x0) * (fy - y0)) / d
                w2 = ((x1 - x0) * (fy - y0) - (fx - x0) * (y1 - y0)) / d
                if w0 >= -INSIDE_EPS and w1 >= -INSIDE_EPS and w2 >= -INSIDE_EPS:
                    out[r, c] = w0 * z0 + w1 * z1 + w2 * z2
    return out
