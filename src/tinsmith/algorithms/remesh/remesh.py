"""Isotropic remeshing with an exact vertex budget: error diffusion and weighted CVT with features (seed 003).

Any disk-like triangle mesh (a full-resolution DEM mesh, a TIN from another
method, a scanned patch), or a heightfield (its full-resolution mesh), to a
mesh of exactly ``n_vertices`` well-shaped vertices:

1. **Sampling** (section 3, :mod:`.sampling`): the feature skeleton
   (boundary and sharp edges and user breaklines chained into backbones,
   corners), a density
   (uniform or curvature, its spacing graded by ``gradation``: without it
   the triangles between fine and coarse sampling come out distorted),
   calibration and error diffusion: exactly ``n_vertices`` samples, corners
   kept.
2. **Parameter space** (section 4.2, :mod:`.parameterize`): the x-y plane for terrain (every
   triangle faces up, and the area at most 1.5 times the footprint or the
   mesh not a disk: holes); otherwise a least-squares conformal map (LSCM, Lévy
   et al. 2002) with free boundary, for a mesh with one boundary loop and
   genus 0 (closed and higher-genus meshes are refused: the paper cuts
   them, this does not yet).  The density is corrected by the area stretch
   ``s = area / area_uv`` (section 4.4) and squared for the weight of the
   centroidal Voronoi tessellation, whose points then follow the density as
   the samples of step 1 do (Gersho: a 2-D CVT's point density goes as the
   square root of its weight).
3. **1-D Lloyd** along each backbone (section 4.4.2) on its arc length,
   corners fixed; the feature samples stay put afterwards.
4. **Constrained Delaunay** of the samples in parameter space, consecutive
   samples of every backbone joined by constrained segments (section 4.3),
   and **weighted Lloyd** (section 4.4.1): every site moves to the centroid
   of its cell, computed on quadrature points of the input triangles; a
   point belongs to the nearest corner of the constrained Delaunay triangle
   that holds it, so cells are clipped by the backbones.  Triangles outside
   the input's parameter domain are left out.
5. **Lift** (section 4.5): each vertex goes back onto the input surface
   through its barycentric coordinates in the input triangle holding it.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree

from ...core import Heightfield, StopCriteria, TerrainMesh
from ...errors import InvalidInputError, InvalidOptionError
from ...kernels import locate as kl
from ..greedy.delaunay import delaunay
from .parameterize import lscm, offset, parameterise, signed_areas
from ..grid.grid import grid_mesh
from ..registry import register
from .sampling import CORNER, FEATURE, SURFACE, Sampling, sample_mesh
from .skeleton import Breaklines

__all__ = ["lscm", "remesh"]

#: Quadrature points per site the Lloyd iterations aim at (a triangle is cut into k x k pieces for it).
QUADRATURE_PER_SITE = 16


# -- the locator ---------------------------------------------------------------------------
class _Locator:
    """Point location in a planar triangulation (:mod:`tinsmith.kernels.locate`)."""

    def __init__(self, uv: np.ndarray, tri: np.ndarray):
        self.uv, self.tri = np.ascontiguousarray(uv, np.float64), np.ascontiguousarray(tri, np.int64)
        self.grid = kl.grid_for(self.uv, max(len(self.tri) // 2, 1))
        self.start, self.items = kl.build(self.uv, self.tri, *self.grid)

    def __call__(self, points: np.ndarray, eps: float = 1e-9):
        return kl.locate(self.uv, self.tri, self.start, self.items, *self.grid, np.ascontiguousarray(points, np.float64), eps)


# -- 1-D Lloyd on the backbones -----------------------------------------------------------
def _relax_backbones(sampling: Sampling, density, uv, iterations: int):
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
def _pieces(k: int) -> np.ndarray:
    """Barycentric coordinates of the centroids of the k x k pieces a triangle is cut into."""
    ij = [(i, j) for i in range(k) for j in range(k - i)]
    up = [((i + 1 / 3) / k, (j + 1 / 3) / k) for i, j in ij]
    down = [((i + 2 / 3) / k, (j + 2 / 3) / k) for i, j in ij if i + j <= k - 2]
    st = np.array(up + down)
    return np.column_stack([1 - st.sum(axis=1), st])


def _quadrature(uv, tri, rho, sites_per_triangle):
    """Quadrature points of the input triangles in parameter space: (points (Q, 2), weights (Q,)).

    A triangle is cut into k x k pieces, k chosen so that each site it is
    expected to hold gets about :data:`QUADRATURE_PER_SITE` points.
    """
    k_of = np.clip(np.ceil(np.sqrt(QUADRATURE_PER_SITE * sites_per_triangle)), 1, 16).astype(np.int64)
    area = np.abs(signed_areas(uv, tri))
    pts, weights = [], []
    for k in np.unique(k_of):
        these = np.flatnonzero(k_of == k)
        bary = _pieces(int(k))
        t = tri[these]
        p = np.einsum("qc,tcd->tqd", bary, uv[t]).reshape(-1, 2)
        w = (np.einsum("qc,tc->tq", bary, rho[t]) * (area[these] / (k * k))[:, None]).ravel()
        pts.append(p)
        weights.append(w)
    return np.concatenate(pts), np.concatenate(weights)


def _triangulate(sites, constraints, walls, domain: _Locator):
    """Constrained Delaunay triangles of the sites inside the parameter domain.

    The boundary backbones (``walls``, rows of ``constraints``) cut the
    triangulation into regions; a region is kept when most of its triangles'
    centroids lie in the input's parameter domain.  (A test triangle by
    triangle would keep chords across a concave stretch of the boundary.)
    """
    tri = delaunay(sites, constraints=constraints if len(constraints) else None).triangles
    m = len(tri)
    a = np.concatenate([tri[:, 0], tri[:, 1], tri[:, 2]])
    b = np.concatenate([tri[:, 1], tri[:, 2], tri[:, 0]])
    n = len(sites)
    key = np.minimum(a, b) * n + np.maximum(a, b)
    owner = np.tile(np.arange(m), 3)
    order = np.argsort(key, kind="stable")
    k, o = key[order], owner[order]
    pair = np.flatnonzero(k[1:] == k[:-1])
    wall = np.isin(k[pair], np.minimum(walls[:, 0], walls[:, 1]) * n + np.maximum(walls[:, 0], walls[:, 1]))
    pair = pair[~wall]
    from scipy.sparse.csgraph import connected_components

    graph = sparse.coo_matrix((np.ones(len(pair)), (o[pair], o[pair + 1])), shape=(m, m))
    count, region = connected_components(graph, directed=False)
    inside = domain(sites[tri].mean(axis=1), eps=0.0)[0] >= 0
    share = np.bincount(region, weights=inside, minlength=count) / np.bincount(region, minlength=count)
    return tri[share[region] > 0.5]


def _adopt_orphans(sites, free, constraints, walls, domain, rounds: int = 5):
    """(triangles, sites): a free site in no kept triangle (it lies between a boundary backbone and the
    boundary it cuts short) moves to the centroid of the nearest kept triangle, until none is left."""
    for _ in range(rounds):
        tri = _triangulate(sites, constraints, walls, domain)
        used = np.zeros(len(sites), bool)
        used[tri.ravel()] = True
        orphans = np.flatnonzero(free & ~used)
        if len(orphans) == 0:
            return tri, sites
        centroids = sites[tri].mean(axis=1)
        sites = sites.copy()
        sites[orphans] = centroids[cKDTree(centroids).query(sites[orphans])[1]]
    return _triangulate(sites, constraints, walls, domain), sites


def _lloyd(sites, free, constraints, walls, domain, qpts, qw, iterations, tol):
    """Weighted Lloyd in parameter space (see the module docstring); returns (sites, iterations run, last move)."""
    spacing = np.sqrt(np.abs(signed_areas(domain.uv, domain.tri)).sum() / max(len(sites), 1))
    moved = np.inf
    done = 0
    for done in range(1, iterations + 1):
        tri, sites = _adopt_orphans(sites, free, constraints, walls, domain)
        where, _ = _Locator(sites, tri)(qpts)
        ok = where >= 0
        corners = tri[where[ok]]
        d = np.linalg.norm(sites[corners] - qpts[ok][:, None, :], axis=2)
        owner = corners[np.arange(len(corners)), np.argmin(d, axis=1)]
        mass = np.bincount(owner, weights=qw[ok], minlength=len(sites))
        cx = np.bincount(owner, weights=qw[ok] * qpts[ok, 0], minlength=len(sites))
        cy = np.bincount(owner, weights=qw[ok] * qpts[ok, 1], minlength=len(sites))
        move = free & (mass > 0)
        target = sites.copy()
        target[move, 0] = cx[move] / mass[move]
        target[move, 1] = cy[move] / mass[move]
        # a centroid outside the domain (a concave stretch of it) is not taken
        outside = domain(target[move], eps=0.0)[0] < 0
        idx = np.flatnonzero(move)[outside]
        target[idx] = sites[idx]
        moved = float(np.linalg.norm(target - sites, axis=1).max()) / spacing
        sites = target
        if moved < tol:
            break
    return sites, done, moved


# -- the method ------------------------------------------------------------------------------
@register("remesh")
def remesh(source, *, n_vertices, density, gamma, smooth, gradation, feature_angle, iterations, parameterization,
           seed, breaklines, stop: StopCriteria, progress=None) -> TerrainMesh:
    """Exactly ``n_vertices`` well-shaped vertices on the input surface, density chosen, features kept (seed 003).

    A heightfield is meshed at full resolution first.  ``mesh.info["remesh"]``
    holds the parameterisation used, the corner, feature and surface counts,
    the Lloyd iterations run and their last relative move.
    """
    if n_vertices is not None and stop.max_vertices is not None and n_vertices != stop.max_vertices:
        raise InvalidOptionError(f"remesh takes one vertex count: n_vertices={n_vertices} and max_vertices="
                                 f"{stop.max_vertices} differ")
    n_vertices = n_vertices if n_vertices is not None else stop.max_vertices
    if n_vertices is None:
        raise InvalidOptionError("remesh needs max_vertices (or n_vertices), the exact number of vertices of the result")
    mesh = grid_mesh(source) if isinstance(source, Heightfield) else source
    if progress:
        progress(0.0)
    if isinstance(source, Heightfield) and parameterization == "auto":
        parameterization = "xy"  # a heightfield is terrain, however steep
    uv, used = parameterise(mesh, parameterization)
    tri = mesh.triangles.astype(np.int64)
    domain = _Locator(uv, tri)
    lines = None
    if breaklines is not None:
        if used != "xy":
            raise InvalidOptionError("breaklines are x-y lines: they need the x-y parameter space (a terrain)")
        lines = _breaklines(breaklines, mesh, uv, domain)
    sampling = sample_mesh(mesh, n_vertices, density=density, gamma=gamma, smooth=smooth, gradation=gradation,
                           feature_angle=feature_angle, seed=seed, breaklines=lines)
    points = sampling.skeleton.points  # the mesh's vertices, then the breakline points
    uv_all = uv if lines is None else np.concatenate([uv, lines.points[:, :2] - offset(mesh)])
    d = sampling.density[: len(uv)]
    # density in parameter space: times the area stretch at each vertex, squared for the CVT's weight
    area3 = np.linalg.norm(np.cross(mesh.vertices[tri[:, 1]] - mesh.vertices[tri[:, 0]],
                                    mesh.vertices[tri[:, 2]] - mesh.vertices[tri[:, 0]]), axis=1) / 2
    area2 = np.abs(signed_areas(uv, tri))
    num, den = np.zeros(len(uv)), np.zeros(len(uv))
    np.add.at(num, tri.ravel(), np.repeat(area3, 3))
    np.add.at(den, tri.ravel(), np.repeat(area2, 3))
    rho = (d * num / np.maximum(den, 1e-300)) ** 2
    if progress:
        progress(0.2)
    # sites in parameter space: corners, features after their 1-D relaxation, surface samples
    kind = sampling.kind
    sites = np.zeros((n_vertices, 2))
    corner = kind == CORNER
    sites[corner] = uv_all[sampling.vertex[corner]]
    feat_pts, feat_uv = _relax_backbones(sampling, sampling.density, uv_all, max(iterations, 1) * 5)
    sites[kind == FEATURE] = feat_uv
    surf = kind == SURFACE
    sites[surf] = np.einsum("ij,ijk->ik", sampling.bary[surf], uv[tri[sampling.triangle[surf]]])
    constraints, walls = _backbone_segments(sampling)
    expected = area3 * d[tri].mean(axis=1)
    qpts, qw = _quadrature(uv, tri, rho, n_vertices * expected / expected.sum())
    sites, run, last = _lloyd(sites, surf, constraints, walls, domain, qpts, qw, iterations, tol=1e-3)
    if progress:
        progress(0.9)
    out_tri, sites = _adopt_orphans(sites, surf, constraints, walls, domain)
    # lift: corners and features exactly, the rest through the input triangle that holds them
    xyz = np.zeros((n_vertices, 3))
    xyz[corner] = points[sampling.vertex[corner]]
    xyz[kind == FEATURE] = feat_pts
    where, bary = domain(sites[surf])
    lost = where < 0
    if lost.any():  # on the very edge of the domain by rounding: the nearest input triangle
        near = cKDTree(uv[tri].mean(axis=1)).query(sites[surf][lost])[1]
        where[lost] = near
        bary[lost] = _barycentric(uv[tri[near]], sites[surf][lost])
    xyz[surf] = np.einsum("ij,ijk->ik", bary, mesh.vertices[tri[where]])
    if used == "xy":  # x and y are the parameters themselves: the triangles keep the orientation they have in them
        xyz[surf, :2] = sites[surf] + offset(mesh)
    out_tri = _split_slivers(xyz[:, :2], out_tri)
    result = TerrainMesh(xyz, out_tri, crs=mesh.crs)
    unused = n_vertices - len(np.unique(out_tri))
    result.info["remesh"] = {
        "parameterization": used, "corners": int(corner.sum()), "feature_samples": int((kind == FEATURE).sum()),
        "surface_samples": int(surf.sum()), "lloyd_iterations": run, "last_move": last,
        "unused_vertices": int(unused), "rates": list(sampling.rates),
    }
    if progress:
        progress(1.0)
    return result


def _split_slivers(xy: np.ndarray, tri: np.ndarray, rel: float = 1e-12) -> np.ndarray:
    """Triangles without the slivers of three (nearly) collinear vertices that the lift can leave.

    Feature samples are lifted to their exact points and surface samples keep
    their parameters, so three samples along a boundary backbone that made a
    thin triangle in parameter space can come out collinear, or turned over by
    1e-17.  Such a triangle ``(a, m, b)``, ``m`` between ``a`` and ``b``, is
    removed and its neighbour across ``a-b``, ``(b, a, x)``, becomes
    ``(a, m, x)`` and ``(m, b, x)``: the same area, every vertex still used.
    """
    def area(t):
        p = xy[t]
        return (p[..., 1, 0] - p[..., 0, 0]) * (p[..., 2, 1] - p[..., 0, 1]) - \
               (p[..., 2, 0] - p[..., 0, 0]) * (p[..., 1, 1] - p[..., 0, 1])

    span = np.ptp(xy, axis=0)
    tol = rel * max(float(span[0] * span[1]), float(span.max()) ** 2, 1e-300)
    if not (area(tri) <= tol).any():  # the common case, at numpy speed
        return tri
    tri = [list(t) for t in tri]
    for _ in range(len(tri)):
        bad = next((i for i, t in enumerate(tri) if area(np.array(t)) <= tol), None)
        if bad is None:
            break
        t = tri[bad]
        lengths = [np.sum((xy[t[(k + 1) % 3]] - xy[t[(k + 2) % 3]]) ** 2) for k in range(3)]
        k = int(np.argmax(lengths))  # m: the vertex opposite the longest edge a-b
        m, a, b = t[k], t[(k + 1) % 3], t[(k + 2) % 3]
        other = next((i for i, u in enumerate(tri) if i != bad and a in u and b in u), None)
        if other is None:  # on the outline: nothing to fill
            del tri[bad]
            continue
        x = next(v for v in tri[other] if v not in (a, b))
        split = [[a, m, x], [m, b, x]]
        split = [u if area(np.array(u)) > 0 else [u[0], u[2], u[1]] for u in split]
        tri = [u for i, u in enumerate(tri) if i not in (bad, other)] + split
    return np.asarray(tri, dtype=np.int64).reshape(-1, 3)


def _barycentric(corners: np.ndarray, p: np.ndarray) -> np.ndarray:
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    d = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    w1 = ((p[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1])) / d
    w2 = ((b[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1]) - (p[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / d
    w = np.clip(np.column_stack([1 - w1 - w2, w1, w2]), 0, None)
    return w / w.sum(axis=1, keepdims=True)


def _breaklines(lines, mesh: TerrainMesh, uv: np.ndarray, domain: _Locator) -> Breaklines | None:
    """User breaklines as skeleton points and segments: noded where they cross, cut to the data, densified to
    half the input's edge length, heights from the surface under them."""
    from ...errors import require

    shapely = require("shapely", "vector", "breaklines")
    if isinstance(lines, np.ndarray) and lines.ndim == 2:
        lines = [lines]
    geoms = []
    for i, line in enumerate(lines):
        a = np.asarray(line, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] < 2 or len(a) < 2 or not np.isfinite(a).all():
            raise InvalidInputError(f"breaklines[{i}] must be a (K, 2) array of finite x, y with K >= 2, got {a.shape}")
        geoms.append(shapely.LineString(a[:, :2]))
    if not geoms:
        return None
    origin = offset(mesh)
    e, _ = mesh.edges()
    step = 0.5 * float(np.median(np.linalg.norm(uv[e[:, 0]] - uv[e[:, 1]], axis=1)))
    index, coords, segments = {}, [], []
    for g in shapely.get_parts(shapely.union_all(geoms)):  # split where the lines cross
        c = shapely.get_coordinates(g)
        dense = [c[:1]]
        for p, q in zip(c[:-1], c[1:]):
            k = max(1, int(np.ceil(np.linalg.norm(q - p) / step)))
            dense.append(p + (q - p) * (np.arange(1, k + 1) / k)[:, None])
        dense = np.concatenate(dense)
        inside = domain(dense - origin)[0] >= 0
        ids = []
        for xy, ok in zip(dense, inside):
            if not ok:
                ids = []
                continue
            key = (round(float(xy[0]), 9), round(float(xy[1]), 9))
            if key not in index:
                index[key] = len(coords)
                coords.append(xy)
            ids.append(index[key])
            if len(ids) >= 2 and ids[-1] != ids[-2]:
                segments.append((ids[-2], ids[-1]))
    if not segments:
        raise InvalidInputError("no breakline crosses the data")
    xy = np.array(coords)
    where, bary = domain(xy - origin)
    z = np.einsum("ij,ij->i", bary, mesh.vertices[mesh.triangles[where], 2])
    n = mesh.n_vertices
    return Breaklines(np.column_stack([xy, z]), np.array(segments, dtype=np.int64) + n, where, bary)


def _backbone_segments(sampling: Sampling) -> tuple:
    """(constrained segments, those of boundary backbones): consecutive samples along every backbone, its
    corners at the ends."""
    corner_site = {int(v): i for i, v in enumerate(sampling.vertex) if sampling.kind[i] == CORNER}
    feat = np.flatnonzero(sampling.kind == FEATURE)
    segments, walls = [], []
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
        pairs = [(a, b) for a, b in zip(ids[:-1], ids[1:]) if a != b]
        segments += pairs
        if sampling.skeleton.kind[i] == "boundary":
            walls += pairs
    return (np.array(segments, dtype=np.int64).reshape(-1, 2), np.array(walls, dtype=np.int64).reshape(-1, 2))
