"""Edge flips that improve triangle shape on a surface mesh (the remesher's seam relaxation).

Layout: ``v`` float64 (N, 3); ``tri`` int64 (M, 3), consistently oriented;
``twin`` int64 (3M,): halfedge ``3t + k`` runs from corner ``k`` to corner
``k + 1`` of triangle ``t``, ``twin`` gives the opposite halfedge (-1 on the
border); ``locked`` sorted int64 keys ``min * N + max`` of edges no flip may
remove.
"""

import numpy as np

from ._jit import jit


@jit
def _min_angle(v, a, b, c):
    """The smallest angle (radians) of triangle a, b, c; 0 for a degenerate one."""
    best = np.pi
    for i in range(3):
        p = a if i == 0 else (b if i == 1 else c)
        q = b if i == 0 else (c if i == 1 else a)
        r = c if i == 0 else (a if i == 1 else b)
        ux, uy, uz = v[q, 0] - v[p, 0], v[q, 1] - v[p, 1], v[q, 2] - v[p, 2]
        wx, wy, wz = v[r, 0] - v[p, 0], v[r, 1] - v[p, 1], v[r, 2] - v[p, 2]
        nu = np.sqrt(ux * ux + uy * uy + uz * uz)
        nw = np.sqrt(wx * wx + wy * wy + wz * wz)
        if nu == 0.0 or nw == 0.0:
            return 0.0
        cos = (ux * wx + uy * wy + uz * wz) / (nu * nw)
        cos = min(1.0, max(-1.0, cos))
        best = min(best, np.arccos(cos))
    return best


@jit
def _normal(v, a, b, c):
    ux, uy, uz = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1], v[b, 2] - v[a, 2]
    wx, wy, wz = v[c, 0] - v[a, 0], v[c, 1] - v[a, 1], v[c, 2] - v[a, 2]
    return uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx


@jit
def _joined(tri, twin, vedge, c, d):
    """Whether c and d already share an edge: the fan round c, both ways from one of its halfedges."""
    start = vedge[c]
    e = start
    for _ in range(2 * tri.shape[0]):  # counter-clockwise: c -> x, then the halfedge into c before it, its twin
        t = e // 3
        if tri[t, (e % 3 + 1) % 3] == d or tri[t, (e % 3 + 2) % 3] == d:
            return True
        prev = 3 * t + (e % 3 + 2) % 3
        e = twin[prev]
        if e < 0 or e == start:
            break
    if e < 0:  # a border: the other way round
        e = start
        for _ in range(2 * tri.shape[0]):
            g = twin[e]
            if g < 0:
                break
            t = g // 3
            e = 3 * t + (g % 3 + 1) % 3
            if tri[t, (e % 3 + 1) % 3] == d or tri[t, (e % 3 + 2) % 3] == d:
                return True
            if e == start:
                break
    return False


@jit
def flip_pass(v, tri, twin, vedge, band, locked):
    """One pass of improving flips over the edges with an end in ``band``; returns the flips made.

    An edge a-b between triangles (a, b, c) and (b, a, d) becomes c-d when
    that raises the smaller of the two triangles' minimum angles, c and d
    are not joined already, and the new pair neither turns against the old
    pair's normal nor folds by more than 60 degrees.
    """
    n = v.shape[0]
    flips = 0
    for h in range(3 * tri.shape[0]):
        g = twin[h]
        if g < h:
            continue
        t, k = h // 3, h % 3
        u, j = g // 3, g % 3
        a, b = tri[t, k], tri[t, (k + 1) % 3]
        if not (band[a] or band[b]):
            continue
        key = min(a, b) * n + max(a, b)
        i = np.searchsorted(locked, key)
        if i < locked.shape[0] and locked[i] == key:
            continue
        c = tri[t, (k + 2) % 3]
        d = tri[u, (j + 2) % 3]
        if c == d or _joined(tri, twin, vedge, c, d):
            continue
        o0 = _normal(v, a, b, c)
        o1 = _normal(v, b, a, d)
        rx, ry, rz = o0[0] + o1[0], o0[1] + o1[1], o0[2] + o1[2]
        n0 = _normal(v, a, d, c)
        n1 = _normal(v, d, b, c)
        if n0[0] * rx + n0[1] * ry + n0[2] * rz <= 0.0 or n1[0] * rx + n1[1] * ry + n1[2] * rz <= 0.0:
            continue
        l0 = np.sqrt(n0[0] ** 2 + n0[1] ** 2 + n0[2] ** 2)
        l1 = np.sqrt(n1[0] ** 2 + n1[1] ** 2 + n1[2] ** 2)
        if l0 == 0.0 or l1 == 0.0 or n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] < 0.5 * l0 * l1:
            continue
        old = min(_min_angle(v, a, b, c), _min_angle(v, b, a, d))
        if min(_min_angle(v, a, d, c), _min_angle(v, d, b, c)) <= old + 1e-9:
            continue
        # halfedges before: h a->b, h1 b->c, h2 c->a; g b->a, g1 a->d, g2 d->b
        h1, h2 = 3 * t + (k + 1) % 3, 3 * t + (k + 2) % 3
        g1, g2 = 3 * u + (j + 1) % 3, 3 * u + (j + 2) % 3
        o_h1, o_h2, o_g1, o_g2 = twin[h1], twin[h2], twin[g1], twin[g2]
        # after: t = (a, d, c): a->d, d->c, c->a; u = (d, b, c): d->b, b->c, c->d
        tri[t, 0], tri[t, 1], tri[t, 2] = a, d, c
        tri[u, 0], tri[u, 1], tri[u, 2] = d, b, c
        pairs = ((3 * t, o_g1), (3 * t + 2, o_h2), (3 * u, o_g2), (3 * u + 1, o_h1))
        for e, o in pairs:
            twin[e] = o
            if o >= 0:
                twin[o] = e
        twin[3 * t + 1] = 3 * u + 2
        twin[3 * u + 2] = 3 * t + 1
        vedge[a] = 3 * t
        vedge[d] = 3 * t + 1
        vedge[c] = 3 * t + 2
        vedge[b] = 3 * u + 1
        flips += 1
    return flips
