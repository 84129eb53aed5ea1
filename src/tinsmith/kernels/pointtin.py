"""Kernels of the point-cloud TIN (:mod:`tinsmith.algorithms.greedy.pointtin`)."""

import numpy as np

from ._jit import jit, jit_inline


@jit
def edge_lengths(m):
    """(E,) the horizontal length of every edge of ``m`` once (from its higher halfedge, or its only one on the hull)."""
    px, py, tri, half, n = m[0], m[1], m[2], m[3], m[9][1]
    count = 0
    for e in range(3 * n):
        count += half[e] < e
    lengths = np.empty(count + 1)  # a spare slot: every halfedge is written, the next one's over it when not kept
    count = 0
    for t in range(n):
        for k in range(3):
            e = 3 * t + k
            a, b = tri[e], tri[3 * t + (k + 1) % 3]
            lengths[count] = np.sqrt((px[a] - px[b]) ** 2 + (py[a] - py[b]) ** 2)
            count += half[e] < e  # no branch: whether a halfedge is an edge's higher one is a coin toss
    return lengths[:count]


#: :func:`median` and :func:`edge_counts` count the values in at most this many bins (32 KB of counts:
#: 65,536 bins held 0.5 MB a part, 9-14 bytes a point of the two-worker TIN of lidR Topography or Autzen).
MEDIAN_BINS = 1 << 12


@jit
def _shift_of(low, high):
    """The right shift that puts the bit patterns ``low..high`` in at most :data:`MEDIAN_BINS` bins."""
    shift = 0
    while (high - low) >> shift >= MEDIAN_BINS:
        shift += 1
    return shift


@jit
def _middle_bins(bins, n):
    """``(first, last, skipped)``: the bins holding the middle value(s) of ``n`` counted ones, and how many
    values the bins before ``first`` hold."""
    k_low, k_high = (n - 1) // 2, n // 2  # the middle one, or the middle two
    below = 0
    first = last = -1
    skipped = 0
    for i in range(len(bins)):
        if first < 0 and below + bins[i] > k_low:
            first, skipped = i, below
        if below + bins[i] > k_high:
            last = i
            break
        below += bins[i]
    return first, last, skipped


@jit
def median(values):
    """``np.median`` of (N,) non-negative values (N >= 1), without reordering or copying them.

    The values' bit patterns order as the values do (non-negative floats);
    they are counted in at most :data:`MEDIAN_BINS` bins between the least
    and the greatest, and only the one or two bins holding the middle values
    are gathered and sorted.
    """
    n = len(values)
    bits = values.view(np.int64)
    low = high = bits[0]
    for i in range(n):
        low = min(low, bits[i])
        high = max(high, bits[i])
    shift = _shift_of(low, high)
    bins = np.zeros(((high - low) >> shift) + 1, np.int64)
    for i in range(n):
        bins[(bits[i] - low) >> shift] += 1
    first, last, skipped = _middle_bins(bins, n)
    size = 0
    for i in range(first, last + 1):
        size += bins[i]
    middle = np.empty(size)
    size = 0
    for i in range(n):
        key = (bits[i] - low) >> shift
        if first <= key <= last:
            middle[size] = values[i]
            size += 1
    middle.sort()
    a, b = middle[(n - 1) // 2 - skipped], middle[n // 2 - skipped]
    return a if n % 2 else (a + b) / 2


@jit_inline
def _squared(px, py, a, b):
    """The squared horizontal length of the edge a - b (the same both ways)."""
    return (px[a] - px[b]) ** 2 + (py[a] - py[b]) ** 2


@jit_inline
def _squared3(px, py, tri, t):
    """The squared horizontal lengths of triangle t's three edges."""
    a, b, c = tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]
    return _squared(px, py, a, b), _squared(px, py, b, c), _squared(px, py, c, a)


@jit_inline
def _key(value, low, scale, top):
    """The bin of a value: linear from ``low``, those beyond the bins' range in the first or the last (monotone)."""
    return int(min(max((value - low) * scale, 0.0), top))


@jit
def edge_counts(px, py, tri, n_tri, hull, low, scale):
    """(:data:`MEDIAN_BINS`,) how many squared horizontal edge lengths fall in each even bin from ``low``:
    ``(value - low) * scale``, clamped to the bins (which keeps the order).

    The values are those of the three halfedges of the ``n_tri`` triangles of
    ``tri`` and of the (H, 2) edges ``hull``: counted over every triangle
    and the hull's edges once more, each edge comes twice (and the median of
    a list where every value comes twice is that of the list), so the counts
    of parts of the triangles, one of them with the hull, add up to those of
    every edge.
    """
    top = float(MEDIAN_BINS - 1)
    bins = np.zeros(MEDIAN_BINS, np.int64)
    for t in range(n_tri):
        u, v, w = _squared3(px, py, tri, t)
        bins[_key(u, low, scale, top)] += 1
        bins[_key(v, low, scale, top)] += 1
        bins[_key(w, low, scale, top)] += 1
    for i in range(len(hull)):
        bins[_key(_squared(px, py, hull[i, 0], hull[i, 1]), low, scale, top)] += 1
    return bins


@jit
def edge_middle(px, py, tri, n_tri, hull, low, scale, first, last, size):
    """The ``size`` values that :func:`edge_counts` counts in bins ``first..last`` for the same triangles and
    hull edges, in no order."""
    top = float(MEDIAN_BINS - 1)
    middle = np.empty(size + 1)  # a spare slot for the value written over
    size = 0
    for t in range(n_tri):
        u, v, w = _squared3(px, py, tri, t)
        # three tests, no branch taken per corner: a value outside the middle bins is written over
        middle[size] = u
        size += first <= _key(u, low, scale, top) <= last
        middle[size] = v
        size += first <= _key(v, low, scale, top) <= last
        middle[size] = w
        size += first <= _key(w, low, scale, top) <= last
    for i in range(len(hull)):
        value = _squared(px, py, hull[i, 0], hull[i, 1])
        middle[size] = value
        size += first <= _key(value, low, scale, top) <= last
    return middle[:size]


@jit
def short_triangles(px, py, tri, n, limit):
    """(n,) bool: the triangles of ``tri`` whose every edge is at most ``limit`` long (horizontally)."""
    keep = np.empty(n, np.bool_)
    for t in range(n):
        top = 0.0
        for k in range(3):
            a, b = tri[3 * t + k], tri[3 * t + (k + 1) % 3]
            top = max(top, (px[a] - px[b]) ** 2 + (py[a] - py[b]) ** 2)
        keep[t] = np.sqrt(top) <= limit
    return keep


@jit
def folded_heights(same, z, rule):
    """The heights of the groups of points at one place: ``(ids, heights)``.

    ``same`` maps each point to its group's point (``same[i] != i`` for the
    others); ``ids`` (G,) lists, ascending, the points that others map to,
    ``heights`` their group's lowest (``rule`` 0), highest (1) or mean (2)
    height of ``z``.  Memory in the number of groups, not of points.
    """
    n = len(same)
    shared = np.zeros(n, np.bool_)
    for i in range(n):
        if same[i] != i:
            shared[same[i]] = True
    ids = np.flatnonzero(shared)
    heights = z[ids].copy()
    count = np.ones(len(ids), np.int64)
    for i in range(n):
        j = same[i]
        if j != i:
            k = np.searchsorted(ids, j)
            if rule == 0:
                heights[k] = min(heights[k], z[i])
            elif rule == 1:
                heights[k] = max(heights[k], z[i])
            else:
                heights[k] += z[i]
                count[k] += 1
    if rule == 2:
        heights /= count
    return ids, heights


@jit
def used_points(xyz, used, ids, heights):
    """(K, 3) the points that ``used`` marks, in order, with the heights of ``ids`` replaced by ``heights``."""
    out = np.empty((np.count_nonzero(used), 3))
    k = j = 0
    for i in range(len(used)):
        while j < len(ids) and ids[j] < i:
            j += 1
        if used[i]:
            out[k, 0], out[k, 1] = xyz[i, 0], xyz[i, 1]
            out[k, 2] = heights[j] if j < len(ids) and ids[j] == i else xyz[i, 2]
            k += 1
    return out


@jit
def merge_duplicates(m, same, z, rule):
    """Fold the points that ``same`` maps onto another (``same[i] != i``) into it, in place.

    ``z`` takes the lowest (``rule`` 0), highest (1) or mean (2) height of
    each group (:func:`folded_heights`); the kept vertices are renumbered in
    their order and moved to the front of the vertex arrays and of ``z``; the
    triangles are rewritten.  Returns the (V,) new id of every point (that of
    its group for a merged one) and the number of vertices kept.
    """
    px, py, tri, vedge, cnt = m[0], m[1], m[2], m[5], m[9]
    n = len(same)
    ids, heights = folded_heights(same, z, rule)
    z[ids] = heights
    new = np.empty(n, np.int64)
    kept = 0
    for i in range(n):
        if same[i] == i:
            new[i] = kept
            px[kept], py[kept], vedge[kept], z[kept] = px[i], py[i], vedge[i], z[i]
            kept += 1
    for i in range(n):
        new[i] = new[same[i]]
    for e in range(3 * cnt[1]):
        tri[e] = new[tri[e]]
    cnt[0] = kept
    return new, kept


@jit
def kept_mesh(tri, keep, n_vertices, out):
    """The triangles ``keep`` marks, over the vertices they use, written to ``out``: ``(used, count)``.

    ``used`` (V,) bool marks the vertices of kept triangles; the first
    ``count`` rows of ``out`` (K, 3) index the used vertices in their order.
    ``out`` may be ``tri`` itself (viewed as rows): a triangle is written
    no later than it is read.
    """
    used = np.zeros(n_vertices, np.bool_)
    for t in range(len(keep)):
        if keep[t]:
            for k in range(3):
                used[tri[3 * t + k]] = True
    remap = np.empty(n_vertices, np.int32)
    count = 0
    for v in range(n_vertices):
        remap[v] = count
        count += used[v]
    kept = 0
    for t in range(len(keep)):
        if keep[t]:
            for k in range(3):
                out[kept, k] = remap[tri[3 * t + k]]
            kept += 1
    return used, kept


@jit
def xy_covariance(xyz):
    """(sxx, sxy, syy): the covariance of the x-y of (N, 3) points (N >= 1), about their mean."""
    n = len(xyz)
    mx = my = 0.0
    for i in range(n):
        mx += xyz[i, 0]
        my += xyz[i, 1]
    mx /= n
    my /= n
    sxx = sxy = syy = 0.0
    for i in range(n):
        dx, dy = xyz[i, 0] - mx, xyz[i, 1] - my
        sxx += dx * dx
        sxy += dx * dy
        syy += dy * dy
    return sxx / n, sxy / n, syy / n


@jit
def tile_keep(tri, cons, n_tri, px, py, n_points, keys, key_covered, line_x, line_y, max_edge):
    """(T,) bool: the triangles of a tile's TIN kept by the rule of :func:`tinsmith.tiles.points._tile_keep`.

    ``keys`` (sorted) name the seam segments ``min * V + max`` of their vertex
    ids, ``key_covered`` whether each is covered; ``line_x`` / ``line_y`` hold,
    for a seam vertex on a covered segment, the x (y) of its vertical
    (horizontal) side, NaN elsewhere.  The edges of a triangle that touches a
    covered side count their points' distance to that side.
    """
    n_v = len(px)
    keep = np.empty(n_tri, np.bool_)
    d = np.empty(3)
    for t in range(n_tri):
        tx = np.nan
        ty = np.nan
        for j in range(3):
            w = tri[3 * t + j]
            if not np.isnan(line_x[w]) and (np.isnan(tx) or line_x[w] < tx):
                tx = line_x[w]
            if not np.isnan(line_y[w]) and (np.isnan(ty) or line_y[w] < ty):
                ty = line_y[w]
        near = not np.isnan(tx) or not np.isnan(ty)
        if near:
            for j in range(3):
                w = tri[3 * t + j]
                a = abs(px[w] - tx)  # NaN where that side is not touched
                b = abs(py[w] - ty)
                d[j] = b if np.isnan(a) else (a if np.isnan(b) else min(a, b))
        along_covered = False
        along_gap = False
        free_ok = True
        for k in range(3):
            e = 3 * t + k
            u, v = tri[e], tri[3 * t + (k + 1) % 3]
            on_seam = False
            if cons[e] and len(keys):
                key = np.int64(min(u, v)) * n_v + max(u, v)
                i = np.searchsorted(keys, key)
                if i < len(keys) and keys[i] == key:
                    on_seam = True
                    if key_covered[i]:
                        along_covered = True
                    else:
                        along_gap = True
            if on_seam:
                continue
            pu, pv = u < n_points, v < n_points
            if near and (pu or pv):
                du, dv = d[k], d[(k + 1) % 3]
                length = max(du, dv) if (pu and pv) else (du if pu else dv)
            else:
                length = np.hypot(px[u] - px[v], py[u] - py[v])
            if not length <= max_edge:
                free_ok = False
        keep[t] = along_covered or (not along_gap and free_ok)
    return keep
