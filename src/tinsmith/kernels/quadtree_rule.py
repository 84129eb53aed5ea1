"""Restricted quadtree of squares cut by Goebbels and Pohle-Fröhlich (2015)'s diagonal rule, with fans where a neighbour is finer.

Goebbels and Pohle-Fröhlich (2015) (section 2) splits a square into four while its two triangles
deviate more than the bound from the heights, and cuts every square along
the diagonal of formula 1 (the one that does not end at the corner whose
height is furthest from the mean of the four).  Its quadtree is not
crack-free: a square next to finer ones has corners of theirs in the middle
of its edges.  Here the quadtree is *restricted* (neighbouring leaves differ
by one level at most) and a leaf with a finer neighbour is cut instead into
a fan around its centre, through the middle of each edge whose neighbour is
split: no T-junction anywhere.

Squares: level ``l`` (0 = the whole grid) has ``2**l`` x ``2**l`` squares of
side ``(size - 1) >> l`` cells; square ``(l, i, j)`` (row ``i``, column
``j``) is entry ``(4**l - 1) // 3 + i * 2**l + j`` of the flat arrays.

- ``rule_err`` float64: the largest error over the cells of the square cut
  by the rule (MIXED when it holds cells with and without data);
- ``fan_err`` float64: the largest error of any fan the square can be cut
  into (each edge with or without its middle), so that a leaf cut into
  whatever fan its neighbours ask for keeps the bound.

Both are computed once per grid (:func:`square_errors`); :func:`extract`
builds the leaves for a bound.  Grid layout as :mod:`.quadtree`: ``z`` and
``valid`` (size * size,), x the column, y the row.  Every triangle is
written clockwise in (col, row), corner order as measured (the first corner
is the one :func:`.quadtree._triangle_error` interpolates from).
"""

import numpy as np

from ._jit import jit, jit_inline
from .quadtree import _clip, _clipped_error, _vertex

#: ``state`` values of a square in :func:`extract` (stored as ``stamp * 4 + state``).
ABSENT, LEAF, SPLIT = 0, 1, 2


@jit_inline
def offset(level):
    return ((1 << (2 * level)) - 1) // 3


@jit_inline
def main_diagonal(z, size, r0, c0, r1, c1):
    """Formula 1 of Goebbels and Pohle-Fröhlich (2015): cut along (r0, c0)-(r1, c1) (else along the other diagonal)."""
    za, zb = np.float64(z[r0 * size + c0]), np.float64(z[r0 * size + c1])
    zc, zd = np.float64(z[r1 * size + c0]), np.float64(z[r1 * size + c1])
    mean = (za + zb + zc + zd) / 4.0
    return max(abs(za - mean), abs(zd - mean)) < max(abs(zb - mean), abs(zc - mean))


@jit_inline
def _corners(c0, r0, c1, r1, k):
    """Corner ``k`` (0..3) of a square in the clockwise order (col, row): (c0, r0), (c0, r1), (c1, r1), (c1, r0)."""
    if k == 0:
        return c0, r0
    if k == 1:
        return c0, r1
    if k == 2:
        return c1, r1
    return c1, r0


@jit
def square_errors(z, valid, size, all_valid, levels, right, bottom):
    """(rule_err, fan_err) of every square of every level (see the module docstring).

    A square reaching past the last column ``right`` or row ``bottom`` of
    the data is measured as its triangles cut back to the data (fans, as
    :func:`.quadtree._clipped_error` and :func:`_emit` write them).
    """
    total = offset(levels + 1)
    rule_err = np.zeros(total)
    fan_err = np.zeros(total)
    for level in range(levels + 1):
        n = 1 << level
        side = (size - 1) >> level
        base = offset(level)
        for i in range(n):
            for j in range(n):
                r0, c0 = i * side, j * side
                r1, c1 = r0 + side, c0 + side
                if main_diagonal(z, size, r0, c0, r1, c1):
                    e = max(_clipped_error(z, valid, size, all_valid, right, bottom, c0, r0, c0, r1, c1, r1),
                            _clipped_error(z, valid, size, all_valid, right, bottom, c0, r0, c1, r1, c1, r0))
                else:
                    e = max(_clipped_error(z, valid, size, all_valid, right, bottom, c0, r0, c0, r1, c1, r0),
                            _clipped_error(z, valid, size, all_valid, right, bottom, c1, r0, c0, r1, c1, r1))
                rule_err[base + i * n + j] = e
                if side < 2:
                    continue
                cc, rc = c0 + side // 2, r0 + side // 2
                f = 0.0
                for k in range(4):
                    px, py = _corners(c0, r0, c1, r1, k)
                    qx, qy = _corners(c0, r0, c1, r1, (k + 1) % 4)
                    mx, my = (px + qx) // 2, (py + qy) // 2
                    f = max(f, _clipped_error(z, valid, size, all_valid, right, bottom, cc, rc, px, py, qx, qy))
                    f = max(f, _clipped_error(z, valid, size, all_valid, right, bottom, cc, rc, px, py, mx, my))
                    f = max(f, _clipped_error(z, valid, size, all_valid, right, bottom, cc, rc, mx, my, qx, qy))
                fan_err[base + i * n + j] = f
    return rule_err, fan_err


@jit_inline
def _state(state, stamp, idx):
    v = state[idx]
    return v & 3 if (v >> 2) == stamp else ABSENT


@jit_inline
def _set(state, stamp, idx, s):
    state[idx] = stamp * 4 + s


@jit_inline
def _refine(level, i, j, levels, rule_err, max_error, state, stamp, nxt, head, stack):
    """Make square (level, i, j) a leaf, or split it and its children while the rule error exceeds the bound."""
    stack[0], stack[1], stack[2] = level, i, j
    top = 3
    while top > 0:
        top -= 3
        lv, a, b = stack[top], stack[top + 1], stack[top + 2]
        n = 1 << lv
        idx = offset(lv) + a * n + b
        if lv < levels and rule_err[idx] > max_error:
            _set(state, stamp, idx, SPLIT)
            for da in range(2):
                for db in range(2):
                    stack[top], stack[top + 1], stack[top + 2] = lv + 1, 2 * a + da, 2 * b + db
                    top += 3
        else:
            _set(state, stamp, idx, LEAF)
            nxt[idx] = head[lv]
            head[lv] = idx


@jit_inline
def _split(level, i, j, levels, rule_err, max_error, state, stamp, nxt, head, stack):
    """Split leaf (level, i, j); its children are refined by the rule."""
    n = 1 << level
    _set(state, stamp, offset(level) + i * n + j, SPLIT)
    for da in range(2):
        for db in range(2):
            _refine(level + 1, 2 * i + da, 2 * j + db, levels, rule_err, max_error, state, stamp, nxt, head, stack)


@jit_inline
def _neighbour_split(level, i, j, k, state, stamp):
    """Whether the neighbour of square (level, i, j) across edge ``k`` (see :func:`_corners`) is split."""
    n = 1 << level
    if k == 0:
        j -= 1
    elif k == 1:
        i += 1
    elif k == 2:
        j += 1
    else:
        i -= 1
    if i < 0 or j < 0 or i >= n or j >= n:
        return False
    return _state(state, stamp, offset(level) + i * n + j) == SPLIT


@jit_inline
def _needs_fan(level, i, j, state, stamp):
    for k in range(4):
        if _neighbour_split(level, i, j, k, state, stamp):
            return True
    return False


@jit
def extract(rule_err, fan_err, z, valid, size, all_valid, levels, max_error, state, stamp, lookup, transform, flip,
            right, bottom):
    """The mesh at ``max_error``: vertices (V, 3) in world coordinates and triangles (M, 3).

    ``state`` (one int32 a square) and ``lookup`` (as in
    :func:`.quadtree.extract`) are scratch arrays that never need clearing:
    ``stamp`` is new for every call.  The leaves are found top-down by
    ``rule_err``; then, until nothing changes, the quadtree is restricted
    (from the finest level up, a leaf whose edge neighbour lies inside a
    leaf two or more levels coarser has that leaf split) and a leaf that
    must be a fan is split when ``fan_err`` exceeds the bound.
    """
    nxt = np.full(len(rule_err), -1, np.int32)  # leaves of a level, linked
    head = np.full(levels + 1, -1, np.int64)
    stack = np.empty(3 * (3 * levels + 8), np.int64)
    _refine(0, 0, 0, levels, rule_err, max_error, state, stamp, nxt, head, stack)
    changed = True
    while changed:
        changed = False
        for level in range(levels, 1, -1):
            n = 1 << level
            idx = head[level]
            while idx >= 0:
                if _state(state, stamp, idx) == LEAF:
                    local = idx - offset(level)
                    i, j = local // n, local % n
                    for di, dj in ((0, -1), (1, 0), (0, 1), (-1, 0)):
                        ni, nj = i + di, j + dj
                        if ni < 0 or nj < 0 or ni >= n or nj >= n:
                            continue
                        # the square one level up that holds the neighbour must exist
                        plevel, pi, pj = level - 1, ni >> 1, nj >> 1
                        if _state(state, stamp, offset(plevel) + pi * (n >> 1) + pj) != ABSENT:
                            continue
                        m, mi, mj = plevel, pi, pj
                        while _state(state, stamp, offset(m) + mi * (1 << m) + mj) == ABSENT:
                            m, mi, mj = m - 1, mi >> 1, mj >> 1
                        while m < plevel:  # split the coarse leaf, and the leaves on the way, down to plevel
                            if _state(state, stamp, offset(m) + mi * (1 << m) + mj) == LEAF:
                                _split(m, mi, mj, levels, rule_err, max_error, state, stamp, nxt, head, stack)
                            m += 1
                            mi, mj = pi >> (plevel - m), pj >> (plevel - m)
                        changed = True
                idx = nxt[idx]
        if changed:
            continue
        for level in range(levels):
            n = 1 << level
            idx = head[level]
            while idx >= 0:
                if _state(state, stamp, idx) == LEAF and fan_err[idx] > max_error:
                    local = idx - offset(level)
                    i, j = local // n, local % n
                    if _needs_fan(level, i, j, state, stamp):
                        _split(level, i, j, levels, rule_err, max_error, state, stamp, nxt, head, stack)
                        changed = True
                idx = nxt[idx]
    return _emit(z, valid, size, all_valid, levels, state, stamp, nxt, head, lookup, transform, flip, right, bottom)


@jit_inline
def _put(tris, n, a, b, c, flip):
    tris[3 * n] = a
    tris[3 * n + 1] = c if flip else b
    tris[3 * n + 2] = b if flip else c
    return n + 1


@jit_inline
def _put_cut(tris, n, ax, ay, bx, by, cx, cy, size, right, bottom, valid, all_valid, poly, flip):
    """Put triangle (a, b, c), cut back to the data when it reaches past ``right`` or ``bottom``: the fan
    from the first corner of the cut polygon, as :func:`.quadtree._clipped_error` measures it."""
    if max(ax, bx, cx) <= right and max(ay, by, cy) <= bottom:
        m = 3
        poly[0], poly[1], poly[2], poly[3], poly[4], poly[5] = ax, ay, bx, by, cx, cy
    else:
        m = _clip(ax, ay, bx, by, cx, cy, right, bottom, poly)
    for i in range(1, m - 1):
        x0, y0, x1, y1, x2, y2 = poly[0], poly[1], poly[2 * i], poly[2 * i + 1], poly[2 * i + 2], poly[2 * i + 3]
        if (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0) == 0:
            continue
        p0, p1, p2 = y0 * size + x0, y1 * size + x1, y2 * size + x2
        if all_valid or (valid[p0] and valid[p1] and valid[p2]):  # else the piece holds no data (not MIXED)
            n = _put(tris, n, p0, p1, p2, flip)
    return n


@jit
def _emit(z, valid, size, all_valid, levels, state, stamp, nxt, head, lookup, transform, flip, right, bottom):
    """Triangles of every leaf, as grid points; then numbered, with world coordinates (see :func:`.quadtree._vertex`).

    A leaf past the data is left out; one across its last row or column is
    written cut back to the data (:func:`_put_cut`).
    """
    n_leaves = 0
    n_cut = 0
    for level in range(levels + 1):
        side = (size - 1) >> level
        width = 1 << level
        idx = head[level]
        while idx >= 0:
            if _state(state, stamp, idx) == LEAF:
                n_leaves += 1
                local = idx - offset(level)
                r0, c0 = (local // width) * side, (local % width) * side
                n_cut += r0 + side > bottom or c0 + side > right
            idx = nxt[idx]
    tris = np.empty(3 * 8 * n_leaves + 3 * 16 * n_cut, np.int64)  # a cut triangle is at most three pieces
    poly = np.empty(32, np.int64)
    n = 0
    for level in range(levels + 1):
        side = (size - 1) >> level
        width = 1 << level
        idx = head[level]
        while idx >= 0:
            if _state(state, stamp, idx) != LEAF:
                idx = nxt[idx]
                continue
            local = idx - offset(level)
            i, j = local // width, local % width
            r0, c0 = i * side, j * side
            r1, c1 = r0 + side, c0 + side
            if r0 >= bottom or c0 >= right:  # past the data (at most a line of it)
                idx = nxt[idx]
                continue
            if r1 > bottom or c1 > right:  # across the data's last row or column: cut back
                if side >= 2 and _needs_fan(level, i, j, state, stamp):
                    cx, cy = c0 + side // 2, r0 + side // 2
                    for k in range(4):
                        px, py = _corners(c0, r0, c1, r1, k)
                        qx, qy = _corners(c0, r0, c1, r1, (k + 1) % 4)
                        if _neighbour_split(level, i, j, k, state, stamp):
                            mx, my = (px + qx) // 2, (py + qy) // 2
                            n = _put_cut(tris, n, cx, cy, px, py, mx, my, size, right, bottom, valid, all_valid, poly, flip)
                            n = _put_cut(tris, n, cx, cy, mx, my, qx, qy, size, right, bottom, valid, all_valid, poly, flip)
                        else:
                            n = _put_cut(tris, n, cx, cy, px, py, qx, qy, size, right, bottom, valid, all_valid, poly, flip)
                elif main_diagonal(z, size, r0, c0, r1, c1):
                    n = _put_cut(tris, n, c0, r0, c0, r1, c1, r1, size, right, bottom, valid, all_valid, poly, flip)
                    n = _put_cut(tris, n, c0, r0, c1, r1, c1, r0, size, right, bottom, valid, all_valid, poly, flip)
                else:
                    n = _put_cut(tris, n, c0, r0, c0, r1, c1, r0, size, right, bottom, valid, all_valid, poly, flip)
                    n = _put_cut(tris, n, c1, r0, c0, r1, c1, r1, size, right, bottom, valid, all_valid, poly, flip)
                idx = nxt[idx]
                continue
            pa, pb, pc, pd = r0 * size + c0, r0 * size + c1, r1 * size + c0, r1 * size + c1
            n_valid = 4 if all_valid else valid[pa] + valid[pb] + valid[pc] + valid[pd]
            if n_valid == 3 and side == 1:  # one triangle of the three corners with data, as the grid mesh
                if not valid[pa]:
                    n = _put(tris, n, pb, pc, pd, flip)
                elif not valid[pb]:
                    n = _put(tris, n, pa, pc, pd, flip)
                elif not valid[pc]:
                    n = _put(tris, n, pa, pd, pb, flip)
                else:
                    n = _put(tris, n, pa, pc, pb, flip)
            elif n_valid == 4:
                if side >= 2 and _needs_fan(level, i, j, state, stamp):
                    centre = (r0 + side // 2) * size + c0 + side // 2
                    for k in range(4):
                        px, py = _corners(c0, r0, c1, r1, k)
                        qx, qy = _corners(c0, r0, c1, r1, (k + 1) % 4)
                        p, q = py * size + px, qy * size + qx
                        if _neighbour_split(level, i, j, k, state, stamp):
                            mid = ((py + qy) // 2) * size + (px + qx) // 2
                            n = _put(tris, n, centre, p, mid, flip)
                            n = _put(tris, n, centre, mid, q, flip)
                        else:
                            n = _put(tris, n, centre, p, q, flip)
                elif main_diagonal(z, size, r0, c0, r1, c1):
                    n = _put(tris, n, pa, pc, pd, flip)
                    n = _put(tris, n, pa, pd, pb, flip)
                else:
                    n = _put(tris, n, pa, pc, pb, flip)
                    n = _put(tris, n, pb, pc, pd, flip)
            idx = nxt[idx]
    vertices = np.empty((3 * n, 3), np.float64)
    n_points = 0
    for k in range(3 * n):
        tris[k], n_points = _vertex(tris[k], lookup, stamp, vertices, n_points, z, size, transform)
    return vertices[:n_points], tris[: 3 * n].reshape(n, 3)
