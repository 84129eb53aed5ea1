"""Scan-convert triangles onto a grid of cell centres.

Buffer layout: vertex coordinates come as three float64 arrays ``px`` (column),
``py`` (row) and ``pz`` (height) in *pixel* space, where the centre of cell
``(row, col)`` is the integer point ``(col, row)``.  ``triangles`` is an
``(M, 3)`` int64 array.  The output is an ``(H, W)`` float64 grid holding the
linear interpolation of the triangle that covers each cell centre, NaN where
none does.

Heights come from :func:`interpolate` with the
barycentric numerators ``w1 = orient(v0, p, v2)`` and ``w2 = orient(v0, v1, p)``
over ``d = orient(v0, v1, v2)``: exact at the corners, so a mesh whose
vertices sit on cell centres reproduces their heights, and bit for bit the
value greedy insertion (:mod:`.greedy`) measured.  Points on a shared edge are written by both
triangles, with the same value up to rounding.
"""

import math

import numpy as np

from ._jit import jit, jit_inline

#: Tolerance on barycentric weights for "inside" (edges and vertices count as inside).
INSIDE_EPS = 1e-9


@jit_inline
def interpolate(z0, z1, z2, w1, w2, d, k1, k2):
    """Height at barycentric numerators (w1, w2) over d, with k1 = (z1 - z0) / d, k2 = (z2 - z0) / d.

    ``z0 + (w1 * k1 + w2 * k2)``: no division per cell, exact at the three
    corners (the corner cases are returned as they are), and bit for bit the
    same for the triangle written (v0, v1, v2) or (v0, v2, v1), as a mesh
    turned from pixel to world orientation is.
    """
    if w1 == d:
        return z1
    if w2 == d:
        return z2
    return z0 + (w1 * k1 + w2 * k2)


@jit_inline
def _inside(w1, w2, d, tol):
    """Whether barycentric numerators ``w1``, ``w2`` (and ``d - w1 - w2``) put a point inside, edges included."""
    w0 = d - w1 - w2
    if d > 0.0:
        return w0 >= -tol and w1 >= -tol and w2 >= -tol
    return w0 <= tol and w1 <= tol and w2 <= tol


@jit_inline
def _corners(px, py, pz, triangles, t):
    """The corners of triangle ``t`` and ``d = orient(v0, v1, v2)``."""
    i0, i1, i2 = triangles[t, 0], triangles[t, 1], triangles[t, 2]
    x0, y0, x1, y1, x2, y2 = px[i0], py[i0], px[i1], py[i1], px[i2], py[i2]
    return x0, y0, pz[i0], x1, y1, pz[i1], x2, y2, pz[i2], (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)


@jit_inline
def _cell_box(x0, y0, x1, y1, x2, y2, h, w):
    """The rows and columns (inclusive, clipped to the grid) of the cell centres a triangle's bounding box holds."""
    c_lo = max(0, int(math.ceil(min(x0, x1, x2) - 1e-7)))
    c_hi = min(w - 1, int(math.floor(max(x0, x1, x2) + 1e-7)))
    r_lo = max(0, int(math.ceil(min(y0, y1, y2) - 1e-7)))
    r_hi = min(h - 1, int(math.floor(max(y0, y1, y2) + 1e-7)))
    return r_lo, r_hi, c_lo, c_hi


@jit
def rasterize_triangles(px, py, pz, triangles, h, w):
    out = np.full((h, w), np.nan)
    for t in range(triangles.shape[0]):
        x0, y0, z0, x1, y1, z1, x2, y2, z2, d = _corners(px, py, pz, triangles, t)
        if d == 0.0:
            continue
        tol = INSIDE_EPS * abs(d)
        k1 = (z1 - z0) / d
        k2 = (z2 - z0) / d
        r_lo, r_hi, c_lo, c_hi = _cell_box(x0, y0, x1, y1, x2, y2, h, w)
        for r in range(r_lo, r_hi + 1):
            fy = float(r)
            for c in range(c_lo, c_hi + 1):
                fx = float(c)
                w1 = (fx - x0) * (y2 - y0) - (x2 - x0) * (fy - y0)
                w2 = (x1 - x0) * (fy - y0) - (fx - x0) * (y1 - y0)
                if _inside(w1, w2, d, tol):
                    out[r, c] = interpolate(z0, z1, z2, w1, w2, d, k1, k2)
    return out



@jit_inline
def _boxes(px, py, i0, i1, i2, x_lo, y_lo, sx, sy, side):
    """The bucket rows and columns (inclusive) that a triangle's bounding box overlaps."""
    c_lo = min(side - 1, int((min(px[i0], px[i1], px[i2]) - x_lo) / sx))
    c_hi = min(side - 1, int((max(px[i0], px[i1], px[i2]) - x_lo) / sx))
    r_lo = min(side - 1, int((min(py[i0], py[i1], py[i2]) - y_lo) / sy))
    r_hi = min(side - 1, int((max(py[i0], py[i1], py[i2]) - y_lo) / sy))
    return r_lo, r_hi, c_lo, c_hi


@jit
def sample_triangles(px, py, pz, triangles, qx, qy):
    """Heights of the triangles at the points ``(qx, qy)`` (NaN outside every triangle), by a bucket grid.

    The triangles go into the buckets their bounding boxes overlap, a grid
    of about one bucket per triangle; each point tests the triangles of its
    bucket.  Heights come from :func:`interpolate`, as in
    :func:`rasterize_triangles`.
    """
    m = triangles.shape[0]
    out = np.full(len(qx), np.nan)
    if m == 0 or len(qx) == 0:
        return out
    x_lo, x_hi, y_lo, y_hi = px.min(), px.max(), py.min(), py.max()
    side = max(1, int(math.sqrt(m)))
    sx = (x_hi - x_lo) / side if x_hi > x_lo else 1.0
    sy = (y_hi - y_lo) / side if y_hi > y_lo else 1.0
    start = np.zeros(side * side + 1, np.int64)
    for t in range(m):
        r_lo, r_hi, c_lo, c_hi = _boxes(px, py, triangles[t, 0], triangles[t, 1], triangles[t, 2], x_lo, y_lo, sx, sy, side)
        for r in range(r_lo, r_hi + 1):
            for c in range(c_lo, c_hi + 1):
                start[r * side + c + 1] += 1
    for b in range(side * side):
        start[b + 1] += start[b]
    bucket = np.empty(start[-1], np.int64)
    fill = start[:-1].copy()
    for t in range(m):
        r_lo, r_hi, c_lo, c_hi = _boxes(px, py, triangles[t, 0], triangles[t, 1], triangles[t, 2], x_lo, y_lo, sx, sy, side)
        for r in range(r_lo, r_hi + 1):
            for c in range(c_lo, c_hi + 1):
                bucket[fill[r * side + c]] = t
                fill[r * side + c] += 1
    for p in range(len(qx)):
        fx, fy = qx[p], qy[p]
        if not (fx >= x_lo and fy >= y_lo and fx <= x_hi and fy <= y_hi):
            continue  # outside the box of the triangles (or NaN); tested on the coordinates: a point on its
            # top or right side can land a rounding past the last bucket
        fc, fr = (fx - x_lo) / sx, (fy - y_lo) / sy
        b = min(int(fr), side - 1) * side + min(int(fc), side - 1)
        for j in range(start[b], start[b + 1]):
            x0, y0, z0, x1, y1, z1, x2, y2, z2, d = _corners(px, py, pz, triangles, bucket[j])
            if d == 0.0:
                continue
            tol = INSIDE_EPS * abs(d)
            w1 = (fx - x0) * (y2 - y0) - (x2 - x0) * (fy - y0)
            w2 = (x1 - x0) * (fy - y0) - (fx - x0) * (y1 - y0)
            if _inside(w1, w2, d, tol):
                out[p] = interpolate(z0, z1, z2, w1, w2, d, (z1 - z0) / d, (z2 - z0) / d)
                break
    return out


@jit
def cell_weights(px, py, triangles, h, w):
    """(triangle of each cell centre, -1 for none; its barycentric weights (H, W, 3)), cells as in :func:`rasterize_triangles`.

    The height the mesh gives a cell is ``sum(weights * z[triangle's corners])``:
    what :func:`tinsmith.algorithms.cvt.fit.fit_heights` fits.  A cell on a shared
    edge belongs to the last triangle that covers it, as in the rasteriser.
    """
    owner = np.full((h, w), -1, np.int64)
    bary = np.zeros((h, w, 3))
    for t in range(triangles.shape[0]):
        x0, y0, _, x1, y1, _, x2, y2, _, d = _corners(px, py, px, triangles, t)  # heights not needed: px stands in
        if d == 0.0:
            continue
        tol = INSIDE_EPS * abs(d)
        r_lo, r_hi, c_lo, c_hi = _cell_box(x0, y0, x1, y1, x2, y2, h, w)
        for r in range(r_lo, r_hi + 1):
            fy = float(r)
            for c in range(c_lo, c_hi + 1):
                fx = float(c)
                w1 = (fx - x0) * (y2 - y0) - (x2 - x0) * (fy - y0)
                w2 = (x1 - x0) * (fy - y0) - (fx - x0) * (y1 - y0)
                if _inside(w1, w2, d, tol):
                    owner[r, c] = t
                    bary[r, c, 1] = w1 / d
                    bary[r, c, 2] = w2 / d
                    bary[r, c, 0] = 1.0 - w1 / d - w2 / d
    return owner, bary


@jit_inline
def scan_triangle(x0, y0, z0, x1, y1, z1, x2, y2, z2, zf, vf, all_valid, h, w):
    """(largest |plane - DEM| over the valid cell centres (``vf`` flat, unless ``all_valid``) the triangle covers,
    flat index of the first such cell or -1), with the inside test and height expression of
    :func:`rasterize_triangles`; in cell units (x column, y row)."""
    d = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    best, best_at = 0.0, np.int64(-1)
    if d == 0.0:
        return best, best_at
    tol = INSIDE_EPS * abs(d)
    k1 = (z1 - z0) / d
    k2 = (z2 - z0) / d
    r_lo, r_hi, c_lo, c_hi = _cell_box(x0, y0, x1, y1, x2, y2, h, w)
    for r in range(r_lo, r_hi + 1):
        fy = float(r)
        for c in range(c_lo, c_hi + 1):
            at = r * w + c
            if not (all_valid or vf[at]):
                continue
            fx = float(c)
            w1 = (fx - x0) * (y2 - y0) - (x2 - x0) * (fy - y0)
            w2 = (x1 - x0) * (fy - y0) - (fx - x0) * (y1 - y0)
            if _inside(w1, w2, d, tol):
                e = abs(interpolate(z0, z1, z2, w1, w2, d, k1, k2) - zf[at])
                if e > best:
                    best, best_at = e, at
    return best, best_at


@jit
def triangle_errors(px, py, pz, triangles, zf, vf, h, w):
    """Per triangle of ``triangles`` (vertices in cell units): :func:`scan_triangle`'s largest error and its cell."""
    m = triangles.shape[0]
    err = np.zeros(m)
    at = np.full(m, -1, np.int64)
    for t in range(m):
        x0, y0, z0, x1, y1, z1, x2, y2, z2, _ = _corners(px, py, pz, triangles, t)
        err[t], at[t] = scan_triangle(x0, y0, z0, x1, y1, z1, x2, y2, z2, zf, vf, False, h, w)
    return err, at
