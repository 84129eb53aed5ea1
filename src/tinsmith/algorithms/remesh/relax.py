"""The remesher's relaxation: 1-D Lloyd on the backbones, weighted 2-D Lloyd in parameter space (Alliez et al. 2003, 4.3-4.4).

:func:`relax_patch` runs steps 3-5 of :mod:`.remesh` on one flat piece (the
whole input, or one chart of :mod:`.charts`): quadrature of the density in
parameter space, weighted Lloyd on the constrained Delaunay triangulation
of the sites, and the lift of the free sites back onto the input.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np
from scipy.spatial import cKDTree

from ...kernels import cvt as kcvt
from ...kernels import lloyd as kll
from ...kernels import locate as kl
from ...kernels import tin
from ...triangulation.delaunay import constrain_all, triangulate_points
from .parameterize import signed_areas
from .sampling import CORNER, FEATURE, Sampling

__all__ = ["Locator", "backbone_segments", "barycentric", "relax_backbones", "relax_patch"]

#: Quadrature points per site the Lloyd iterations aim at (a triangle is cut into k x k pieces for it).
QUADRATURE_PER_SITE = 16


# -- the locator ---------------------------------------------------------------------------
class Locator:
    """Point location in a planar triangulation (:mod:`tinsmith.kernels.locate`)."""

    def __init__(self, uv: np.ndarray, tri: np.ndarray):
        self.uv, self.tri = np.ascontiguousarray(uv, np.float64), np.ascontiguousarray(tri, np.int64)
        self.grid = kl.grid_for(self.uv, max(len(self.tri) // 2, 1))
        self.start, self.items = kl.build(self.uv, self.tri, *self.grid)

    def __call__(self, points: np.ndarray, eps: float = 1e-9):
        return kl.locate(self.uv, self.tri, self.start, self.items, *self.grid, np.ascontiguousarray(points, np.float64), eps)


# -- 1-D Lloyd on the backbones -----------------------------------------------------------
def relax_backbones(sampling: Sampling, density, uv, iterations: int):
    """Move the feature samples of every backbone to the centroids of their 1-D cells (corners fixed).

    ``density`` and ``uv`` are given at the skeleton's points.  Returns
    (points (F, 3), uv (F, 2)) of the feature samples in the order of ``sampling``.
    """
    v = sampling.skeleton.points
    feat = np.flatnonzero(sampling.kind == FEATURE)
    pts, puv = sampling.points[feat].copy(), np.zeros((len(feat), 2))
    weight = density**1.5  # a 1-D CVT's point density goes as the cube root of its weight: sqrt(d) per length
    for i, chain in enumerate(sampling.skeleton.backbones):
        mine = feat[sampling.backbone[feat] == i]
        local = np.flatnonzero(sampling.backbone[feat] == i)
        if len(mine) == 0:
            continue
        seg = np.linalg.norm(np.diff(v[chain], axis=0), axis=1)
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        total = arc[-1]
        s = arc[sampling.edge[mine]] + sampling.t[mine] * seg[sampling.edge[mine]]
        order = np.argsort(s, kind="stable")
        s = s[order]
        # quadrature along the chain: 8 points an edge, weights from the linear density
        q = 8
        frac = (np.arange(q) + 0.5) / q
        qs = (arc[:-1, None] + frac[None, :] * seg[:, None]).ravel()
        wv = weight[chain]
        qw = ((wv[:-1, None] * (1 - frac) + wv[1:, None] * frac) * (seg[:, None] / q)).ravel()
        closed = sampling.skeleton.closed[i] and not np.isin(chain[0], sampling.skeleton.corners)
        if closed:  # a loop without a corner: the first sample stays, the rest relax between its two copies
            shift = s[0]
            qs = np.mod(qs - shift, total)
            qorder = np.argsort(qs)
            qs, qw = qs[qorder], qw[qorder]
            s = s - shift
        cum_w = np.concatenate([[0.0], np.cumsum(qw)])
        cum_ws = np.concatenate([[0.0], np.cumsum(qw * qs)])
        for _ in range(iterations):
            ends = np.concatenate([[0.0], 0.5 * (s[:-1] + s[1:]), [total]])
            lo, hi = np.searchsorted(qs, ends[:-1]), np.searchsorted(qs, ends[1:])
            mass = cum_w[hi] - cum_w[lo]
            new = np.where(mass > 0, (cum_ws[hi] - cum_ws[lo]) / np.where(mass > 0, mass, 1.0), s)
            if closed:
                new[0] = 0.0
            moved = np.abs(new - s).max()
            s = new
            if moved < 1e-6 * total:
                break
        if closed:
            s = np.mod(s + shift, total)
        edge = np.clip(np.searchsorted(arc, s, side="right") - 1, 0, len(seg) - 1)
        tt = np.clip((s - arc[edge]) / np.where(seg[edge] > 0, seg[edge], 1.0), 0.0, 1.0)
        a, b = chain[edge], chain[edge + 1]
        back = local[order]
        pts[back] = v[a] + tt[:, None] * (v[b] - v[a])
        puv[back] = uv[a] + tt[:, None] * (uv[b] - uv[a])
        sampling.edge[mine[order]] = edge
        sampling.t[mine[order]] = tt
    return pts, puv


# -- 2-D weighted Lloyd ---------------------------------------------------------------------
def pieces(k: int) -> np.ndarray:
    """Barycentric coordinates of the centroids of the k x k pieces a triangle is cut into."""
    ij = [(i, j) for i in range(k) for j in range(k - i)]
    up = [((i + 1 / 3) / k, (j + 1 / 3) / k) for i, j in ij]
    down = [((i + 2 / 3) / k, (j + 2 / 3) / k) for i, j in ij if i + j <= k - 2]
    st = np.array(up + down)
    return np.column_stack([1 - st.sum(axis=1), st])


def quadrature(uv, tri, rho, sites_per_triangle):
    """Quadrature points of the input triangles in parameter space: (points (Q, 2), weights (Q,)).

    A triangle is cut into k x k pieces, k chosen so that each site it is
    expected to hold gets about :data:`QUADRATURE_PER_SITE` points.
    """
    k_of = np.clip(np.ceil(np.sqrt(QUADRATURE_PER_SITE * sites_per_triangle)), 1, 1024).astype(np.int64)
    area = np.abs(signed_areas(uv, tri))
    pts, weights = [], []
    for k in np.unique(k_of):
        these = np.flatnonzero(k_of == k)
        bary = pieces(int(k))
        t = tri[these]
        p = np.einsum("qc,tcd->tqd", bary, uv[t]).reshape(-1, 2)
        w = (np.einsum("qc,tc->tq", bary, rho[t]) * (area[these] / (k * k))[:, None]).ravel()
        pts.append(p)
        weights.append(w)
    pts, weights = np.concatenate(pts), np.concatenate(weights)
    order = np.argsort(tin.morton_keys(pts, 16), kind="stable")  # neighbours in memory: short, cached walks
    return pts[order], weights[order]


def triangulate(sites, constraints, walls, domain: Locator, walls_closed: bool = False):
    """(triangles (M, 3), neighbours (M, 3)): the constrained Delaunay triangles of the sites inside the domain.

    The boundary backbones (``walls``, rows of ``constraints``) cut the
    triangulation into regions; a region is kept when most of its triangles'
    centroids lie in the input's parameter domain (tested on all of a small
    region's triangles, on some 256 spread over a large one).  (A test triangle by
    triangle would keep chords across a concave stretch of the boundary.)
    With ``walls_closed`` (a chart, whose border is all wall) a region is kept
    when it lies inside the walls by the even-odd rule: exact, where the
    domain test can keep a thin pocket between a wall and a hull edge.
    ``neighbours[t, k]`` is the kept triangle across the edge opposite corner
    ``k``, -1 on the border.  Two sites at one place (orphans moved to one
    centroid) are one vertex, the first inserted.
    """
    n = len(sites)
    m, same, stack = triangulate_points(sites)
    if len(constraints):
        constrain_all(m, constraints, same, n, stack)
    count = int(m[9][1])
    flat = m[2][: 3 * count].astype(np.int64)
    half = m[3][: 3 * count].astype(np.int64)
    keys = np.unique(np.minimum(walls[:, 0], walls[:, 1]) * n + np.maximum(walls[:, 0], walls[:, 1]))
    region, n_regions = kll.wall_regions(flat, half, keys, n)
    tri = flat.reshape(-1, 3)
    if walls_closed:
        x, y, usable = kll.region_probes(sites, tri, region, n_regions)
        loops = np.column_stack([sites[walls[:, 0]], sites[walls[:, 1]]])
        keep = (usable & kcvt.inside_loops(x, y, loops))[region]  # the even-odd rule
        new_id = np.where(keep, np.cumsum(keep) - 1, -1)
        twin = half.reshape(-1, 3)[:, [1, 2, 0]]
        return tri[keep], np.where(twin >= 0, new_id[twin // 3], -1)[keep]
    # the share of a large region is estimated on some 256 of its triangles, spread over its numbering
    size = np.bincount(region, minlength=n_regions)
    order = np.argsort(region, kind="stable")
    rank = np.empty(len(tri), np.int64)
    rank[order] = np.arange(len(tri)) - np.repeat(np.cumsum(size) - size, size)
    test = np.flatnonzero(rank % np.maximum(size // 256, 1)[region] == 0)
    inside = domain(sites[tri[test]].mean(axis=1), eps=0.0)[0] >= 0
    share = np.bincount(region[test], weights=inside, minlength=n_regions) / np.bincount(region[test], minlength=n_regions)
    keep = share[region] > 0.5
    new_id = np.where(keep, np.cumsum(keep) - 1, -1)
    # the edge opposite corner k is halfedge k + 1
    twin = half.reshape(-1, 3)[:, [1, 2, 0]]
    neighbour = np.where(twin >= 0, new_id[twin // 3], -1)[keep]
    return tri[keep], neighbour


def adopt_orphans(sites, free, constraints, walls, domain, walls_closed=False, rounds: int = 5):
    """(triangles, neighbours, sites): a free site in no kept triangle (it lies between a boundary backbone and the
    boundary it cuts short, or on another site) moves to the centroid of the nearest kept triangle, until none
    is left."""
    for _ in range(rounds):
        tri, neighbour = triangulate(sites, constraints, walls, domain, walls_closed)
        used = np.zeros(len(sites), bool)
        used[tri.ravel()] = True
        orphans = np.flatnonzero(free & ~used)
        if len(orphans) == 0:
            return tri, neighbour, sites
        centroids = sites[tri].mean(axis=1)
        sites = sites.copy()
        sites[orphans] = centroids[cKDTree(centroids).query(sites[orphans])[1]]
    return (*triangulate(sites, constraints, walls, domain, walls_closed), sites)


def lloyd(sites, free, constraints, walls, domain, qpts, qw, iterations, tol, walls_closed=False):
    """Weighted Lloyd in parameter space (see the module docstring); returns (sites, iterations run, last move).

    Each quadrature point keeps the site that owned it and walks from there
    (:mod:`tinsmith.kernels.lloyd`); only the points whose walk fails are
    located afresh.
    """
    spacing = np.sqrt(np.abs(signed_areas(domain.uv, domain.tri)).sum() / max(len(sites), 1))
    owner = np.full(len(qpts), -1, np.int64)
    moved = np.inf
    done = 0
    while done < iterations:
        done += 1
        tri, neighbour, sites = adopt_orphans(sites, free, constraints, walls, domain, walls_closed)
        first = np.full(len(sites), -1, np.int64)
        first[tri.ravel()] = np.repeat(np.arange(len(tri)), 3)
        mass, cx, cy, lost = kll.moments(sites, tri, neighbour, first, qpts, qw, owner, 64)
        if len(lost):
            where, _ = Locator(sites, tri)(qpts[lost])
            ok = where >= 0
            q = lost[ok]
            corners = tri[where[ok]]
            d = ((sites[corners] - qpts[q][:, None, :]) ** 2).sum(axis=2)
            owner[q] = corners[np.arange(len(q)), np.argmin(d, axis=1)]
            mass += np.bincount(owner[q], weights=qw[q], minlength=len(sites))
            cx += np.bincount(owner[q], weights=qw[q] * qpts[q, 0], minlength=len(sites))
            cy += np.bincount(owner[q], weights=qw[q] * qpts[q, 1], minlength=len(sites))
        move = free & (mass > 0)
        target = sites.copy()
        target[move, 0] = cx[move] / mass[move]
        target[move, 1] = cy[move] / mass[move]
        # a centroid outside the domain (a concave stretch of it) is not taken
        outside = domain(target[move], eps=0.0)[0] < 0
        idx = np.flatnonzero(move)[outside]
        target[idx] = sites[idx]
        moved = float(np.sqrt(((target - sites) ** 2).sum(axis=1).max())) / spacing
        sites = target
        if moved < tol:
            break
    return sites, done, moved


def relax_patch(vertices, tri, uv, d, sites, free, constraints, walls, iterations, domain=None, walls_closed=False):
    """Weighted Lloyd on one flat piece (the whole input, or a chart) and its triangulation.

    ``d`` is the density at the piece's vertices: in parameter space it is
    multiplied by the area stretch at each vertex and squared for the CVT's
    weight.  Returns (triangles over the sites, sites, the lifted 3-D points
    of the free sites, Lloyd iterations run, last relative move).
    """
    domain = domain if domain is not None else Locator(uv, tri)
    area3 = np.linalg.norm(np.cross(vertices[tri[:, 1]] - vertices[tri[:, 0]],
                                    vertices[tri[:, 2]] - vertices[tri[:, 0]]), axis=1) / 2
    area2 = np.abs(signed_areas(uv, tri))
    num, den = np.zeros(len(uv)), np.zeros(len(uv))
    np.add.at(num, tri.ravel(), np.repeat(area3, 3))
    np.add.at(den, tri.ravel(), np.repeat(area2, 3))
    rho = (d * num / np.maximum(den, 1e-300)) ** 2
    expected = area3 * d[tri].mean(axis=1)
    qpts, qw = quadrature(uv, tri, rho, len(sites) * expected / expected.sum())
    sites, run, last = lloyd(sites, free, constraints, walls, domain, qpts, qw, iterations, 1e-3, walls_closed)
    out_tri, _, sites = adopt_orphans(sites, free, constraints, walls, domain, walls_closed)
    # the free sites go back onto the input through the input triangle that holds them
    where, bary = domain(sites[free])
    lost = where < 0
    if lost.any():  # on the very edge of the domain by rounding: the nearest input triangle
        near = cKDTree(uv[tri].mean(axis=1)).query(sites[free][lost])[1]
        where[lost] = near
        bary[lost] = barycentric(uv[tri[near]], sites[free][lost])
    return out_tri, sites, np.einsum("ij,ijk->ik", bary, vertices[tri[where]]), run, last


def barycentric(corners: np.ndarray, p: np.ndarray) -> np.ndarray:
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    d = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    w1 = ((p[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1])) / d
    w2 = ((b[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1]) - (p[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / d
    w = np.clip(np.column_stack([1 - w1 - w2, w1, w2]), 0, None)
    return w / w.sum(axis=1, keepdims=True)


def backbone_segments(sampling: Sampling) -> tuple:
    """(constrained segments, those of boundary and cut backbones, the backbone of each segment): consecutive
    samples along every backbone, its corners at the ends."""
    corner_site = {int(v): i for i, v in enumerate(sampling.vertex) if sampling.kind[i] == CORNER}
    feat = np.flatnonzero(sampling.kind == FEATURE)
    segments, wall, owner = [], [], []
    for i, chain in enumerate(sampling.skeleton.backbones):
        mine = feat[sampling.backbone[feat] == i]
        order = mine[np.lexsort((sampling.t[mine], sampling.edge[mine]))]
        ids = list(order)
        first, last = int(chain[0]), int(chain[-1])
        if first in corner_site:
            ids = [corner_site[first]] + ids
        if last in corner_site:
            ids = ids + [corner_site[last]]
        elif sampling.skeleton.closed[i] and len(ids) > 2:
            ids = ids + [ids[0]]
        pairs = [(a, b) for a, b in pairwise(ids) if a != b]
        segments += pairs
        wall += [sampling.skeleton.kind[i] in ("boundary", "cut")] * len(pairs)
        owner += [i] * len(pairs)
    segments = np.array(segments, dtype=np.int64).reshape(-1, 2)
    return segments, segments[np.array(wall, bool)], np.array(owner, np.int64)
