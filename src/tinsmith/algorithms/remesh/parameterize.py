"""Parameter spaces for the remesher (Alliez et al. 2003, section 4.2): the x-y plane for terrain, LSCM otherwise.

The least-squares conformal map (Lévy, Petitjean, Ray and Maillot 2002)
flattens a disk-like mesh with free boundary: angle-preserving, locally
isotropic, so that well-shaped triangles in the plane stay well shaped once
lifted back (only their size changes, which the density corrects).
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import spsolve

from ...core import TerrainMesh
from ...errors import InvalidInputError
from .skeleton import mesh_edges

__all__ = ["AUTO_XY_STRETCH", "lscm", "parameterise"]

#: "auto" maps a mesh whose triangles all face up onto x-y when its area is at most this many times its
#: footprint (St. Helens: 1.08; a hemisphere: 2); steeper surfaces take the conformal map.
AUTO_XY_STRETCH = 1.5


def lscm(mesh: TerrainMesh) -> np.ndarray:
    """(N, 2) least-squares conformal map of a disk-like mesh (Lévy, Petitjean, Ray and Maillot 2002).

    Free boundary; two boundary vertices far apart are pinned at their 3-D
    distance, so the map keeps the mesh's scale near them.  Oriented so that
    the triangles run counter-clockwise in (u, v).
    """
    v, t = mesh.vertices.astype(np.float64), mesh.triangles.astype(np.int64)
    edges = mesh_edges(t)
    boundary = edges.edges[edges.faces[:, 1] < 0]
    n, m = len(v), len(t)
    chi = n - len(edges.edges) + m
    loops = count_loops(boundary, n)
    if loops != 1 or chi != 1:
        raise InvalidInputError(
            f"the conformal path needs a disk-like mesh (one boundary loop, genus 0); this one has {loops} boundary "
            f"loops and Euler characteristic {chi}{' (closed)' if loops == 0 else ''}: cut it into disks first"
        )
    # each triangle in its own plane: corner 0 at the origin, corner 1 on the x axis
    p0, p1, p2 = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    e1 = p1 - p0
    x1 = np.linalg.norm(e1, axis=1)
    ex = e1 / x1[:, None]
    normal = np.cross(e1, p2 - p0)
    twice = np.linalg.norm(normal, axis=1)
    ey = np.cross(normal / twice[:, None], ex)
    x2, y2 = np.einsum("ij,ij->i", p2 - p0, ex), np.einsum("ij,ij->i", p2 - p0, ey)
    xs = np.column_stack([np.zeros(m), x1, x2])
    ys = np.column_stack([np.zeros(m), np.zeros(m), y2])
    # W_j = (x_{j+2} - x_{j+1}) + i (y_{j+2} - y_{j+1}), scaled by 1 / sqrt(2 area)
    scale = 1.0 / np.sqrt(twice)
    wr = np.column_stack([xs[:, 2] - xs[:, 1], xs[:, 0] - xs[:, 2], xs[:, 1] - xs[:, 0]]) * scale[:, None]
    wi = np.column_stack([ys[:, 2] - ys[:, 1], ys[:, 0] - ys[:, 2], ys[:, 1] - ys[:, 0]]) * scale[:, None]
    # pins: a boundary vertex far from another, twice
    bverts = np.unique(boundary)
    a = bverts[np.argmax(np.linalg.norm(v[bverts] - v[bverts[0]], axis=1))]
    b = bverts[np.argmax(np.linalg.norm(v[bverts] - v[a], axis=1))]
    pinned = {int(a): (0.0, 0.0), int(b): (float(np.linalg.norm(v[b] - v[a])), 0.0)}
    free = np.ones(n, bool)
    free[[a, b]] = False
    col = np.full(n, -1, np.int64)
    col[free] = np.arange(free.sum())
    nf = int(free.sum())
    # rows: real and imaginary parts of sum_j W_j U_j, unknowns (u_free, v_free)
    rows, cols, vals = [], [], []
    rhs = np.zeros(2 * m)
    for j in range(3):
        vj = t[:, j]
        f = free[vj]
        r = np.arange(m)[f]
        c = col[vj[f]]
        # Re: wr u - wi v ; Im: wi u + wr v
        rows += [r, r, m + r, m + r]
        cols += [c, nf + c, c, nf + c]
        vals += [wr[f, j], -wi[f, j], wi[f, j], wr[f, j]]
        for k, (pu, pv) in pinned.items():
            hit = vj == k
            rhs[np.flatnonzero(hit)] -= wr[hit, j] * pu - wi[hit, j] * pv
            rhs[m + np.flatnonzero(hit)] -= wi[hit, j] * pu + wr[hit, j] * pv
    a_mat = sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(2 * m, 2 * nf))
    x = spsolve((a_mat.T @ a_mat).tocsc(), a_mat.T @ rhs)
    uv = np.zeros((n, 2))
    uv[free, 0], uv[free, 1] = x[:nf], x[nf:]
    for k, (pu, pv) in pinned.items():
        uv[k] = (pu, pv)
    if signed_areas(uv, t).sum() < 0:
        uv[:, 1] = -uv[:, 1]
    return uv


def _is_disk(mesh: TerrainMesh) -> bool:
    """One boundary loop and Euler characteristic 1."""
    e = mesh_edges(mesh.triangles)
    boundary = e.edges[e.faces[:, 1] < 0]
    return count_loops(boundary, mesh.n_vertices) == 1 and mesh.n_vertices - len(e.edges) + mesh.n_triangles == 1


def count_loops(boundary: np.ndarray, n: int) -> int:
    """Connected sets of the boundary edges (B, 2) of a mesh of ``n`` vertices: its border loops."""
    if len(boundary) == 0:
        return 0
    from scipy.sparse.csgraph import connected_components

    g = sparse.coo_matrix((np.ones(len(boundary)), (boundary[:, 0], boundary[:, 1])), shape=(n, n))
    _, label = connected_components(g, directed=False)
    return len(np.unique(label[np.unique(boundary)]))


def offset(mesh: TerrainMesh) -> np.ndarray:
    """The x-y origin of the x-y parameter space (the mean of the vertices, for well-conditioned numbers)."""
    return mesh.vertices[:, :2].astype(np.float64).mean(axis=0)


def signed_areas(uv: np.ndarray, t: np.ndarray) -> np.ndarray:
    a, b, c = uv[t[:, 0]], uv[t[:, 1]], uv[t[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))


def parameterise(mesh: TerrainMesh, parameterization: str) -> tuple:
    """(uv, the name of the map used) for ``parameterization`` "auto", "xy" or "conformal".

    A mesh that is not a disk cannot take one conformal map: it gets
    ``(None, "charts")``, and the remesher cuts it (:mod:`.charts`).
    """
    if parameterization == "auto":  # terrain: every triangle faces up, and the surface is not much steeper than that
        flat = signed_areas(mesh.vertices[:, :2], mesh.triangles)
        v, t = mesh.vertices, mesh.triangles
        area = np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1).sum() / 2
        faces_up = bool((flat > 0).all())
        terrain = faces_up and (area <= AUTO_XY_STRETCH * flat.sum() or not _is_disk(mesh))
        parameterization = "xy" if terrain else "conformal"
    if parameterization == "xy":
        uv = mesh.vertices[:, :2].astype(np.float64)
        areas = signed_areas(uv, mesh.triangles)
        if (areas <= 0).any():
            raise InvalidInputError(
                f"{int((areas <= 0).sum())} triangles do not face up in x-y: not a terrain; use parameterization='conformal'"
            )
        return uv - offset(mesh), "xy"
    if not _is_disk(mesh):  # a closed or higher-genus surface, or one with holes: one map per chart
        return None, "charts"
    return lscm(mesh), "conformal"
