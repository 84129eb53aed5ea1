"""Breaklines and control points on a grid: world geometry snapped to cell centres, split where lines cross.

Grid methods that keep lines as edges (greedy insertion, the quality method,
cCVT) take them as (row, col) segments between cell centres: each vertex is
snapped to the nearest cell, which must hold data (:func:`.outline.covered`),
and where two segments cross away from their ends, the cell nearest the
crossing becomes a vertex of both, so the constraints never cross.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from ..core import Heightfield
from ..errors import InvalidInputError
from .outline import covered

__all__ = ["breakline_segments", "snap_to_cells"]


def snap_to_cells(hf: Heightfield, name: str, xy) -> np.ndarray:
    """(K, 2) world points -> (K, 2) (row, col) of their nearest cells, which must hold data; errors name ``name``."""
    pts = np.asarray(xy, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] < 2 or not np.isfinite(pts[:, :2]).all():
        raise InvalidInputError(f"{name} must be finite (K, 2) world coordinates, got shape {pts.shape}")
    rows, cols = hf.world_to_pixel(pts[:, 0], pts[:, 1])
    rc = np.column_stack([np.rint(rows), np.rint(cols)]).astype(np.int64)
    h, w = hf.shape
    valid = hf.valid
    for k, (r, c) in enumerate(rc.tolist()):
        if not (0 <= r < h and 0 <= c < w):
            raise InvalidInputError(
                f"{name}: point {k} at ({pts[k, 0]:.10g}, {pts[k, 1]:.10g}) lies outside the grid of the DEM"
            )
        if not covered(valid, float(r), float(c)):
            raise InvalidInputError(f"{name}: point {k} at {tuple(pts[k, :2])} falls on a cell without data")
    return rc


def breakline_segments(hf: Heightfield, lines) -> np.ndarray:
    """(S, 4) grid segments (r0, c0, r1, c1) of world polylines: vertices snapped to cells, split where two cross."""
    if isinstance(lines, np.ndarray) and lines.ndim == 2:
        lines = [lines]
    segments = []
    for i, line in enumerate(lines):
        rc = snap_to_cells(hf, f"breaklines[{i}]", line)
        keep = np.r_[True, np.any(rc[1:] != rc[:-1], axis=1)]
        rc = rc[keep]
        segments += [(a[0], a[1], b[0], b[1]) for a, b in pairwise(rc.tolist())]
    if not segments:
        return np.empty((0, 4), np.int64)
    return _split_crossings(np.unique(np.asarray(segments, np.int64), axis=0), hf.valid)


def _orient(p, q, r):
    """Exact sign of the orientation of integer points (arrays of (..., 2) row, col)."""
    v = (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0])
    return np.sign(v)


def _split_crossings(segments: np.ndarray, valid: np.ndarray, rounds: int = 5) -> np.ndarray:
    """Split (S, 4) integer segments (r0, c0, r1, c1) where two cross away from their ends.

    The crossing is snapped to the nearest cell centre, which both segments
    then pass through; repeated until nothing crosses.
    """
    for _ in range(rounds):
        p, q = segments[:, None, :2], segments[:, None, 2:]
        r, s = segments[None, :, :2], segments[None, :, 2:]
        proper = (_orient(p, q, r) * _orient(p, q, s) < 0) & (_orient(r, s, p) * _orient(r, s, q) < 0)
        i, j = np.nonzero(np.triu(proper, 1))
        if len(i) == 0:
            return segments
        a, b = segments[i], segments[j]
        # intersection of a = p + t (q - p) with b
        d1 = (a[:, 2:] - a[:, :2]).astype(float)
        d2 = (b[:, 2:] - b[:, :2]).astype(float)
        denom = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
        t = ((b[:, 0] - a[:, 0]) * d2[:, 1] - (b[:, 1] - a[:, 1]) * d2[:, 0]) / denom
        cross = np.rint(a[:, :2] + t[:, None] * d1).astype(np.int64)
        cuts: dict[int, list] = {}
        for k, (si, sj) in enumerate(zip(i.tolist(), j.tolist(), strict=True)):
            node = tuple(cross[k])
            if not valid[node]:
                raise InvalidInputError(
                    f"two breaklines cross over a cell without data (row {node[0]}, col {node[1]})"
                )
            cuts.setdefault(si, []).append(node)
            cuts.setdefault(sj, []).append(node)
        out = []
        for k, seg in enumerate(segments.tolist()):
            if k not in cuts:
                out.append(seg)
                continue
            start, end = np.array(seg[:2]), np.array(seg[2:])
            nodes = sorted(set(cuts[k]), key=lambda n: float(np.dot(np.array(n) - start, end - start)))
            chain = [tuple(start)] + [n for n in nodes if n != tuple(start) and n != tuple(end)] + [tuple(end)]
            out += [(u[0], u[1], v[0], v[1]) for u, v in pairwise(chain)]
        segments = np.unique(np.asarray(out, np.int64), axis=0)
    raise InvalidInputError("breaklines still cross after snapping their crossings to cells; simplify them")
