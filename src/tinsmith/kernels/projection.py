"""The greedy projection front of seed 001 (Gopi and Krishnan 2002, section 4), in one numba kernel.

Buffers: ``p`` (N, 3) float64 points without duplicates; the dexel array as
``cstart`` (ny * nx + 1) and ``cidx`` (N) (the points of dexel k are
``cidx[cstart[k]:cstart[k+1]]``, sorted by z) over a grid of ``h`` from
``(x0, y0)``.  Point states: 0 free, 1 fringe, 2 boundary, 3 completed.
Triangles are counter-clockwise about the surface normal the front carries;
a hash of directed edges keeps every edge in at most two triangles, walked
once each way (manifold and consistently oriented).
"""

import math

import numpy as np

from ._jit import jit, jit_inline
from .intersect import _segment_hits

FREE, FRINGE, BOUNDARY, COMPLETED = 0, 1, 2, 3
_EMPTY = -1


@jit_inline
def _slot(keys, key):
    mask = keys.shape[0] - 1
    k = (key * 6364136223846793005) & 9223372036854775807
    i = k & mask
    while keys[i] != _EMPTY and keys[i] != key:
        i = (i + 1) & mask
    return i


@jit_inline
def _has(keys, n, a, b):
    return keys[_slot(keys, a * n + b)] != _EMPTY


@jit_inline
def _corner(tri, t, v):
    """Which corner (0, 1, 2) of triangle t is vertex v."""
    return 0 if tri[t, 0] == v else (1 if tri[t, 1] == v else 2)


@jit_inline
def _angle_between(p, r, a, b):
    """Angle at r between r->a and r->b in space (radians)."""
    ux, uy, uz = p[a, 0] - p[r, 0], p[a, 1] - p[r, 1], p[a, 2] - p[r, 2]
    vx, vy, vz = p[b, 0] - p[r, 0], p[b, 1] - p[r, 1], p[b, 2] - p[r, 2]
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    return math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), ux * vx + uy * vy + uz * vz)


@jit_inline
def _ccw_span(a, b):
    """Counter-clockwise turn from angle a to angle b, in [0, 2 pi)."""
    d = b - a
    while d < 0.0:
        d += 2.0 * math.pi
    while d >= 2.0 * math.pi:
        d -= 2.0 * math.pi
    return d


@jit_inline
def _cross2(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@jit
def greedy_projection(p, nnd, cstart, cidx, x0, y0, h, nx, ny, mu, max_angle, min_angle, max_candidates, seed_up):
    """(triangles (M, 3), state (N,)): the mesh the breadth-first front grows, re-seeded for every component.

    ``nnd[i]`` is the distance from point i to its nearest other point (the
    ``m`` of the sphere of influence); at most ``max_candidates`` points, the
    nearest, are candidates of one reference point.
    """
    n = p.shape[0]
    state = np.zeros(n, np.int8)
    cap_t = 2 * n + 64
    tri = np.empty((cap_t, 3), np.int64)
    nt = 0
    head = np.full(n, -1, np.int64)  # first triangle at each vertex
    nxt = np.full(3 * cap_t, -1, np.int64)  # next triangle at the same vertex, per corner
    size = 1
    while size < 2 * (3 * cap_t):  # directed edges: at most 3 per triangle; load at most one half
        size *= 2
    keys = np.full(size, _EMPTY, np.int64)
    queue = np.empty(n, np.int64)  # a point joins it once, when it turns from free to fringe
    q_head = 0
    q_tail = 0
    seed_next = 0
    # scratch, grown as needed
    cand = np.empty(256, np.int64)
    ang = np.empty(256)
    keep = np.empty(256, np.bool_)
    nbr = np.empty(256, np.int64)
    near_p = np.empty(1024, np.int64)
    near_t = np.empty(1024, np.int64)
    near_box = np.empty((1024, 6))
    seen_t = np.full(cap_t, -1, np.int64)  # stamps: triangle already in near_t for this reference point
    owner_of = np.full(n, -1, np.int64)  # stamps: point is a candidate or a neighbour of this reference point
    edge_a = np.empty(256, np.int64)
    edge_b = np.empty(256, np.int64)
    edge_xy = np.empty((256, 4))
    dist = np.empty(256)
    starts = np.empty(16, np.int64)
    ends = np.empty(16, np.int64)
    seq = np.empty(258, np.int64)
    buf = np.empty(258, np.int64)
    max_angle_r = math.radians(max_angle)
    min_angle_r = math.radians(min_angle)
    done = 0
    while True:
        # next reference point: the front first, else a fresh seed
        if q_head < q_tail:
            r = queue[q_head]
            q_head += 1
            if state[r] == COMPLETED:
                continue
        else:
            while seed_next < n and state[seed_next] != FREE:
                seed_next += 1
            if seed_next >= n:
                break
            r = seed_next
            seed_next += 1
        done += 1
        # -- what r already has: neighbours (stamped) and the normal of its triangles
        nn = 0
        ax = ay = az = 0.0
        t = head[r]
        while t >= 0:
            kk = _corner(tri, t, r)
            a, b = tri[t, (kk + 1) % 3], tri[t, (kk + 2) % 3]
            ux, uy, uz = p[a, 0] - p[r, 0], p[a, 1] - p[r, 1], p[a, 2] - p[r, 2]
            vx, vy, vz = p[b, 0] - p[r, 0], p[b, 1] - p[r, 1], p[b, 2] - p[r, 2]
            ax += uy * vz - uz * vy
            ay += uz * vx - ux * vz
            az += ux * vy - uy * vx
            for v in (a, b):
                if owner_of[v] != done:
                    owner_of[v] = done
                    if nn == nbr.shape[0]:
                        nbr = np.concatenate((nbr, np.empty(nbr.shape[0], np.int64)))
                    nbr[nn] = v
                    nn += 1
            t = nxt[3 * t + kk]
        radius = mu * nnd[r]
        # -- candidates: the box, then the sphere of influence; not completed, not r, not a neighbour of r
        while True:
            nc = _box(p, cstart, cidx, x0, y0, h, nx, ny, r, radius, state, cand)
            if nc <= cand.shape[0]:
                break
            cand = np.empty(2 * nc, np.int64)
            ang = np.empty(2 * nc)
            keep = np.empty(2 * nc, np.bool_)
            dist = np.empty(2 * nc)
        c = 0
        for i in range(nc):
            q = cand[i]
            d2 = (p[q, 0] - p[r, 0]) ** 2 + (p[q, 1] - p[r, 1]) ** 2 + (p[q, 2] - p[r, 2]) ** 2
            if d2 <= radius * radius and owner_of[q] != done:
                cand[c] = q
                dist[c] = d2
                c += 1
        nc = c
        if nc > max_candidates:  # the nearest only: an outlier beside a dense patch stays cheap
            nearest = np.argsort(dist[:nc])[:max_candidates]
            chosen = cand[nearest]
            nc = max_candidates
            cand[:nc] = chosen
        for i in range(nc):
            owner_of[cand[i]] = done
        # -- the projection plane: the normal of r's triangles, or the least-spread direction of the candidates
        if nn > 0:
            nx_, ny_, nz_ = ax, ay, az
        else:
            if nc < 2:
                state[r] = BOUNDARY
                continue
            nx_, ny_, nz_ = _least_spread(p, r, cand, nc)
            if seed_up and nz_ < 0.0:
                nx_, ny_, nz_ = -nx_, -ny_, -nz_
        ln = math.sqrt(nx_ * nx_ + ny_ * ny_ + nz_ * nz_)
        if ln == 0.0:
            state[r] = BOUNDARY
            continue
        nx_, ny_, nz_ = nx_ / ln, ny_ / ln, nz_ / ln
        # u, v: an orthonormal basis of the plane, (u, v, n) right-handed
        if abs(nx_) < 0.9:
            ux, uy, uz = 0.0, -nz_, ny_  # n x (1, 0, 0)
        else:
            ux, uy, uz = nz_, 0.0, -nx_  # (0, 1, 0) x n
        lu = math.sqrt(ux * ux + uy * uy + uz * uz)
        ux, uy, uz = ux / lu, uy / lu, uz / lu
        vx, vy, vz = ny_ * uz - nz_ * uy, nz_ * ux - nx_ * uz, nx_ * uy - ny_ * ux
        # -- the free ranges of r: from the end of one fan (counter-clockwise) to the start of the next
        # a fan end: triangle (r, a, b) with no triangle holding r -> b; a fan start: (r, a, b) with none holding a -> r
        n_starts = 0
        n_ends = 0
        t = head[r]
        while t >= 0:
            kk = _corner(tri, t, r)
            a, b = tri[t, (kk + 1) % 3], tri[t, (kk + 2) % 3]
            if not _has(keys, n, r, b) and n_starts < 16:
                starts[n_starts] = b  # a free range starts at b
                n_starts += 1
            if not _has(keys, n, a, r) and n_ends < 16:
                ends[n_ends] = a  # and ends at a
                n_ends += 1
            t = nxt[3 * t + kk]
        if nn > 0 and n_starts == 0:
            state[r] = COMPLETED
            continue
        # -- angles of the candidates in the plane
        for i in range(nc):
            ang[i] = _proj_angle(p, r, cand[i], ux, uy, uz, vx, vy, vz)
            keep[i] = True
        # rule 2: drop candidates that have r in their invisible region (inside one of their fans)
        for i in range(nc):
            q = cand[i]
            t = head[q]
            if t < 0:
                continue
            tr = _proj_angle(p, q, r, ux, uy, uz, vx, vy, vz)
            while t >= 0 and keep[i]:
                kk = _corner(tri, t, q)
                a, b = tri[t, (kk + 1) % 3], tri[t, (kk + 2) % 3]
                ta = _proj_angle(p, q, a, ux, uy, uz, vx, vy, vz)
                span = _ccw_span(ta, _proj_angle(p, q, b, ux, uy, uz, vx, vy, vz))
                off = _ccw_span(ta, tr)
                if 1e-9 < off < span - 1e-9 and span < math.pi:
                    keep[i] = False
                t = nxt[3 * t + kk]
        # rule 3: drop candidates hidden behind a border edge of a candidate or of r's neighbours; the border
        # edges are gathered once (each from the end it leaves), projected once
        ne = 0
        for j in range(nc + nn):
            owner = cand[j] if j < nc else nbr[j - nc]
            t = head[owner]
            while t >= 0:
                kk = _corner(tri, t, owner)
                a, b = tri[t, (kk + 1) % 3], tri[t, (kk + 2) % 3]
                for e in range(2):
                    s, w = (owner, a) if e == 0 else (b, owner)
                    if s == r or w == r or (e == 1 and owner_of[b] == done) or _has(keys, n, w, s):
                        continue  # at r, gathered from its other end, or an inner edge
                    if ne == edge_a.shape[0]:
                        edge_a = np.concatenate((edge_a, np.empty(ne, np.int64)))
                        edge_b = np.concatenate((edge_b, np.empty(ne, np.int64)))
                        edge_xy = np.concatenate((edge_xy, np.empty((ne, 4))))
                    edge_a[ne], edge_b[ne] = s, w
                    edge_xy[ne, 0], edge_xy[ne, 1] = _proj(p, r, s, ux, uy, uz, vx, vy, vz)
                    edge_xy[ne, 2], edge_xy[ne, 3] = _proj(p, r, w, ux, uy, uz, vx, vy, vz)
                    ne += 1
                t = nxt[3 * t + kk]
        for i in range(nc):
            if not keep[i]:
                continue
            qi = cand[i]
            px_, py_ = _proj(p, r, qi, ux, uy, uz, vx, vy, vz)
            for e in range(ne):
                if edge_a[e] == qi or edge_b[e] == qi:
                    continue
                sx, sy, wx, wy = edge_xy[e, 0], edge_xy[e, 1], edge_xy[e, 2], edge_xy[e, 3]
                d1 = _cross2(0.0, 0.0, px_, py_, sx, sy)
                d2 = _cross2(0.0, 0.0, px_, py_, wx, wy)
                d3 = _cross2(sx, sy, wx, wy, 0.0, 0.0)
                d4 = _cross2(sx, sy, wx, wy, px_, py_)
                if ((d1 > 0) != (d2 > 0)) and d1 != 0 and d2 != 0 and ((d3 > 0) != (d4 > 0)) and d3 != 0 and d4 != 0:
                    keep[i] = False
                    break
        # sort the kept candidates by angle; the reach of r's new triangles
        c = 0
        reach2 = 0.0
        for i in range(nc):
            if keep[i]:
                cand[c] = cand[i]
                ang[c] = ang[i]
                c += 1
        nc = c
        for j in range(nc + nn):
            q = cand[j] if j < nc else nbr[j - nc]
            reach2 = max(reach2, (p[q, 0] - p[r, 0]) ** 2 + (p[q, 1] - p[r, 1]) ** 2 + (p[q, 2] - p[r, 2]) ** 2)
        order = np.argsort(ang[:nc])
        if seq.shape[0] < nc + 2:
            seq = np.empty(2 * nc + 2, np.int64)
            buf = np.empty(2 * nc + 2, np.int64)
        # the triangles a new one could cut: those at any point within twice its reach, each once, with its box
        while True:
            nb = _box(p, cstart, cidx, x0, y0, h, nx, ny, r, 2.0 * math.sqrt(reach2), state, near_p, False)
            if nb <= near_p.shape[0]:
                break
            near_p = np.empty(2 * nb, np.int64)
        n_near = 0
        for i in range(nb):
            v = near_p[i]
            t = head[v]
            while t >= 0:
                if seen_t[t] != done:
                    seen_t[t] = done
                    if n_near == near_t.shape[0]:
                        near_t = np.concatenate((near_t, np.empty(n_near, np.int64)))
                        near_box = np.concatenate((near_box, np.empty((n_near, 6))))
                    near_t[n_near] = t
                    for k in range(3):
                        lo = min(p[tri[t, 0], k], p[tri[t, 1], k], p[tri[t, 2], k])
                        hi = max(p[tri[t, 0], k], p[tri[t, 1], k], p[tri[t, 2], k])
                        near_box[n_near, k], near_box[n_near, 3 + k] = lo, hi
                    n_near += 1
                t = nxt[3 * t + _corner(tri, t, v)]
        # -- connect in angular order within each free range
        if nn == 0:
            # a fresh seed: the whole circle is free
            if nc < 2:
                state[r] = BOUNDARY
                continue
            kept = _thin(p, r, cand, ang, order, nc, min_angle_r, seq, 0, ux, uy, uz, vx, vy, vz, buf)
            for i in range(kept):
                s_, t_ = seq[i], seq[(i + 1) % kept]
                if kept == 2 and i == 1:
                    break
                nt = _add(p, tri, nt, head, nxt, keys, n, state, r, s_, t_, max_angle_r, cap_t, nx_, ny_, nz_,
                          near_t, near_box, n_near)
                q_tail = _enqueue(state, queue, q_tail, s_, t_)
        else:
            for si in range(n_starts):
                b0 = starts[si]
                tb0 = _proj_angle(p, r, b0, ux, uy, uz, vx, vy, vz)
                # the end of this free range: the fan start reached first counter-clockwise from b0
                best = -1
                best_span = 10.0
                for ei in range(n_ends):
                    sp = _ccw_span(tb0, _proj_angle(p, r, ends[ei], ux, uy, uz, vx, vy, vz))
                    if sp == 0.0 and ends[ei] != b0:
                        sp = 2.0 * math.pi
                    if ends[ei] == b0:
                        sp = 2.0 * math.pi  # the same point: the free range is the rest of the circle
                    if sp < best_span:
                        best_span = sp
                        best = ends[ei]
                if best < 0:
                    continue
                seq[0] = b0
                ns = 1
                for i in range(nc):
                    q = cand[order[i]]
                    off = _ccw_span(tb0, ang[order[i]])
                    if 1e-12 < off < best_span - 1e-12:
                        seq[ns] = q
                        ns += 1
                # the candidates in angular order from b0 (rotate the sorted order)
                _rotate_from(seq, ns, p, r, tb0, ux, uy, uz, vx, vy, vz)
                kept = _thin(p, r, seq, ang, order, ns, min_angle_r, seq, 1, ux, uy, uz, vx, vy, vz, buf)
                seq[kept] = best
                kept += 1
                for i in range(kept - 1):
                    nt = _add(p, tri, nt, head, nxt, keys, n, state, r, seq[i], seq[i + 1], max_angle_r, cap_t,
                              nx_, ny_, nz_, near_t, near_box, n_near)
                    q_tail = _enqueue(state, queue, q_tail, seq[i], seq[i + 1])
        # -- r is completed when its fan closed
        open_edge = False
        t = head[r]
        while t >= 0:
            kk = _corner(tri, t, r)
            a, b = tri[t, (kk + 1) % 3], tri[t, (kk + 2) % 3]
            if not _has(keys, n, r, b) or not _has(keys, n, a, r):
                open_edge = True
            t = nxt[3 * t + kk]
        state[r] = COMPLETED if head[r] >= 0 and not open_edge else BOUNDARY
    return tri[:nt].copy(), state


@jit
def _least_spread(p, r, cand, nc):
    """The direction of least spread of r and ``cand[:nc]`` (the normal of a fresh seed's plane, section 4)."""
    mx, my, mz = p[r, 0], p[r, 1], p[r, 2]
    for i in range(nc):
        mx += p[cand[i], 0]
        my += p[cand[i], 1]
        mz += p[cand[i], 2]
    mx /= nc + 1
    my /= nc + 1
    mz /= nc + 1
    cov = np.zeros((3, 3))
    for i in range(-1, nc):
        q = r if i < 0 else cand[i]
        dx, dy, dz = p[q, 0] - mx, p[q, 1] - my, p[q, 2] - mz
        cov[0, 0] += dx * dx
        cov[0, 1] += dx * dy
        cov[0, 2] += dx * dz
        cov[1, 1] += dy * dy
        cov[1, 2] += dy * dz
        cov[2, 2] += dz * dz
    cov[1, 0], cov[2, 0], cov[2, 1] = cov[0, 1], cov[0, 2], cov[1, 2]
    _, vec = np.linalg.eigh(cov)
    return vec[0, 0], vec[1, 0], vec[2, 0]


@jit_inline
def _proj(p, r, q, ux, uy, uz, vx, vy, vz):
    dx, dy, dz = p[q, 0] - p[r, 0], p[q, 1] - p[r, 1], p[q, 2] - p[r, 2]
    return dx * ux + dy * uy + dz * uz, dx * vx + dy * vy + dz * vz


@jit_inline
def _proj_angle(p, r, q, ux, uy, uz, vx, vy, vz):
    a, b = _proj(p, r, q, ux, uy, uz, vx, vy, vz)
    return math.atan2(b, a)


@jit
def _rotate_from(seq, ns, p, r, t0, ux, uy, uz, vx, vy, vz):
    """Sort ``seq[1:ns]`` by counter-clockwise angle from ``t0`` (insertion sort: a handful of points)."""
    for i in range(2, ns):
        q = seq[i]
        key = _ccw_span(t0, _proj_angle(p, r, q, ux, uy, uz, vx, vy, vz))
        j = i - 1
        while j >= 1 and _ccw_span(t0, _proj_angle(p, r, seq[j], ux, uy, uz, vx, vy, vz)) > key:
            seq[j + 1] = seq[j]
            j -= 1
        seq[j + 1] = q


@jit
def _thin(p, r, src, ang, order, ns, min_angle_r, out, fixed_first, ux, uy, uz, vx, vy, vz, buf):
    """The neighbours kept, in order, into ``out`` (section 4.1, angle criterion).

    A point that makes an angle below ``min_angle_r`` at r with the one kept
    before it is dropped, unless that would trap it: it is dropped only when
    it lies beyond the segment from the kept one to the next (seen from r),
    so the triangle that skips it does not cover it.  The last point is kept.
    ``buf`` is scratch of at least ``ns``.
    """
    kept = 0
    for i in range(ns):
        buf[i] = src[i] if fixed_first else src[order[i]]
    for i in range(ns):
        q = buf[i]
        if kept > 0 and min_angle_r > 0.0 and i < ns - 1 and not (fixed_first and i == 0):
            if _angle_between(p, r, out[kept - 1], q) < min_angle_r:
                ax, ay = _proj(p, r, out[kept - 1], ux, uy, uz, vx, vy, vz)
                bx, by = _proj(p, r, buf[i + 1], ux, uy, uz, vx, vy, vz)
                qx, qy = _proj(p, r, q, ux, uy, uz, vx, vy, vz)
                # r at the origin; q is outside triangle (r, a, b) when it is on the far side of a -> b
                if _cross2(ax, ay, bx, by, qx, qy) < 0.0 and _cross2(ax, ay, bx, by, 0.0, 0.0) > 0.0:
                    continue
        out[kept] = q
        kept += 1
    return kept


@jit_inline
def _enqueue(state, queue, q_tail, a, b):
    """Free points become fringe points and join the back of the queue (each point is a reference once)."""
    for v in (a, b):
        if state[v] == FREE:
            state[v] = FRINGE
            queue[q_tail] = v
            q_tail += 1
    return q_tail


@jit
def _add(p, tri, nt, head, nxt, keys, n, state, r, s, t, max_angle_r, cap_t, nx_, ny_, nz_, near_t, near_box, n_near):
    """Add triangle (r, s, t) when its edges allow it (each directed edge new, so each edge is in at most two
    triangles, walked once each way) and it cuts none of the triangles ``near_t[:n_near]`` (boxes ``near_box``:
    low x, y, z, high x, y, z)."""
    if s == t or nt >= cap_t or state[s] == COMPLETED or state[t] == COMPLETED:
        return nt
    if _angle_between(p, r, s, t) >= max_angle_r:
        return nt
    # oriented like the plane's normal, with area
    ux, uy, uz = p[s, 0] - p[r, 0], p[s, 1] - p[r, 1], p[s, 2] - p[r, 2]
    vx, vy, vz = p[t, 0] - p[r, 0], p[t, 1] - p[r, 1], p[t, 2] - p[r, 2]
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    if cx * nx_ + cy * ny_ + cz * nz_ <= 0.0:
        return nt
    for a, b in ((r, s), (s, t), (t, r)):
        if _has(keys, n, a, b):
            return nt
    if _has(keys, n, s, r) and _has(keys, n, t, s) and _has(keys, n, r, t):
        # the three edges exist the other way round: a triangular hole to close, or this triangle reversed (a fold)
        k = head[r]
        while k >= 0:
            if (tri[k, 0] == s or tri[k, 1] == s or tri[k, 2] == s) and (tri[k, 0] == t or tri[k, 1] == t or tri[k, 2] == t):
                return nt
            k = nxt[3 * k + _corner(tri, k, r)]
    lo0, hi0 = min(p[r, 0], p[s, 0], p[t, 0]), max(p[r, 0], p[s, 0], p[t, 0])
    lo1, hi1 = min(p[r, 1], p[s, 1], p[t, 1]), max(p[r, 1], p[s, 1], p[t, 1])
    lo2, hi2 = min(p[r, 2], p[s, 2], p[t, 2]), max(p[r, 2], p[s, 2], p[t, 2])
    for i in range(n_near):
        if (near_box[i, 3] < lo0 or near_box[i, 0] > hi0 or near_box[i, 4] < lo1 or near_box[i, 1] > hi1
                or near_box[i, 5] < lo2 or near_box[i, 2] > hi2):
            continue  # the boxes are apart
        k = near_t[i]
        a, b, c = tri[k, 0], tri[k, 1], tri[k, 2]
        if a == r or a == s or a == t or b == r or b == s or b == t or c == r or c == s or c == t:
            continue
        if (_segment_hits(p[r], p[s], p[a], p[b], p[c]) or _segment_hits(p[s], p[t], p[a], p[b], p[c])
                or _segment_hits(p[t], p[r], p[a], p[b], p[c]) or _segment_hits(p[a], p[b], p[r], p[s], p[t])
                or _segment_hits(p[b], p[c], p[r], p[s], p[t]) or _segment_hits(p[c], p[a], p[r], p[s], p[t])):
            return nt
    tri[nt, 0], tri[nt, 1], tri[nt, 2] = r, s, t
    for k in range(3):
        v = tri[nt, k]
        nxt[3 * nt + k] = head[v]
        head[v] = nt
    for a, b in ((r, s), (s, t), (t, r)):
        keys[_slot(keys, a * n + b)] = a * n + b
    return nt + 1


@jit
def _box(p, cstart, cidx, x0, y0, h, nx, ny, r, reach, state, out, skip_completed=True):
    """Points other than r, not completed, in the axis-aligned box of half-width ``reach`` about r; their count
    (more than ``out`` holds: only counted)."""
    px, py, pz = p[r, 0], p[r, 1], p[r, 2]
    c0 = max(0, int(math.floor((px - reach - x0) / h)))
    c1 = min(nx - 1, int(math.floor((px + reach - x0) / h)))
    r0 = max(0, int(math.floor((py - reach - y0) / h)))
    r1 = min(ny - 1, int(math.floor((py + reach - y0) / h)))
    count = 0
    for i in range(r0, r1 + 1):
        for j in range(c0, c1 + 1):
            k = i * nx + j
            lo, hi = cstart[k], cstart[k + 1]
            # the dexel's points are sorted by z: binary search the lower end
            a, b = lo, hi
            while a < b:
                mid = (a + b) // 2
                if p[cidx[mid], 2] < pz - reach:
                    a = mid + 1
                else:
                    b = mid
            for m in range(a, hi):
                q = cidx[m]
                if p[q, 2] > pz + reach:
                    break
                if q == r or (skip_completed and state[q] == COMPLETED):
                    continue
                if abs(p[q, 0] - px) <= reach and abs(p[q, 1] - py) <= reach:
                    if count < out.shape[0]:
                        out[count] = q
                    count += 1
    return count
