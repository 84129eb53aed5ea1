"""Point location in a planar triangulation by a bucket grid (the remesher's parameter space).

:func:`build` sorts the triangles into the buckets of a uniform grid that
their bounding boxes touch (CSR: ``start``, ``items``); :func:`locate`
tests each point against the triangles of its bucket and returns the first
that holds it (with a tolerance ``eps`` on the barycentric coordinates, so
points on shared edges are found), with its barycentric coordinates.  A
point in no triangle gets -1.

Layout: ``uv`` float64 (N, 2) corners, ``tri`` int64 (M, 3), points float64 (P, 2).
"""

import numpy as np

from ._jit import jit


@jit
def _span(uv, tri, t, lo_x, lo_y, cell, nx, ny):
    """The bucket columns i0..i1 and rows j0..j1 the triangle's bounding box touches."""
    x0 = min(uv[tri[t, 0], 0], uv[tri[t, 1], 0], uv[tri[t, 2], 0])
    x1 = max(uv[tri[t, 0], 0], uv[tri[t, 1], 0], uv[tri[t, 2], 0])
    y0 = min(uv[tri[t, 0], 1], uv[tri[t, 1], 1], uv[tri[t, 2], 1])
    y1 = max(uv[tri[t, 0], 1], uv[tri[t, 1], 1], uv[tri[t, 2], 1])
    i0 = max(0, min(nx - 1, int((x0 - lo_x) / cell)))
    i1 = max(0, min(nx - 1, int((x1 - lo_x) / cell)))
    j0 = max(0, min(ny - 1, int((y0 - lo_y) / cell)))
    j1 = max(0, min(ny - 1, int((y1 - lo_y) / cell)))
    return i0, i1, j0, j1


@jit
def build(uv, tri, lo_x, lo_y, cell, nx, ny):
    """(start (nx*ny + 1,), items): the triangles of every bucket."""
    m = tri.shape[0]
    start = np.zeros(nx * ny + 1, np.int64)
    for t in range(m):
        i0, i1, j0, j1 = _span(uv, tri, t, lo_x, lo_y, cell, nx, ny)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                start[j * nx + i + 1] += 1
    for b in range(nx * ny):
        start[b + 1] += start[b]
    items = np.empty(start[nx * ny], np.int64)
    fill = start[:-1].copy()
    for t in range(m):
        i0, i1, j0, j1 = _span(uv, tri, t, lo_x, lo_y, cell, nx, ny)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                b = j * nx + i
                items[fill[b]] = t
                fill[b] += 1
    return start, items


@jit
def locate(uv, tri, start, items, lo_x, lo_y, cell, nx, ny, points, eps):
    """(triangle (P,) int64, barycentric (P, 3)) of every point; -1 where no triangle holds it."""
    p = points.shape[0]
    found = np.full(p, -1, np.int64)
    bary = np.zeros((p, 3))
    for k in range(p):
        x, y = points[k, 0], points[k, 1]
        i = int((x - lo_x) / cell)
        j = int((y - lo_y) / cell)
        if i < 0 or j < 0 or i >= nx or j >= ny:
            continue
        b = j * nx + i
        best = -1
        best_min = -np.inf
        for s in range(start[b], start[b + 1]):
            t = items[s]
            ax, ay = uv[tri[t, 0], 0], uv[tri[t, 0], 1]
            bx, by = uv[tri[t, 1], 0], uv[tri[t, 1], 1]
            cx, cy = uv[tri[t, 2], 0], uv[tri[t, 2], 1]
            d = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay)
            if d == 0.0:
                continue
            w1 = ((x - ax) * (cy - ay) - (cx - ax) * (y - ay)) / d
            w2 = ((bx - ax) * (y - ay) - (x - ax) * (by - ay)) / d
            w0 = 1.0 - w1 - w2
            low = min(w0, w1, w2)
            if low > best_min:  # the triangle the point is most inside of
                best_min = low
                best = t
                bary[k, 0], bary[k, 1], bary[k, 2] = w0, w1, w2
                if low >= 0.0:
                    break
        if best >= 0 and best_min >= -eps:
            found[k] = best
    return found, bary


def grid_for(uv: np.ndarray, n_items: int):
    """(lo_x, lo_y, cell, nx, ny) of a bucket grid of about one triangle per bucket over ``uv``."""
    lo = uv.min(axis=0)
    hi = uv.max(axis=0)
    span = np.maximum(hi - lo, 1e-12)
    cell = float(np.sqrt(span[0] * span[1] / max(n_items, 1))) or float(max(span))
    nx = int(span[0] / cell) + 1
    ny = int(span[1] / cell) + 1
    return float(lo[0]), float(lo[1]), cell, nx, ny
