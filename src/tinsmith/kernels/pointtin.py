"""Kernels of the point-cloud TIN (:mod:`tinsmith.algorithms.pointtin`)."""

import numpy as np

from ._jit import jit


@jit
def longest_edges(m):
    """(T,) the longest horizontal edge of each triangle of ``m``, and (3T,) every halfedge's length."""
    px, py, tri, n = m[0], m[1], m[2], m[9][1]
    longest = np.empty(n)
    lengths = np.empty(3 * n)
    for t in range(n):
        top = 0.0
        for k in range(3):
            a, b = tri[3 * t + k], tri[3 * t + (k + 1) % 3]
            d = np.sqrt((px[a] - px[b]) ** 2 + (py[a] - py[b]) ** 2)
            lengths[3 * t + k] = d
            top = max(top, d)
        longest[t] = top
    return longest, lengths
