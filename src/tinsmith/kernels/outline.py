"""Chaining unit boundary edges into straight runs.

Buffer layout: ``n0``, ``n1`` int64 (E,): the end nodes of each edge, as
``row * w + col``; the result is (K, 2) int64 end nodes of the merged runs.
A node joins two edges of one run when exactly two edges meet there and they
continue in the same direction.
"""

import numpy as np

from ._jit import jit


@jit
def _other(n0, n1, e, node):
    return n1[e] if n0[e] == node else n0[e]


@jit
def merge_straight_runs(n0, n1, w):
    e_count = len(n0)
    ends = np.concatenate((n0, n1))
    edge_of = np.concatenate((np.arange(e_count), np.arange(e_count)))
    order = np.argsort(ends, kind="mergesort")
    nodes = ends[order]
    incident = edge_of[order]
    used = np.zeros(e_count, dtype=np.bool_)
    out = np.empty((e_count, 2), dtype=np.int64)
    k = 0
    for i in range(e_count):
        if used[i]:
            continue
        used[i] = True
        for side in range(2):
            node = n0[i] if side == 0 else n1[i]
            edge = i
            while True:
                lo = np.searchsorted(nodes, node, side="left")
                hi = np.searchsorted(nodes, node, side="right")
                if hi - lo != 2:
                    break
                a, b = incident[lo], incident[lo + 1]
                u, v = _other(n0, n1, a, node), _other(n0, n1, b, node)
                nr, nc = node // w, node % w
                if (nr - u // w, nc - u % w) != (v // w - nr, v % w - nc):
                    break  # a corner: the run ends here
                nxt = b if a == edge else a
                if used[nxt]:
                    break
                used[nxt] = True
                edge = nxt
                node = _other(n0, n1, nxt, node)
            out[k, side] = node
        k += 1
    return out[:k]
