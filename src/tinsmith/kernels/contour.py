"""Collapsed contouring (the Salt Lake City thesis, section 4.2): outlines through grid points, traced with N/S/E/W moves.

Buffer layout: grids are (H, W) row-major; a grid point is ``(row, col)``
and, in the traced coordinates, ``(x, y) = (col, row)``.  Square ``(i, j)``
is the unit square between points ``(i, j)``, ``(i, j + 1)``,
``(i + 1, j)`` and ``(i + 1, j + 1)``; it *qualifies* when its four corners
do.  A region is a set of qualifying squares connected through their edges;
its outline runs along the edges between its squares and the others, so it
passes through grid points only, never an interpolated one, and every step
is one of the four moves of the thesis.  A point that qualifies but lies
in no qualifying square (a one-point-wide spur) is on no outline.

Directions: 0 east (+x), 1 south (+y), 2 west, 3 north.  A directed
boundary edge has its region's square on its right (y pointing down the
rows), so outer rings and the rings of holes wind opposite ways.
"""

import numpy as np

from ._jit import jit, jit_inline

#: Unit steps (dx, dy) of the four directions.
DX = (1, 0, -1, 0)
DY = (0, 1, 0, -1)


@jit
def label_squares(point_ok, inside):
    """Label the regions: (labels (H-1, W-1) int32, 0 for none; their count).

    A square is in a region when its four corners are ``point_ok`` and
    ``inside[i, j]`` (the squares of the parent regions, or all True).
    Squares are joined through shared edges, by a stack flood fill: linear
    in the number of squares.
    """
    h, w = point_ok.shape
    hs, ws = h - 1, w - 1
    labels = np.zeros((hs, ws), np.int32)
    ok = np.zeros((hs, ws), np.bool_)
    for i in range(hs):
        for j in range(ws):
            ok[i, j] = inside[i, j] and point_ok[i, j] and point_ok[i, j + 1] and point_ok[i + 1, j] and point_ok[i + 1, j + 1]
    stack = np.empty(hs * ws, np.int64)
    n = 0
    for i0 in range(hs):
        for j0 in range(ws):
            if not ok[i0, j0] or labels[i0, j0]:
                continue
            n += 1
            labels[i0, j0] = n
            top = 0
            stack[top] = i0 * ws + j0
            top += 1
            while top > 0:
                top -= 1
                i, j = stack[top] // ws, stack[top] % ws
                for k in range(4):
                    a, b = i + DY[k], j + DX[k]
                    if 0 <= a < hs and 0 <= b < ws and ok[a, b] and labels[a, b] == 0:
                        labels[a, b] = n
                        stack[top] = a * ws + b
                        top += 1
    return labels, n


@jit_inline
def _square(labels, i, j):
    """The label of square (i, j), 0 outside the grid of squares."""
    if i < 0 or j < 0 or i >= labels.shape[0] or j >= labels.shape[1]:
        return 0
    return labels[i, j]


@jit_inline
def _around(labels, x, y, seen):
    """Write the distinct labels of the four squares around point (x, y) to ``seen`` (0 included); return how many."""
    m = 0
    for a, b in ((y - 1, x - 1), (y - 1, x), (y, x - 1), (y, x)):
        lab = _square(labels, a, b)
        new = True
        for k in range(m):
            if seen[k] == lab:
                new = False
        if new:
            seen[m] = lab
            m += 1
    return m


@jit_inline
def _sides(labels, x, y, d):
    """(label on the right, label on the left) of the edge leaving point (x, y) in direction ``d``."""
    if d == 0:
        return _square(labels, y, x), _square(labels, y - 1, x)
    if d == 1:
        return _square(labels, y, x - 1), _square(labels, y, x)
    if d == 2:
        return _square(labels, y - 1, x - 1), _square(labels, y, x - 1)
    return _square(labels, y - 1, x), _square(labels, y - 1, x - 1)


@jit_inline
def _is_boundary(labels, x, y, d, label):
    right, left = _sides(labels, x, y, d)
    return right == label and left != label


@jit
def trace(labels, n_labels, keep):
    """Every outline of every region, compressed to its corners.

    Returns ``(ring_label, ring_start, xy, n_points)``: ring ``r`` belongs
    to region ``ring_label[r]`` and its corners are
    ``xy[ring_start[r]:ring_start[r + 1]]`` (x = col, y = row, not closed);
    ``n_points[L]`` is the number of grid points of region ``L`` (corners
    of its squares; index 0 unused), the count the noise controller uses.

    Each boundary edge is walked once (a bit per point and direction), so
    the work is linear in the outline length.  At a point where two
    squares of the region meet only at a corner the walk turns right, so
    that every ring is simple.  A point is kept only where the direction
    changes (contour compression during the tracing), and where ``keep``
    (H, W) is True: the points where three regions meet, for outlines that
    must share their points (:func:`junctions`).
    """
    hs, ws = labels.shape
    h, w = hs + 1, ws + 1
    # grid points of each region (a point in squares of two regions counts for both)
    n_points = np.zeros(n_labels + 1, np.int64)
    seen = np.zeros(4, np.int64)
    for y in range(h):
        for x in range(w):
            for k in range(_around(labels, x, y, seen)):
                if seen[k]:
                    n_points[seen[k]] += 1
    visited = np.zeros((h, w), np.uint8)
    ring_label = []
    ring_start = [0]
    xs = []
    ys = []
    for i in range(hs):
        for j in range(ws):
            label = labels[i, j]
            if label == 0:
                continue
            # the square's four edges, each as (start point, direction) with the square on the right
            for x0, y0, d0 in ((j, i, 0), (j + 1, i, 1), (j + 1, i + 1, 2), (j, i + 1, 3)):
                if visited[y0, x0] & (1 << d0) or not _is_boundary(labels, x0, y0, d0, label):
                    continue
                # walk the ring, recording a point where the direction changes
                first = len(xs)
                x, y, d = x0, y0, d0
                last_d = -1
                while True:
                    visited[y, x] |= 1 << d
                    if d != last_d or keep[y, x]:
                        xs.append(x)
                        ys.append(y)
                    last_d = d
                    x, y = x + DX[d], y + DY[d]
                    for turn in (1, 0, 3):  # right, straight, left
                        if _is_boundary(labels, x, y, (d + turn) % 4, label):
                            d = (d + turn) % 4
                            break
                    if visited[y, x] & (1 << d):
                        break  # back on the first edge: the ring is closed
                if last_d == d0 and not keep[y0, x0]:  # the first point lies on a straight run: no corner
                    for k in range(first, len(xs) - 1):
                        xs[k] = xs[k + 1]
                        ys[k] = ys[k + 1]
                    xs.pop()
                    ys.pop()
                ring_label.append(label)
                ring_start.append(len(xs))
    xy = np.empty((len(xs), 2), np.int64)
    for k in range(len(xs)):
        xy[k, 0] = xs[k]
        xy[k, 1] = ys[k]
    return np.array(ring_label, np.int64), np.array(ring_start, np.int64), xy, n_points


@jit
def junctions(labels):
    """(H, W) bool: the grid points where the squares around meet three or more labels (0 counts as one)."""
    hs, ws = labels.shape
    out = np.zeros((hs + 1, ws + 1), np.bool_)
    seen = np.zeros(4, np.int64)
    for y in range(hs + 1):
        for x in range(ws + 1):
            out[y, x] = _around(labels, x, y, seen) >= 3
    return out


@jit
def fill_pinches(owner, rank):
    """Remove the points where two blocks would touch along a vertical line only, in place; return the squares changed.

    At a point where two diagonal squares belong to one face, or where the
    two diagonal faces are both higher (``rank``, by face + 1) than both
    others, the walls of a block model would meet four to an edge: no
    manifold.  One of the other two squares joins the higher diagonal;
    repeated until no such point is left (each change raises a square, so
    it ends).
    """
    hs, ws = owner.shape
    changed = 0
    dirty = True
    while dirty:
        dirty = False
        for i in range(hs - 1):
            for j in range(ws - 1):
                a, b, c, d = owner[i, j], owner[i, j + 1], owner[i + 1, j], owner[i + 1, j + 1]
                ra, rb, rc, rd = rank[a + 1], rank[b + 1], rank[c + 1], rank[d + 1]
                main = (a == d and b != a and c != a) or min(ra, rd) > max(rb, rc)
                anti = (b == c and a != b and d != b) or min(rb, rc) > max(ra, rd)
                if not (main or anti):
                    continue
                if main and (not anti or max(ra, rd) >= max(rb, rc)):
                    owner[i, j + 1] = a if ra >= rd else d
                else:
                    owner[i, j] = b if rb >= rc else c
                changed += 1
                dirty = True
    return changed


@jit
def chamfer_depth(labels):
    """(H-1, W-1) float64: for each square of a region, its distance in squares to the nearest square outside it.

    Two passes of the 3-4 chamfer mask (Borgefors), divided by 3: about the
    Euclidean distance, linear time.  Twice the largest value of a region
    is its width, in cells.
    """
    hs, ws = labels.shape
    big = 3.0 * (hs + ws + 2)
    dist = np.empty((hs, ws))
    for i in range(hs):
        for j in range(ws):
            dist[i, j] = big if labels[i, j] else 0.0
    for i in range(hs):
        for j in range(ws):
            if dist[i, j] == 0.0:
                continue
            lab = labels[i, j]
            best = dist[i, j]
            for di, dj, c in ((-1, -1, 4.0), (-1, 0, 3.0), (-1, 1, 4.0), (0, -1, 3.0)):
                a, b = i + di, j + dj
                v = 0.0 if (a < 0 or b < 0 or b >= ws or labels[a, b] != lab) else dist[a, b]
                best = min(best, v + c)
            dist[i, j] = best
    for i in range(hs - 1, -1, -1):
        for j in range(ws - 1, -1, -1):
            if dist[i, j] == 0.0:
                continue
            lab = labels[i, j]
            best = dist[i, j]
            for di, dj, c in ((1, 1, 4.0), (1, 0, 3.0), (1, -1, 4.0), (0, 1, 3.0)):
                a, b = i + di, j + dj
                v = 0.0 if (a >= hs or b < 0 or b >= ws or labels[a, b] != lab) else dist[a, b]
                best = min(best, v + c)
            dist[i, j] = best
    return dist / 3.0
