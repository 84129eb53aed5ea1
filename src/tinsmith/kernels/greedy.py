"""Greedy insertion (HFPR) on a grid: scan triangles for their worst cell, insert the worst of all.

Buffer layout, on top of the triangulation ``m`` of :mod:`.tin` (vertices are
grid points: ``px`` is the column, ``py`` the row, whole numbers):

- ``zf`` float32 or float64 (H*W,): heights, row-major, ``w`` columns a row;
  ``vf`` uint8 (H*W,): 1 where a cell has data; ``all_valid``: True to skip
  that test on grids without nodata.
- ``cand`` int64 (T,): flat index ``row * W + col`` of each triangle's worst
  cell; ``err`` float64 (T,): its absolute vertical error (0 when the
  triangle has no cell left to insert).
- ``heap`` int32 (T,), ``qpos`` int32 (T,): an indexed max-heap of triangles
  keyed on ``err`` (``qpos[t]`` is the heap position of ``t``, -1 if absent),
  as in delatin and hmm.
- ``cnt`` int64 (4,): vertices, triangles, dirty triangles (as in :mod:`.tin`,
  whose triangulation tuple ``m`` these functions take), heap size.
- Triangles with a non-zero ``region`` (outside the data) are never scanned.

The height of the mesh at a cell is :func:`interpolate`, the same expression
the metrics rasteriser uses, so the error the kernel sees is the error the
metrics report, bit for bit.
"""

import numpy as np

from ._jit import jit, jit_inline
from .raster import interpolate
from .tin import insert_in_triangle

#: Return codes of :func:`refine`.
STOP_ERROR, STOP_VERTICES, STOP_TRIANGLES, STOP_EXHAUSTED, NEED_SPACE = 0, 1, 2, 3, 4


# -- indexed max-heap ------------------------------------------------------------------------------
@jit_inline
def _swap(i, j, heap, qpos):
    ti, tj = heap[i], heap[j]
    heap[i], heap[j] = tj, ti
    qpos[tj], qpos[ti] = i, j


@jit_inline
def _up(i, heap, qpos, err):
    while i > 0:
        parent = (i - 1) >> 1
        if err[heap[i]] <= err[heap[parent]]:
            break
        _swap(i, parent, heap, qpos)
        i = parent


@jit_inline
def _down(i, n, heap, qpos, err):
    start = i
    while True:
        left = 2 * i + 1
        if left >= n:
            break
        j = left
        if left + 1 < n and err[heap[left + 1]] > err[heap[left]]:
            j = left + 1
        if err[heap[j]] <= err[heap[i]]:
            break
        _swap(i, j, heap, qpos)
        i = j
    return i > start


@jit_inline
def heap_push(t, heap, qpos, err, cnt):
    n = cnt[3]
    heap[n] = t
    qpos[t] = n
    cnt[3] = n + 1
    _up(n, heap, qpos, err)


@jit_inline
def heap_update(t, heap, qpos, err, cnt):
    """Restore the heap after ``err[t]`` changed (``t`` must be in the heap)."""
    i = qpos[t]
    if not _down(i, cnt[3], heap, qpos, err):
        _up(i, heap, qpos, err)


@jit_inline
def heap_remove(t, heap, qpos, err, cnt):
    i = qpos[t]
    if i < 0:
        return
    n = cnt[3] - 1
    if i != n:
        _swap(i, n, heap, qpos)
        if not _down(i, n, heap, qpos, err):
            _up(i, heap, qpos, err)
    qpos[t] = -1
    cnt[3] = n


# -- scanning ----------------------------------------------------------------------------------------
@jit_inline
def _span(w, dw, inv, lo, hi):
    """Narrow the column offsets [lo, hi] to those where ``w + dw * s >= 0`` (int64, exact).

    ``inv`` is ``1 / dw``: the rounded float quotient is corrected by exact
    integer tests (no integer division in the loop over rows).
    """
    if dw > 0:
        if w < 0:
            s = np.int64(np.ceil(-w * inv))
            while s > 0 and w + dw * (s - 1) >= 0:
                s -= 1
            while w + dw * s < 0:
                s += 1
            lo = max(lo, s)
    elif dw < 0:
        if w < 0:
            return lo, np.int64(-1)
        s = np.int64(np.floor(-w * inv))
        while w + dw * s < 0:
            s -= 1
        while w + dw * (s + 1) >= 0:
            s += 1
        hi = min(hi, s)
    elif w < 0:
        return lo, np.int64(-1)
    return lo, hi


@jit_inline
def _corner_row(r, y1, y2):
    return r == y1 or r == y2


@jit_inline
def _scan_span(zf, vf, all_valid, corner_row, base, lo, hi, f1, f2, d1, d2, z0, z1, z2, d, k1, k2, best, best_at):
    """Measure the cells base+lo .. base+hi of one row; return the updated (best, best_at).

    ``f1``, ``f2`` are the integer numerators at ``lo`` as floats, stepped by
    the whole numbers ``d1``, ``d2``: every value is an integer below 2**53,
    so the float sums are exact (and cheaper than converting an int each
    cell).  Only a row through corner 1 or 2 needs :func:`interpolate`'s
    corner tests; elsewhere its last line is inlined (the same expression, so
    the same bits).
    """
    if corner_row or not all_valid:
        for s in range(lo, hi + 1):
            if all_valid or vf[base + s]:
                e = abs(interpolate(z0, z1, z2, f1, f2, d, k1, k2) - zf[base + s])
                if e > best:
                    best = e
                    best_at = base + s
            f1 += d1
            f2 += d2
        return best, best_at
    for s in range(lo, hi + 1):
        e = abs(z0 + (f1 * k1 + f2 * k2) - zf[base + s])
        if e > best:
            best = e
            best_at = base + s
        f1 += d1
        f2 += d2
    return best, best_at


@jit
def scan_triangle(t, px, py, tri, region, zf, vf, w, all_valid, cand, err):
    """Find the valid cell of triangle ``t`` with the largest |mesh - DEM| (ties: first in row order).

    Row by row, the exact column span inside the triangle is found from the
    three edge functions (whole numbers in int64, so every test is exact), then
    the cells of the span are measured.
    """
    if region[t]:
        cand[t] = -1
        err[t] = 0.0
        return
    i0, i1, i2 = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    x0, y0 = np.int64(px[i0]), np.int64(py[i0])
    x1, y1 = np.int64(px[i1]), np.int64(py[i1])
    x2, y2 = np.int64(px[i2]), np.int64(py[i2])
    z0 = float(zf[y0 * w + x0])
    z1 = float(zf[y1 * w + x1])
    z2 = float(zf[y2 * w + x2])
    di = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    d = float(di)
    k1 = (z1 - z0) / d
    k2 = (z2 - z0) / d
    best = 0.0
    best_at = np.int64(-1)
    r_lo = min(y0, y1, y2)
    r_hi = max(y0, y1, y2)
    x_lo = min(x0, x1, x2)
    width = max(x0, x1, x2) - x_lo
    # per column w1 grows by (y2 - y0), w2 by -(y1 - y0); per row by -(x2 - x0) and (x1 - x0)
    dw1, dw2 = y2 - y0, -(y1 - y0)
    dw0 = -(dw1 + dw2)
    fd1, fd2 = float(dw1), float(dw2)
    inv0 = 1.0 / dw0 if dw0 != 0 else 0.0
    inv1 = 1.0 / dw1 if dw1 != 0 else 0.0
    inv2 = 1.0 / dw2 if dw2 != 0 else 0.0
    w1_row = (x_lo - x0) * dw1 - (x2 - x0) * (r_lo - y0)
    w2_row = (x1 - x0) * (r_lo - y0) + (x_lo - x0) * dw2
    for r in range(r_lo, r_hi + 1):
        w1s, w2s = w1_row, w2_row
        w1_row -= x2 - x0
        w2_row += x1 - x0
        w0s = di - w1s - w2s
        lo, hi = _span(w0s, dw0, inv0, np.int64(0), width)
        lo, hi = _span(w1s, dw1, inv1, lo, hi)
        lo, hi = _span(w2s, dw2, inv2, lo, hi)
        if lo > hi:
            continue
        best, best_at = _scan_span(
            zf, vf, all_valid, _corner_row(r, y1, y2), r * w + x_lo, lo, hi, float(w1s + dw1 * lo),
            float(w2s + dw2 * lo), fd1, fd2, z0, z1, z2, d, k1, k2, best, best_at,
        )
    cand[t] = best_at
    err[t] = best


@jit
def flush(m, zf, vf, w, all_valid, cand, err, heap, qpos):
    """Rescan every dirty triangle of the triangulation ``m`` and (re)queue it."""
    px, py, tri, region, dirty, is_dirty, cnt = m[0], m[1], m[2], m[6], m[7], m[8], m[9]
    for k in range(cnt[2]):
        t = dirty[k]
        is_dirty[t] = 0
        scan_triangle(t, px, py, tri, region, zf, vf, w, all_valid, cand, err)
        if qpos[t] >= 0:
            if cand[t] >= 0:
                heap_update(t, heap, qpos, err, cnt)
            else:
                heap_remove(t, heap, qpos, err, cnt)
        elif cand[t] >= 0:
            heap_push(t, heap, qpos, err, cnt)
    cnt[2] = 0


@jit
def refine(m, zf, vf, w, all_valid, cand, err, heap, qpos, stack, max_error, max_vertices, max_triangles):
    """Insert worst cells until a stop rule holds or the buffers are full.

    Returns (code, stack): ``code`` is one of STOP_* or NEED_SPACE (grow the
    buffers and call again); ``stack`` is the legalisation stack, possibly grown.
    """
    px, py, cnt = m[0], m[1], m[9]
    cap_v = len(px)
    cap_t = len(err)
    while True:
        flush(m, zf, vf, w, all_valid, cand, err, heap, qpos)
        if cnt[3] == 0:
            return STOP_EXHAUSTED, stack
        t = heap[0]
        if err[t] <= max_error:
            return STOP_ERROR, stack
        if cnt[0] + 1 > max_vertices:
            return STOP_VERTICES, stack
        if cnt[1] + 2 > max_triangles:
            return STOP_TRIANGLES, stack
        if cnt[0] + 1 > cap_v or cnt[1] + 2 > cap_t:
            return NEED_SPACE, stack
        heap_remove(t, heap, qpos, err, cnt)
        n = cnt[0]
        cnt[0] += 1
        px[n] = cand[t] % w
        py[n] = cand[t] // w
        stack = insert_in_triangle(m, t, n, stack)
