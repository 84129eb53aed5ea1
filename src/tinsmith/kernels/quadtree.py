"""Right-triangulated irregular network (RTIN) on a (2^k + 1)-square grid, after Martini.

Triangles are the nodes of an implicit binary tree, as in Martini (mapbox):
the square splits along its diagonal into two right isosceles triangles,
and a triangle (a, b, c) with hypotenuse a-b and right angle at c splits at
the midpoint m of a-b into (c, a, m) and (b, c, m).  Triangle ``i`` of the
tree (``0 <= i < 2 * (size - 1)**2 - 2``) is decoded from the bits of
``i + 2``; the leaves have legs of sqrt(2) cells and a grid point at the
middle of their hypotenuse, and split once more, at extraction, into the
triangles of one cell (which hold their corners only).  A triangle is split when the error stored at its hypotenuse
midpoint exceeds the bound; that error is shared with the triangle across
the hypotenuse and includes the errors of the midpoints below, so that
neighbours split together and the mesh has no T-junction.

Grid layout: ``z`` float32 or float64 (size * size,), ``valid`` uint8, row
major; x is the column, y the row.
"""

import numpy as np

from ._jit import jit, jit_inline
from .raster import interpolate

#: the error of a triangle that holds both cells with and without data: it must split
MIXED = np.inf


@jit_inline
def decode(i, tile):
    """Corners (ax, ay, bx, by, cx, cy) of triangle ``i`` of the tree (hypotenuse a-b, right angle at c)."""
    t = i + 2
    ax = ay = bx = by = cx = cy = 0
    if t & 1:
        bx = by = cx = tile  # bottom-left triangle
    else:
        ax = ay = cy = tile  # top-right triangle
    t >>= 1
    while t > 1:
        mx = (ax + bx) >> 1
        my = (ay + by) >> 1
        if t & 1:  # left half
            bx, by = ax, ay
            ax, ay = cx, cy
        else:  # right half
            ax, ay = bx, by
            bx, by = cx, cy
        cx, cy = mx, my
        t >>= 1
    return ax, ay, bx, by, cx, cy


@jit_inline
def _triangle_error(z, valid, size, all_valid, ax, ay, bx, by, cx, cy):
    """Largest |mesh - z| over the cells of the closed triangle (a, b, c), interpolated from a.

    The expression of :func:`.raster.interpolate` with the corner order the
    mesh is written in, so the metrics measure the same bits.  MIXED when
    the triangle holds cells with and without data, 0 when it holds none
    with data.
    """
    x0, y0, x1, y1, x2, y2 = ax, ay, bx, by, cx, cy
    di = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    d = float(di)
    z0 = np.float64(z[y0 * size + x0])
    z1 = np.float64(z[y1 * size + x1])
    z2 = np.float64(z[y2 * size + x2])
    k1 = (z1 - z0) / d
    k2 = (z2 - z0) / d
    r_lo, r_hi = min(y0, y1, y2), max(y0, y1, y2)
    c_lo, c_hi = min(x0, x1, x2), max(x0, x1, x2)
    best = 0.0
    n_valid = n_invalid = 0
    for r in range(r_lo, r_hi + 1):
        for c in range(c_lo, c_hi + 1):
            w1 = (c - x0) * (y2 - y0) - (x2 - x0) * (r - y0)
            w2 = (x1 - x0) * (r - y0) - (c - x0) * (y1 - y0)
            w0 = di - w1 - w2
            inside = (w0 >= 0 and w1 >= 0 and w2 >= 0) if di > 0 else (w0 <= 0 and w1 <= 0 and w2 <= 0)
            if not inside:
                continue
            k = r * size + c
            if not (all_valid or valid[k]):
                n_invalid += 1
                continue
            n_valid += 1
            e = abs(interpolate(z0, z1, z2, float(w1), float(w2), d, k1, k2) - z[k])
            if e > best:
                best = e
    if n_invalid and n_valid:
        return MIXED
    return best


@jit_inline
def _clip(ax, ay, bx, by, cx, cy, right, bottom, poly):
    """Clip triangle (a, b, c) to x <= right, y <= bottom; the polygon's corners go to ``poly`` (x, y pairs), count returned.

    Sutherland-Hodgman against the two lines.  The tree's edges run along
    the axes or at 45 degrees, so every corner of the result is a grid
    point; a corner on a line is kept once.
    """
    n = 3
    poly[0], poly[1], poly[2], poly[3], poly[4], poly[5] = ax, ay, bx, by, cx, cy
    out = poly[16:32]
    for axis in range(2):
        limit = right if axis == 0 else bottom
        m = 0
        for i in range(n):
            px, py = poly[2 * i], poly[2 * i + 1]
            j = (i + 1) % n
            qx, qy = poly[2 * j], poly[2 * j + 1]
            p_in = (px if axis == 0 else py) <= limit
            q_in = (qx if axis == 0 else qy) <= limit
            if p_in:
                out[2 * m], out[2 * m + 1] = px, py
                m += 1
            if p_in != q_in:
                pv, qv = (px, qx) if axis == 0 else (py, qy)
                if pv != limit and qv != limit:  # the crossing is strictly between: a grid point
                    if axis == 0:
                        out[2 * m], out[2 * m + 1] = limit, py + (qy - py) * (limit - px) // (qx - px)
                    else:
                        out[2 * m], out[2 * m + 1] = px + (qx - px) * (limit - py) // (qy - py), limit
                    m += 1
        n = m
        for k in range(2 * n):
            poly[k] = out[k]
    return n


@jit_inline
def _inside_data(ax, ay, bx, by, cx, cy, right, bottom):
    return max(ax, bx, cx) <= right and max(ay, by, cy) <= bottom


@jit_inline
def _clipped_error(z, valid, size, all_valid, right, bottom, ax, ay, bx, by, cx, cy):
    """:func:`_triangle_error` of the triangle cut back to the data (a fan from the polygon's first corner)."""
    if _inside_data(ax, ay, bx, by, cx, cy, right, bottom):
        return _triangle_error(z, valid, size, all_valid, ax, ay, bx, by, cx, cy)
    poly = np.empty(32, dtype=np.int64)  # only for the triangles along the cut
    n = _clip(ax, ay, bx, by, cx, cy, right, bottom, poly)
    best = 0.0
    for i in range(1, n - 1):
        x0, y0, x1, y1, x2, y2 = poly[0], poly[1], poly[2 * i], poly[2 * i + 1], poly[2 * i + 2], poly[2 * i + 3]
        if (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0) != 0:
            best = max(best, _triangle_error(z, valid, size, all_valid, x0, y0, x1, y1, x2, y2))
    return best


@jit_inline
def _node_error(z, valid, size, all_valid, strict, errors, right, bottom, ax, ay, bx, by, cx, cy, parent):
    """Add the split error of triangle (a, b, c) to its hypotenuse midpoint; ``parent``: it has children."""
    mid = ((ay + by) >> 1) * size + ((ax + bx) >> 1)
    if strict:
        errors[mid] = max(errors[mid], _clipped_error(z, valid, size, all_valid, right, bottom, ax, ay, bx, by, cx, cy))
    elif _inside_data(ax, ay, bx, by, cx, cy, right, bottom):
        # in float64 from float32 heights, stored as float32: Martini's (and pymartini's) arithmetic
        za, zb = np.float64(np.float32(z[ay * size + ax])), np.float64(np.float32(z[by * size + bx]))
        e = abs((za + zb) / 2.0 - np.float64(np.float32(z[mid])))
        if not all_valid and _triangle_error(z, valid, size, False, ax, ay, bx, by, cx, cy) == MIXED:
            e = np.inf
        errors[mid] = max(np.float64(errors[mid]), e)
    else:  # Martini has no grids to cut back to: the error of the cut triangle
        cut = _clipped_error(z, valid, size, all_valid, right, bottom, ax, ay, bx, by, cx, cy)
        errors[mid] = max(np.float64(errors[mid]), cut)
    if parent:
        left = ((ay + cy) >> 1) * size + ((ax + cx) >> 1)
        right_ = ((by + cy) >> 1) * size + ((bx + cx) >> 1)
        errors[mid] = max(errors[mid], errors[left], errors[right_])


@jit
def hierarchy_errors(z, valid, size, all_valid, strict, errors, right, bottom):
    """Fill ``errors`` (size * size, zeros; float64 when strict, float32 not) with the split test of every grid point.

    The error at a grid point decides the split of the triangles whose
    hypotenuse it halves.  ``strict=False`` is Martini's estimate, to the
    last bit: the height at the hypotenuse midpoint against the mean of the
    hypotenuse ends (heights as float32, arithmetic in float64, errors
    stored as float32, as Martini and pymartini do), propagated up from the
    children.  ``strict=True`` takes instead the largest error over every
    cell the triangle covers, so that an unsplit triangle never exceeds the
    bound.  With cells without data (both modes) a triangle that holds some
    is MIXED (it always splits) unless it holds no cell with data.  A
    triangle reaching beyond the data (columns past ``right``, rows past
    ``bottom``: the padding up to the (2^k + 1)-square) is measured as the
    fan it is written as, cut back to the data (:func:`_clip`).

    The levels of the tree are visited from the finest up, as Martini's
    loop over the tree indices does (a grid point halves the hypotenuses of
    one level only, so the order within a level does not matter), each by a
    walk down from the roots that steps the corners: about four visits per
    triangle instead of decoding every index bit by bit.
    """
    tile = size - 1
    deepest = 0
    while (2 << deepest) < tile * tile:  # both roots together have 2 ** (deepest + 1) = tile**2 leaves
        deepest += 1
    stack = np.empty(7 * 2 * (deepest + 2), dtype=np.int64)
    for level in range(deepest, -1, -1):
        stack[0:7] = (tile, tile, 0, 0, 0, tile, 0)
        stack[7:14] = (0, 0, tile, tile, tile, 0, 0)
        top = 14
        while top > 0:
            top -= 7
            ax, ay, bx, by = stack[top], stack[top + 1], stack[top + 2], stack[top + 3]
            cx, cy, depth = stack[top + 4], stack[top + 5], stack[top + 6]
            if depth == level:
                _node_error(z, valid, size, all_valid, strict, errors, right, bottom, ax, ay, bx, by, cx, cy, level < deepest)
                continue
            mx, my = (ax + bx) >> 1, (ay + by) >> 1
            stack[top], stack[top + 1], stack[top + 2], stack[top + 3] = cx, cy, ax, ay
            stack[top + 4], stack[top + 5], stack[top + 6] = mx, my, depth + 1
            stack[top + 7], stack[top + 8], stack[top + 9], stack[top + 10] = bx, by, cx, cy
            stack[top + 11], stack[top + 12], stack[top + 13] = mx, my, depth + 1
            top += 14


@jit_inline
def _vertex(g, lookup, stamp, vertices, n_points, z, size, t):
    """(the vertex number of grid point ``g``, the vertex count); a new vertex on first use."""
    if lookup[g, 0] == stamp:
        return lookup[g, 1], n_points
    lookup[g, 0] = stamp
    lookup[g, 1] = n_points
    col = float(g % size) + 0.5
    row = float(g // size) + 0.5
    vertices[n_points, 0] = t[0] * col + t[1] * row + t[2]
    vertices[n_points, 1] = t[3] * col + t[4] * row + t[5]
    vertices[n_points, 2] = np.float64(z[g])
    return n_points, n_points + 1


@jit
def extract(errors, z, valid, size, all_valid, max_error, lookup, stamp, transform, flip, right, bottom):
    """The mesh at ``max_error``: vertices (V, 3) in world coordinates and triangles (M, 3), corner a first.

    A triangle splits while its legs are longer than one cell and the error
    at its hypotenuse midpoint exceeds ``max_error``; a triangle kept with a
    corner without data is left out (a MIXED triangle never is kept above
    the finest level).  Depth first, in Martini's order.

    Vertices are numbered in order of first use and written at once:
    ``lookup`` (size * size, 2) int32 holds, per grid point, the ``stamp``
    of the extraction that numbered it last and its number, so that it
    never needs clearing (a new stamp per extraction).  ``transform`` is the
    (a, b, c, d, e, f) of :meth:`Heightfield.pixel_to_world` (the same
    arithmetic, so the same bits); ``flip`` writes the triangles (a, c, b),
    counter-clockwise in the world when the transform keeps the orientation
    of (col, row).  A triangle reaching past column ``right`` or row
    ``bottom`` is cut back to the data and written as a fan.
    """
    tile = size - 1
    # every split adds one triangle, and a grid point halves at most two hypotenuses;
    # the arrays are only touched as far as they are filled
    over = 0
    for k in range(len(errors)):
        if errors[k] > max_error:
            over += 1
    cut = right < tile or bottom < tile  # a cut triangle becomes up to three
    bound = (2 + 2 * over) * (3 if cut else 1)
    tris = np.empty(3 * bound, dtype=np.int64)
    vertices = np.empty((3 * bound, 3), dtype=np.float64)
    poly = np.empty(32, dtype=np.int64)
    pieces = np.empty(9, dtype=np.int64)
    n = n_points = 0
    # frames of six corner coordinates; the depth is at most 2 log2(tile) + 2
    stack = np.empty(6 * 160, dtype=np.int64)
    stack[0:6] = (tile, tile, 0, 0, 0, tile)
    stack[6:12] = (0, 0, tile, tile, tile, 0)
    top = 12
    while top > 0:
        top -= 6
        ax, ay, bx, by = stack[top], stack[top + 1], stack[top + 2], stack[top + 3]
        cx, cy = stack[top + 4], stack[top + 5]
        mx, my = (ax + bx) >> 1, (ay + by) >> 1
        if abs(ax - cx) + abs(ay - cy) > 1 and errors[my * size + mx] > max_error:
            # (b, c, m) below (c, a, m) on the stack, so that (c, a, m) comes out first, as Martini recurses
            stack[top], stack[top + 1], stack[top + 2], stack[top + 3] = bx, by, cx, cy
            stack[top + 4], stack[top + 5] = mx, my
            stack[top + 6], stack[top + 7], stack[top + 8], stack[top + 9] = cx, cy, ax, ay
            stack[top + 10], stack[top + 11] = mx, my
            top += 12
            continue
        # the triangle, or the fan of its part in the data, as grid points
        if not cut or _inside_data(ax, ay, bx, by, cx, cy, right, bottom):
            pieces[0], pieces[1], pieces[2] = ay * size + ax, by * size + bx, cy * size + cx
            n_pieces = 1
        else:
            k = _clip(ax, ay, bx, by, cx, cy, right, bottom, poly)
            n_pieces = 0
            for i in range(1, k - 1):
                x0, y0, x1, y1 = poly[0], poly[1], poly[2 * i], poly[2 * i + 1]
                x2, y2 = poly[2 * i + 2], poly[2 * i + 3]
                if (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0) != 0:
                    pieces[3 * n_pieces] = y0 * size + x0
                    pieces[3 * n_pieces + 1] = y1 * size + x1
                    pieces[3 * n_pieces + 2] = y2 * size + x2
                    n_pieces += 1
        for i in range(n_pieces):
            a, b, c = pieces[3 * i], pieces[3 * i + 1], pieces[3 * i + 2]
            if not all_valid and not (valid[a] and valid[b] and valid[c]):
                continue
            if flip:
                b, c = c, b
            tris[3 * n], n_points = _vertex(a, lookup, stamp, vertices, n_points, z, size, transform)
            tris[3 * n + 1], n_points = _vertex(b, lookup, stamp, vertices, n_points, z, size, transform)
            tris[3 * n + 2], n_points = _vertex(c, lookup, stamp, vertices, n_points, z, size, transform)
            n += 1
    return vertices[:n_points], tris[: 3 * n].reshape(n, 3)
