"""Hydrology on grids: depression filling, D8 flow directions, accumulation, stream tracing, HAND.

Every kernel works on a row-major (H, W) grid and a boolean ``valid`` mask;
nodata cells take no part in the flow.  D8 codes index :data:`DR` and
:data:`DC` (0 east, then clockwise: south-east, south, south-west, west,
north-west, north, north-east), -1 marks an outlet or a nodata cell.
"""

import numpy as np

from ._jit import jit, jit_inline

#: Row and column offsets of the D8 codes 0..7 (east, then clockwise; row 0 is north).
DR = np.array([0, 1, 1, 1, 0, -1, -1, -1], dtype=np.int64)
DC = np.array([1, 1, 0, -1, -1, -1, 0, 1], dtype=np.int64)


@jit_inline
def _before(za, sa, zb, sb):
    """True when (za, sa) comes before (zb, sb): the lower height first, then the earlier push."""
    return za < zb or (za == zb and sa < sb)


@jit_inline
def _push(heap, hz, hs, n, cell, z, seq):
    """Push ``cell`` with key (z, seq) on the min-heap of size ``n``; returns the new size."""
    i = n
    while i > 0:
        parent = (i - 1) >> 1
        if not _before(z, seq, hz[parent], hs[parent]):
            break
        heap[i] = heap[parent]
        hz[i] = hz[parent]
        hs[i] = hs[parent]
        i = parent
    heap[i] = cell
    hz[i] = z
    hs[i] = seq
    return n + 1


@jit_inline
def _pop(heap, hz, hs, n):
    """Remove the top of the min-heap of size ``n`` (the caller read it first); returns the new size."""
    n -= 1
    if n == 0:
        return 0
    cell, z, seq = heap[n], hz[n], hs[n]
    i = 0
    while True:
        left = 2 * i + 1
        if left >= n:
            break
        j = left
        if left + 1 < n and _before(hz[left + 1], hs[left + 1], hz[left], hs[left]):
            j = left + 1
        if not _before(hz[j], hs[j], z, seq):
            break
        heap[i] = heap[j]
        hz[i] = hz[j]
        hs[i] = hs[j]
        i = j
    heap[i] = cell
    hz[i] = z
    hs[i] = seq
    return n


@jit
def seeds(valid):
    """(H, W) bool: the valid cells on the grid's edge or with a nodata cell among their 8 neighbours."""
    h, w = valid.shape
    out = np.zeros((h, w), dtype=np.bool_)
    for r in range(h):
        for c in range(w):
            if not valid[r, c]:
                continue
            if r == 0 or c == 0 or r == h - 1 or c == w - 1:
                out[r, c] = True
                continue
            for k in range(8):
                if not valid[r + DR[k], c + DC[k]]:
                    out[r, c] = True
                    break
    return out


@jit
def priority_flood_epsilon(z, valid):
    """Depression-filled heights (float64, NaN at nodata): Priority-Flood+epsilon with a pit queue.

    Seeds (the edge and the cells next to nodata) enter a min-heap keyed by
    (height, push order).  A neighbour no higher than ``nextafter`` of the
    cell it is reached from is raised to that and goes on a FIFO pit queue,
    which is served first; any other neighbour goes on the heap.  Every cell
    that is not a seed ends strictly higher than the cell that reached it.
    """
    h, w = z.shape
    n = h * w
    filled = np.full((h, w), np.nan)
    closed = ~valid
    heap = np.empty(n, dtype=np.int64)
    hz = np.empty(n)
    hs = np.empty(n, dtype=np.int64)
    pit = np.empty(n, dtype=np.int64)
    size = 0
    seq = 0
    is_seed = seeds(valid)
    for r in range(h):
        for c in range(w):
            if is_seed[r, c]:
                filled[r, c] = z[r, c]
                closed[r, c] = True
                size = _push(heap, hz, hs, size, r * w + c, filled[r, c], seq)
                seq += 1
    head = tail = 0
    while size > 0 or tail > head:
        if tail > head:
            cell = pit[head]
            head += 1
        else:
            cell = heap[0]
            size = _pop(heap, hz, hs, size)
        r, c = cell // w, cell % w
        lift = np.nextafter(filled[r, c], np.inf)
        for k in range(8):
            rr, cc = r + DR[k], c + DC[k]
            if rr < 0 or cc < 0 or rr >= h or cc >= w or closed[rr, cc]:
                continue
            closed[rr, cc] = True
            v = np.float64(z[rr, cc])
            if v <= lift:
                filled[rr, cc] = lift
                pit[tail] = rr * w + cc
                tail += 1
            else:
                filled[rr, cc] = v
                size = _push(heap, hz, hs, size, rr * w + cc, v, seq)
                seq += 1
    return filled


@jit
def d8(filled, valid, dx, dy):
    """D8 code of every cell (int8): its steepest strictly lower valid neighbour, -1 when none or nodata.

    The drop is divided by ``dx``, ``dy`` or ``hypot(dx, dy)``; of equal
    slopes the first code wins.
    """
    h, w = filled.shape
    dist = np.empty(8)
    diag = np.hypot(dx, dy)
    for k in range(8):
        dist[k] = diag if DR[k] != 0 and DC[k] != 0 else (dx if DR[k] == 0 else dy)
    codes = np.full((h, w), -1, dtype=np.int8)
    for r in range(h):
        for c in range(w):
            if not valid[r, c]:
                continue
            zc = filled[r, c]
            best = 0.0
            found = False
            for k in range(8):
                rr, cc = r + DR[k], c + DC[k]
                if rr < 0 or cc < 0 or rr >= h or cc >= w or not valid[rr, cc]:
                    continue
                drop = zc - filled[rr, cc]
                if drop > 0.0:
                    # a drop of one ulp near 0 is subnormal and its slope may round to 0: still lower
                    s = drop / dist[k]
                    if not found or s > best:
                        found = True
                        best = s
                        codes[r, c] = k
    return codes


@jit
def downstream(codes):
    """Flat index of the cell each cell drains to, -1 for outlets and nodata."""
    h, w = codes.shape
    down = np.full(h * w, -1, dtype=np.int64)
    for r in range(h):
        for c in range(w):
            k = codes[r, c]
            if k >= 0:
                down[r * w + c] = (r + DR[k]) * w + c + DC[k]
    return down


@jit
def topological_order(down, valid_flat):
    """Valid cells, every cell before the cell it drains to (Kahn's algorithm, O(n)); ties by index."""
    n = down.size
    indeg = np.zeros(n, dtype=np.int64)
    for i in range(n):
        if down[i] >= 0:
            indeg[down[i]] += 1
    order = np.empty(n, dtype=np.int64)
    m = 0
    for i in range(n):
        if valid_flat[i] and indeg[i] == 0:
            order[m] = i
            m += 1
    head = 0
    while head < m:
        j = down[order[head]]
        head += 1
        if j >= 0:
            indeg[j] -= 1
            if indeg[j] == 0:
                order[m] = j
                m += 1
    return order[:m]


@jit
def accumulate(down, order, weight):
    """Sum of ``weight`` over each cell and every cell upstream of it (cells not in ``order`` stay 0)."""
    acc = np.zeros(down.size)
    for t in range(order.size):
        i = order[t]
        acc[i] += weight
        if down[i] >= 0:
            acc[down[i]] += acc[i]
    return acc


@jit
def trace_streams(down, stream):
    """Stream cells as polylines split at confluences: (flat cell indices, offsets).

    A polyline starts at a stream cell with no stream cell or several stream
    cells flowing into it (heads in index order) and runs downstream to an
    outlet or up to and including the next such cell.  One-cell polylines
    are left out.
    """
    n = down.size
    n_up = np.zeros(n, dtype=np.int64)
    for i in range(n):
        if stream[i] and down[i] >= 0 and stream[down[i]]:
            n_up[down[i]] += 1
    cells = np.empty(2 * n + 1, dtype=np.int64)
    offsets = np.empty(n + 1, dtype=np.int64)
    m = 0
    lines = 0
    offsets[0] = 0
    for i in range(n):
        if not stream[i] or n_up[i] == 1:
            continue
        start = m
        cells[m] = i
        m += 1
        j = down[i]
        while j >= 0 and stream[j]:
            cells[m] = j
            m += 1
            if n_up[j] != 1:
                break
            j = down[j]
        if m - start < 2:
            m = start
            continue
        lines += 1
        offsets[lines] = m
    return cells[:m].copy(), offsets[: lines + 1].copy()


@jit
def drainage_height(filled_flat, down, order, stream):
    """``filled`` of the first stream cell each cell drains to (itself on a stream); NaN if it reaches none."""
    base = np.full(down.size, np.nan)
    for t in range(order.size - 1, -1, -1):
        i = order[t]
        if stream[i]:
            base[i] = filled_flat[i]
        elif down[i] >= 0:
            base[i] = base[down[i]]
    return base
