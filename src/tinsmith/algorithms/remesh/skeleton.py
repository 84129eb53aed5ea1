"""The feature skeleton of a triangle mesh: feature edges chained into backbones, and corners (Alliez et al. 2003, section 2).

Feature edges are of two kinds here: **boundary** edges (used by one
triangle) and **sharp** edges, whose two triangles' normals differ by more
than ``feature_angle`` degrees (dihedral angle thresholding).  As Botsch and
Kobbelt (2004) and the paper, incident feature edges are chained into
*backbones*: maximal chains whose inner vertices have exactly two feature
edges and do not turn by more than ``feature_angle`` there.  The other
vertices of the chains are **corners**: ends of open chains, meetings of
three or more feature edges, and sharp turns.  A closed chain without a
corner is a closed backbone (a smooth boundary loop).

The remesher keeps every corner, samples the backbones along their length
(1-D) and the rest of the surface in 2-D.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ... import _checks
from ...core import TerrainMesh
from ...errors import InvalidMeshError, require

__all__ = ["Breaklines", "FeatureSkeleton", "drop_short_sharp", "feature_skeleton", "mesh_edges"]


@dataclass
class MeshEdges:
    """The undirected edges of a manifold mesh: ``edges`` (E, 2) smaller index first, ``faces`` (E, 2) the
    triangles on either side (-1 on a boundary), ``of_triangle`` (M, 3) the edge opposite each corner."""

    edges: np.ndarray
    faces: np.ndarray
    of_triangle: np.ndarray


def mesh_edges(triangles: np.ndarray) -> MeshEdges:
    """Edges and triangle adjacency; refuses edges with more than two triangles and inconsistent orientation."""
    t = np.asarray(triangles, dtype=np.int64)
    m = len(t)
    # the edge opposite corner c runs from corner c+1 to corner c+2 (in the triangle's winding)
    a = np.concatenate([t[:, 1], t[:, 2], t[:, 0]])
    b = np.concatenate([t[:, 2], t[:, 0], t[:, 1]])
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * (int(t.max()) + 1 if m else 1) + hi
    edges_key, first, inverse, counts = np.unique(key, return_index=True, return_inverse=True, return_counts=True)
    if (counts > 2).any():
        raise InvalidMeshError(f"the mesh is not manifold: {int((counts > 2).sum())} edges have more than two triangles")
    edges = np.column_stack([lo[first], hi[first]])
    owner = np.tile(np.arange(m), 3)
    order = np.argsort(inverse, kind="stable")
    faces = np.full((len(edges), 2), -1, dtype=np.int64)
    slot = np.zeros(len(key), dtype=np.int64)
    sorted_inv = inverse[order]
    slot[order[1:]] = (sorted_inv[1:] == sorted_inv[:-1]).astype(np.int64)
    faces[inverse, slot] = owner
    # two triangles must traverse a shared edge in opposite directions
    shared = counts == 2
    forward = np.zeros(len(edges), dtype=np.int64)
    np.add.at(forward, inverse, (a < b).astype(np.int64))
    if (forward[shared] != 1).any():
        raise InvalidMeshError(
            f"the mesh is not consistently oriented: {int((forward[shared] != 1).sum())} edges are traversed the same "
            "way by both their triangles"
        )
    return MeshEdges(edges, faces, inverse.reshape(3, m).T.copy())


@dataclass
class FeatureSkeleton:
    """Backbones (each an array of indices into ``points`` along the chain; closed ones repeat their first
    index at the end) and corners (indices) of a mesh; ``kind`` of each backbone: "boundary", "sharp",
    "breakline" or "cut" (a border between two charts, :mod:`.charts`)."""

    backbones: list
    closed: list
    kind: list
    corners: np.ndarray
    feature_edges: np.ndarray  #: (F, 2) the edges the backbones are made of
    feature_kind: np.ndarray  #: (F,) 0 boundary, 1 sharp, 2 breakline, 3 cut
    cos_limit: float  #: cosine of the feature angle
    points: np.ndarray  #: (N + P, 3) what the backbones index: the mesh's vertices, then breakline points

    def weighted_lengths(self, vertices: np.ndarray, weight: np.ndarray) -> list:
        """The integral of ``weight`` (per vertex, linear along edges) over each backbone."""
        return [float((np.linalg.norm(np.diff(vertices[b], axis=0), axis=1) * 0.5 * (weight[b[:-1]] + weight[b[1:]])).sum())
                for b in self.backbones]

    def length(self, vertices: np.ndarray) -> float:
        """Total length of the backbones (3-D)."""
        return float(sum(np.linalg.norm(np.diff(vertices[b], axis=0), axis=1).sum() for b in self.backbones))


_KINDS = ("boundary", "sharp", "breakline", "cut")


def _face_normals(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    length = np.linalg.norm(n, axis=1)
    return n / np.where(length > 0, length, 1.0)[:, None]


@dataclass
class Breaklines:
    """User breaklines as extra chain vertices: ``points`` (P, 3) on the surface, ``segments`` (S, 2) indexing
    the mesh's vertices followed by these points (so ``n_mesh + i`` is ``points[i]``)."""

    points: np.ndarray
    segments: np.ndarray
    triangle: np.ndarray  #: (P,) the mesh triangle under each point
    bary: np.ndarray  #: (P, 3) its barycentric coordinates there


def feature_skeleton(mesh: TerrainMesh, *, feature_angle: float = 60.0, edges: MeshEdges | None = None,
                     breaklines: Breaklines | None = None, cuts: np.ndarray | None = None) -> FeatureSkeleton:
    """The boundary and sharp edges of ``mesh`` chained into backbones, with the corners (module docstring).

    ``feature_angle`` (degrees, 0 to 180): an interior edge is sharp when its
    triangles' normals differ by more; a chain turns at a corner when its
    direction changes by more.  180 keeps the boundary only.  ``breaklines``
    become backbones too; a sharp edge that crosses one in x-y is dropped (the
    user's line wins).  The skeleton's ``points`` are the mesh's vertices
    followed by the breakline points.  ``cuts`` (C, 2), interior edges of the
    mesh, become backbones of kind "cut" (a sharp edge among them stays
    sharp); a cut turns without a corner unless it doubles back.
    """
    feature_angle = _checks.number("feature_angle", feature_angle, minimum=0.0, maximum=180.0)
    v, t = mesh.vertices, mesh.triangles
    e = edges if edges is not None else mesh_edges(t)
    boundary = e.faces[:, 1] < 0
    cos_limit = np.cos(np.radians(feature_angle))
    normals = _face_normals(v, t)
    inner = ~boundary
    cos = np.ones(len(e.edges))
    cos[inner] = np.einsum("ij,ij->i", normals[e.faces[inner, 0]], normals[e.faces[inner, 1]])
    sharp = inner & (cos < cos_limit) if feature_angle < 180.0 else np.zeros(len(e.edges), bool)
    if breaklines is not None and len(breaklines.segments) and sharp.any():
        sharp &= ~_crosses(v, e.edges, sharp, np.concatenate([v, breaklines.points]), breaklines.segments)
    cut = np.zeros(len(e.edges), bool)
    if cuts is not None and len(cuts):
        n = len(v)
        keys = np.sort(np.asarray(cuts, np.int64), axis=1) @ np.array([n, 1])
        cut = np.isin(e.edges @ np.array([n, 1]), keys) & ~boundary
    is_feature = boundary | sharp | cut
    fe, kind = e.edges[is_feature], np.where(boundary[is_feature], 0, np.where(sharp[is_feature], 1, 3))
    if breaklines is not None and len(breaklines.segments):
        v = np.concatenate([v, breaklines.points])
        fe = np.concatenate([fe, np.sort(breaklines.segments, axis=1)])
        kind = np.concatenate([kind, np.full(len(breaklines.segments), 2)])
    return _chain(v, fe, kind, cos_limit)


def _crosses(v, edges, which, points, segments) -> np.ndarray:
    """(E,) bool: the edges among ``which`` whose x-y segment meets one of ``segments`` (of ``points``)."""
    shapely = require("shapely", "vector", "breaklines")

    ids = np.flatnonzero(which)
    mine = shapely.linestrings(np.stack([v[edges[ids, 0], :2], v[edges[ids, 1], :2]], axis=1))
    lines = shapely.linestrings(np.stack([points[segments[:, 0], :2], points[segments[:, 1], :2]], axis=1))
    hit = np.unique(shapely.STRtree(lines).query(mine, predicate="intersects")[0])
    out = np.zeros(len(edges), bool)
    out[ids[hit]] = True
    return out


def drop_short_sharp(skeleton: FeatureSkeleton, min_length: float, keep: np.ndarray | None = None) -> FeatureSkeleton:
    """The skeleton without its sharp backbones shorter than ``min_length`` (features finer than the sampling
    can hold: they would only leave slivers); corners are found again.  Boundary backbones always stay, and so
    do the sharp backbones with an edge among ``keep`` (K, 2) (a chart's border)."""
    vertices = skeleton.points
    n = len(vertices)
    kept = set() if keep is None or not len(keep) else set((np.sort(keep, axis=1) @ np.array([n, 1])).tolist())

    def held(b):
        return bool(kept) and not kept.isdisjoint((np.sort(np.column_stack([b[:-1], b[1:]]), axis=1)
                                                   @ np.array([n, 1])).tolist())

    short = [b for b, k in zip(skeleton.backbones, skeleton.kind, strict=True)
             if k == "sharp" and np.linalg.norm(np.diff(vertices[b], axis=0), axis=1).sum() < min_length
             and not held(b)]
    if not short:
        return skeleton
    gone = np.unique(np.sort(np.concatenate([np.column_stack([b[:-1], b[1:]]) for b in short]), axis=1), axis=0)
    fe = skeleton.feature_edges
    n = int(max(fe.max(), gone.max())) + 1
    keep = ~np.isin(fe[:, 0] * n + fe[:, 1], gone[:, 0] * n + gone[:, 1])
    return _chain(vertices, fe[keep], skeleton.feature_kind[keep], skeleton.cos_limit)


def _chain(v: np.ndarray, fe: np.ndarray, kind_of: np.ndarray, cos_limit: float) -> FeatureSkeleton:
    """Backbones and corners of the feature edges ``fe`` (kinds as :attr:`FeatureSkeleton.feature_kind`)."""
    n = len(v)
    degree = np.bincount(fe.ravel(), minlength=n)
    # adjacency of the feature graph: for every vertex, its feature edges (CSR)
    ends = np.concatenate([fe[:, 0], fe[:, 1]])
    other = np.concatenate([fe[:, 1], fe[:, 0]])
    edge_id = np.concatenate([np.arange(len(fe)), np.arange(len(fe))])
    order = np.argsort(ends, kind="stable")
    start = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(ends, minlength=n), out=start[1:])
    nb, nb_edge = other[order], edge_id[order]

    corner = (degree > 0) & (degree != 2)
    two = np.flatnonzero(degree == 2)
    if len(two):  # a turn sharper than the feature angle, or where a boundary meets a sharp edge
        p, q = nb[start[two]], nb[start[two] + 1]
        d1 = v[two] - v[p]
        d2 = v[q] - v[two]
        l1, l2 = np.linalg.norm(d1, axis=1), np.linalg.norm(d2, axis=1)
        c = np.einsum("ij,ij->i", d1, d2) / np.maximum(l1 * l2, 1e-300)
        kind_a, kind_b = kind_of[nb_edge[start[two]]], kind_of[nb_edge[start[two] + 1]]
        mixed = kind_a != kind_b
        turns = (c < cos_limit) & (kind_a != 3)  # a cut zigzags along the edges: its turns are no corners
        corner[two[turns | mixed]] = True
    used = np.zeros(len(fe), bool)
    backbones, closed, kinds = [], [], []

    def walk(first_vertex, first_edge):
        chain = [first_vertex]
        vertex, edge = first_vertex, first_edge
        while True:
            used[edge] = True
            a, b = fe[edge]
            vertex = b if a == vertex else a
            chain.append(vertex)
            if corner[vertex] or vertex == first_vertex:
                return np.array(chain, dtype=np.int64)
            lo_, hi_ = start[vertex], start[vertex + 1]
            nxt = [nb_edge[k] for k in range(lo_, hi_) if not used[nb_edge[k]]]
            if not nxt:
                return np.array(chain, dtype=np.int64)
            edge = nxt[0]

    for c_vertex in np.flatnonzero(corner):  # open backbones start and end at corners
        for k in range(start[c_vertex], start[c_vertex + 1]):
            if not used[nb_edge[k]]:
                chain = walk(c_vertex, nb_edge[k])
                backbones.append(chain)
                closed.append(bool(chain[0] == chain[-1]))
                kinds.append(_KINDS[kind_of[nb_edge[k]]])
    for k in np.flatnonzero(~used):  # what is left: loops without a corner
        if used[k]:
            continue
        chain = walk(fe[k, 0], k)
        backbones.append(chain)
        closed.append(True)
        kinds.append(_KINDS[kind_of[k]])
    return FeatureSkeleton(backbones, closed, kinds, np.flatnonzero(corner), fe, kind_of, cos_limit, v)
