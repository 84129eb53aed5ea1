"""Exact integrals of a piecewise-linear density over polygons, for the centroids of the cCVT (seed 002, Algorithm 2).

The density lives on the full-resolution grid mesh: each square of four
cell centres is cut into two triangles by a diagonal (``main[i, j]``:
along (i, j)-(i+1, j+1), as :func:`tinsmith.algorithms.grid.lattice_mesh`
chooses it), and the density is linear on each triangle.  A polygon (a
Voronoi or dual cell, in pixel coordinates x = col, y = row) is clipped
against every grid triangle it overlaps (Sutherland-Hodgman: exact, no
pixel zig-zag), and the integrals of ``rho``, ``rho x`` and ``rho y`` over
each clipped piece come in closed form from its area and first and second
moments.  Triangles with a nodata corner carry no density.

Buffer layout: ``rho`` float64 (H, W), NaN at nodata; ``main`` bool
(H-1, W-1); polygons float64 (K, 2).
"""

import math

import numpy as np

from ._jit import jit, jit_inline


@jit_inline
def _clip_half(px, py, n, ax, ay, bx, by, qx, qy):
    """Clip polygon (px, py)[:n] to the left of the directed line a -> b; write to (qx, qy), return the count."""
    m = 0
    for i in range(n):
        j = (i + 1) % n
        si = (bx - ax) * (py[i] - ay) - (by - ay) * (px[i] - ax)
        sj = (bx - ax) * (py[j] - ay) - (by - ay) * (px[j] - ax)
        if si >= 0.0:
            qx[m], qy[m] = px[i], py[i]
            m += 1
        if (si >= 0.0) != (sj >= 0.0):
            t = si / (si - sj)
            qx[m] = px[i] + t * (px[j] - px[i])
            qy[m] = py[i] + t * (py[j] - py[i])
            m += 1
    return m


@jit_inline
def _moments(px, py, n, out):
    """Integrals over a polygon (signed by orientation) of 1, x, y, x^2, xy, y^2, x^3, x^2 y, x y^2, y^3, into ``out``.

    Green's theorem edge by edge: each monomial of degree ``d`` integrates
    to a sum over the edges of the cross product ``x_i y_j - x_j y_i``
    times a symmetric polynomial in the edge's end points.
    """
    for k in range(10):
        out[k] = 0.0
    for i in range(n):
        j = (i + 1) % n
        x0, y0, x1, y1 = px[i], py[i], px[j], py[j]
        cr = x0 * y1 - x1 * y0
        out[0] += cr
        out[1] += (x0 + x1) * cr
        out[2] += (y0 + y1) * cr
        out[3] += (x0 * x0 + x0 * x1 + x1 * x1) * cr
        out[4] += (x0 * y1 + 2.0 * x0 * y0 + 2.0 * x1 * y1 + x1 * y0) * cr
        out[5] += (y0 * y0 + y0 * y1 + y1 * y1) * cr
        out[6] += (x0 + x1) * (x0 * x0 + x1 * x1) * cr
        out[7] += (3.0 * x0 * x0 * y0 + x0 * x0 * y1 + 2.0 * x0 * x1 * y0 + 2.0 * x0 * x1 * y1 + x1 * x1 * y0 + 3.0 * x1 * x1 * y1) * cr
        out[8] += (3.0 * y0 * y0 * x0 + y0 * y0 * x1 + 2.0 * y0 * y1 * x0 + 2.0 * y0 * y1 * x1 + y1 * y1 * x0 + 3.0 * y1 * y1 * x1) * cr
        out[9] += (y0 + y1) * (y0 * y0 + y1 * y1) * cr
    out[0] /= 2.0
    out[1] /= 6.0
    out[2] /= 6.0
    out[3] /= 12.0
    out[4] /= 24.0
    out[5] /= 12.0
    out[6] /= 20.0
    out[7] /= 60.0
    out[8] /= 60.0
    out[9] /= 20.0


@jit
def polygon_integrals(poly, rho, main):
    """(mass, mx, my, m2): the integrals of ``rho``, ``rho x``, ``rho y`` and ``rho (x^2 + y^2)`` over ``poly``.

    ``poly`` is in pixel coordinates, either orientation.  The centroid of
    the cell under the density is ``(mx / mass, my / mass)``; the CVT energy
    of a site ``v`` in the cell is ``m2 - 2 v . (mx, my) + |v|^2 mass``.
    Cost: the grid squares of the polygon's bounding box, each clipped twice.
    """
    h, w = rho.shape
    n = poly.shape[0]
    cap = n + 8
    px = np.empty(cap)
    py = np.empty(cap)
    qx = np.empty(cap)
    qy = np.empty(cap)
    sx0 = np.empty(cap)
    sy0 = np.empty(cap)
    for k in range(n):
        sx0[k], sy0[k] = poly[k, 0], poly[k, 1]
    # orientation: clip with counter-clockwise triangles, so the polygon must be counter-clockwise too
    area = 0.0
    for k in range(n):
        area += sx0[k] * sy0[(k + 1) % n] - sx0[(k + 1) % n] * sy0[k]
    if area < 0.0:
        for k in range(n // 2):
            sx0[k], sx0[n - 1 - k] = sx0[n - 1 - k], sx0[k]
            sy0[k], sy0[n - 1 - k] = sy0[n - 1 - k], sy0[k]
    c_lo = max(0, int(math.floor(sx0[:n].min())))
    c_hi = min(w - 2, int(math.floor(sx0[:n].max())))
    r_lo = max(0, int(math.floor(sy0[:n].min())))
    r_hi = min(h - 2, int(math.floor(sy0[:n].max())))
    mass = mx = my = m2 = 0.0
    mom = np.empty(10)
    for i in range(r_lo, r_hi + 1):
        for j in range(c_lo, c_hi + 1):
            for half in range(2):
                # the triangle's corners (x, y) counter-clockwise in (x, y) and its three densities
                if main[i, j]:
                    if half == 0:
                        x0, y0, x1, y1, x2, y2 = j, i, j + 1, i + 1, j, i + 1
                    else:
                        x0, y0, x1, y1, x2, y2 = j, i, j + 1, i, j + 1, i + 1
                else:
                    if half == 0:
                        x0, y0, x1, y1, x2, y2 = j, i, j + 1, i, j, i + 1
                    else:
                        x0, y0, x1, y1, x2, y2 = j + 1, i, j + 1, i + 1, j, i + 1
                r0, r1, r2 = rho[y0, x0], rho[y1, x1], rho[y2, x2]
                if not (r0 == r0 and r1 == r1 and r2 == r2):
                    continue  # a corner without data: no density here
                m = n
                for k in range(m):
                    px[k], py[k] = sx0[k], sy0[k]
                m = _clip_half(px, py, m, x0, y0, x1, y1, qx, qy)
                m = _clip_half(qx, qy, m, x1, y1, x2, y2, px, py)
                m = _clip_half(px, py, m, x2, y2, x0, y0, qx, qy)
                if m < 3:
                    continue
                _moments(qx, qy, m, mom)
                a, sx, sy, sxx, sxy, syy = mom[0], mom[1], mom[2], mom[3], mom[4], mom[5]
                sxxx, sxxy, sxyy, syyy = mom[6], mom[7], mom[8], mom[9]
                # rho = c0 + cx x + cy y on the triangle
                d = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
                cx = ((r1 - r0) * (y2 - y0) - (r2 - r0) * (y1 - y0)) / d
                cy = ((x1 - x0) * (r2 - r0) - (x2 - x0) * (r1 - r0)) / d
                c0 = r0 - cx * x0 - cy * y0
                mass += c0 * a + cx * sx + cy * sy
                mx += c0 * sx + cx * sxx + cy * sxy
                my += c0 * sy + cx * sxy + cy * syy
                m2 += c0 * (sxx + syy) + cx * (sxxx + sxyy) + cy * (sxxy + syyy)
    return mass, mx, my, m2


@jit
def cell_integrals(x, y, tri, rho, main):
    """(mass, mx, my, m2) of every site's barycentric dual cell: the integrals of :func:`polygon_integrals`.

    A site's cell is the union, over its triangles, of the quadrilateral
    site - middle of one edge - the triangle's centroid - middle of the
    other edge: no ordering of the fan is needed, and a site on the border
    gets a closed cell that includes it.  ``x``, ``y`` are pixel
    coordinates (col, row), ``tri`` (M, 3) indexes them.
    """
    n = len(x)
    out = np.zeros((n, 4))
    quad = np.empty((4, 2))
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        gx = (x[a] + x[b] + x[c]) / 3.0
        gy = (y[a] + y[b] + y[c]) / 3.0
        for k in range(3):
            v = tri[t, k]
            p = tri[t, (k + 1) % 3]
            q = tri[t, (k + 2) % 3]
            quad[0, 0], quad[0, 1] = x[v], y[v]
            quad[1, 0], quad[1, 1] = (x[v] + x[p]) / 2.0, (y[v] + y[p]) / 2.0
            quad[2, 0], quad[2, 1] = gx, gy
            quad[3, 0], quad[3, 1] = (x[v] + x[q]) / 2.0, (y[v] + y[q]) / 2.0
            mass, mx, my, m2 = polygon_integrals(quad, rho, main)
            out[v, 0] += mass
            out[v, 1] += mx
            out[v, 2] += my
            out[v, 3] += m2
    return out
