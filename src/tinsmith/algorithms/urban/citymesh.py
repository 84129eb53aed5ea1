"""One mesh of a city: the terrain with every building welded into it, open or closed into a CFD-ready solid.

The footprints (non-overlapping polygons) and the domain's outline are
noded into one planar straight-line graph, with the ground's points
(greedy insertion on the ground, kept clear of the footprints) and the
roofs' points inside; its constrained Delaunay triangulation
(:func:`tinsmith.triangulation.delaunay.delaunay`) is the plan of the mesh.
Every triangle belongs to one face: the ground, or the roof of the
footprint that holds it.  Then, as in the block model of the Salt Lake City thesis
(:mod:`tinsmith.algorithms.urban.blocks`):

- each face's triangles get its heights: the ground at the ground's
  height, a roof at the roof's (flat, or its planes);
- every edge between two faces of different heights gets a vertical wall
  between them, split at every height another face brings to its ends, so
  that walls meeting at a vertical line share its vertices; a wall faces
  the lower side;
- with ``solid=True`` the outline of the domain gets vertical sides down
  to the ``base`` height and a bottom closes it: the mesh is a closed,
  consistently oriented volume (every edge in exactly two triangles,
  normals out), what snappyHexMesh, cfMesh or Fluent's wrapper expect.

Where two buildings' roofs cross along their common wall (planar roofs),
the wall is split where they cross, so it is never twisted.
``mesh.triangle_attributes["patch"]`` says what each triangle is (0 ground,
1 roof, 2 wall, 3 side, 4 bottom; names in ``mesh.labels["patch"]``)
and ``mesh.triangle_attributes["building"]`` which building (-1 for none).
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from ...core import TerrainMesh
from ...errors import require
from ...triangulation.delaunay import delaunay
from .blocks import KINDS, wall_triangles

__all__ = ["PATCHES", "city_mesh", "with_vertices"]

#: Names of the patches of a city mesh, by ``triangle_attributes["patch"]``.
PATCHES = ("ground", "buildings", "walls", "sides", "bottom")


def _segments(shapely, lines) -> np.ndarray:
    """(S, 2, 2) the segments of the noded union of ``lines``."""
    noded = shapely.union_all(lines)
    parts = shapely.get_parts(noded)
    segs = []
    for part in parts:
        c = shapely.get_coordinates(part)
        if len(c) >= 2:
            segs.append(np.stack([c[:-1], c[1:]], axis=1))
    segs = np.concatenate(segs) if segs else np.empty((0, 2, 2))
    return segs[np.any(segs[:, 0] != segs[:, 1], axis=1)]


def _plan(shapely, footprints, domain, extra: np.ndarray):
    """Points, constrained Delaunay triangles, and each triangle's face (-1 ground, else footprint index)."""
    lines = [domain.exterior] + [r for p in footprints for r in [p.exterior, *p.interiors]]
    segs = _segments(shapely, lines)
    ends = segs.reshape(-1, 2)
    pts, inverse = np.unique(np.concatenate([ends, extra]), axis=0, return_inverse=True)
    inverse = inverse.ravel()
    edges = inverse[:len(ends)].reshape(-1, 2)
    edges = edges[edges[:, 0] != edges[:, 1]]
    cdt = delaunay(pts, constraints=edges)
    tri = cdt.triangles
    centre = pts[tri].mean(axis=1)
    face = np.full(len(tri), -1, np.int64)
    if footprints:
        tree = shapely.STRtree(footprints)
        t_idx, f_idx = tree.query(shapely.points(centre), predicate="within")
        face[t_idx] = f_idx
    inside = shapely.contains_xy(domain, centre[:, 0], centre[:, 1]) | (face >= 0)
    return pts, tri[inside], face[inside]


def _edges(tri: np.ndarray):
    """Edges (p, q) and the triangles on their left and right (-1 for none; a border edge has its triangle on the left)."""
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    owner = np.tile(np.arange(len(tri)), 3)
    key = np.sort(directed, axis=1)
    uniq, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    sides = np.full((len(uniq), 2), -1, np.int64)
    # the triangle in which the edge runs from the smaller to the larger index goes first (it lies on the left)
    forward = directed[:, 0] == key[:, 0]
    sides[inv[forward], 0] = owner[forward]
    sides[inv[~forward], 1] = owner[~forward]
    flip = sides[:, 0] < 0  # a border edge whose triangle runs it the other way: turn it round
    uniq[flip] = uniq[flip][:, ::-1]
    sides[flip] = sides[flip][:, ::-1]
    return uniq, sides


def city_mesh(footprints, domain, ground_height, roof_height, *, ground_points=None, roof_points=None,
              solid: bool = False, base: float | None = None, crs=None, pinch_size: float = 0.0,
              max_rounds: int = 8) -> tuple[TerrainMesh, list]:
    """The mesh of the module docstring, and the footprints it was made of (pinches repaired).

    Parameters
    ----------
    footprints : list of shapely Polygon
        Valid, non-overlapping (they may share edges), inside ``domain``.
    domain : shapely Polygon
        The outline of the mesh (convex: a box).
    ground_height : callable (x, y) -> z
        The ground, vectorised.
    roof_height : callable (b, x, y) -> z
        The roof of footprint ``b`` at the points (x, y), vectorised; held at least a little above the ground.
    ground_points, roof_points : (K, 2) arrays, optional
        More points of the ground and of the roofs (their face is found from the footprints).
    solid : bool
        Close the mesh with sides down to ``base`` and a bottom.
    base : float
        The bottom's height (needed with ``solid``).
    pinch_size : float
        Where faces meet at a point only (two buildings touching at a corner, a ring touching itself),
        the highest building there takes a square of this half-width around the point, so that every edge of
        the mesh has two triangles (world units; 0 leaves pinches).
    """
    shapely = require("shapely", "vector", "city meshes")
    extra = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in (ground_points, roof_points) if p is not None]
    extra = np.concatenate(extra) if extra else np.empty((0, 2))
    footprints = list(footprints)
    pinned: dict = {}  # crossing points: the height where the two roofs' edges meet, for both
    for _ in range(max_rounds):
        pts, tri, face = _plan(shapely, footprints, domain, extra)
        heights = _face_heights(pts, tri, face, ground_height, roof_height, pinned)
        edges, sides = _edges(tri)
        crossings = _crossings(pts, tri, edges, sides, face, heights)
        pinches = _pinches(pts, tri, face, heights, edges, sides, base if solid else None) if pinch_size > 0 else []
        if len(crossings) == 0 and not pinches:
            break
        pinned.update((tuple(xy), z) for xy, z in zip(crossings[:, :2].tolist(), crossings[:, 2].tolist(), strict=True))
        footprints = with_vertices(shapely, footprints, crossings[:, :2])
        footprints = _unpinch(shapely, footprints, pts, pinches, pinch_size, domain)
    else:  # pragma: no cover - would need a pinch or a crossing on every round
        raise RuntimeError("the city mesh still has pinched points or crossing roofs after repair")
    return _assemble(pts, tri, face, heights, edges, sides, solid, base, crs), footprints


def _face_heights(pts, tri, face, ground_height, roof_height, pinned=None) -> dict:
    """{(point, face): height} for every corner of every triangle; -1 is the ground; ``pinned`` {(x, y): z} overrides."""
    g = np.asarray(ground_height(pts[:, 0], pts[:, 1]), dtype=np.float64)
    out = {}
    corners = np.unique(np.column_stack([tri.ravel(), np.repeat(face, 3)]), axis=0)
    for f in np.unique(corners[:, 1]):
        at = corners[corners[:, 1] == f, 0]
        z = g[at] if f < 0 else np.asarray(roof_height(int(f), pts[at, 0], pts[at, 1]), dtype=np.float64)
        out.update(zip(zip(at.tolist(), [int(f)] * len(at), strict=True), z.tolist(), strict=True))
    if pinned:
        index = {xy: i for i, xy in enumerate(map(tuple, pts.tolist()))}
        at = {index[xy]: z for xy, z in pinned.items() if xy in index}
        for (p, f) in list(out):
            if p in at:
                out[p, f] = at[p]
    return out


def _crossings(pts, tri, edges, sides, face, heights) -> np.ndarray:
    """(K, 3) points (x, y, z) where two roofs' edges cross along the edge between them."""
    out = []
    for (p, q), (t1, t2) in zip(edges.tolist(), sides.tolist(), strict=True):
        if t1 < 0 or t2 < 0:
            continue
        f1, f2 = int(face[t1]), int(face[t2])
        if f1 == f2:
            continue
        dp = heights[p, f1] - heights[p, f2]
        dq = heights[q, f1] - heights[q, f2]
        if dp * dq < 0:
            t = dp / (dp - dq)
            z = heights[p, f1] + t * (heights[q, f1] - heights[p, f1])
            out.append([*(pts[p] + t * (pts[q] - pts[p])), z])
    return np.array(out).reshape(-1, 3)


def _pinches(pts, tri, face, heights, edges, sides, base) -> list:
    """[(point, highest building there)] where the faces around a point cross some height more than twice."""
    around: dict = {}
    for t, (a, b, c) in enumerate(tri.tolist()):
        for p in (a, b, c):
            around.setdefault(p, []).append(t)
    on_border = set(edges[sides[:, 1] < 0].ravel().tolist()) if base is not None else set()
    out = []
    for p, ts in around.items():
        faces = {int(face[t]) for t in ts}
        if len(faces) < 2 or faces == {-1}:
            continue
        centre = pts[tri[ts]].mean(axis=1) - pts[p]
        angle = np.arctan2(centre[:, 1], centre[:, 0])
        seq = [heights[p, int(face[t])] for t in np.array(ts)[np.argsort(angle)]]
        if p in on_border:  # the outside, at the base, lies in the widest gap between triangles
            gaps = np.diff(np.r_[np.sort(angle), np.sort(angle)[0] + 2 * np.pi])
            k = int(np.argmax(gaps))
            seq = seq[k + 1:] + seq[:k + 1] + [base]
        levels = sorted(set(seq))
        for lo, hi in pairwise(levels):
            mid = (lo + hi) / 2.0
            above = [z > mid for z in seq]
            if sum(above[i] != above[i - 1] for i in range(len(above))) > 2:
                buildings = [(heights[p, f], f) for f in faces if f >= 0]
                out.append((p, max(buildings)[1]))
                break
    return out


def with_vertices(shapely, footprints, points: np.ndarray) -> list:
    """The footprints with ``points`` (on their edges up to rounding) made vertices of the rings they lie on.

    A point within the tolerance of a ring's vertex moves that vertex onto it; one within the tolerance of a
    segment is inserted there.  (shapely's snap left a point lying exactly on a segment out, so the same
    crossing came back on every round of the repair.)
    """
    if not len(points):
        return footprints
    span = max(float(np.ptp(points)), 1.0)
    tol = 10 * (1e-9 * span + 1e-9 * float(np.abs(points).max()))
    out = []
    for poly in footprints:
        rings = [np.asarray(r.coords)[:, :2] for r in (poly.exterior, *poly.interiors)]
        changed = False
        for i, ring in enumerate(rings):
            for pt in points:
                a, b = ring[:-1], ring[1:]
                ab = b - a
                t = np.clip(((pt - a) * ab).sum(axis=1) / np.maximum((ab * ab).sum(axis=1), 1e-300), 0.0, 1.0)
                dist = np.hypot(*(a + t[:, None] * ab - pt).T)
                k = int(np.argmin(dist))
                if dist[k] > tol:
                    continue
                near = [j for j in (k, k + 1) if np.hypot(*(ring[j] - pt)) <= tol]
                if near:  # a vertex already there: put it exactly on the point
                    if not np.array_equal(ring[near[0]], pt):
                        ring = ring.copy()
                        ring[near[0]] = pt
                        if near[0] in (0, len(ring) - 1):  # the ring's first vertex is also its last
                            ring[0] = ring[-1] = pt
                        changed = True
                    continue
                ring = np.insert(ring, k + 1, pt, axis=0)
                changed = True
            rings[i] = ring
        out.append(shapely.Polygon(rings[0], rings[1:]) if changed else poly)
    return out


def _unpinch(shapely, footprints, pts, pinches, size, domain) -> list:
    """The footprints with a square around each pinched point (inside the domain) given to the highest building there."""
    footprints = list(footprints)
    for p, b in pinches:
        square = shapely.box(*(pts[p] - size), *(pts[p] + size)).intersection(domain)
        grid = shapely.get_precision(footprints[b])
        footprints[b] = _largest(shapely, shapely.set_precision(shapely.union(footprints[b], square), grid))
        for i, other in enumerate(footprints):
            if i != b and other.intersects(square):
                footprints[i] = _largest(shapely, shapely.set_precision(other.difference(footprints[b]), grid))
    return footprints


def _largest(shapely, geom):
    parts = [g for g in shapely.get_parts(geom) if g.geom_type == "Polygon"]
    return max(parts, key=lambda g: g.area) if parts else shapely.Polygon()


def _one_height_each(heights: dict) -> dict:
    """Heights two faces give one point that differ by rounding only (two roof planes evaluated where they meet)
    made one: else the point would be two vertices a hair apart, joined by a wall of zero height."""
    by_point: dict = {}
    for (p, _), z in heights.items():
        by_point.setdefault(p, set()).add(z)
    same: dict = {}
    for p, zs in by_point.items():
        ordered = sorted(zs)
        first = ordered[0]
        for z in ordered:
            if z - first > 1e-9 * max(1.0, abs(z)):
                first = z
            same[p, z] = first
    return {(p, f): same[p, z] for (p, f), z in heights.items()}


def _walls(pts, face, heights, edges, sides, solid, base):
    """The walls along the edges, in edge order, as the arguments of ``_assemble``'s ``wall``: (p, q, low heights at
    p and q, high heights, the face on the high side, the outward direction, the patch).

    A wall stands where the faces on the two sides of an edge have different heights (facing the lower side), and
    on the outline of the domain of a solid (a side down to the base).
    """
    for (p, q), (t1, t2) in zip(edges.tolist(), sides.tolist(), strict=True):
        d = pts[q] - pts[p]
        right = np.array([d[1], -d[0]])  # t1 lies on the left of p -> q
        f1 = int(face[t1])
        z1 = (heights[p, f1], heights[q, f1])
        if t2 < 0:  # the outline of the domain: a side down to the base
            if solid:
                yield p, q, (base, base), z1, f1, right, 3
            continue
        f2 = int(face[t2])
        if f1 == f2:
            continue
        z2 = (heights[p, f2], heights[q, f2])
        if z1 == z2:
            continue
        if z1[0] >= z2[0] and z1[1] >= z2[1]:
            yield p, q, z2, z1, f1, right, 2  # f1 higher: the wall faces f2, on the right
        else:
            yield p, q, z1, z2, f2, -right, 2


def _assemble(pts, tri, face, heights, edges, sides, solid, base, crs) -> TerrainMesh:
    index: dict = {}
    xyz: list = []
    heights = _one_height_each(heights)

    def vertex(p: int, z: float) -> int:
        key = (p, z)
        i = index.get(key)
        if i is None:
            i = index[key] = len(xyz)
            xyz.append((pts[p, 0], pts[p, 1], z))
        return i

    # every height a face brings to each point (and the base on the outline of a solid)
    at_point: dict = {}
    for (p, _), z in heights.items():
        at_point.setdefault(p, set()).add(z)
    border = sides[:, 1] < 0
    if solid:
        for p in np.unique(edges[border]).tolist():
            at_point[p].add(float(base))
    triangles, patch, building = [], [], []
    for t, f in zip(tri.tolist(), face.tolist(), strict=True):
        triangles.append(tuple(vertex(p, heights[p, f]) for p in t))
        patch.append(0 if f < 0 else 1)
        building.append(f)

    def wall(p, q, z_low, z_high, high_face, outward, kind):
        sides_ = []
        for point, lo, hi in ((p, z_low[0], z_high[0]), (q, z_low[1], z_high[1])):
            levels = sorted(h for h in at_point[point] if lo <= h <= hi)
            sides_.append([vertex(point, h) for h in levels])
        made = wall_triangles(sides_[0], sides_[1], xyz, outward)
        triangles.extend(made)
        patch.extend([kind] * len(made))
        building.extend([high_face] * len(made))

    for args in _walls(pts, face, heights, edges, sides, solid, base):
        wall(*args)
    if solid:
        ring = edges[border]
        used, local = np.unique(ring, return_inverse=True)
        cdt = delaunay(pts[used], constraints=local.reshape(-1, 2))
        for t in used[cdt.triangles].tolist():
            triangles.append((vertex(t[0], base), vertex(t[2], base), vertex(t[1], base)))  # clockwise: facing down
            patch.append(4)
            building.append(-1)
    patch = np.array(patch, dtype=np.int64)
    # kind, for the CityJSON writer: 0 ground, 1 roof, 2 wall (sides and bottom are not city objects)
    attributes = {"patch": patch, "building": np.array(building, dtype=np.int64), "kind": np.minimum(patch, 2)}
    return TerrainMesh(np.array(xyz, dtype=np.float64), np.array(triangles, dtype=np.int64).reshape(-1, 3), crs=crs,
                       info={"surface": "3d"}, triangle_attributes=attributes,
                       labels={"patch": dict(enumerate(PATCHES)), "kind": dict(enumerate(KINDS))})
