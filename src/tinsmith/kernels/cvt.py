"""Exact integrals of a piecewise-linear density over polygons, for the centroids of the cCVT (Duan et al. 2016, Algorithm 2).

The density lives on the full-resolution grid mesh: each square of four
cell centres is cut into two triangles by a diagonal (``main[i, j]``:
along (i, j)-(i+1, j+1), as :func:`tinsmith.algorithms.grid.grid.lattice_mesh`
chooses it), and the density is linear on each triangle.  A polygon (a
Voronoi or dual cell, in pixel coordinates x = col, y = row) is clipped
against every grid triangle it overlaps (Sutherland-Hodgman: exact, no
pixel zig-zag), and the integrals of ``rho``, ``rho x``, ``rho y``, ``rho x^2``
and ``rho y^2`` over each clipped piece come in closed form from its moments
up to third order.  Triangles with a nodata corner carry no density.

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
        out[7] += (3.0 * x0 * x0 * y0 + x0 * x0 * y1 + 2.0 * x0 * x1 * y0
                   + 2.0 * x0 * x1 * y1 + x1 * x1 * y0 + 3.0 * x1 * x1 * y1) * cr
        out[8] += (3.0 * y0 * y0 * x0 + y0 * y0 * x1 + 2.0 * y0 * y1 * x0
                   + 2.0 * y0 * y1 * x1 + y1 * y1 * x0 + 3.0 * y1 * y1 * x1) * cr
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
    """(mass, mx, my, mxx, myy): the integrals of ``rho``, ``rho x``, ``rho y``, ``rho x^2`` and ``rho y^2`` over ``poly``.

    ``poly`` is in pixel coordinates, either orientation.  The centroid of
    the cell under the density is ``(mx / mass, my / mass)``; the CVT energy
    of a site ``v`` in the cell is ``sx^2 (mxx - 2 vx mx + vx^2 mass) +
    sy^2 (myy - 2 vy my + vy^2 mass)`` for pixel sizes ``sx``, ``sy``.
    Cost: the grid squares of the polygon's bounding box, each clipped twice.
    """
    n = poly.shape[0]
    buf = np.empty((6, n + 8))
    out = np.zeros(5)
    mom = np.empty(10)
    for k in range(n):
        buf[4, k], buf[5, k] = poly[k, 0], poly[k, 1]
    _accumulate(buf, n, rho, main, mom, out)
    return out[0], out[1], out[2], out[3], out[4]


@jit_inline
def _accumulate(buf, n, rho, main, mom, out):
    """Add the integrals of the polygon ``buf[4:6, :n]`` to ``out`` (mass, mx, my, mxx, myy); ``buf`` rows 0-3 are scratch."""
    h, w = rho.shape
    px, py, qx, qy, sx0, sy0 = buf[0], buf[1], buf[2], buf[3], buf[4], buf[5]
    # orientation: clip with counter-clockwise triangles, so the polygon must be counter-clockwise too
    area = 0.0
    for k in range(n):
        area += sx0[k] * sy0[(k + 1) % n] - sx0[(k + 1) % n] * sy0[k]
    if area < 0.0:
        for k in range(n // 2):
            sx0[k], sx0[n - 1 - k] = sx0[n - 1 - k], sx0[k]
            sy0[k], sy0[n - 1 - k] = sy0[n - 1 - k], sy0[k]
    xmin = xmax = sx0[0]
    ymin = ymax = sy0[0]
    for k in range(1, n):
        xmin = min(xmin, sx0[k])
        xmax = max(xmax, sx0[k])
        ymin = min(ymin, sy0[k])
        ymax = max(ymax, sy0[k])
    c_lo = max(0, int(math.floor(xmin)))
    c_hi = min(w - 2, int(math.floor(xmax)))
    r_lo = max(0, int(math.floor(ymin)))
    r_hi = min(h - 2, int(math.floor(ymax)))
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
                out[0] += c0 * a + cx * sx + cy * sy
                out[1] += c0 * sx + cx * sxx + cy * sxy
                out[2] += c0 * sy + cx * sxy + cy * syy
                out[3] += c0 * sxx + cx * sxxx + cy * sxxy
                out[4] += c0 * syy + cx * sxyy + cy * syyy


@jit
def cell_integrals(x, y, tri, rho, main):
    """(N, 5) integrals (mass, mx, my, mxx, myy) of every site's barycentric dual cell, as :func:`polygon_integrals`.

    A site's cell is the union, over its triangles, of the quadrilateral
    site - middle of one edge - the triangle's centroid - middle of the
    other edge: no ordering of the fan is needed, and a site on the border
    gets a closed cell that includes it.  ``x``, ``y`` are pixel
    coordinates (col, row), ``tri`` (M, 3) indexes them.
    """
    n = len(x)
    out = np.zeros((n, 5))
    buf = np.empty((6, 12))
    mom = np.empty(10)
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        gx = (x[a] + x[b] + x[c]) / 3.0
        gy = (y[a] + y[b] + y[c]) / 3.0
        for k in range(3):
            v = tri[t, k]
            p = tri[t, (k + 1) % 3]
            q = tri[t, (k + 2) % 3]
            buf[4, 0], buf[5, 0] = x[v], y[v]
            buf[4, 1], buf[5, 1] = (x[v] + x[p]) / 2.0, (y[v] + y[p]) / 2.0
            buf[4, 2], buf[5, 2] = gx, gy
            buf[4, 3], buf[5, 3] = (x[v] + x[q]) / 2.0, (y[v] + y[q]) / 2.0
            _accumulate(buf, 4, rho, main, mom, out[v])
    return out


@jit
def surface_heights(x, y, z, main):
    """Heights of the grid mesh (cell centres joined as ``main`` cuts the squares) at pixel points (x = col, y = row).

    ``z`` must be finite everywhere (nodata filled beforehand); points
    outside the grid are clamped to it.
    """
    h, w = z.shape
    out = np.empty(len(x))
    for k in range(len(x)):
        px = min(max(x[k], 0.0), w - 1.0)
        py = min(max(y[k], 0.0), h - 1.0)
        j = min(int(px), w - 2)
        i = min(int(py), h - 2)
        u = px - j
        v = py - i
        za, zb, zc, zd = z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]
        if main[i, j]:  # triangles (a, d, c) below the diagonal u = v and (a, b, d) above
            if v >= u:
                out[k] = za + u * (zd - zc) + v * (zc - za)
            else:
                out[k] = za + u * (zb - za) + v * (zd - zb)
        else:  # triangles (a, b, c) with u + v <= 1 and (b, d, c)
            if u + v <= 1.0:
                out[k] = za + u * (zb - za) + v * (zc - za)
            else:
                out[k] = zd + (1.0 - u) * (zc - zd) + (1.0 - v) * (zb - zd)
    return out


@jit
def covered_points(x, y, valid):
    """True where the pixel point lies on the covered region.

    That is a grid square with four valid corners, or the triangle of the three valid corners of a
    square with one missing (as :func:`tinsmith.algorithms.greedy.outline.covered`).
    """
    h, w = valid.shape
    out = np.zeros(len(x), np.bool_)
    for k in range(len(x)):
        px, py = x[k], y[k]
        if not (0.0 <= px <= w - 1.0 and 0.0 <= py <= h - 1.0):
            continue
        for i in range(max(0, int(math.ceil(py)) - 1), min(h - 2, int(math.floor(py))) + 1):
            for j in range(max(0, int(math.ceil(px)) - 1), min(w - 2, int(math.floor(px))) + 1):
                a, b, c, d = valid[i, j], valid[i, j + 1], valid[i + 1, j], valid[i + 1, j + 1]
                u, v = px - j, py - i
                count = int(a) + int(b) + int(c) + int(d)
                if count == 4 or (count == 3 and ((not a and u + v >= 1.0) or (not d and u + v <= 1.0)
                                                  or (not b and v >= u) or (not c and u >= v))):
                    out[k] = True
    return out


@jit
def inside_loops(x, y, seg):
    """Even-odd test of pixel points against closed loops given as segments ``seg`` (K, 4): x0, y0, x1, y1."""
    out = np.zeros(len(x), np.bool_)
    for k in range(len(x)):
        px, py = x[k], y[k]
        inside = False
        for s in range(seg.shape[0]):
            x0, y0, x1, y1 = seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3]
            if (y0 > py) != (y1 > py):
                xc = x0 + (py - y0) * (x1 - x0) / (y1 - y0)
                if xc > px:
                    inside = not inside
        out[k] = inside
    return out
