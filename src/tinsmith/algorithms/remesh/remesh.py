"""Isotropic remeshing with an exact vertex budget: error diffusion and weighted CVT with features (Alliez et al. 2003).

Any manifold triangle mesh (a full-resolution DEM mesh, a TIN from another
method, a scanned patch, a closed solid or a surface of higher genus), or a
heightfield (its full-resolution mesh), to a mesh of exactly ``max_vertices``
well-shaped vertices:

1. **Sampling** (section 3, :mod:`.sampling`): the feature skeleton
   (boundary and sharp edges and user breaklines chained into backbones,
   corners), a density
   (uniform or curvature, its spacing graded by ``gradation``: without it
   the triangles between fine and coarse sampling come out distorted),
   calibration and error diffusion: exactly ``max_vertices`` samples, corners
   kept.
2. **Parameter space** (section 4.2, :mod:`.parameterize`): the x-y plane for terrain (every
   triangle faces up, and the area at most 1.5 times the footprint or the
   mesh not a disk: holes); otherwise a least-squares conformal map (LSCM, Lévy
   et al. 2002) with free boundary, for a mesh with one boundary loop and
   genus 0.  A mesh that is not a disk (closed, higher genus, holes) is cut
   into disk-like charts (section 4.1, :mod:`.charts`), the cut sampled as
   a backbone shared by the charts on both sides, each chart flattened and
   relaxed on its own, and the seams relaxed once the surface is whole
   (:mod:`.seams`).  The density is corrected by the area stretch
   ``s = area / area_uv`` (section 4.4) and squared for the weight of the
   centroidal Voronoi tessellation, whose points then follow the density as
   the samples of step 1 do (Gersho: a 2-D CVT's point density goes as the
   square root of its weight).
3. **1-D Lloyd** along each backbone (section 4.4.2) on its arc length,
   corners fixed; the feature samples stay put afterwards.
4. **Constrained Delaunay** of the samples in parameter space, consecutive
   samples of every backbone joined by constrained segments (section 4.3),
   and **weighted Lloyd** (section 4.4.1, :mod:`.relax`): every site moves
   to the centroid of its cell, computed on quadrature points of the input
   triangles; a point belongs to the nearest corner of the constrained
   Delaunay triangle that holds it, so cells are clipped by the backbones.
   Each iteration re-triangulates the sites, and each quadrature point walks
   from the triangle of the site that owned it last (a step or two), so an
   iteration costs a triangulation and a walk, not a location of every
   point.  Triangles outside the input's parameter domain are left out.
5. **Lift** (section 4.5): each vertex goes back onto the input surface
   through its barycentric coordinates in the input triangle holding it.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from ...core import Heightfield, StopCriteria, TerrainMesh
from ...errors import InvalidInputError, InvalidOptionError, require
from ...triangulation.grid import grid_mesh
from ..registry import register
from .charts import remesh_charts
from .parameterize import lscm, offset, parameterise
from .relax import Locator, backbone_segments, relax_backbones, relax_patch
from .sampling import CORNER, FEATURE, SURFACE, sample_mesh
from .skeleton import Breaklines

__all__ = ["lscm", "remesh"]


# -- the method ------------------------------------------------------------------------------
@register("remesh")
def remesh(source, *, density, gamma, smooth, gradation, feature_angle, iterations, parameterization,
           seed, breaklines, stop: StopCriteria, progress=None) -> TerrainMesh:
    """Exactly ``max_vertices`` well-shaped vertices on the input surface, density chosen, features kept (Alliez et al. 2003).

    ``max_vertices`` is required: the number of vertices placed, exactly
    (``n_vertices``, its former name, is deprecated).  A heightfield is
    meshed at full resolution first.  ``mesh.info["remesh"]`` holds the
    parameterisation used, the corner, feature and surface counts, the
    Lloyd iterations run and their last relative move.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> mesh = tinsmith.remesh(dem, max_vertices=300)
    >>> mesh.n_vertices  # exactly the budget
    300
    >>> tinsmith.triangle_quality(mesh)["min_angle"]["median"] > 40.0
    True
    """
    n_vertices = stop.max_vertices
    if n_vertices is None:
        raise InvalidOptionError("remesh needs max_vertices, the exact number of vertices of the result")
    mesh = grid_mesh(source) if isinstance(source, Heightfield) else source
    if progress:
        progress(0.0)
    if isinstance(source, Heightfield) and parameterization == "auto":
        parameterization = "xy"  # a heightfield is terrain, however steep
    uv, used = parameterise(mesh, parameterization)
    if used == "charts":
        if breaklines is not None:
            raise InvalidOptionError("breaklines are x-y lines: they need the x-y parameter space (a terrain)")
        return remesh_charts(mesh, n_vertices, dict(density=density, gamma=gamma, smooth=smooth, gradation=gradation,
                                                     feature_angle=feature_angle, seed=seed), iterations, progress)
    tri = mesh.triangles.astype(np.int64)
    domain = Locator(uv, tri)
    lines = None
    if breaklines is not None:
        if used != "xy":
            raise InvalidOptionError("breaklines are x-y lines: they need the x-y parameter space (a terrain)")
        lines = _breaklines(breaklines, mesh, uv, domain)
    sampling = sample_mesh(mesh, n_vertices, density=density, gamma=gamma, smooth=smooth, gradation=gradation,
                           feature_angle=feature_angle, seed=seed, breaklines=lines)
    points = sampling.skeleton.points  # the mesh's vertices, then the breakline points
    uv_all = uv if lines is None else np.concatenate([uv, lines.points[:, :2] - offset(mesh)])
    if progress:
        progress(0.2)
    # sites in parameter space: corners, features after their 1-D relaxation, surface samples
    kind = sampling.kind
    sites = np.zeros((n_vertices, 2))
    corner = kind == CORNER
    sites[corner] = uv_all[sampling.vertex[corner]]
    feat_pts, feat_uv = relax_backbones(sampling, sampling.density, uv_all, max(iterations, 1) * 5)
    sites[kind == FEATURE] = feat_uv
    surf = kind == SURFACE
    sites[surf] = np.einsum("ij,ijk->ik", sampling.bary[surf], uv[tri[sampling.triangle[surf]]])
    constraints, walls, _ = backbone_segments(sampling)
    out_tri, sites, surf_xyz, run, last = relax_patch(mesh.vertices, tri, uv, sampling.density[: len(uv)], sites, surf,
                                                 constraints, walls, iterations, domain)
    if progress:
        progress(0.9)
    # lift: corners and features exactly, the rest through the input triangle that holds them
    xyz = np.zeros((n_vertices, 3))
    xyz[corner] = points[sampling.vertex[corner]]
    xyz[kind == FEATURE] = feat_pts
    xyz[surf] = surf_xyz
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


def _breaklines(lines, mesh: TerrainMesh, uv: np.ndarray, domain: Locator) -> Breaklines | None:
    """User breaklines as skeleton points and segments: noded where they cross, cut to the data, densified to
    half the input's edge length, heights from the surface under them."""
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
        for p, q in pairwise(c):
            k = max(1, int(np.ceil(np.linalg.norm(q - p) / step)))
            dense.append(p + (q - p) * (np.arange(1, k + 1) / k)[:, None])
        dense = np.concatenate(dense)
        inside = domain(dense - origin)[0] >= 0
        ids = []
        for xy, ok in zip(dense, inside, strict=True):
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


