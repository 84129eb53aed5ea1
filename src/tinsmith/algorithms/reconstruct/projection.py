"""General mode of the projection-based reconstruction (Gopi and Krishnan 2002, section 4; Gopi and Krishnan 2002).

Duplicates are dropped and the points bucketed in the dexel array, with
each point's distance ``m`` to its second-nearest point (see ``M_RANK``)
found ring by ring on it (:mod:`tinsmith.kernels.cloud`).  A breadth-first front then takes
one reference point R at a time
(:func:`tinsmith.kernels.projection.greedy_projection`):

1. **Distance pruning**: the L-infinity box about R (a few dexels, each
   searched by height), then the sphere of influence of radius ``mu * m``;
   of what is left, the 64 nearest.  Completed points are never
   candidates.  The paper takes ``m`` from R's nearest *connected*
   neighbour once R has triangles; a long edge then widens the next sphere,
   and on CODEM radii ran up to 67 m, 1,193 candidates at the 99th
   percentile and 35 s for 55,000 points.  A distance to the cloud's own
   points keeps every sphere local.
2. **Projection plane**: the mean normal of the triangles already at R; for
   a fresh seed, the direction of least spread of R and its candidates
   (PCA), turned upwards.
3. **Visibility pruning** in that plane: candidates between R's consecutive
   border edges (inside its fans) are dropped (rule 1); so are those that
   have R inside one of their own fans (rule 2), and those hidden behind a
   border edge of a candidate or of R's neighbours (rule 3: only border
   edges can hide a point, the paper's theorem).
4. **Angle pruning** (``min_angle``): a point that makes too small an angle
   with the one before it is dropped, only where the triangle that skips it
   does not cover it (no point is trapped).
5. **Connection** in angular order within each free range of R; neighbours
   more than ``max_angle`` apart leave a gap.  A triangle is added only if
   each of its directed edges is new, so every edge has at most two
   triangles walked in opposite directions: the mesh is manifold and
   consistently oriented by construction; and only if it cuts no triangle
   made before (every triangle is indexed by the dexels its box covers).
   The rules alone do not ensure that on LiDAR, where layers lie closer
   than the paper assumes.  New neighbours become fringe points at the back
   of the queue; R becomes completed when its fan closes, a boundary point
   otherwise.  An empty queue re-seeds at the next free point (one seed per
   component).

Clouds of ``2 * STRIP_POINTS`` points or more are cut into strips of dexel
columns meshed side by side on ``workers`` threads, their pieces turned to
face the same way across each cut (:func:`_orient_pieces`, view "any"), then
joined by a front over the two columns along each cut, which no strip takes
(:func:`_front`).
The strips depend on the cloud alone, so the mesh is the same on any number
of workers.  Each component is then
turned so that its normals point outwards (closed) or upwards (open).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ...core import PointCloud, TerrainMesh
from ...errors import InvalidInputError, InvalidOptionError
from ...kernels import cloud as cloud_kernel
from ...kernels import front_mesh
from ...kernels import projection as kernel
from ...kernels.projection import COMPLETED, FREE

__all__ = ["dexel_buckets", "dexel_grid", "general_mesh"]

MAX_CANDIDATES = 64
"""At most this many points, the nearest, are candidates of one reference point."""
M_RANK = 2
"""``m`` is the distance to a point's second-nearest point.  On locally uniform samples that is about the
nearest point's distance, the paper's ``m``; where spacing is irregular (random or scan-line samples) the
nearest point is often unusually close and the sphere too small.  The second-nearest leaves fewer border loops
on such clouds at some cost in time; the third-nearest costs much more time (docs/design.md has the
figures)."""
STRIP_POINTS, MAX_STRIPS = 100_000, 8
"""A cloud is meshed in strips of at least this many points (at most this many strips), in parallel."""
MAX_POINTS = 100_000_000
"""General mode's limit: point, triangle and entry numbers are int32."""
#: Per ``view``: the lowest z a new triangle's unit normal may have, negated.  "above" (an airborne scan: the
#: sensor saw every surface from above, so none faces down) refuses a triangle that faces more than 17 degrees
#: below the horizon while the surfaces grow: a fold where the front wraps round a roof edge or an eave.  A
#: last pass over the points left on a border then closes the gaps between the finished surfaces with the
#: paper's rules.  "any" never refuses.
VIEW_MAX_DOWN = {"any": 2.0, "above": 0.3}
#: The last pass of view "above" looks this many times further (``mu``) than the growth did: the gaps it
#: bridges (an eave's underside, from the roof's edge to the wall's top) are wider than the spacing.  Measured
#: on Delft (classes 2 and 6): reach 1, 1.5 and 2 leave 2,843, 2,015 and 1,480 border loops with 3.0%, 3.7% and
#: 4.3% of the area facing steeply down.
CLOSING_REACH = 1.5

BUFFERS = {"triangles": 2.25, "entries": 24.0, "neighbours": 256, "edges": 1024}
"""The front's first buffers: triangles and dexel entries per point, neighbours of a point, border edges near one
(doubled and run again when too small).  Entries used per point, measured: 6.2 on a torus, 7.3 on Delft (ground and
buildings), 8.2 on the lidR Topography tile, 18.7 on MixedConifer, 21.2 on a synthetic forest: a first guess of 9 made
the forests run twice (a third of the time on the forest tile).  The entry buffer is allocated, not filled, so pages
it never reaches cost no memory."""


def dexel_grid(xy: np.ndarray, size: float):
    """(row, col) of every point's dexel, the grid shape (ny, nx) and its corner; rows go up in y.

    A grid far larger than the cloud (a dexel size far below the spacing) is refused.
    """
    lo = xy.min(axis=0)
    with np.errstate(over="ignore"):  # in floats first: a tiny size must not overflow int64
        nx, ny = np.floor((xy.max(axis=0) - lo) / size) + 1
        cells = nx * ny
    if cells > 4 * len(xy) + 1_000_000:
        raise InvalidOptionError(
            f"dexel_size {size:g} makes a {ny:.4g} x {nx:.4g} dexel grid for {len(xy)} points; choose a larger dexel_size"
        )
    idx = np.floor((xy - lo) / size).astype(np.int64)
    nx, ny = int(idx[:, 0].max()) + 1, int(idx[:, 1].max()) + 1
    return idx[:, 1], idx[:, 0], (ny, nx), lo


def dexel_buckets(xyz: np.ndarray, size: float):
    """(cstart, cidx, x0, y0, nx, ny): the points of dexel k are ``cidx[cstart[k]:cstart[k+1]]``, sorted by z."""
    rows, cols, (ny, nx), lo = dexel_grid(xyz[:, :2], size)
    cstart, cidx = cloud_kernel.bucket(rows * nx + cols, np.ascontiguousarray(xyz[:, 2]), nx * ny)
    return cstart, cidx, float(lo[0]), float(lo[1]), nx, ny


def _strips(cstart: np.ndarray, cidx: np.ndarray, nx: int, count: int):
    """(strip of each point, dexel column of each point, the columns where strips 1, 2, ... start): ``count``
    runs of dexel columns holding about as many points each (fewer where columns are few).  The columns are the
    dexel array's own (``cstart``, ``cidx``)."""
    col = np.empty(len(cidx), np.int64)
    col[cidx] = np.repeat(np.arange(len(cstart) - 1), np.diff(cstart)) % nx
    cum = np.cumsum(np.bincount(col, minlength=nx))
    cuts = np.unique(np.searchsorted(cum, len(cidx) * np.arange(1, count) / count) + 1)
    cuts = cuts[(cuts > 0) & (cuts < nx)]
    return np.searchsorted(cuts, col, side="right").astype(np.int32), col, cuts


def _front(p, m, dexels, mu, max_angle, min_angle, strips=1, max_down=2.0, workers=1):
    """(triangles, nxt, head, state): the kernel's front, with every buffer it needs.

    With ``strips`` > 1 the dexel array is cut into runs of columns with even
    numbers of points.  The two columns along each cut (the gap) belong to no
    strip; each strip is meshed on its own, on ``workers`` threads (the
    kernel holds no lock, and the strips share no point, triangle or
    dexel).  A front over the gap then joins them: it grows from the points
    the strips left open within two columns of a cut, with every point a
    candidate, and seeds at the gap's points it does not reach.  A buffer
    that is too small makes that run stop; everything is run again with
    larger ones.  With ``max_down`` below 2 (``view="above"``) a last pass
    takes the points left on a border with every rule of the paper and no
    limit on facing down, to close the gaps between the finished surfaces:
    strip by strip on the threads for the points whose triangles all lie in
    their strip (:func:`_within_strip`), then over the rest.
    """
    cstart, cidx, x0, y0, h, nx, ny = dexels
    strip_of, col, cuts = _strips(cstart, cidx, nx, strips)
    band = np.zeros(len(p), bool)
    gap = np.zeros(len(p), bool)
    for c in cuts:
        band |= (col >= c - 2) & (col <= c + 1)
        gap |= (col >= c - 1) & (col <= c)
    strip_of[gap] = len(cuts) + 1  # in no strip: only the joining front meshes these
    parts = [np.flatnonzero(strip_of == j).astype(np.int32) for j in range(len(cuts) + 1)]
    args = (p, m, cstart, cidx.astype(np.int32), x0, y0, h, nx, ny, mu, max_angle, min_angle, True, max_down)
    scale = dict(BUFFERS)
    while True:
        status, runs, shared = _attempt(args, strip_of, parts, band, scale, workers, (col, cuts))
        if status == kernel.DONE:
            break
        scale[_FULL[status]] *= 2
    starts, ends = np.array(runs, np.int64).reshape(-1, 2).T.copy()
    nt = front_mesh.compact(shared["tri"], shared["nxt"], shared["head"], starts, ends) if len(runs) > 1 else ends[0]
    return shared["tri"][:nt], shared["nxt"], shared["head"], shared["state"]


_FULL = {kernel.MORE_TRIANGLES: "triangles", kernel.MORE_ENTRIES: "entries", kernel.MORE_NEIGHBOURS: "neighbours",
         kernel.MORE_EDGES: "edges"}
STAMPS = 1 << 40
"""Each strip's stamps start this far above the last strip's: threads that look at the same triangle (one of
the joining front's, listed in both strips' dexels) never take another thread's stamp for their own."""


def _attempt(args, strip_of, parts, band, scale, workers, columns):
    """One run of the front with buffers of ``scale``: (status, (first, end) of the triangles of every run, the
    buffers).

    Runs, each with its own slice of the triangle and entry buffers: the strips, the joining front, and for
    ``view="above"`` the last pass in each strip and over the rest.
    """
    n, cidx, nx, ny = len(args[0]), args[3], args[7], args[8]
    count = len(parts)
    n_band = int(np.count_nonzero(band)) if count > 1 else 0
    closing = args[13] < 2.0  # a view that refuses faces: a last pass closes the gaps between finished surfaces
    sizes = [len(j) for j in parts] + [4 * n_band]
    if closing:
        sizes += [len(j) // 4 for j in parts] + [n_band]
    t_cap = [int(scale["triangles"] * k) + 64 for k in sizes]
    e_cap = [int(scale["entries"] * k) + 256 for k in sizes]
    t_at, e_at = np.r_[0, np.cumsum(t_cap)], np.r_[0, np.cumsum(e_cap)]
    shared = {"tri": np.empty((t_at[-1], 3), np.int32), "nxt": np.empty(3 * t_at[-1], np.int32),
              "head": np.full(n, -1, np.int32), "box": np.empty((t_at[-1], 6), np.float32),
              "state": np.zeros(n, np.int8), "grid_head": np.full(nx * ny, -1, np.int32),
              "ent": np.empty((e_at[-1], 2), np.int32), "seen_t": np.full(t_at[-1], -1, np.int64),
              "owner_of": np.full(n, -1, np.int64)}
    state, head = shared["state"], shared["head"]
    k, nb, ne = MAX_CANDIDATES, scale["neighbours"], scale["edges"]
    runs = []

    none = np.empty(0, np.int32)

    def run(slot, queued, strip, stamp, seeds=none, rules=args):
        # room for every free point the run can reach: each joins the queue once at most, when the front reaches it
        reach = len(parts[strip]) if strip >= 0 else int(np.count_nonzero(state == FREE))
        queue = np.empty(len(queued) + reach, np.int32)
        queue[: len(queued)] = queued
        return kernel.greedy_projection(
            *rules, seeds, strip_of, strip, queue, len(queued),
            t_at[slot], t_at[slot + 1], e_at[slot], e_at[slot + 1], stamp,
            shared["tri"], shared["nxt"], head, shared["box"], state, shared["grid_head"],
            shared["ent"], shared["seen_t"], shared["owner_of"],
            np.empty(k, np.int32), np.empty(k), np.empty(k), np.empty(k, np.bool_), np.empty(k, np.int32),
            np.empty(k + 2, np.int32), np.empty(k + 2, np.int32), np.empty(nb, np.int32),
            np.empty((2, nb), np.int32), np.empty((ne, 2), np.int32), np.empty((ne, 4)),
            np.empty((2, kernel.MAX_FANS), np.int32))

    def stage(jobs):
        """Run ``jobs`` (slot, queued, strip, stamp[, seeds[, rules]]), in threads when there are several;
        the worst status and the stamp above every one used."""
        if len(jobs) > 1 and workers > 1:
            with ThreadPoolExecutor(min(len(jobs), workers)) as pool:
                results = list(pool.map(lambda job: run(*job), jobs))
        else:
            results = [run(*job) for job in jobs]
        runs.extend((t_at[job[0]], r[1]) for job, r in zip(jobs, results, strict=True))
        return max(r[0] for r in results), max(r[3] for r in results) + 1

    def points(mask):
        return cidx[mask[cidx]]  # in dexel order

    status, stamp = stage([(j, none, j if count > 1 else -1, j * STAMPS, parts[j])
                           for j in range(count)])
    if status == kernel.DONE and count > 1 and not closing:  # (view "any": "above" keeps every piece facing up)
        _orient_pieces(args[0], shared, runs, columns, args[6])
    if status == kernel.DONE and count > 1:
        # the gap: grown from the points the strips left open near a cut, every point a candidate, seeded at the
        # gap's points no front reaches
        open_ = band & (state != COMPLETED)
        status, stamp = stage([(count, points(open_ & (head >= 0)), -1, stamp, points(open_ & (head < 0)))])
    if status == kernel.DONE and closing:
        # the rims: points on a border, in dexel order, the paper's rules again. Every finished surface is
        # completed inside, so the pass can only bridge a gap between two of them (an eave's underside between
        # a roof's edge and a wall's top), not grow a folded sheet over one
        rules = args[:9] + (args[9] * CLOSING_REACH,) + args[10:13] + (VIEW_MAX_DOWN["any"],)
        rim = (state != COMPLETED) & (head >= 0)
        own = _within_strip(shared["tri"], runs, strip_of, count) if count > 1 else np.ones(n, bool)
        status, stamp = stage([(count + 1 + j, points(rim & own & (strip_of == j)), j if count > 1 else -1,
                                stamp + j * STAMPS, none, rules) for j in range(count)])
        if status == kernel.DONE and count > 1:
            rest = (state != COMPLETED) & (head >= 0) & ~own
            status, stamp = stage([(2 * count + 1, points(rest), -1, stamp, none, rules)])
    return status, runs, shared


#: Pieces on the two sides of a cut are compared at pairs of points no further apart than this many dexels
#: (the gap is two columns wide), whose normals are this near to parallel (|cos|).
PAIR_REACH, PAIR_COS = 4.0, 0.5


def _orient_pieces(p, shared, runs, columns, h):
    """Turn the strips' pieces so that pieces facing each other across a cut face the same way.

    Each strip seeds its pieces facing up, so a piece of a closed surface
    seeded under it faces in while its neighbour across the cut faces out,
    and the joining front cannot join them (a front only adds a triangle
    whose edges run the other way to its neighbours').  Pieces (connected
    triangles) are compared at the nearest pairs of meshed points across
    each cut, by the sign of the dot product of their normals; the pairs of
    pieces are taken from the strongest agreement down and joined into
    groups of known relative turn (the first word on a pair wins), and in
    each group the pieces with fewer points are turned.  A piece is turned
    by reversing its triangles (two corners swapped, with their links).
    (Growing the joining front from the borders of the turned pieces as well,
    where they met a piece of their own strip that faced the other way, left
    4% fewer loops on Delft but took 1.3 s more of the serial front.)
    """
    from scipy.spatial import cKDTree

    col, cuts = columns
    n = len(p)
    first, end = (np.array(v, np.int64) for v in zip(*runs, strict=True))
    label, normal = front_mesh.pieces(p, shared["tri"], first, end)
    length = np.linalg.norm(normal, axis=1)
    meshed = (label >= 0) & (length > 0)
    votes: dict[tuple[int, int], float] = {}
    for cut in cuts:
        left = np.flatnonzero(meshed & (col == cut - 2))
        right = np.flatnonzero(meshed & (col == cut + 1))
        if not len(left) or not len(right):
            continue
        dist, near = cKDTree(p[left]).query(p[right], distance_upper_bound=PAIR_REACH * h)
        found = np.isfinite(dist)
        r, l_ = right[found], left[near[found]]
        cos = np.einsum("ij,ij->i", normal[r], normal[l_]) / (length[r] * length[l_])
        strong = np.abs(cos) >= PAIR_COS
        for la, lb, sign in zip(label[l_[strong]], label[r[strong]], np.sign(cos[strong]), strict=True):
            key = (int(min(la, lb)), int(max(la, lb)))
            votes[key] = votes.get(key, 0.0) + float(sign)
    if not votes:
        return
    # groups of pieces with their turn relative to the group's root: union-find with parity
    parent: dict[int, int] = {}
    turn: dict[int, int] = {}  # parity to the parent: 1 turned, 0 not

    def root(v):
        path = []
        while parent.setdefault(v, v) != v:
            path.append(v)
            v = parent[v]
        acc = 0
        for u in reversed(path):  # parity of u to the root, compressed
            acc ^= turn[u]
            turn[u], parent[u] = acc, v
        return v

    for (la, lb), vote in sorted(votes.items(), key=lambda kv: (-abs(kv[1]), kv[0])):
        if vote == 0:
            continue
        ra, rb = root(la), root(lb)
        if ra == rb:
            continue
        parent[rb] = ra
        turn[rb] = turn.get(la, 0) ^ turn.get(lb, 0) ^ (1 if vote < 0 else 0)
    size = np.bincount(label[label >= 0], minlength=n)  # points a piece holds
    groups: dict[int, list[int]] = {}
    for v in list(parent):
        groups.setdefault(root(v), []).append(v)
    turned = []
    for members in groups.values():
        parity = [turn.get(v, 0) if parent[v] != v else 0 for v in members]
        on = sum(int(size[v]) for v, q in zip(members, parity, strict=True) if q)
        off = sum(int(size[v]) for v, q in zip(members, parity, strict=True) if not q)
        side = 1 if on <= off else 0  # the side with fewer points is turned
        turned += [v for v, q in zip(members, parity, strict=True) if q == side]
    is_turned = np.zeros(n, np.bool_)
    is_turned[turned] = True
    front_mesh.turn_pieces(shared["tri"], shared["nxt"], first, end, label, is_turned)


def _within_strip(tri, runs, strip_of, count):
    """Points in a strip whose triangles all lie in that strip: a strip's thread may add triangles at these
    without touching a point another thread can reach."""
    mixed = np.zeros(len(strip_of), bool)
    for first, end in runs:
        label = strip_of[tri[first:end]]
        across = (label != label[:, :1]).any(axis=1)
        mixed[tri[first:end][across].ravel()] = True
    return ~mixed & (strip_of < count)


def general_mesh(cloud: PointCloud, *, mu: float, max_angle: float, min_angle: float, dexel_size: float,
                 view: str = "any", workers: int = 1) -> TerrainMesh:
    """The general mode of :func:`tinsmith.reconstruct` (see the module docstring)."""
    if len(cloud) > MAX_POINTS:
        raise InvalidInputError(
            f"general mode takes at most {MAX_POINTS:,} points, got {len(cloud):,}; thin the cloud or use "
            "mode='heightfield'"
        )
    xyz = np.ascontiguousarray(cloud.xyz, dtype=np.float64) + 0.0  # -0.0 becomes 0.0: equal values, equal bits
    xyz = xyz[cloud_kernel.first_occurrences(xyz.view(np.int64))]  # duplicates dropped, input order kept
    centre = xyz.mean(axis=0)
    p = np.ascontiguousarray(xyz - centre)  # local coordinates: no cancellation at world offsets
    cstart, cidx, x0, y0, nx, ny = dexel_buckets(p, dexel_size)
    m = cloud_kernel.nearest_distances(p, cstart, cidx, x0, y0, dexel_size, nx, ny, M_RANK)
    strips = max(1, min(MAX_STRIPS, len(p) // STRIP_POINTS))  # from the size alone: the same mesh on any machine
    tri, nxt, head, state = _front(p, m, (cstart, cidx, x0, y0, dexel_size, nx, ny), mu, max_angle, min_angle,
                                   strips, VIEW_MAX_DOWN[view], workers)
    label, flip, loops = front_mesh.surface_summary(p, tri, nxt, head, state)
    turn = flip[label[tri[:, 0]]]  # each component outwards (closed) or upwards (open)
    tri[turn] = tri[turn][:, [0, 2, 1]]
    used = head >= 0
    index = np.cumsum(used) - 1  # new vertex numbers
    vertices, tri = xyz[used], index[tri]
    components = len(np.unique(label[used]))
    mesh = TerrainMesh(vertices, tri, crs=cloud.crs)
    mesh.info["reconstruct"] = {
        "mode": "general", "dexel_size": dexel_size, "points_in": len(cloud), "duplicates": len(cloud) - len(xyz),
        "points_unused": int(len(xyz) - np.count_nonzero(used)), "completed": int(np.count_nonzero(state == COMPLETED)),
        "components": components, "border_loops": loops, "strips": strips, "view": view,
    }
    return mesh
