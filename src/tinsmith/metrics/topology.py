"""Checks on the connectivity of a mesh: the Delaunay property of its x-y projection, a 3-D surface's manifold edges."""

from __future__ import annotations

from itertools import pairwise
from math import gcd

import numpy as np

from ..core import TerrainMesh
from ..kernels._jit import jit
from ..kernels.intersect import intersecting_pairs
from ..kernels.predicates import incircle
from ..kernels.raster import sample_triangles
from ..triangulation.edges import border_edges, edge_twins
from ..triangulation.outline import boundary_edges

__all__ = [
    "border_edges", "border_loops", "non_delaunay_edges", "point_seam_defects", "seam_coverage", "seam_defects",
    "self_intersections", "surface_problems",
]


def surface_problems(mesh: TerrainMesh) -> dict:
    """The rules a 3-D surface (vertical walls allowed) breaks, with the count of its border edges.

    Returns ``{"degenerate": triangles of zero area in 3-D, "duplicate":
    triangles repeating another, "overused": edges of more than two
    triangles, "misoriented": edges two triangles walk the same way (their
    orientations disagree), "border": edges of one triangle}``; a valid
    surface has zeros everywhere but ``border``.
    """
    v, t = mesh.vertices, mesh.triangles
    area2 = np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    undirected, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    _, same_way = np.unique(directed, axis=0, return_counts=True)
    return {
        "degenerate": int(np.count_nonzero(area2 == 0.0)),
        "duplicate": int(len(t) - len(np.unique(np.sort(t, axis=1), axis=0))),
        "overused": int(np.count_nonzero(counts > 2)),
        "misoriented": int(np.count_nonzero(same_way > 1)),
        "border": int(np.count_nonzero(counts == 1)),
    }


def border_loops(triangles: np.ndarray, n_vertices: int) -> int:
    """Number of border loops (connected sets of border edges; 0 for a closed surface)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    border = border_edges(triangles, n_vertices)
    if not len(border):
        return 0
    graph = coo_matrix((np.ones(len(border)), (border[:, 0], border[:, 1])), shape=(n_vertices, n_vertices))
    _, label = connected_components(graph, directed=False)
    return len(np.unique(label[np.unique(border)]))


def self_intersections(mesh: TerrainMesh) -> int:
    """Pairs of triangles with no common vertex that cut each other in 3-D (coplanar overlaps not counted).

    Candidate pairs come from a grid of twice the median edge length
    (:func:`tinsmith.kernels.intersect.intersecting_pairs`); 0 for a mesh
    without self-intersections.
    """
    if mesh.n_triangles < 2:
        return 0
    v = np.ascontiguousarray(mesh.vertices - mesh.vertices.mean(axis=0))
    t = np.ascontiguousarray(mesh.triangles, dtype=np.int64)
    edges = np.linalg.norm(v[t[:, [1, 2, 0]]] - v[t], axis=2)
    cell = 2.0 * float(np.median(edges))
    if cell <= 0.0:
        cell = 1.0
    return int(intersecting_pairs(v, t, cell))


@jit
def _violations(x, y, tri, pairs):
    out = np.zeros(len(pairs), dtype=np.bool_)
    for k in range(len(pairs)):
        ta, ea, tb, eb = pairs[k, 0], pairs[k, 1], pairs[k, 2], pairs[k, 3]
        a0 = tri[ta, ea]
        a1 = tri[ta, (ea + 1) % 3]
        a2 = tri[ta, (ea + 2) % 3]  # opposite the shared edge in ta
        b2 = tri[tb, (eb + 2) % 3]  # opposite the shared edge in tb
        out[k] = incircle(x[a0], y[a0], x[a1], y[a1], x[a2], y[a2], x[b2], y[b2]) > 0.0
    return out


def non_delaunay_edges(mesh: TerrainMesh, constrained=None) -> np.ndarray:
    """Interior edges whose flip would make the x-y triangulation more Delaunay.

    An edge shared by two triangles is *not locally Delaunay* when the vertex
    of one triangle opposite it lies strictly inside the circumcircle of the
    other (robust in-circle test, so cocircular cases do not count).

    Parameters
    ----------
    mesh : TerrainMesh
        Counter-clockwise triangles.
    constrained : (K, 2) array_like of int, optional
        Vertex pairs of constrained edges, which are exempt.

    Returns
    -------
    (E, 2) ndarray of int
        The offending edges (smaller vertex index first); empty for a
        Delaunay triangulation.

    Examples
    --------
    >>> import tinsmith
    >>> kite = [[0, 0, 0], [2, -1, 0], [4, 0, 0], [2, 1, 0]]
    >>> long_diagonal = tinsmith.TerrainMesh(kite, [[0, 1, 2], [0, 2, 3]])
    >>> tinsmith.non_delaunay_edges(long_diagonal).tolist()  # vertex 3 lies in the circle of 0, 1, 2
    [[0, 2]]
    >>> tinsmith.non_delaunay_edges(long_diagonal, constrained=[[0, 2]]).tolist()  # unless it is constrained
    []
    """
    t = mesh.triangles
    base = mesh.n_vertices + 1
    first, second, key = edge_twins(t, mesh.n_vertices)
    pairs = np.column_stack([first // 3, first % 3, second // 3, second % 3]).astype(np.int64)
    if len(t) == 0 or len(pairs) == 0:
        return np.empty((0, 2), dtype=np.int64)
    bad = _violations(mesh.vertices[:, 0].copy(), mesh.vertices[:, 1].copy(), t, pairs)
    edges = np.column_stack([key[bad] // base, key[bad] % base])
    if constrained is not None and len(edges):
        c = np.sort(np.asarray(constrained, dtype=np.int64).reshape(-1, 2), axis=1)
        exempt = np.isin(edges[:, 0] * (mesh.n_vertices + 1) + edges[:, 1], c[:, 0] * (mesh.n_vertices + 1) + c[:, 1])
        edges = edges[~exempt]
    return edges


def seam_defects(mesh: TerrainMesh, hf) -> dict:
    """T-junctions and cracks of a mesh whose vertices are cells of the heightfield ``hf`` (tiled runs).

    A T-junction is a vertex inside a border edge (an edge of one triangle
    only); a crack is a border edge that does not run along the outline of
    the data (:mod:`tinsmith.triangulation.outline`): both can only come from
    pieces that do not join.  Returns ``{"t_junctions", "cracks",
    "border_edges", "overused_edges", "t_junction_vertices"}`` (the last: the
    indices of the vertices that sit inside a border edge).
    """
    r, c = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    rc = np.column_stack([np.rint(r), np.rint(c)]).astype(np.int64)
    W = hf.shape[1]
    t = mesh.triangles
    edges, counts = np.unique(np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1),
                              axis=0, return_counts=True)
    outline = {(min((a, b), (c_, d)), max((a, b), (c_, d))) for a, b, c_, d in boundary_edges(hf.valid).tolist()}
    cells = dict(zip((rc[:, 0] * W + rc[:, 1]).tolist(), range(len(rc)), strict=True))
    inside, cracks = [], 0
    border = edges[counts == 1]
    for i, j in border.tolist():
        (r0, c0), (r1, c1) = rc[i].tolist(), rc[j].tolist()
        g = gcd(abs(r1 - r0), abs(c1 - c0))
        steps = [(r0 + k * (r1 - r0) // g, c0 + k * (c1 - c0) // g) for k in range(g + 1)]
        inside += [cells[p[0] * W + p[1]] for p in steps[1:-1] if p[0] * W + p[1] in cells]
        cracks += any((min(p, q), max(p, q)) not in outline for p, q in pairwise(steps))
    return {"t_junctions": len(inside), "cracks": cracks, "border_edges": len(border),
            "overused_edges": int((counts > 2).sum()), "t_junction_vertices": np.array(inside, np.int64)}


def point_seam_defects(mesh: TerrainMesh, seams: np.ndarray) -> dict:
    """T-junctions and cracks along the seams of a tiled point-cloud run (:func:`tinsmith.tiles.tile_cloud`).

    ``seams`` is ``TiledPointRun.seam_segments()``: (S, 5) rows ``x0, y0, x1,
    y1, covered`` of segments on vertical (x0 == x1) or horizontal seam lines.
    On every seam line, a T-junction is a mesh vertex strictly inside a border
    edge (an edge of one triangle) lying on that line, and a crack is a border
    edge on a stretch the points' TIN covers (a covered segment), where
    triangles should meet from both sides.  Returns ``{"t_junctions",
    "cracks", "seam_border_edges", "overused_edges"}``.
    """
    v, t = mesh.vertices, mesh.triangles
    edges, counts = np.unique(np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1),
                              axis=0, return_counts=True)
    border = edges[counts == 1]
    seams = np.asarray(seams, np.float64).reshape(-1, 5)
    t_junctions = cracks = on_seams = 0
    for axis in (0, 1):  # 0: vertical lines x = const, 1: horizontal y = const
        lines = seams[seams[:, axis] == seams[:, axis + 2]]
        for at in np.unique(lines[:, axis]).tolist():
            segs = lines[lines[:, axis] == at]
            lo = np.minimum(segs[:, 1 - axis], segs[:, 3 - axis])
            hi = np.maximum(segs[:, 1 - axis], segs[:, 3 - axis])
            cov = segs[:, 4] > 0
            on = v[:, axis] == at
            e = border[on[border[:, 0]] & on[border[:, 1]]]
            on_seams += len(e)
            if not len(e):
                continue
            a = np.minimum(v[e[:, 0], 1 - axis], v[e[:, 1], 1 - axis])
            b = np.maximum(v[e[:, 0], 1 - axis], v[e[:, 1], 1 - axis])
            pos = np.sort(v[on, 1 - axis])
            t_junctions += int((np.searchsorted(pos, b, "left") - np.searchsorted(pos, a, "right")).sum())
            inside = (a[:, None] >= lo[None, cov]) & (b[:, None] <= hi[None, cov])
            cracks += int(inside.any(axis=1).sum())
    return {"t_junctions": t_junctions, "cracks": cracks, "seam_border_edges": on_seams,
            "overused_edges": int((counts > 2).sum())}


def seam_coverage(mesh: TerrainMesh, reference: TerrainMesh, lines, step: float) -> dict:
    """Where a reference mesh covers the seam lines of a tiled run and the run's mesh does not.

    ``lines`` are ``(axis, at, lo, hi)``: the line ``x = at`` (axis 0) or
    ``y = at`` (axis 1) from ``lo`` to ``hi`` along the other axis
    (``TiledPointRun.seam_lines()``).  Positions every ``step`` along each
    line, and a hundredth of a step to either side of it, are tested against
    both meshes: a crack between tiles (a stretch where no seam joins them)
    shows as positions the reference covers and the mesh misses.  Returns
    ``{"samples", "reference_covered", "missed", "extra"}`` (``extra``: covered
    by the mesh only).
    """
    q = []
    for axis, at, lo, hi in lines:
        s = np.arange(lo + step / 2, hi, step)
        for off in (-step / 100, 0.0, step / 100):
            fixed = np.full(len(s), at + off)
            q.append(np.column_stack([fixed, s] if axis == 0 else [s, fixed]))
    q = np.concatenate(q) if q else np.empty((0, 2))

    def covered(m: TerrainMesh) -> np.ndarray:
        v = m.vertices
        z = sample_triangles(v[:, 0].copy(), v[:, 1].copy(), v[:, 2].copy(), m.triangles, q[:, 0].copy(), q[:, 1].copy())
        return ~np.isnan(z)

    ours, ref = covered(mesh), covered(reference)
    return {"samples": int(len(q)), "reference_covered": int(ref.sum()), "missed": int((ref & ~ours).sum()),
            "extra": int((ours & ~ref).sum())}
