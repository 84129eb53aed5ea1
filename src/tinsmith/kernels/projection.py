"""The greedy projection front of Gopi and Krishnan (2002) (Gopi and Krishnan 2002, section 4), in one numba kernel.

Inputs: ``p`` (N, 3) float64 points without duplicates; ``nnd`` (N) each
point's ``m`` (the sphere of influence is ``mu * m``); the dexel array as
``cstart`` (ny * nx + 1) and ``cidx`` (N) (the points of dexel k are
``cidx[cstart[k]:cstart[k+1]]``, sorted by z) over a grid of ``h`` from
``(x0, y0)``.  Point states: 0 free, 1 fringe, 2 boundary, 3 completed.

Triangles are counter-clockwise about the surface normal the front carries.
A triangle is added only when none of its directed edges is walked yet
(found among the triangles at the edge's first point), so every edge has at
most two triangles, walked once each way: the mesh is manifold and
consistently oriented by construction.  Nor may it cut a triangle already
made: every triangle is entered in the dexels its x-y box reaches, and a new
one is tested (segment against triangle) against those its box meets.

The kernel allocates nothing (``jit_no_refcount``: numba's reference
counting cost a third of the time).  :func:`greedy_projection` takes every
buffer from its caller and returns a status: when a buffer is too small it
stops with the status naming it, and the caller runs it again with a larger
one (same input, same mesh).
"""

import math

from ._jit import jit_inline, jit_no_refcount
from .intersect import _segment_hits

FREE, FRINGE, BOUNDARY, COMPLETED = 0, 1, 2, 3
DONE, MORE_TRIANGLES, MORE_ENTRIES, MORE_NEIGHBOURS, MORE_EDGES = 0, 1, 2, 3, 4
MAX_FANS = 16  # free ranges of one reference point that are filled (more are left for later)


@jit_no_refcount
def greedy_projection(p, nnd, cstart, cidx, x0, y0, h, nx, ny, mu, max_angle, min_angle, seed_up, max_down,
                      seeds, strip_of, strip, queue, q_tail, t_first, t_end, e_first, e_end, stamp,
                      tri, nxt, head, box, state, grid_head, ent, seen_t, owner_of,
                      cand, dist, ang, keep, order, seq, buf, nbr, links, edge_v, edge_xy, fans):
    """Grow the mesh with a breadth-first front from ``queue[:q_tail]``, re-seeded at the free points of
    ``seeds`` in turn (one seed per component); (status, triangles end, entries end, stamp end).

    With ``strip >= 0`` only points with ``strip_of == strip`` are candidates
    (strips of the dexel array meshed side by side, see
    :func:`tinsmith.algorithms.reconstruct.projection.general_mesh`).  New triangles take
    the numbers ``t_first`` .. ``t_end - 1`` and their dexel entries
    ``e_first`` .. ``e_end - 1``; stamps count up from ``stamp``.  A triangle
    whose unit normal has a z below ``-max_down`` is not made (a cloud seen
    from above has no surface facing down; 2 or more turns the rule off).

    Buffers, filled in: ``tri`` (T, 3) and ``nxt`` (3 T) the triangles and,
    per corner, the next triangle at the same point; ``box`` (T, 6) float32
    their boxes; ``head`` (N, -1) the first triangle at each point;
    ``state`` (N, 0); ``queue`` (the points that can join it);
    ``grid_head`` (ny * nx, -1) and ``ent`` (E, 2) the triangles by dexel
    (triangle, next entry); ``seen_t`` (T, -1) and ``owner_of`` (N, -1)
    stamps.  Scratch: ``cand``, ``dist``, ``ang``, ``keep``, ``order`` (K,
    the most candidates of one point), ``seq``, ``buf`` (K + 2), ``nbr``
    (neighbours), ``links`` (2, L) (the triangles at one point), ``edge_v``
    (B, 2) and ``edge_xy`` (B, 4) (border edges), ``fans`` (2, MAX_FANS).
    """
    nt = t_first
    n_ent = e_first
    q_head = 0
    seed_next = 0
    query = stamp
    done = stamp
    cos_max = math.cos(math.radians(max_angle))
    cos_min = math.cos(math.radians(min_angle))
    while True:
        # next reference point: the front first, else a fresh seed
        if q_head < q_tail:
            r = queue[q_head]
            q_head += 1
            if state[r] == COMPLETED:
                continue
        else:
            while seed_next < seeds.shape[0] and state[seeds[seed_next]] != FREE:
                seed_next += 1
            if seed_next >= seeds.shape[0]:
                break
            r = seeds[seed_next]
            seed_next += 1
        done += 1
        # -- what r already has: neighbours (stamped) and the normal of its triangles
        nn = 0
        ax = ay = az = 0.0
        deg = _links(tri, head, nxt, r, links)
        if deg < 0:
            return MORE_NEIGHBOURS, nt, n_ent, max(done, query)
        for i in range(deg):
            a, b = links[0, i], links[1, i]
            ux, uy, uz = p[a, 0] - p[r, 0], p[a, 1] - p[r, 1], p[a, 2] - p[r, 2]
            vx, vy, vz = p[b, 0] - p[r, 0], p[b, 1] - p[r, 1], p[b, 2] - p[r, 2]
            ax += uy * vz - uz * vy
            ay += uz * vx - ux * vz
            az += ux * vy - uy * vx
            for v in (a, b):
                if owner_of[v] != done:
                    if nn == nbr.shape[0]:
                        return MORE_NEIGHBOURS, nt, n_ent, max(done, query)
                    owner_of[v] = done
                    nbr[nn] = v
                    nn += 1
        # -- candidates: the box, then the sphere of influence (mu * m, m the distance to the nearest point);
        # not completed, not r, not a neighbour of r; the nearest max_candidates, by distance
        nc = _candidates(p, cstart, cidx, x0, y0, h, nx, ny, r, mu * nnd[r], state, owner_of, done, strip_of, strip,
                         cand, dist)
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
        for i in range(deg):
            if not _listed(links, 0, deg, links[1, i]) and n_starts < MAX_FANS:
                fans[0, n_starts] = links[1, i]  # a free range starts at b
                n_starts += 1
            if not _listed(links, 1, deg, links[0, i]) and n_ends < MAX_FANS:
                fans[1, n_ends] = links[0, i]  # and ends at a
                n_ends += 1
        if nn > 0 and n_starts == 0:
            state[r] = COMPLETED
            continue
        # -- angles of the candidates in the plane
        for i in range(nc):
            ang[i] = _proj_angle(p, r, cand[i], ux, uy, uz, vx, vy, vz)
            keep[i] = True
        # rule 2: drop candidates that have r in their invisible region (inside one of their fans, a wedge
        # under a half turn); rule 3: gather the border edges of the candidates and of r's neighbours (only
        # border edges can hide a point), each from the end it leaves, projected once
        ne = 0
        for j in range(nc + nn):
            owner = cand[j] if j < nc else nbr[j - nc]
            deg_o = _links(tri, head, nxt, owner, links)
            if deg_o < 0:
                return MORE_NEIGHBOURS, nt, n_ent, max(done, query)
            ox, oy = _proj(p, r, owner, ux, uy, uz, vx, vy, vz)
            for k in range(deg_o):
                a, b = links[0, k], links[1, k]
                axp, ayp = _proj(p, r, a, ux, uy, uz, vx, vy, vz)
                bxp, byp = _proj(p, r, b, ux, uy, uz, vx, vy, vz)
                if (j < nc and keep[j] and a != r and b != r
                        and _cross2(ox, oy, axp, ayp, 0.0, 0.0) > 0.0 and _cross2(ox, oy, 0.0, 0.0, bxp, byp) > 0.0
                        and _cross2(ox, oy, axp, ayp, bxp, byp) > 0.0):
                    keep[j] = False
                for e in range(2):
                    if e == 0:
                        s, w = owner, a
                        inner = _listed(links, 1, deg_o, a)  # a -> owner walked too
                    else:
                        s, w = b, owner
                        inner = _listed(links, 0, deg_o, b) or owner_of[b] == done  # or gathered from b
                    if s == r or w == r or inner:
                        continue
                    if ne == edge_v.shape[0]:
                        return MORE_EDGES, nt, n_ent, max(done, query)
                    edge_v[ne, 0], edge_v[ne, 1] = s, w
                    if e == 0:
                        edge_xy[ne, 0], edge_xy[ne, 1], edge_xy[ne, 2], edge_xy[ne, 3] = ox, oy, axp, ayp
                    else:
                        edge_xy[ne, 0], edge_xy[ne, 1], edge_xy[ne, 2], edge_xy[ne, 3] = bxp, byp, ox, oy
                    ne += 1
        for i in range(nc):
            if not keep[i]:
                continue
            qi = cand[i]
            px_, py_ = _proj(p, r, qi, ux, uy, uz, vx, vy, vz)
            for e in range(ne):
                if edge_v[e, 0] == qi or edge_v[e, 1] == qi:
                    continue
                sx, sy, wx, wy = edge_xy[e, 0], edge_xy[e, 1], edge_xy[e, 2], edge_xy[e, 3]
                d1 = _cross2(0.0, 0.0, px_, py_, sx, sy)
                d2 = _cross2(0.0, 0.0, px_, py_, wx, wy)
                d3 = _cross2(sx, sy, wx, wy, 0.0, 0.0)
                d4 = _cross2(sx, sy, wx, wy, px_, py_)
                if ((d1 > 0) != (d2 > 0)) and d1 != 0 and d2 != 0 and ((d3 > 0) != (d4 > 0)) and d3 != 0 and d4 != 0:
                    keep[i] = False
                    break
        # the kept candidates, sorted by angle (insertion sort: a handful; ties keep the nearer first)
        c = 0
        for i in range(nc):
            if keep[i]:
                cand[c] = cand[i]
                ang[c] = ang[i]
                c += 1
        nc = c
        for i in range(nc):
            j = i
            while j > 0 and ang[order[j - 1]] > ang[i]:
                order[j] = order[j - 1]
                j -= 1
            order[j] = i
        # -- connect in angular order within each free range
        if nn == 0:
            # a fresh seed: the whole circle is free
            if nc < 2:
                state[r] = BOUNDARY
                continue
            for i in range(nc):
                buf[i] = cand[order[i]]
            kept = _thin(p, r, buf, nc, cos_min, seq, False, ux, uy, uz, vx, vy, vz)
            for i in range(kept if kept > 2 else 1):
                s_, t_ = seq[i], seq[(i + 1) % kept]
                query += 1
                status = _add(p, tri, nxt, head, box, nt, state, r, s_, t_, cos_max, nx_, ny_, nz_, grid_head, ent,
                              n_ent, seen_t, query, x0, y0, h, nx, ny, t_end, e_end, max_down)
                if status < 0:
                    return MORE_TRIANGLES if status == -1 else MORE_ENTRIES, nt, n_ent, max(done, query)
                if status > 0:
                    n_ent = status
                    nt += 1
                q_tail = _enqueue(state, queue, q_tail, s_, t_)
        else:
            for si in range(n_starts):
                b0 = fans[0, si]
                tb0 = _proj_angle(p, r, b0, ux, uy, uz, vx, vy, vz)
                # the end of this free range: the fan start reached first counter-clockwise from b0
                best = -1
                best_span = 10.0
                for ei in range(n_ends):
                    sp = _ccw_span(tb0, _proj_angle(p, r, fans[1, ei], ux, uy, uz, vx, vy, vz))
                    if sp == 0.0 or fans[1, ei] == b0:
                        sp = 4.0  # the same direction, or point: the free range is the rest of the circle
                    if sp < best_span:
                        best_span = sp
                        best = fans[1, ei]
                if best < 0:
                    continue
                # the candidates inside the free range, counter-clockwise from b0: the sorted order, rotated
                start = 0
                while start < nc and ang[order[start]] <= tb0:
                    start += 1
                buf[0] = b0
                ns = 1
                for k in range(nc):
                    i = order[(start + k) % nc]
                    off = _ccw_span(tb0, ang[i])
                    if 1e-12 < off < best_span - 1e-12:
                        buf[ns] = cand[i]
                        ns += 1
                kept = _thin(p, r, buf, ns, cos_min, seq, True, ux, uy, uz, vx, vy, vz)
                seq[kept] = best
                kept += 1
                for i in range(kept - 1):
                    query += 1
                    status = _add(p, tri, nxt, head, box, nt, state, r, seq[i], seq[i + 1], cos_max, nx_, ny_, nz_,
                                  grid_head, ent, n_ent, seen_t, query, x0, y0, h, nx, ny, t_end, e_end, max_down)
                    if status < 0:
                        return MORE_TRIANGLES if status == -1 else MORE_ENTRIES, nt, n_ent, max(done, query)
                    if status > 0:
                        n_ent = status
                        nt += 1
                    q_tail = _enqueue(state, queue, q_tail, seq[i], seq[i + 1])
        # -- r is completed when its fan closed
        deg = _links(tri, head, nxt, r, links)
        if deg < 0:
            return MORE_NEIGHBOURS, nt, n_ent, max(done, query)
        open_edge = False
        for i in range(deg):
            if not _listed(links, 0, deg, links[1, i]) or not _listed(links, 1, deg, links[0, i]):
                open_edge = True
        state[r] = COMPLETED if deg > 0 and not open_edge else BOUNDARY
    return DONE, nt, n_ent, max(done, query)


@jit_inline
def _corner(tri, t, v):
    """Which corner (0, 1, 2) of triangle t is vertex v."""
    return 0 if tri[t, 0] == v else (1 if tri[t, 1] == v else 2)


@jit_inline
def _has(tri, head, nxt, a, b):
    """True when a triangle walks the directed edge a -> b (found among the triangles at a)."""
    t = head[a]
    while t >= 0:
        k = _corner(tri, t, a)
        if tri[t, (k + 1) % 3] == b:
            return True
        t = nxt[3 * t + k]
    return False


@jit_inline
def _links(tri, head, nxt, v, links):
    """The triangles (v, a, b) at v as ``links[0, i] = a`` (the next corner) and ``links[1, i] = b``; their count,
    or -1 when ``links`` is too small."""
    deg = 0
    t = head[v]
    while t >= 0:
        if deg == links.shape[1]:
            return -1
        k = _corner(tri, t, v)
        links[0, deg] = tri[t, (k + 1) % 3]
        links[1, deg] = tri[t, (k + 2) % 3]
        deg += 1
        t = nxt[3 * t + k]
    return deg


@jit_inline
def _listed(links, row, deg, v):
    """True when v is among ``links[row, :deg]``: a -> v is walked (row 1) or v -> a is (row 0), a the point."""
    for i in range(deg):
        if links[row, i] == v:
            return True
    return False


@jit_inline
def _cos_between(p, r, a, b):
    """Cosine of the angle at r between r->a and r->b in space."""
    ux, uy, uz = p[a, 0] - p[r, 0], p[a, 1] - p[r, 1], p[a, 2] - p[r, 2]
    vx, vy, vz = p[b, 0] - p[r, 0], p[b, 1] - p[r, 1], p[b, 2] - p[r, 2]
    return (ux * vx + uy * vy + uz * vz) / math.sqrt((ux * ux + uy * uy + uz * uz) * (vx * vx + vy * vy + vz * vz))


@jit_inline
def _pseudo_angle(x, y):
    """A monotone stand-in for the direction of (x, y), in [0, 4) (0 along +x, 1 along +y, 2 along -x, ...);
    opposite directions differ by exactly 2.  No trigonometry."""
    if y >= 0.0:
        if x >= 0.0:
            return y / (x + y) if x + y > 0.0 else 0.0
        return 1.0 - x / (y - x)
    if x < 0.0:
        return 2.0 - y / (-x - y)
    return 3.0 + x / (x - y)


@jit_inline
def _ccw_span(a, b):
    """Counter-clockwise turn from pseudo-angle a to pseudo-angle b, in [0, 4)."""
    d = b - a
    while d < 0.0:
        d += 4.0
    while d >= 4.0:
        d -= 4.0
    return d


@jit_inline
def _cross2(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@jit_inline
def _proj(p, r, q, ux, uy, uz, vx, vy, vz):
    dx, dy, dz = p[q, 0] - p[r, 0], p[q, 1] - p[r, 1], p[q, 2] - p[r, 2]
    return dx * ux + dy * uy + dz * uz, dx * vx + dy * vy + dz * vz


@jit_inline
def _proj_angle(p, r, q, ux, uy, uz, vx, vy, vz):
    """The pseudo-angle of q about r in the plane (u, v)."""
    a, b = _proj(p, r, q, ux, uy, uz, vx, vy, vz)
    return _pseudo_angle(a, b)


@jit_no_refcount
def _candidates(p, cstart, cidx, x0, y0, h, nx, ny, r, radius, state, owner_of, stamp, strip_of, strip, cand,
                dist):
    """The points in the sphere of ``radius`` about r, not completed, not r, not stamped (r's neighbours), in
    r's strip (``strip`` >= 0): the nearest ``len(cand)`` of them in ``cand``, by distance (squared distances in
    ``dist``); their count.

    The dexels of the box about r are scanned, each from the lowest point within reach (binary search by z).
    """
    px, py, pz = p[r, 0], p[r, 1], p[r, 2]
    cap = cand.shape[0]
    c0 = max(0, int(math.floor((px - radius - x0) / h)))
    c1 = min(nx - 1, int(math.floor((px + radius - x0) / h)))
    r0 = max(0, int(math.floor((py - radius - y0) / h)))
    r1 = min(ny - 1, int(math.floor((py + radius - y0) / h)))
    r2 = radius * radius
    count = 0
    for i in range(r0, r1 + 1):
        for j in range(c0, c1 + 1):
            k = i * nx + j
            lo, hi = cstart[k], cstart[k + 1]
            a, b = lo, hi
            while a < b:
                mid = (a + b) // 2
                if p[cidx[mid], 2] < pz - radius:
                    a = mid + 1
                else:
                    b = mid
            for m in range(a, hi):
                q = cidx[m]
                if p[q, 2] > pz + radius:
                    break
                if (strip >= 0 and strip_of[q] != strip) or q == r or state[q] == COMPLETED or owner_of[q] == stamp:
                    continue
                d2 = (p[q, 0] - px) ** 2 + (p[q, 1] - py) ** 2 + (p[q, 2] - pz) ** 2
                if d2 > r2 or (count == cap and d2 >= dist[cap - 1]):
                    continue
                # insert in distance order, the farthest dropped when full
                pos = count if count < cap else cap - 1
                while pos > 0 and dist[pos - 1] > d2:
                    dist[pos] = dist[pos - 1]
                    cand[pos] = cand[pos - 1]
                    pos -= 1
                dist[pos] = d2
                cand[pos] = q
                if count < cap:
                    count += 1
    return count


@jit_no_refcount
def _least_spread(p, r, cand, nc):
    """The unit direction of least spread of r and ``cand[:nc]`` (the normal of a fresh seed's plane, section 4):
    the eigenvector of the smallest eigenvalue of their covariance, in closed form (Smith 1961)."""
    mx, my, mz = p[r, 0], p[r, 1], p[r, 2]
    for i in range(nc):
        mx += p[cand[i], 0]
        my += p[cand[i], 1]
        mz += p[cand[i], 2]
    mx /= nc + 1
    my /= nc + 1
    mz /= nc + 1
    a00 = a01 = a02 = a11 = a12 = a22 = 0.0
    for i in range(-1, nc):
        q = r if i < 0 else cand[i]
        dx, dy, dz = p[q, 0] - mx, p[q, 1] - my, p[q, 2] - mz
        a00 += dx * dx
        a01 += dx * dy
        a02 += dx * dz
        a11 += dy * dy
        a12 += dy * dz
        a22 += dz * dz
    q = (a00 + a11 + a22) / 3.0
    off = a01 * a01 + a02 * a02 + a12 * a12
    spread = math.sqrt(((a00 - q) ** 2 + (a11 - q) ** 2 + (a22 - q) ** 2 + 2.0 * off) / 6.0)
    if spread == 0.0:
        return 0.0, 0.0, 1.0  # no direction stands out
    b00, b11, b22 = (a00 - q) / spread, (a11 - q) / spread, (a22 - q) / spread
    b01, b02, b12 = a01 / spread, a02 / spread, a12 / spread
    det = b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02)
    phi = math.acos(min(1.0, max(-1.0, det / 2.0))) / 3.0
    low = q + 2.0 * spread * math.cos(phi + 2.0 * math.pi / 3.0)  # the smallest eigenvalue
    # the eigenvector: the largest cross product of two rows of A - low I
    r0x, r0y, r0z = a00 - low, a01, a02
    r1x, r1y, r1z = a01, a11 - low, a12
    r2x, r2y, r2z = a02, a12, a22 - low
    bx, by, bz = 0.0, 0.0, 0.0
    best = 0.0
    for k in range(3):
        if k == 0:
            cx, cy, cz = r0y * r1z - r0z * r1y, r0z * r1x - r0x * r1z, r0x * r1y - r0y * r1x
        elif k == 1:
            cx, cy, cz = r0y * r2z - r0z * r2y, r0z * r2x - r0x * r2z, r0x * r2y - r0y * r2x
        else:
            cx, cy, cz = r1y * r2z - r1z * r2y, r1z * r2x - r1x * r2z, r1x * r2y - r1y * r2x
        size = cx * cx + cy * cy + cz * cz
        if size > best:
            best, bx, by, bz = size, cx, cy, cz
    if best <= 1e-24 * (q * q + off) ** 2:
        # a double smallest eigenvalue (points on a line): any direction across the largest row will do
        rx, ry, rz = r0x, r0y, r0z
        for k in range(1, 3):
            sx, sy, sz = (r1x, r1y, r1z) if k == 1 else (r2x, r2y, r2z)
            if sx * sx + sy * sy + sz * sz > rx * rx + ry * ry + rz * rz:
                rx, ry, rz = sx, sy, sz
        if abs(rx) <= abs(ry) and abs(rx) <= abs(rz):
            bx, by, bz = 0.0, -rz, ry
        elif abs(ry) <= abs(rz):
            bx, by, bz = rz, 0.0, -rx
        else:
            bx, by, bz = -ry, rx, 0.0
        best = bx * bx + by * by + bz * bz
        if best == 0.0:
            return 0.0, 0.0, 1.0
    size = math.sqrt(best)
    return bx / size, by / size, bz / size


@jit_no_refcount
def _thin(p, r, src, ns, cos_min, out, fixed_first, ux, uy, uz, vx, vy, vz):
    """The neighbours kept from ``src[:ns]`` (in angular order), in order, into ``out``; their count (section
    4.1, angle criterion).

    A point that makes an angle below the minimum (cosine ``cos_min``) at r with the one kept
    before it is dropped, unless that would trap it: it is dropped only when
    it lies beyond the segment from the kept one to the next (seen from r),
    so the triangle that skips it does not cover it.  The last point, and
    with ``fixed_first`` the first, are kept.
    """
    kept = 0
    for i in range(ns):
        q = src[i]
        if (kept > 0 and cos_min < 1.0 and i < ns - 1 and not (fixed_first and i == 0)
                and _cos_between(p, r, out[kept - 1], q) > cos_min):
            ax, ay = _proj(p, r, out[kept - 1], ux, uy, uz, vx, vy, vz)
            bx, by = _proj(p, r, src[i + 1], ux, uy, uz, vx, vy, vz)
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


@jit_inline
def _dexel_span(p, a, b, c, x0, y0, h, nx, ny):
    """The dexel columns c0..c1 and rows r0..r1 the x-y box of triangle a, b, c reaches."""
    c0 = int(math.floor((min(p[a, 0], p[b, 0], p[c, 0]) - x0) / h))
    c1 = int(math.floor((max(p[a, 0], p[b, 0], p[c, 0]) - x0) / h))
    r0 = int(math.floor((min(p[a, 1], p[b, 1], p[c, 1]) - y0) / h))
    r1 = int(math.floor((max(p[a, 1], p[b, 1], p[c, 1]) - y0) / h))
    return max(c0, 0), min(c1, nx - 1), max(r0, 0), min(r1, ny - 1)


@jit_inline
def _down(x):
    return x - 1e-6 * (1.0 + abs(x))


@jit_inline
def _up(x):
    return x + 1e-6 * (1.0 + abs(x))


@jit_no_refcount
def _add(p, tri, nxt, head, box, nt, state, r, s, t, cos_max, nx_, ny_, nz_, grid_head, ent, n_ent, seen_t,
         query, x0, y0, h, nx, ny, t_end, e_end, max_down):
    """Add triangle (r, s, t) as triangle ``nt`` when its edges allow it and it cuts no triangle already made.

    Returns 0 when it is not added; else the number of dexel entries after
    entering it, or -1 when the triangle numbers (up to ``t_end``) are used up, -2 when the entries (up to
    ``e_end``) are.  The
    triangles tested are those entered in the dexels its x-y box reaches
    whose boxes (``box``: low x, y, z, high x, y, z, float32) meet its own,
    each once (``seen_t`` stamped with ``query``).
    """
    if s == t or state[s] == COMPLETED or state[t] == COMPLETED:
        return 0
    if _cos_between(p, r, s, t) <= cos_max:
        return 0
    # oriented like the plane's normal, with area
    ux, uy, uz = p[s, 0] - p[r, 0], p[s, 1] - p[r, 1], p[s, 2] - p[r, 2]
    vx, vy, vz = p[t, 0] - p[r, 0], p[t, 1] - p[r, 1], p[t, 2] - p[r, 2]
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    if cx * nx_ + cy * ny_ + cz * nz_ <= 0.0:
        return 0
    if cz < -max_down * math.sqrt(cx * cx + cy * cy + cz * cz):  # facing down, in a cloud seen from above
        return 0
    if _has(tri, head, nxt, r, s) or _has(tri, head, nxt, s, t) or _has(tri, head, nxt, t, r):
        return 0
    if _has(tri, head, nxt, s, r) and _has(tri, head, nxt, t, s) and _has(tri, head, nxt, r, t):
        # the three edges exist the other way round: a triangular hole to close, or this triangle reversed (a fold)
        k = head[r]
        while k >= 0:
            has_s = tri[k, 0] == s or tri[k, 1] == s or tri[k, 2] == s
            if has_s and (tri[k, 0] == t or tri[k, 1] == t or tri[k, 2] == t):
                return 0
            k = nxt[3 * k + _corner(tri, k, r)]
    lo0, hi0 = min(p[r, 0], p[s, 0], p[t, 0]), max(p[r, 0], p[s, 0], p[t, 0])
    lo1, hi1 = min(p[r, 1], p[s, 1], p[t, 1]), max(p[r, 1], p[s, 1], p[t, 1])
    lo2, hi2 = min(p[r, 2], p[s, 2], p[t, 2]), max(p[r, 2], p[s, 2], p[t, 2])
    c0, c1, r0, r1 = _dexel_span(p, r, s, t, x0, y0, h, nx, ny)
    for i in range(r0, r1 + 1):
        for j in range(c0, c1 + 1):
            e = grid_head[i * nx + j]
            while e >= 0:
                k = ent[e, 0]
                e = ent[e, 1]
                # the boxes apart (no short cut: one branch, mostly taken, is cheaper than six unpredictable ones)
                if ((box[k, 3] < lo0) | (box[k, 0] > hi0) | (box[k, 4] < lo1) | (box[k, 1] > hi1) | (box[k, 5] < lo2)
                        | (box[k, 2] > hi2)):
                    continue
                if seen_t[k] == query:
                    continue  # tested already
                seen_t[k] = query
                a, b, c = tri[k, 0], tri[k, 1], tri[k, 2]
                if a in (r, s, t) or b in (r, s, t) or c in (r, s, t):
                    continue
                if (_segment_hits(p[r], p[s], p[a], p[b], p[c]) or _segment_hits(p[s], p[t], p[a], p[b], p[c])
                        or _segment_hits(p[t], p[r], p[a], p[b], p[c]) or _segment_hits(p[a], p[b], p[r], p[s], p[t])
                        or _segment_hits(p[b], p[c], p[r], p[s], p[t]) or _segment_hits(p[c], p[a], p[r], p[s], p[t])):
                    return 0
    if nt == t_end:
        return -1
    if n_ent + (c1 - c0 + 1) * (r1 - r0 + 1) > e_end:
        return -2
    tri[nt, 0], tri[nt, 1], tri[nt, 2] = r, s, t
    # its box in single precision, rounded outwards
    box[nt, 0], box[nt, 1], box[nt, 2] = _down(lo0), _down(lo1), _down(lo2)
    box[nt, 3], box[nt, 4], box[nt, 5] = _up(hi0), _up(hi1), _up(hi2)
    for k in range(3):
        v = tri[nt, k]
        nxt[3 * nt + k] = head[v]
        head[v] = nt
    for i in range(r0, r1 + 1):
        for j in range(c0, c1 + 1):
            k = i * nx + j
            ent[n_ent, 0] = nt
            ent[n_ent, 1] = grid_head[k]
            grid_head[k] = n_ent
            n_ent += 1
    return n_ent
