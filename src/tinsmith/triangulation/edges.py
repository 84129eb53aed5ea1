"""Edges of a triangle mesh: the twins two triangles share, the border, values spread along edges.

Plain numpy on ``(M, 3)`` vertex indices, so readers and writers (the
boundaries of solver formats) use them without the numba kernels.
"""

from __future__ import annotations

import numpy as np

__all__ = ["border_edges", "edge_twins", "fill_from_neighbours"]


def border_edges(triangles: np.ndarray, n_vertices: int) -> np.ndarray:
    """(K, 2) directed edges (as the triangles walk them) whose reverse no triangle walks: the border."""
    t = np.asarray(triangles, dtype=np.int64)
    edges = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    walked = np.sort(edges[:, 0] * n_vertices + edges[:, 1])
    reverse = edges[:, 1] * n_vertices + edges[:, 0]
    at = np.minimum(np.searchsorted(walked, reverse), max(len(walked) - 1, 0))
    return edges[walked[at] != reverse] if len(walked) else edges


def edge_twins(triangles: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The edges two triangles share: (first halfedge, second halfedge, key), in key order.

    Halfedge ``3 * i + k`` runs from corner k of triangle i to corner k + 1;
    an edge's key is ``smaller vertex * (n_vertices + 1) + larger vertex``.
    """
    t = np.asarray(triangles, dtype=np.int64)
    src, dst = t.ravel(), t[:, [1, 2, 0]].ravel()
    key = np.minimum(src, dst) * (n_vertices + 1) + np.maximum(src, dst)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    return order[same], order[same + 1], ks[same]


def fill_from_neighbours(h: np.ndarray, edges: np.ndarray, rounds: int = 3) -> np.ndarray:
    """``h`` with each NaN replaced by the mean of its neighbours (along ``edges``) that have a value, for up to
    ``rounds`` rings inwards; what is still missing after that becomes 0."""
    h = h.copy()
    n = len(h)
    a, b = edges[:, 0], edges[:, 1]
    for _ in range(rounds):
        missing = np.isnan(h)
        if not missing.any():
            break
        total, count = np.zeros(n), np.zeros(n)
        for src, dst in ((a, b), (b, a)):
            ok = np.isfinite(h[src])
            np.add.at(total, dst[ok], h[src][ok])
            np.add.at(count, dst[ok], 1)
        fill = missing & (count > 0)
        h[fill] = total[fill] / count[fill]
    h[np.isnan(h)] = 0.0
    return h
