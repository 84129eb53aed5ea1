"""Pairs of triangles that cut each other (self-intersections), through a uniform grid of boxes.

Two triangles with no vertex in common intersect when an edge of one
crosses the other (segment against triangle, Moller and Trumbore 1997,
strict on both); coplanar overlaps are not counted.  Candidate pairs come
from the grid cells their bounding boxes share; a pair is tested only in
the first cell both boxes reach, so it is counted once.
"""

import math

import numpy as np

from ._jit import jit, jit_inline


@jit_inline
def _segment_hits(p, q, a, b, c):
    """True when the open segment p-q crosses the interior of triangle a, b, c (not coplanar)."""
    dx, dy, dz = q[0] - p[0], q[1] - p[1], q[2] - p[2]
    e1x, e1y, e1z = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    e2x, e2y, e2z = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    hx, hy, hz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
    det = e1x * hx + e1y * hy + e1z * hz
    scale = (abs(e1x) + abs(e1y) + abs(e1z)) * (abs(e2x) + abs(e2y) + abs(e2z)) * (abs(dx) + abs(dy) + abs(dz))
    if abs(det) <= 1e-12 * scale:
        return False
    inv = 1.0 / det
    sx, sy, sz = p[0] - a[0], p[1] - a[1], p[2] - a[2]
    u = (sx * hx + sy * hy + sz * hz) * inv
    if u <= 1e-12 or u >= 1.0 - 1e-12:
        return False
    qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x
    v = (dx * qx + dy * qy + dz * qz) * inv
    if v <= 1e-12 or u + v >= 1.0 - 1e-12:
        return False
    t = (e2x * qx + e2y * qy + e2z * qz) * inv
    return 1e-12 < t < 1.0 - 1e-12


@jit
def intersecting_pairs(v, tri, cell):
    """Number of pairs of triangles without a common vertex that cut each other; ``cell`` is the grid spacing."""
    m = tri.shape[0]
    lo = np.empty((m, 3), np.int64)
    hi = np.empty((m, 3), np.int64)
    total = 0
    for t in range(m):
        for k in range(3):
            a = min(v[tri[t, 0], k], v[tri[t, 1], k], v[tri[t, 2], k])
            b = max(v[tri[t, 0], k], v[tri[t, 1], k], v[tri[t, 2], k])
            lo[t, k] = int(math.floor(a / cell))
            hi[t, k] = int(math.floor(b / cell))
        total += (hi[t, 0] - lo[t, 0] + 1) * (hi[t, 1] - lo[t, 1] + 1) * (hi[t, 2] - lo[t, 2] + 1)
    keys = np.empty(total, np.int64)
    owner = np.empty(total, np.int64)
    j = 0
    for t in range(m):
        for x in range(lo[t, 0], hi[t, 0] + 1):
            for y in range(lo[t, 1], hi[t, 1] + 1):
                for z in range(lo[t, 2], hi[t, 2] + 1):
                    keys[j] = ((x * 73856093) ^ (y * 19349663) ^ (z * 83492791)) & 0x3FFFFFFFFFFFFFFF
                    owner[j] = t
                    j += 1
    order = np.argsort(keys)
    count = 0
    start = 0
    while start < total:
        end = start + 1
        while end < total and keys[order[end]] == keys[order[start]]:
            end += 1
        for i in range(start, end):
            s = owner[order[i]]
            for jj in range(i + 1, end):
                t = owner[order[jj]]
                if s == t:
                    continue
                shared = False
                for a in range(3):
                    for b in range(3):
                        if tri[s, a] == tri[t, b]:
                            shared = True
                if shared:
                    continue
                # boxes overlap, and this cell is the first both reach (so the pair counts once)
                ok = True
                for k in range(3):
                    if lo[s, k] > hi[t, k] or lo[t, k] > hi[s, k]:
                        ok = False
                if not ok:
                    continue
                fx, fy, fz = max(lo[s, 0], lo[t, 0]), max(lo[s, 1], lo[t, 1]), max(lo[s, 2], lo[t, 2])
                first = ((fx * 73856093) ^ (fy * 19349663) ^ (fz * 83492791)) & 0x3FFFFFFFFFFFFFFF
                if first != keys[order[start]]:
                    continue
                hit = False
                for e in range(3):
                    if _segment_hits(v[tri[s, e]], v[tri[s, (e + 1) % 3]], v[tri[t, 0]], v[tri[t, 1]], v[tri[t, 2]]):
                        hit = True
                    if _segment_hits(v[tri[t, e]], v[tri[t, (e + 1) % 3]], v[tri[s, 0]], v[tri[s, 1]], v[tri[s, 2]]):
                        hit = True
                if hit:
                    count += 1
        start = end
    return count
