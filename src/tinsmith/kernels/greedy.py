"""Greedy insertion (HFPR) on a grid: scan triangles for their worst cell, insert the worst of all.

Buffer layout, on top of the triangulation ``m`` of :mod:`.tin` (vertices are
grid points: ``px`` is the column, ``py`` the row, whole numbers):

- ``g``, the grid tuple ``(zf, vf, w, all_valid, tp, tw, bound, where, bp, bw, bbound, bwhere)``
  (see :func:`make_grid`): ``zf`` float32
  or float64 (H*W,), heights, row-major, ``w`` columns a row; ``vf`` uint8
  (H*W,), 1 where a cell has data; ``all_valid``, True to skip that test on
  grids without nodata; ``tp`` float64 (tiles, 5), a plane fitted to each
  TILE x TILE block with the range of its residuals, ``tw`` blocks a row
  (see :func:`tile_planes`); ``bound`` float64 and ``where`` int64, one
  slot a tile, scratch space of :func:`_scan_tiled`; ``bp``, ``bw``,
  ``bbound``, ``bwhere``, the same for BLOCK x BLOCK blocks of tiles (see
  :func:`block_planes`).
- ``cand`` int64 (T,): flat index ``row * W + col`` of each triangle's worst
  cell, -1 when the triangle has no cell left to insert.
- ``q`` = ``(heap, qpos, key)``, int32, int32, float64 (T,): an indexed
  max-heap of the triangles with a candidate, keyed on the absolute vertical
  error of that cell (``qpos[t]`` is the heap position of ``t``, -1 if
  absent; ``key[i]`` is the error of triangle ``heap[i]``), as in delatin
  and hmm.
- ``cnt`` int64 (4,): vertices, triangles, dirty triangles (as in :mod:`.tin`,
  whose triangulation tuple ``m`` these functions take), heap size.
- Triangles with a non-zero ``region`` (outside the data) are never scanned.

The height of the mesh at a cell is :func:`interpolate`, the same expression
the metrics rasteriser uses, so the error the kernel sees is the error the
metrics report, bit for bit.
"""

import numpy as np

from ._jit import jit, jit_inline, jit_no_refcount, jit_no_refcount_unchecked, prefetch, stack_buffer
from .heap import heap_remove, heap_requeue
from .raster import interpolate
from .tin import insert_in_triangle

#: Tiles of TILE x TILE cells carry a fitted plane and the range of its residuals (for :func:`_scan_tiled`).
TILE_SHIFT = 3
TILE = 1 << TILE_SHIFT
#: Triangles whose bounding box has at least this many cells are scanned tile by tile.
TILED_CELLS = 1024
#: Blocks of BLOCK x BLOCK cells (TILE x TILE tiles) carry a plane and a residual range too, found from their tiles'
#: (:func:`block_planes`); a triangle whose box spans at least BLOCKED blocks is bounded block by block first and
#: its tiles only in the blocks that can still hold its worst cell (:func:`_scan_tiled`).  On a strip a triangle
#: that keeps most of a long strip while greedy insertion peels a few cells off its end at every step (a smooth
#: profile) would otherwise be bounded tile by tile at every step: N/8 tiles of 2 x 8 cells each time.
BLOCK_SHIFT = 6
BLOCK = 1 << BLOCK_SHIFT
BLOCKED = 16
#: A large triangle of at most 1 / SLIVER of its bounding box (``SLIVER * di < 2 * box cells``) has its tiles found
#: line by line (:func:`_sliver_tiles`): the exact span of every row (or column) it crosses, not the box of each band.
#: On a 2 x N grid a triangle from one end to the other holds a few cells of its 2 x N box; a band's columns reach
#: all of them.
SLIVER = 16
#: Heights of more than this many bytes (a grid beyond the cache): the rows of the triangles to rescan are fetched
#: before the scans (:func:`_flush`).  On a smaller grid the rows are in the cache already and the requests only
#: cost time (the figures are in docs/design.md, "Measurements behind the kernels' design").
PREFETCH_BYTES = 8 << 20

#: Grids of at most this many cells a side: every pairwise difference of vertex coordinates is at most 2**12, where
#: the plain in-circle and orientation evaluations are exact (:func:`.predicates.incircle_small_ints`); their
#: floating-point filter is skipped.
SMALL_GRID = 4097

#: Return codes of :func:`refine`.
STOP_ERROR, STOP_VERTICES, STOP_TRIANGLES, STOP_EXHAUSTED, NEED_SPACE = 0, 1, 2, 3, 4


# -- scanning ----------------------------------------------------------------------------------------
@jit
def tile_planes(zf, vf, all_valid, h, w):
    """Fit a plane to the valid heights of every TILE x TILE block; return it with the range of the residuals.

    Returns ``(tp, tw)``: ``tp`` float64 (th * tw, 5) holds, per tile, the
    plane's height at the tile's first cell, its slopes along columns and
    rows, and the lowest and highest residual (height minus plane) of the
    tile's valid cells (+inf, -inf when it has none).  A least-squares fit
    (one pass for the sums, one for the residuals) keeps the residuals, and
    with them the error bounds of :func:`_tile_bound`, small wherever the
    terrain is smooth.
    """
    th, tw = (h + TILE - 1) >> TILE_SHIFT, (w + TILE - 1) >> TILE_SHIFT
    tp = np.empty((th * tw, 5))
    for ty in range(th):
        r0, r1 = ty * TILE, min(h, (ty + 1) * TILE)
        for tx in range(tw):
            c0, c1 = tx * TILE, min(w, (tx + 1) * TILE)
            n = sx = sy = sz = sxx = syy = sxy = sxz = syz = 0.0
            for r in range(r0, r1):
                dy = float(r - r0)
                for c in range(c0, c1):
                    if all_valid or vf[r * w + c]:
                        dx, z = float(c - c0), np.float64(zf[r * w + c])
                        n += 1.0
                        sx += dx
                        sy += dy
                        sz += z
                        sxx += dx * dx
                        syy += dy * dy
                        sxy += dx * dy
                        sxz += dx * z
                        syz += dy * z
            k = ty * tw + tx
            if n == 0.0:
                tp[k, 0] = tp[k, 1] = tp[k, 2] = 0.0
                tp[k, 3], tp[k, 4] = np.inf, -np.inf
                continue
            # any plane gives valid bounds (the residual range is measured
            # against it); centred sums keep it close to the best fit
            cx, cy, cz = sx / n, sy / n, sz / n
            sxx -= sx * cx
            syy -= sy * cy
            sxy -= sx * cy
            sxz -= sx * cz
            syz -= sy * cz
            det = sxx * syy - sxy * sxy
            gx = gy = 0.0
            if det > 1e-9 * (sxx * syy):
                gx = (sxz * syy - syz * sxy) / det
                gy = (syz * sxx - sxz * sxy) / det
            a = cz - gx * cx - gy * cy
            lo, hi = np.inf, -np.inf
            for r in range(r0, r1):
                for c in range(c0, c1):
                    if all_valid or vf[r * w + c]:
                        res = zf[r * w + c] - (a + gx * (c - c0) + gy * (r - r0))
                        lo = min(lo, res)
                        hi = max(hi, res)
            tp[k, 0], tp[k, 1], tp[k, 2], tp[k, 3], tp[k, 4] = a, gx, gy, lo, hi
    return tp, tw


@jit
def block_planes(tp, tw, h, w):
    """A plane and a residual range for every BLOCK x BLOCK block, from the planes and ranges of its tiles.

    Returns ``(bp, bw)`` laid out as :func:`tile_planes`' ``(tp, tw)``.  The
    plane's slopes are the mean of the tiles' and it passes through their
    mean height at their first cells; a tile's residuals against it are its
    own plus the difference of the two planes, whose range over the tile is
    that of its corner cells.  The range is widened by a relative 1e-11 for
    the rounding of these sums (any plane gives valid bounds).
    """
    ratio = BLOCK_SHIFT - TILE_SHIFT
    th = len(tp) // tw
    bh, bw = (th + (1 << ratio) - 1) >> ratio, (tw + (1 << ratio) - 1) >> ratio
    bp = np.empty((bh * bw, 5))
    for by in range(bh):
        for bx in range(bw):
            xb, yb = bx << BLOCK_SHIFT, by << BLOCK_SHIFT
            n = sa = sgx = sgy = 0.0
            for ty in range(by << ratio, min(th, (by + 1) << ratio)):
                for tx in range(bx << ratio, min(tw, (bx + 1) << ratio)):
                    k = ty * tw + tx
                    if tp[k, 3] <= tp[k, 4]:
                        n += 1.0
                        sgx += tp[k, 1]
                        sgy += tp[k, 2]
            b = by * bw + bx
            if n == 0.0:
                bp[b, 0] = bp[b, 1] = bp[b, 2] = 0.0
                bp[b, 3], bp[b, 4] = np.inf, -np.inf
                continue
            gx, gy = sgx / n, sgy / n
            for ty in range(by << ratio, min(th, (by + 1) << ratio)):
                for tx in range(bx << ratio, min(tw, (bx + 1) << ratio)):
                    k = ty * tw + tx
                    if tp[k, 3] <= tp[k, 4]:
                        sa += tp[k, 0] - gx * ((tx << TILE_SHIFT) - xb) - gy * ((ty << TILE_SHIFT) - yb)
            a = sa / n
            lo, hi = np.inf, -np.inf
            for ty in range(by << ratio, min(th, (by + 1) << ratio)):
                for tx in range(bx << ratio, min(tw, (bx + 1) << ratio)):
                    k = ty * tw + tx
                    if tp[k, 3] > tp[k, 4]:
                        continue
                    xt, yt = tx << TILE_SHIFT, ty << TILE_SHIFT
                    xe, ye = min(w, xt + TILE) - 1, min(h, yt + TILE) - 1
                    mag = abs(a) + abs(tp[k, 0]) + BLOCK * (abs(gx) + abs(gy) + abs(tp[k, 1]) + abs(tp[k, 2]))
                    for c, r in ((xt, yt), (xe, yt), (xt, ye), (xe, ye)):
                        # tile plane minus block plane at the cell
                        dz = (tp[k, 0] + tp[k, 1] * (c - xt) + tp[k, 2] * (r - yt)) - (a + gx * (c - xb) + gy * (r - yb))
                        lo = min(lo, tp[k, 3] + dz - 1e-11 * (mag + abs(tp[k, 3])))
                        hi = max(hi, tp[k, 4] + dz + 1e-11 * (mag + abs(tp[k, 4])))
            bp[b, 0], bp[b, 1], bp[b, 2], bp[b, 3], bp[b, 4] = a, gx, gy, lo, hi
    return bp, bw


def make_grid(zf, vf, all_valid, h, w):
    """The grid tuple of the module notes for heights ``zf`` (H*W,) and validity ``vf``."""
    tp, tw = tile_planes(zf, vf, all_valid, h, w)
    bp, bw = block_planes(tp, tw, h, w)
    return (zf, vf, w, all_valid, tp, tw, np.empty(len(tp)), np.empty(len(tp), np.int64), bp, bw, np.empty(len(bp)),
            np.empty(len(bp), np.int64))


@jit_inline
def _better(e, at, best, best_at):
    """The order of candidates: larger error first, then the lower flat index (row order)."""
    return e > best or (e == best and at < best_at)


@jit_inline
def _scan_span(zf, vf, all_valid, corner_row, base, lo, hi, f1, f2, d1, d2, z0, z1, z2, d, k1, k2, best, best_at):
    """Measure the cells base+lo .. base+hi of one row; return the updated (best, best_at).

    ``f1``, ``f2`` are the integer numerators at ``lo`` as floats, stepped by
    the whole numbers ``d1``, ``d2``: every value is an integer below 2**53,
    so the float sums are exact (and cheaper than converting an int each
    cell).  Only a row through corner 1 or 2 needs :func:`interpolate`'s
    corner tests; elsewhere its last line is inlined (the same expression, so
    the same bits).  A tie keeps the lower flat index (:func:`_better`).
    """
    if corner_row or not all_valid:
        for s in range(lo, hi + 1):
            if all_valid or vf[base + s]:
                e = abs(interpolate(z0, z1, z2, f1, f2, d, k1, k2) - zf[base + s])
                if e >= best and _better(e, base + s, best, best_at):
                    best = e
                    best_at = base + s
            f1 += d1
            f2 += d2
        return best, best_at
    for s in range(lo, hi + 1):
        e = abs(z0 + (f1 * k1 + f2 * k2) - zf[base + s])
        if e >= best and _better(e, base + s, best, best_at):
            best = e
            best_at = base + s
        f1 += d1
        f2 += d2
    return best, best_at


@jit_inline
def _span(v, a, lo, hi):
    """Narrow the column offsets [lo, hi] to those ``s`` where ``v + a * s >= 0`` (int64, exact); empty: hi < lo."""
    if a > 0:
        if v < 0:
            lo = max(lo, (a - 1 - v) // a)
    elif a < 0:
        if v < 0:
            return lo, np.int64(-1)
        hi = min(hi, v // -a)
    elif v < 0:
        return lo, np.int64(-1)
    return lo, hi


@jit_inline
def _scan_rows(g, tg, ra, rb, ca, cb, best, best_at):
    """Measure the cells of the triangle ``tg`` in rows ra..rb, columns ca..cb; return the updated (best, best_at).

    Row by row, the exact column span inside the triangle is found from the
    three edge functions (whole numbers in int64, stepped from row to row,
    so every test is exact), then only the cells of the span are measured.
    """
    zf, vf, w, all_valid = g[0], g[1], g[2], g[3]
    x0, y0, x1, y1, x2, y2, di, z0, z1, z2, d, k1, k2 = tg
    # w1, w2 at (ca, ra); per column they grow by a1, a2, per row by b1, b2
    a1, a2 = y2 - y0, y0 - y1
    b1, b2 = x0 - x2, x1 - x0
    w1 = (ca - x0) * a1 + (ra - y0) * b1
    w2 = (ca - x0) * a2 + (ra - y0) * b2
    a0 = -(a1 + a2)
    fa1, fa2 = float(a1), float(a2)
    width = cb - ca
    for r in range(ra, rb + 1):
        lo, hi = _span(di - w1 - w2, a0, np.int64(0), width)
        lo, hi = _span(w1, a1, lo, hi)
        lo, hi = _span(w2, a2, lo, hi)
        if lo <= hi:
            best, best_at = _scan_span(
                zf, vf, all_valid, r in (y1, y2), r * w + ca, lo, hi, float(w1 + a1 * lo),
                float(w2 + a2 * lo), fa1, fa2, z0, z1, z2, d, k1, k2, best, best_at,
            )
        w1 += b1
        w2 += b2
    return best, best_at


@jit_inline
def _box_cells(g, tg, r_lo, r_hi, c_lo, c_hi, exact):
    """:func:`_scan_box`'s loop.  With ``exact`` False (a constant at each call) every cell takes the plain
    expression, which at the cells of vertices 1 and 2 may round to a tiny non-zero error."""
    zf, vf, w, all_valid = g[0], g[1], g[2], g[3]
    x0, y0, x1, y1, x2, y2, di, z0, z1, z2, d, k1, k2 = tg
    dw1, dw2 = y2 - y0, -(y1 - y0)
    best, best_at = 0.0, np.int64(-1)
    w1_row = (c_lo - x0) * dw1 - (x2 - x0) * (r_lo - y0)
    w2_row = (x1 - x0) * (r_lo - y0) + (c_lo - x0) * dw2
    for r in range(r_lo, r_hi + 1):
        w1, w2 = w1_row, w2_row
        w1_row -= x2 - x0
        w2_row += x1 - x0
        base = r * w
        inside = False
        corner = exact and r in (y1, y2)
        for c in range(c_lo, c_hi + 1):
            if (w1 | w2 | (di - w1 - w2)) >= 0:  # no edge function negative: one test, not three
                inside = True
                if all_valid or vf[base + c]:
                    if corner:
                        v = interpolate(z0, z1, z2, float(w1), float(w2), d, k1, k2)
                    else:
                        v = z0 + (float(w1) * k1 + float(w2) * k2)
                    e = abs(v - zf[base + c])
                    if e > best:
                        best = e
                        best_at = base + c
            elif inside:
                break
            w1 += dw1
            w2 += dw2
    return best, best_at


@jit_inline
def _scan_box(g, tg, r_lo, r_hi, c_lo, c_hi):
    """The worst cell of a small triangle: every cell of its bounding box, tested by the exact edge functions.

    Cheaper than :func:`_scan_rows` on a few cells a row: no span to solve,
    and a row ends at the first cell past the triangle.  The cells of
    vertices 1 and 2 are exact (:func:`.raster.interpolate`), which the
    plain expression of the first pass may miss by a rounding; only when
    the worst cell it finds is one of them (its error then a rounding at
    most) is the triangle scanned again with :func:`.raster.interpolate`
    on their rows, which gives every other cell the same bits.
    """
    x1, y1, x2, y2, w = tg[2], tg[3], tg[4], tg[5], g[2]
    best, best_at = _box_cells(g, tg, r_lo, r_hi, c_lo, c_hi, False)
    if best_at == y1 * w + x1 or best_at == y2 * w + x2:
        best, best_at = _box_cells(g, tg, r_lo, r_hi, c_lo, c_hi, True)
    return best, best_at


@jit_inline
def _tile_bound(tp, tw, shift, tg, ty, tx, ra, rb, ca, cb, slack):
    """An upper bound of |mesh - DEM| over the cells of tile (ty, tx) clipped to rows ra..rb, columns ca..cb.

    ``tp``, ``tw``, ``shift``: the planes of the tiles (TILE_SHIFT) or of
    the blocks (BLOCK_SHIFT).

    -inf when the tile holds no valid cell or lies wholly outside one edge
    of the triangle.  Height = tile plane + residual, so the error is
    |(mesh - tile plane) - residual|: the first term is linear, its range
    over the rectangle that of its four corners; the residual's range is the
    tile's.  ``slack`` covers the rounding of both planes and of the
    per-cell expression.
    """
    x0, y0, x1, y1, x2, y2, di, z0, z1, z2, d, k1, k2 = tg
    k = ty * tw + tx
    a, gx, gy, lo_r, hi_r = tp[k, 0], tp[k, 1], tp[k, 2], tp[k, 3], tp[k, 4]
    if lo_r > hi_r:
        return -np.inf
    xt, yt = tx << shift, ty << shift
    d_lo, d_hi = np.inf, -np.inf
    out0 = out1 = out2 = 0
    for c, r in ((ca, ra), (cb, ra), (ca, rb), (cb, rb)):
        w1 = (c - x0) * (y2 - y0) - (x2 - x0) * (r - y0)
        w2 = (x1 - x0) * (r - y0) - (c - x0) * (y1 - y0)
        out0 += di - w1 - w2 < 0
        out1 += w1 < 0
        out2 += w2 < 0
        dz = z0 + (float(w1) * k1 + float(w2) * k2) - (a + gx * (c - xt) + gy * (r - yt))
        d_lo = min(d_lo, dz)
        d_hi = max(d_hi, dz)
    if out0 == 4 or out1 == 4 or out2 == 4:
        return -np.inf
    mag = abs(a) + (1 << shift) * (abs(gx) + abs(gy)) + abs(lo_r) + abs(hi_r)
    return max(d_hi - lo_r, hi_r - d_lo) * (1.0 + 1e-12) + slack + 1e-12 * mag


@jit_inline
def _band_columns(tg, ra, rb, c_lo, c_hi):
    """The columns, within c_lo..c_hi, that the triangle can reach in rows ra..rb (one cell of margin either side).

    The triangle's part of the band is a convex polygon whose corners are
    the ends of its edges clipped to the band, so its extent is theirs.
    """
    x0, y0, x1, y1, x2, y2 = tg[0], tg[1], tg[2], tg[3], tg[4], tg[5]
    lo, hi = np.inf, -np.inf
    for xa, ya, xb, yb in ((x0, y0, x1, y1), (x1, y1, x2, y2), (x2, y2, x0, y0)):
        if ya > yb:
            xa, ya, xb, yb = xb, yb, xa, ya
        if yb < ra or ya > rb:
            continue
        if ya == yb:
            lo, hi = min(lo, xa, xb), max(hi, xa, xb)
            continue
        slope = (xb - xa) / (yb - ya)
        for y in (max(ya, ra), min(yb, rb)):
            x = xa + slope * (y - ya)
            lo, hi = min(lo, x), max(hi, x)
    return max(c_lo, np.int64(np.floor(lo)) - 1), min(c_hi, np.int64(np.ceil(hi)) + 1)


@jit_inline
def _sliver_tiles(tp, tw, shift, bound, where, tg, r_lo, r_hi, c_lo, c_hi, slack):
    """:func:`_scan_tiled`'s list of tiles and bounds for a sliver: only the tiles that hold one of its cells.

    Lines run along the longer side of the bounding box (rows of a wide
    triangle, columns of a tall one); in each band of TILE lines, the exact
    span of every line (integer edge functions, as in :func:`_scan_rows`)
    gives the tiles it reaches, and the union of those intervals, merged, is
    bounded tile by tile over the band's lines and the spans' extent.  The
    work is a few operations a line and a bound a tile that holds a cell,
    where the band's box (:func:`_band_columns`) costs a bound for every tile
    between a sliver's ends.  Returns ``(n, top, top_k)`` as the band loop of
    :func:`_scan_tiled` leaves them.
    """
    x0, y0, x1, y1, x2, y2, di = tg[0], tg[1], tg[2], tg[3], tg[4], tg[5], tg[6]
    ends = stack_buffer(128)  # the tile intervals of a band's lines, at most BLOCK (whole numbers, exact as float64)
    wide = c_hi - c_lo >= r_hi - r_lo
    # edge functions w1, w2 (and di - w1 - w2) at (c_lo, r_lo); per column they grow by a1, a2, per row by b1, b2
    a1, a2 = y2 - y0, y0 - y1
    b1, b2 = x0 - x2, x1 - x0
    w1_0 = (c_lo - x0) * a1 + (r_lo - y0) * b1
    w2_0 = (c_lo - x0) * a2 + (r_lo - y0) * b2
    if wide:  # lines are rows, stepped by b; along a line the functions grow by a
        l_lo, l_hi, s_lo, s_hi, l1, l2, s1, s2 = r_lo, r_hi, c_lo, c_hi, b1, b2, a1, a2
    else:  # lines are columns
        l_lo, l_hi, s_lo, s_hi, l1, l2, s1, s2 = c_lo, c_hi, r_lo, r_hi, a1, a2, b1, b2
    s0 = -(s1 + s2)
    n = 0
    top, top_k = -np.inf, -1
    for band in range(l_lo >> shift, (l_hi >> shift) + 1):
        la, lb = max(l_lo, band << shift), min(l_hi, ((band + 1) << shift) - 1)
        k = 0
        e_lo, e_hi = s_hi + 1, s_lo - 1  # extent of the spans, in cells
        for line in range(la, lb + 1):
            w1 = w1_0 + (line - l_lo) * l1
            w2 = w2_0 + (line - l_lo) * l2
            lo, hi = _span(di - w1 - w2, s0, np.int64(0), s_hi - s_lo)
            lo, hi = _span(w1, s1, lo, hi)
            lo, hi = _span(w2, s2, lo, hi)
            if lo > hi:
                continue
            e_lo, e_hi = min(e_lo, s_lo + lo), max(e_hi, s_lo + hi)
            t0, t1 = (s_lo + lo) >> shift, (s_lo + hi) >> shift
            j = k  # insertion sort on the first tile
            while j > 0 and ends[2 * j - 2] > t0:
                ends[2 * j] = ends[2 * j - 2]
                ends[2 * j + 1] = ends[2 * j - 1]
                j -= 1
            ends[2 * j] = t0
            ends[2 * j + 1] = t1
            k += 1
        last = np.int64(-1)  # the last tile bounded in this band: merged intervals visit each tile once
        for j in range(k):
            for t in range(max(np.int64(ends[2 * j]), last + 1), np.int64(ends[2 * j + 1]) + 1):
                last = t
                sa, sb = max(e_lo, t << shift), min(e_hi, ((t + 1) << shift) - 1)
                if wide:
                    ty, tx, ra, rb, ca, cb = band, t, la, lb, sa, sb
                else:
                    ty, tx, ra, rb, ca, cb = t, band, sa, sb, la, lb
                b = _tile_bound(tp, tw, shift, tg, ty, tx, ra, rb, ca, cb, slack)
                if b == -np.inf:
                    continue
                bound[n] = b
                where[n] = (ty << 32) | tx
                if b > top:
                    top, top_k = b, n
                n += 1
    return n, top, top_k


@jit_inline
def _band_tiles(tp, tw, shift, bound, where, tg, r_lo, r_hi, c_lo, c_hi, slack):
    """:func:`_scan_tiled`'s list of tiles and bounds: per band of tile rows, the columns of :func:`_band_columns`.

    Returns ``(n, top, top_k)`` as :func:`_sliver_tiles`.
    """
    n = 0
    top, top_k = -np.inf, -1
    for ty in range((r_lo >> shift), (r_hi >> shift) + 1):
        ra, rb = max(r_lo, ty << shift), min(r_hi, ((ty + 1) << shift) - 1)
        ca_band, cb_band = _band_columns(tg, ra, rb, c_lo, c_hi)
        for tx in range(ca_band >> shift, (cb_band >> shift) + 1):
            ca, cb = max(ca_band, tx << shift), min(cb_band, ((tx + 1) << shift) - 1)
            b = _tile_bound(tp, tw, shift, tg, ty, tx, ra, rb, ca, cb, slack)
            if b == -np.inf:
                continue
            bound[n] = b
            where[n] = (ty << 32) | tx
            if b > top:
                top, top_k = b, n
            n += 1
    return n, top, top_k


@jit_inline
def _scan_tiles(g, tg, sliver, r_lo, r_hi, c_lo, c_hi, slack, best, best_at):
    """The tiles of the triangle in rows r_lo..r_hi, columns c_lo..c_hi: bounded, then measured where the bound
    reaches the worst found so far (``best``), the highest bound first; return the updated (best, best_at)."""
    tp, tw, bound, where = g[4], g[5], g[6], g[7]
    if sliver:
        n, top, top_k = _sliver_tiles(tp, tw, TILE_SHIFT, bound, where, tg, r_lo, r_hi, c_lo, c_hi, slack)
    else:
        n, top, top_k = _band_tiles(tp, tw, TILE_SHIFT, bound, where, tg, r_lo, r_hi, c_lo, c_hi, slack)
    for i in range(-1, n):
        k = top_k if i < 0 else i
        if k < 0 or (i == top_k) or bound[k] < best:
            continue
        ty, tx = where[k] >> 32, where[k] & 0xFFFFFFFF
        ra, rb = max(r_lo, ty << TILE_SHIFT), min(r_hi, ((ty + 1) << TILE_SHIFT) - 1)
        ca, cb = max(c_lo, tx << TILE_SHIFT), min(c_hi, ((tx + 1) << TILE_SHIFT) - 1)
        best, best_at = _scan_rows(g, tg, ra, rb, ca, cb, best, best_at)
    return best, best_at


@jit_inline
def _scan_tiled(g, tg, r_lo, r_hi, c_lo, c_hi):
    """The worst cell of a large triangle, skipping every tile whose bound is below the worst found so far.

    Only the tiles the triangle reaches are bounded (per band of tile
    rows, the columns of :func:`_band_columns`; for a sliver, the tiles its
    rows' or columns' spans reach, :func:`_sliver_tiles`), once each; the bounds are
    kept in the grid tuple's scratch arrays.  The tile with the highest
    bound is measured first, so that most others are ruled out by their
    bound alone; the result is the one of a full scan (the candidate order
    of :func:`_better` does not depend on the visiting order).  A triangle
    whose box spans at least BLOCKED blocks is bounded block by block first (the
    same lists, with the blocks' planes), the highest block first, and only
    the blocks whose bound reaches the worst cell found so far have their
    tiles listed and bounded.
    """
    x0, y0, x1, y1, x2, y2, di, z0, z1, z2, d, k1, k2 = tg
    # rounding of z0 + (w1 * k1 + w2 * k2), far above the few ulps it can reach
    w1_max = w2_max = 0.0
    for c, r in ((c_lo, r_lo), (c_hi, r_lo), (c_lo, r_hi), (c_hi, r_hi)):
        w1_max = max(w1_max, abs(float((c - x0) * (y2 - y0) - (x2 - x0) * (r - y0))))
        w2_max = max(w2_max, abs(float((x1 - x0) * (r - y0) - (c - x0) * (y1 - y0))))
    slack = 1e-12 * (abs(z0) + abs(k1) * w1_max + abs(k2) * w2_max) + 1e-300
    cells = (r_hi - r_lo + 1) * (c_hi - c_lo + 1)
    sliver = SLIVER * di < 2 * cells
    if ((r_hi >> BLOCK_SHIFT) - (r_lo >> BLOCK_SHIFT) + 1) * ((c_hi >> BLOCK_SHIFT) - (c_lo >> BLOCK_SHIFT) + 1) < BLOCKED:
        return _scan_tiles(g, tg, sliver, r_lo, r_hi, c_lo, c_hi, slack, 0.0, np.int64(-1))
    # blocks first: the tiles of a block are listed only when its bound reaches the worst found so far
    bp, bw, bound, where = g[8], g[9], g[10], g[11]
    if sliver:
        n, top, top_k = _sliver_tiles(bp, bw, BLOCK_SHIFT, bound, where, tg, r_lo, r_hi, c_lo, c_hi, slack)
    else:
        n, top, top_k = _band_tiles(bp, bw, BLOCK_SHIFT, bound, where, tg, r_lo, r_hi, c_lo, c_hi, slack)
    best, best_at = 0.0, np.int64(-1)
    for i in range(-1, n):
        k = top_k if i < 0 else i
        if k < 0 or (i == top_k) or bound[k] < best:
            continue
        by, bx = where[k] >> 32, where[k] & 0xFFFFFFFF
        ra, rb = max(r_lo, by << BLOCK_SHIFT), min(r_hi, ((by + 1) << BLOCK_SHIFT) - 1)
        ca, cb = max(c_lo, bx << BLOCK_SHIFT), min(c_hi, ((bx + 1) << BLOCK_SHIFT) - 1)
        best, best_at = _scan_tiles(g, tg, sliver, ra, rb, ca, cb, slack, best, best_at)
    return best, best_at


@jit_inline
def _scan_area_one(g, x0, y0, x1, y1, x2, y2, z0, k1, k2):
    """:func:`_scan_box` of a triangle of area 1 (``di == 2``), bit for bit, without the box.

    By Pick's theorem (area = interior + boundary / 2 - 1) its only cell
    besides the corners is the midpoint of the one edge whose deltas are both
    even.  There the barycentric numerators (w1, w2) are (1, 0), (0, 1) or
    (1, 1), never ``di``, so :func:`.raster.interpolate` takes its last line
    and the plain expression is the exact one; the corners are exact, so
    this cell is the only one with an error.
    """
    zf, vf, w, all_valid = g[0], g[1], g[2], g[3]
    if ((x1 - x0) | (y1 - y0)) & 1 == 0:
        at, w1, w2 = ((y0 + y1) >> 1) * w + ((x0 + x1) >> 1), 1.0, 0.0
    elif ((x2 - x0) | (y2 - y0)) & 1 == 0:
        at, w1, w2 = ((y0 + y2) >> 1) * w + ((x0 + x2) >> 1), 0.0, 1.0
    else:
        at, w1, w2 = ((y1 + y2) >> 1) * w + ((x1 + x2) >> 1), 1.0, 1.0
    if all_valid or vf[at]:
        e = abs(z0 + (w1 * k1 + w2 * k2) - zf[at])
        if e > 0.0:
            return e, at
    return 0.0, np.int64(-1)


@jit_inline
def scan_triangle(t, px, py, tri, region, g, cand):
    """Find the valid cell of triangle ``t`` with the largest |mesh - DEM| (ties: first in row order).

    ``g`` is the grid tuple (see the module notes).  Small triangles are
    scanned row by row; large ones tile by tile, with tiles ruled out by a
    bound on their error (:func:`_scan_tiled`).
    """
    if region[t]:
        cand[t] = -1
        return 0.0
    zf, w = g[0], g[2]
    i0, i1, i2 = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    x0, y0 = np.int64(px[i0]), np.int64(py[i0])
    x1, y1 = np.int64(px[i1]), np.int64(py[i1])
    x2, y2 = np.int64(px[i2]), np.int64(py[i2])
    di = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    if di == 1:
        # half a cell: by Pick's theorem its only cells are its corners, which are exact
        cand[t] = -1
        return 0.0
    # np.float64, not float(): numba's float() keeps a float32 a float32, and the
    # corner differences must be taken in float64, as the metrics take them
    z0 = np.float64(zf[y0 * w + x0])
    z1 = np.float64(zf[y1 * w + x1])
    z2 = np.float64(zf[y2 * w + x2])
    d = float(di)
    k1, k2 = (z1 - z0) / d, (z2 - z0) / d
    if di == 2:
        best, best_at = _scan_area_one(g, x0, y0, x1, y1, x2, y2, z0, k1, k2)
        cand[t] = best_at
        return best
    tg = (x0, y0, x1, y1, x2, y2, di, z0, z1, z2, d, k1, k2)
    r_lo, r_hi = min(y0, y1, y2), max(y0, y1, y2)
    c_lo, c_hi = min(x0, x1, x2), max(x0, x1, x2)
    if (r_hi - r_lo + 1) * (c_hi - c_lo + 1) < TILED_CELLS:
        best, best_at = _scan_box(g, tg, r_lo, r_hi, c_lo, c_hi)
    else:
        best, best_at = _scan_tiled(g, tg, r_lo, r_hi, c_lo, c_hi)
    cand[t] = best_at
    return best


@jit_inline
def _prefetch_box(t, px, py, tri, g, whole):
    """Start fetching the rows of a small triangle (one scanned cell by cell) into the cache.

    Each row's first and last cell, or with ``whole`` every cache line of
    its bounding box.
    """
    zf, w = g[0], g[2]
    i0, i1, i2 = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    r_lo, r_hi = np.int64(min(py[i0], py[i1], py[i2])), np.int64(max(py[i0], py[i1], py[i2]))
    c_lo, c_hi = np.int64(min(px[i0], px[i1], px[i2])), np.int64(max(px[i0], px[i1], px[i2]))
    if (r_hi - r_lo + 1) * (c_hi - c_lo + 1) >= TILED_CELLS:
        return
    step = (64 // zf.itemsize) if whole else max(c_hi - c_lo, np.int64(1))
    for r in range(r_lo, r_hi + 1):
        for c in range(c_lo, c_hi + step, step):
            prefetch(zf, r * w + min(c, c_hi))


@jit_inline
def _prefetch_triangle(m, t, deep):
    """Start fetching what splitting triangle ``t`` reads: its records and vertices, and with ``deep`` its neighbours'."""
    px, py, tri, half, cons, vedge = m[0], m[1], m[2], m[3], m[4], m[5]
    for k in range(3):
        e = 3 * t + k
        if not deep:
            prefetch(tri, e)
            prefetch(half, e)
            prefetch(cons, e)
            continue
        v, h = tri[e], half[e]
        prefetch(px, v)
        prefetch(py, v)
        prefetch(vedge, v)
        if h >= 0:
            prefetch(tri, h)
            prefetch(half, h)
            prefetch(cons, h)


@jit_inline
def _flush(m, g, cand, q):
    """Rescan every dirty triangle of the triangulation ``m`` and (re)queue it.

    On a grid beyond the cache (:data:`PREFETCH_BYTES`) the rows of all of
    them are requested from memory first, so that their cache misses overlap
    instead of stalling one scan after another; on every grid so is the data
    of the triangle at the top of the heap, which is most often the next one
    split.
    """
    px, py, tri, region, dirty, is_dirty, cnt = m[0], m[1], m[2], m[6], m[7], m[8], m[9]
    top = q[0][0] if cnt[3] > 0 else -1
    if top >= 0:
        _prefetch_triangle(m, top, False)
        prefetch(cand, top)  # its cell becomes the next vertex
    if len(g[0]) * g[0].itemsize > PREFETCH_BYTES:
        for k in range(cnt[2]):
            _prefetch_box(dirty[k], px, py, tri, g, False)
    for k in range(cnt[2]):
        t = dirty[k]
        is_dirty[t] = 0
        e = scan_triangle(t, px, py, tri, region, g, cand)
        if k == 0 and top >= 0:
            _prefetch_triangle(m, top, True)
        heap_requeue(t, q, e, cand[t] >= 0, cnt)
    cnt[2] = 0


@jit_no_refcount
def flush(m, g, cand, q):
    """:func:`_flush`, called from Python (the engine's first scan); :func:`refine` inlines it (an out-of-line call
    passes every array of its tuples on the stack, once an insertion)."""
    _flush(m, g, cand, q)


@jit_inline
def stop_code(cnt, q, max_error, max_vertices, max_triangles, cap_v, cap_t, slack):
    """The stop rule that holds before the next insertion (one of STOP_*, NEED_SPACE), or -1 to go on.

    The heap must be flushed.  ``max_error`` holds when the worst error plus
    ``slack`` is at most it.
    """
    if cnt[3] == 0:
        return STOP_EXHAUSTED
    if q[2][0] + slack <= max_error:
        return STOP_ERROR
    if cnt[0] + 1 > max_vertices:
        return STOP_VERTICES
    if cnt[1] + 2 > max_triangles:
        return STOP_TRIANGLES
    if cnt[0] + 1 > cap_v or cnt[1] + 2 > cap_t:
        return NEED_SPACE
    return -1


@jit_no_refcount_unchecked
def refine(m, g, cand, q, stack, max_error, max_vertices, max_triangles):
    """Insert worst cells until a stop rule holds or the buffers are full.

    Returns (code, stack): ``code`` is one of STOP_* or NEED_SPACE (grow the
    buffers and call again); ``stack``, the legalisation stack, must come
    from :func:`.tin.reserve` for ``len(cand)`` triangles: this kernel
    allocates nothing and runs without reference counting.
    """
    px, py, cnt, w = m[0], m[1], m[9], g[2]
    small_ints = max(w, len(g[0]) // w) <= SMALL_GRID
    cap_v = len(px)
    cap_t = len(cand)
    while True:
        _flush(m, g, cand, q)
        code = stop_code(cnt, q, max_error, max_vertices, max_triangles, cap_v, cap_t, 0.0)
        if code >= 0:
            return code, stack
        t = q[0][0]
        heap_remove(t, q, cnt)
        # the cells of t are scanned again (by its children) right after the insertion
        _prefetch_box(t, px, py, m[2], g, True)
        n = cnt[0]
        cnt[0] += 1
        row = cand[t] // w  # one division, not two
        px[n] = cand[t] - row * w
        py[n] = row
        stack = insert_in_triangle(m, t, n, stack, small_ints)


# -- output ---------------------------------------------------------------------------------------------
# One pass over the triangulation, writing straight into the arrays the mesh
# keeps: no temporary arrays, so about half the fresh pages of np.unique, fancy
# indexing, astype and column_stack, and fresh pages are a visible share of a
# short run (docs/design.md has the figures).
@jit_inline
def _kept_vertices(m):
    """New ids of the vertices the triangles inside the data (region 0) use, -1 for the others, and counts.

    Returns ``(new, n_vertices, n_triangles, n_constrained)``: the kept
    vertices keep their order; the counts are of kept vertices, inside
    triangles, and constrained sides of inside triangles.
    """
    tri, cons, region, cnt = m[2], m[4], m[6], m[9]
    new = np.full(cnt[0], -1, np.int64)
    n_tri = n_cons = 0
    for k in range(cnt[1]):
        if region[k] == 0:
            n_tri += 1
            for j in range(3 * k, 3 * k + 3):
                new[tri[j]] = 0
                n_cons += cons[j] != 0
    n_out = 0
    for i in range(cnt[0]):
        if new[i] == 0:
            new[i] = n_out
            n_out += 1
    return new, n_out, n_tri, n_cons


@jit_inline
def _inside_triangles(m, new, n_tri, n_cons, swap):
    """(n_tri, 3) int64 inside triangles in the ids ``new``, and (n_cons, 2) int64 constrained sides (low id first).

    ``swap`` reverses the order of each triangle (its last two vertices).
    """
    tri, cons, region, cnt = m[2], m[4], m[6], m[9]
    triangles = np.empty((n_tri, 3), np.int64)
    ends = np.empty((n_cons, 2), np.int64)
    o = q = 0
    for k in range(cnt[1]):
        if region[k] != 0:
            continue
        a, b, c = new[tri[3 * k]], new[tri[3 * k + 1]], new[tri[3 * k + 2]]
        triangles[o, 0] = a
        triangles[o, 1] = c if swap else b
        triangles[o, 2] = b if swap else c
        o += 1
        for j in range(3):
            if cons[3 * k + j] != 0:
                u, v = new[tri[3 * k + j]], new[tri[3 * k + (j + 1) % 3]]
                ends[q, 0] = min(u, v)
                ends[q, 1] = max(u, v)
                q += 1
    return triangles, ends


@jit
def inside_part(m, swap):
    """The triangles inside the data (region 0), renumbered: ``(used, triangles, ends)``.

    ``used`` int64 (N,), the ids of the vertices they use, in order (the
    others, such as grid corners on nodata, are left out); ``triangles``
    int64 (M, 3) indexing ``used``, the order of each reversed when
    ``swap``; ``ends`` int64 (E, 2), the constrained sides, low index
    first, once per triangle that holds them.
    """
    new, n_out, n_tri, n_cons = _kept_vertices(m)
    used = np.empty(n_out, np.int64)
    for i in range(len(new)):
        if new[i] >= 0:
            used[new[i]] = i
    triangles, ends = _inside_triangles(m, new, n_tri, n_cons, swap)
    return used, triangles, ends


@jit
def output_mesh(m, zf, w, transform, swap):
    """As :func:`inside_part`, with ``(vertices, triangles, ends)``: vertices (N, 3) float64 in world coordinates.

    A vertex is the centre of its cell through the affine ``transform``
    ``(a, b, c, d, e, f)`` (the arithmetic of
    :func:`tinsmith.core.heightfield.pixel_to_world`), at the height
    ``zf[row * w + col]``.
    """
    px, py = m[0], m[1]
    new, n_out, n_tri, n_cons = _kept_vertices(m)
    a, b, c, d, e, f = transform
    vertices = np.empty((n_out, 3))
    for i in range(len(new)):
        j = new[i]
        if j >= 0:
            col, row = px[i] + 0.5, py[i] + 0.5
            vertices[j, 0] = a * col + b * row + c
            vertices[j, 1] = d * col + e * row + f
            vertices[j, 2] = zf[int(py[i]) * w + int(px[i])]
    triangles, ends = _inside_triangles(m, new, n_tri, n_cons, swap)
    return vertices, triangles, ends
