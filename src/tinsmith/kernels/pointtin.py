"""Kernels of the point-cloud TIN (:mod:`tinsmith.algorithms.greedy.pointtin`)."""

import numpy as np

from ._jit import jit


@jit
def longest_edges(m):
    """(T,) the longest horizontal edge of each triangle of ``m``, and (E,) the length of every edge once."""
    px, py, tri, half, n = m[0], m[1], m[2], m[3], m[9][1]
    longest = np.empty(n)
    lengths = np.empty(3 * n)
    count = 0
    for t in range(n):
        top = 0.0
        for k in range(3):
            e = 3 * t + k
            a, b = tri[e], tri[3 * t + (k + 1) % 3]
            d2 = (px[a] - px[b]) ** 2 + (py[a] - py[b]) ** 2
            if half[e] < e:  # each edge once: from its higher halfedge, or its only one on the hull
                lengths[count] = d2
                count += 1
            top = max(top, d2)
        longest[t] = np.sqrt(top)
    return longest, np.sqrt(lengths[:count])


@jit
def merge_duplicates(m, same, z, rule):
    """Fold the points that ``same`` maps onto another (``same[i] != i``) into it, in place.

    ``z`` takes the lowest (``rule`` 0), highest (1) or mean (2) height of
    each group; the kept vertices are renumbered in their order and moved to
    the front of the vertex arrays and of ``z``; the triangles are rewritten.
    Returns the (V,) new id of every point (that of its group for a merged one)
    and the number of vertices kept.
    """
    px, py, tri, vedge, cnt = m[0], m[1], m[2], m[5], m[9]
    n = len(same)
    count = np.ones(n, np.int64)
    for i in range(n):
        j = same[i]
        if j != i:
            if rule == 0:
                z[j] = min(z[j], z[i])
            elif rule == 1:
                z[j] = max(z[j], z[i])
            else:
                z[j] += z[i]
                count[j] += 1
    new = np.empty(n, np.int64)
    kept = 0
    for i in range(n):
        if same[i] == i:
            new[i] = kept
            px[kept], py[kept], vedge[kept] = px[i], py[i], vedge[i]
            z[kept] = z[i] / count[i] if rule == 2 else z[i]
            kept += 1
    for i in range(n):
        new[i] = new[same[i]]
    for e in range(3 * cnt[1]):
        tri[e] = new[tri[e]]
    cnt[0] = kept
    return new, kept
