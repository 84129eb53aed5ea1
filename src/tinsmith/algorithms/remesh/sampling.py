"""Exactly N samples on a triangle mesh by error diffusion (Alliez et al. 2003, section 3): the remesher's first stage.

1. **Density** at the vertices: uniform, or curvature (the magnitude of the
   discrete mean curvature of Meyer et al. 2003, floored at ``floor`` times
   its mean, through the transfer ``x ** gamma``, then ``smooth`` rounds of
   averaging with the neighbours), normalised to mean 1 over the area, and
   with ``gradation`` limited so that the sample spacing grows by at most
   that much per unit of distance (a shortest-path pass).  It is linear over
   each triangle.  On feature edges the density of samples per
   unit length is its square root, which keeps isotropic spacing.
2. **Calibration** (section 3.2): with ``R_s`` samples per unit of surface
   density and ``R_f`` per unit of feature density, an ideal equilateral
   tiling gives ``R_s = 2 R_f^2 / sqrt(3)``; with the corners ``C``,
   ``R_s S + R_f L + C = N`` (S, L the integrals of the densities) is a
   quadratic in ``R_f``.
   Sharp backbones shorter than two feature spacings ``2 / R_f`` cannot
   be drawn at this budget (they would only leave slivers): they are
   dropped and the budget calibrated again.
3. **Error diffusion** over the triangles (section 3.3,
   :mod:`tinsmith.kernels.diffusion`), then along every backbone of the
   feature skeleton (section 3.4, :mod:`.skeleton`), the error flowing from
   one to the next and from the surface to the features: no error is
   dropped, so the count is exact.  (Should rounding below zero ever leave a
   difference, it is made up on the surface triangles furthest from their
   ideal count; ``Sampling.adjusted`` says by how many.)
4. **Positions**: in a triangle, points of a scrambled Sobol sequence
   (``seed``) mapped by Turk's square-root rule; on a feature edge, evenly
   spaced; corners stay where they are.  These are the starting sites of the
   weighted centroidal Voronoi relaxation.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components

from ... import _checks
from ...core import TerrainMesh
from ...errors import InvalidInputError, InvalidOptionError
from ...kernels.curvature import mean_curvature_normal
from ...kernels.diffusion import diffuse_chain, diffuse_triangles
from ...triangulation.edges import fill_from_neighbours
from .skeleton import Breaklines, FeatureSkeleton, MeshEdges, drop_short_sharp, feature_skeleton, mesh_edges

__all__ = ["Sampling", "kept_skeleton", "sample_mesh", "vertex_density"]

#: Kinds of :attr:`Sampling.kind`.
CORNER, FEATURE, SURFACE = 0, 1, 2


@dataclass
class Sampling:
    """N samples on a mesh.

    ``points`` (N, 3); ``kind`` CORNER, FEATURE or SURFACE; for surface
    samples ``triangle`` and ``bary`` (barycentric coordinates in it); for
    feature samples ``backbone`` and ``edge`` (index of the chain and of the
    edge along it) and ``t`` (0..1 along that edge); corners have
    ``vertex``.  ``rates`` is (R_s, R_f), ``density`` the density at the
    input's vertices; ``adjusted`` the samples moved by
    the last-resort balancing (0 when the diffusion alone was exact).
    """

    points: np.ndarray
    kind: np.ndarray
    triangle: np.ndarray
    bary: np.ndarray
    backbone: np.ndarray
    edge: np.ndarray
    t: np.ndarray
    vertex: np.ndarray
    skeleton: FeatureSkeleton
    rates: tuple
    density: np.ndarray  #: the density the samples follow, at the skeleton's points (input vertices first)
    adjusted: int = 0


def _triangle_areas(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)


def vertex_density(mesh: TerrainMesh, *, density: str = "uniform", gamma: float = 1.0, smooth: int = 0,
                   floor: float = 0.1, gradation: float | None = None, n_vertices: int | None = None,
                   edges: MeshEdges | None = None) -> np.ndarray:
    """(N,) sampling density at the vertices, area-weighted mean 1 (see the module docstring)."""
    density = _checks.choice("density", density, ("uniform", "curvature"))
    gamma = _checks.number("gamma", gamma, minimum=0.0)
    smooth = _checks.integer("smooth", smooth, minimum=0)
    floor = _checks.number("floor", floor, minimum=0.0, exclusive_min=True)
    if gradation is not None:
        gradation = _checks.number("gradation", gradation, minimum=0.0, exclusive_min=True)
    v, t = mesh.vertices, mesh.triangles
    n = len(v)
    if density == "uniform":
        return np.ones(n)
    e = edges if edges is not None else mesh_edges(t)
    k, mixed, _ = mean_curvature_normal(v - v.mean(axis=0), t)
    with np.errstate(invalid="ignore", divide="ignore"):
        h = np.linalg.norm(k, axis=1) / (4.0 * mixed)  # |H| = |K| / 2, K = k / (2 A_mixed)
    border = np.zeros(n, bool)
    border[e.edges[e.faces[:, 1] < 0].ravel()] = True  # the formula does not hold on the boundary
    h[border | ~np.isfinite(h)] = np.nan
    h = fill_from_neighbours(h, e.edges)
    a, b = e.edges[:, 0], e.edges[:, 1]
    area = np.zeros(n)
    np.add.at(area, t.ravel(), np.repeat(_triangle_areas(v, t) / 3.0, 3))
    mean = (h * area).sum() / max(area.sum(), 1e-300)
    d = (np.maximum(h, floor * mean) / mean) ** gamma if mean > 0 else np.ones(n)  # relative: no overflow
    for _ in range(smooth):  # low pass: each vertex the mean of itself and its neighbours
        total, count = d.copy(), np.ones(n)
        np.add.at(total, a, d[b])
        np.add.at(total, b, d[a])
        np.add.at(count, a, 1)
        np.add.at(count, b, 1)
        d = total / count
    d = d / ((d * area).sum() / area.sum())
    if gradation is not None:
        if n_vertices is None:
            raise InvalidOptionError("gradation needs n_vertices: the spacing it limits depends on the budget")
        spacing = np.sqrt(2.0 * area.sum() / (np.sqrt(3.0) * n_vertices))  # of an equilateral tiling
        d = _grade(v, e.edges, d, gradation, spacing)
        d = d / ((d * area).sum() / area.sum())
    return d


def _grade(v: np.ndarray, edges: np.ndarray, d: np.ndarray, gradation: float, spacing: float) -> np.ndarray:
    """The density whose sample spacing ``h = spacing * d ** -1/2`` grows by at most ``gradation`` per unit
    of distance.

    ``h(v) = min over u of h(u) + gradation * dist(u, v)`` along mesh edges:
    the shortest paths from a virtual source joined to every vertex by an edge
    of length ``h(u)`` (Dijkstra).  Where the density falls off faster than
    that, triangles between fine and coarse sampling come out distorted.
    """
    from scipy.sparse.csgraph import dijkstra

    n = len(v)
    h = spacing / np.sqrt(d)
    length = gradation * np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1)
    rows = np.concatenate([edges[:, 0], edges[:, 1], np.full(n, n)])
    cols = np.concatenate([edges[:, 1], edges[:, 0], np.arange(n)])
    graph = sparse.csr_matrix((np.concatenate([length, length, h]), (rows, cols)), shape=(n + 1, n + 1))
    graded = dijkstra(graph, directed=True, indices=n)[:n]
    return (spacing / graded) ** 2


def _calibrate(surface: float, features: float, corners: int, n_vertices: int) -> tuple:
    """(R_s, R_f) from R_s S + R_f L + C = N with R_s = 2 R_f^2 / sqrt(3)."""
    budget = n_vertices - corners
    a = 2.0 * surface / np.sqrt(3.0)
    rf = budget / features if a <= 0 else (-features + np.sqrt(features * features + 4.0 * a * budget)) / (2.0 * a)
    return 2.0 * rf * rf / np.sqrt(3.0), rf


def _turk(u: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of uniform points in a triangle from points of the unit square (Turk 1990)."""
    r = np.sqrt(u[:, 0])
    return np.column_stack([1.0 - r, r * (1.0 - u[:, 1]), r * u[:, 1]])


def _sobol(n: int, seed: int) -> np.ndarray:
    from scipy.stats import qmc

    if n == 0:
        return np.zeros((0, 2))
    with warnings.catch_warnings():  # a count that is not a power of two loses the balance property only
        warnings.simplefilter("ignore")
        return qmc.Sobol(d=2, scramble=True, seed=seed).random(n)


def _backbone_order(skeleton: FeatureSkeleton) -> list:
    """Backbones in the order of diffusion: each next one, where possible, starts where the last ended."""
    remaining = set(range(len(skeleton.backbones)))
    at = {}
    for i, b in enumerate(skeleton.backbones):
        at.setdefault(int(b[0]), []).append(i)
        at.setdefault(int(b[-1]), []).append(i)
    order = []
    while remaining:
        i = min(remaining)
        while i is not None:
            remaining.discard(i)
            order.append(i)
            end = int(skeleton.backbones[i][-1])
            nxt = [j for j in at.get(end, []) if j in remaining]
            i = nxt[0] if nxt else None
    return order


def kept_skeleton(mesh: TerrainMesh, n_vertices: int, *, density: str = "uniform", gamma: float = 1.0,
                  smooth: int = 0, gradation: float | None = None, feature_angle: float = 60.0,
                  breaklines: Breaklines | None = None, cuts: np.ndarray | None = None) -> tuple:
    """(skeleton, density at its points, edges, density integral per triangle): the feature skeleton of ``mesh``
    with the sharp backbones ``n_vertices`` samples can draw (step 2: shorter ones are dropped and the budget
    calibrated again), before any sample is placed."""
    v, tri = mesh.vertices.astype(np.float64), mesh.triangles.astype(np.int64)
    edges = mesh_edges(tri)
    skeleton = feature_skeleton(mesh, feature_angle=feature_angle, edges=edges, breaklines=breaklines, cuts=cuts)
    d = vertex_density(mesh, density=density, gamma=gamma, smooth=smooth, gradation=gradation, n_vertices=n_vertices,
                       edges=edges)
    if breaklines is not None:  # the density at the breakline points, from the triangles under them
        d = np.concatenate([d, np.einsum("ij,ij->i", breaklines.bary, d[tri[breaklines.triangle]])])
    pv = skeleton.points
    surface_amount = _triangle_areas(v, tri) * d[tri].mean(axis=1)
    root = np.sqrt(d)
    for _ in range(4):  # sharp features shorter than two sample spacings are not kept: calibrate again
        feature_total = sum(skeleton.weighted_lengths(pv, root))
        if surface_amount.sum() <= 0 and feature_total <= 0:
            raise InvalidInputError("the mesh has no area and no feature length to sample")
        if n_vertices <= len(skeleton.corners):  # not even the corners fit: no sharp feature can be kept
            kept = drop_short_sharp(skeleton, np.inf, cuts)
        else:
            rf = _calibrate(float(surface_amount.sum()), feature_total, len(skeleton.corners), n_vertices)[1]
            kept = drop_short_sharp(skeleton, 2.0 / rf, cuts)
        if kept is skeleton:
            break
        skeleton = kept
    return skeleton, d, edges, surface_amount


def sample_mesh(mesh: TerrainMesh, n_vertices: int, *, density: str = "uniform", gamma: float = 1.0,
                smooth: int = 0, gradation: float | None = None, feature_angle: float = 60.0, seed: int = 0,
                breaklines: Breaklines | None = None, cuts: np.ndarray | None = None) -> Sampling:
    """Exactly ``n_vertices`` samples on ``mesh``: corners, backbones, surface (see the module docstring).

    ``breaklines`` (points on the surface and segments between them) are
    backbones too; corners and feature samples then index the skeleton's
    ``points`` (the mesh's vertices followed by the breakline points).  ``cuts``
    (mesh edges between charts) are backbones as well.
    """
    if not isinstance(mesh, TerrainMesh):
        raise InvalidInputError(f"sampling needs a TerrainMesh, got {type(mesh).__name__}")
    n_vertices = _checks.integer("n_vertices", n_vertices, minimum=1)
    seed = _checks.integer("seed", seed, minimum=0)
    v, tri = mesh.vertices.astype(np.float64), mesh.triangles.astype(np.int64)
    skeleton, d, edges, surface_amount = kept_skeleton(
        mesh, n_vertices, density=density, gamma=gamma, smooth=smooth, gradation=gradation,
        feature_angle=feature_angle, breaklines=breaklines, cuts=cuts)
    pv = skeleton.points
    area = _triangle_areas(v, tri)
    root = np.sqrt(d)
    if n_vertices <= len(skeleton.corners):
        raise InvalidOptionError(
            f"n_vertices must exceed the {len(skeleton.corners)} corners of the feature skeleton (every corner is kept), "
            f"got {n_vertices}; raise it or raise feature_angle"
        )
    corners = skeleton.corners
    chains = [(np.linalg.norm(np.diff(pv[b], axis=0), axis=1), 0.5 * (root[b[:-1]] + root[b[1:]]))
              for b in skeleton.backbones]
    rs, rf = _calibrate(float(surface_amount.sum()), float(sum((ln * w).sum() for ln, w in chains)), len(corners),
                        n_vertices)
    # 2-D diffusion over the triangles
    adj = np.where(edges.faces[edges.of_triangle, 0] == np.arange(len(tri))[:, None],
                   edges.faces[edges.of_triangle, 1], edges.faces[edges.of_triangle, 0])
    ends = edges.edges[edges.of_triangle]
    elen = np.linalg.norm(v[ends[..., 0]] - v[ends[..., 1]], axis=-1)
    n_comp, comp = connected_components(
        sparse.coo_matrix((np.ones(int((adj >= 0).sum())), (np.repeat(np.arange(len(tri)), 3)[adj.ravel() >= 0],
                                                             adj.ravel()[adj.ravel() >= 0])), shape=(len(tri), len(tri))),
        directed=False,
    )
    on_boundary = (adj < 0).any(axis=1)
    key = np.where(on_boundary, 0, 1) * len(tri) + np.arange(len(tri))  # boundary triangles first, then by index
    first = np.full(n_comp, np.iinfo(np.int64).max)
    np.minimum.at(first, comp, key)
    seeds = (first % len(tri)).astype(np.int64)
    ideal = rs * surface_amount
    count, carry = diffuse_triangles(tri, adj, elen, area, ideal, seeds, len(v), 0.0)
    # 1-D diffusion along the backbones, in an order that follows their connections
    edge_counts = [None] * len(skeleton.backbones)
    for i in _backbone_order(skeleton):
        length, w = chains[i]
        edge_counts[i], carry = diffuse_chain(rf * length * w, carry)
    total = int(count.sum()) + sum(int(c.sum()) for c in edge_counts) + len(corners)
    adjusted = n_vertices - total
    if adjusted:  # last resort: the surface triangles furthest from their ideal count
        gap = ideal - count
        if adjusted > 0:
            pick = np.argsort(-gap, kind="stable")[:adjusted]
            count[pick] += 1
        else:
            pick = np.argsort(gap + np.where(count > 0, 0.0, np.inf), kind="stable")[:-adjusted]
            count[pick] -= 1
    # positions
    surf_tri = np.repeat(np.arange(len(tri)), count)
    bary = _turk(_sobol(len(surf_tri), seed))
    surf_pts = np.einsum("ij,ijk->ik", bary, v[tri[surf_tri]])
    f_backbone, f_edge, f_t = [], [], []
    for i, c in enumerate(edge_counts):
        for j in np.flatnonzero(c):
            k = int(c[j])
            f_backbone.append(np.full(k, i))
            f_edge.append(np.full(k, j))
            f_t.append((np.arange(k) + 0.5) / k)
    f_backbone = np.concatenate(f_backbone) if f_backbone else np.zeros(0, np.int64)
    f_edge = np.concatenate(f_edge) if f_edge else np.zeros(0, np.int64)
    f_t = np.concatenate(f_t) if f_t else np.zeros(0)
    if len(f_backbone):
        a = np.array([skeleton.backbones[i][j] for i, j in zip(f_backbone, f_edge, strict=True)])
        b = np.array([skeleton.backbones[i][j + 1] for i, j in zip(f_backbone, f_edge, strict=True)])
        f_pts = pv[a] + f_t[:, None] * (pv[b] - pv[a])
    else:
        f_pts = np.zeros((0, 3))
    nc, nf, ns = len(corners), len(f_backbone), len(surf_tri)
    minus = np.full(nc + nf + ns, -1, np.int64)
    return Sampling(
        points=np.concatenate([pv[corners], f_pts, surf_pts]),
        kind=np.concatenate([np.full(nc, CORNER), np.full(nf, FEATURE), np.full(ns, SURFACE)]).astype(np.int8),
        triangle=np.concatenate([minus[: nc + nf], surf_tri]),
        bary=np.concatenate([np.zeros((nc + nf, 3)), bary]),
        backbone=np.concatenate([minus[:nc], f_backbone, minus[:ns]]),
        edge=np.concatenate([minus[:nc], f_edge, minus[:ns]]),
        t=np.concatenate([np.zeros(nc), f_t, np.zeros(ns)]),
        vertex=np.concatenate([corners, minus[: nf + ns]]),
        skeleton=skeleton,
        rates=(rs, rf),
        density=d,
        adjusted=abs(adjusted),
    )
