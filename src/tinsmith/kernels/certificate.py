"""A terrain tile's error against a window of DEM cells, in one pass (:mod:`tinsmith.tiles.certificate`).

For every cell of the window with a height, its centre's longitude and
latitude come bilinearly from a lattice of exactly transformed points (the
weights per row and per column are given); a centre inside the tile's
bounds is located in the tile's mesh (bucket grid of :mod:`.locate`, the
triangle that held the previous cell tried first: neighbouring cells mostly
fall in the same triangle) and the mesh's height there, barycentric over the
decoded heights as CesiumJS interpolates, is compared with the cell's.

Layout: ``expected`` float64 (rows, cols), NaN where there is no data;
``lon``/``lat`` float64 lattice (lattice rows, lattice columns); ``ri``,
``rt`` (rows,) and ``cj``, ``cu`` (cols,) the lattice interval of each row
and column and the weight of its far end (``dr``, ``dc``: 1, or 0 for a
lattice of one line); ``uv`` float64 (V, 2) in node units, ``tri`` int64
(M, 3), ``start``/``items`` of :func:`.locate.build`.
"""

import numpy as np

from ._jit import jit, jit_inline


@jit_inline
def _weights(uv, tri, t, x, y):
    """Barycentric coordinates of (x, y) in triangle t, and False for a degenerate triangle."""
    ax, ay = uv[tri[t, 0], 0], uv[tri[t, 0], 1]
    bx, by = uv[tri[t, 1], 0], uv[tri[t, 1], 1]
    cx, cy = uv[tri[t, 2], 0], uv[tri[t, 2], 1]
    d = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay)
    if d == 0.0:
        return 0.0, 0.0, 0.0, False
    w1 = ((x - ax) * (cy - ay) - (cx - ax) * (y - ay)) / d
    w2 = ((bx - ax) * (y - ay) - (x - ax) * (by - ay)) / d
    return 1.0 - w1 - w2, w1, w2, True


@jit
def cell_errors(expected, offset, lon, lat, ri, rt, dr, cj, cu, dc, west, south, east, north, scale,
                uv, tri, heights, start, items, lo_x, lo_y, cell, nx, ny, eps):
    """(largest |mesh - (expected + offset)|, cells held by a triangle, cells in the bounds held by none)."""
    worst = 0.0
    hits = 0
    missed = 0
    last = -1
    n_rows, n_cols = expected.shape
    for r in range(n_rows):
        i, t = ri[r], rt[r]
        for c in range(n_cols):
            h = expected[r, c]
            if not np.isfinite(h):
                continue
            j, u = cj[c], cu[c]
            # each lattice row at this column, then between the rows (the order of the vectorised version)
            lo0 = lon[i, j] * (1 - u) + lon[i, j + dc] * u
            lo1 = lon[i + dr, j] * (1 - u) + lon[i + dr, j + dc] * u
            la0 = lat[i, j] * (1 - u) + lat[i, j + dc] * u
            la1 = lat[i + dr, j] * (1 - u) + lat[i + dr, j + dc] * u
            x_lon = lo0 * (1 - t) + lo1 * t
            y_lat = la0 * (1 - t) + la1 * t
            if not (x_lon >= west and x_lon <= east and y_lat >= south and y_lat <= north):
                continue
            x, y = (x_lon - west) / scale, (north - y_lat) / scale
            found = -1
            w0 = w1 = w2 = 0.0
            if last >= 0:
                a0, a1, a2, ok = _weights(uv, tri, last, x, y)
                if ok and a0 >= 0.0 and a1 >= 0.0 and a2 >= 0.0:
                    found, w0, w1, w2 = last, a0, a1, a2
            if found < 0:
                bi = int((x - lo_x) / cell)
                bj = int((y - lo_y) / cell)
                if bi >= 0 and bj >= 0 and bi < nx and bj < ny:
                    b = bj * nx + bi
                    best_min = -np.inf
                    for s in range(start[b], start[b + 1]):
                        k = items[s]
                        a0, a1, a2, ok = _weights(uv, tri, k, x, y)
                        if not ok:
                            continue
                        low = min(a0, a1, a2)
                        if low > best_min:  # the triangle the point is most inside of
                            best_min = low
                            found, w0, w1, w2 = k, a0, a1, a2
                            if low >= 0.0:
                                break
                    if found >= 0 and best_min < -eps:
                        found = -1
            if found < 0:
                missed += 1
                continue
            last = found
            hits += 1
            mesh = heights[tri[found, 0]] * w0 + heights[tri[found, 1]] * w1 + heights[tri[found, 2]] * w2
            e = abs(mesh - (h + offset))
            if e > worst:
                worst = e
    return worst, hits, missed
