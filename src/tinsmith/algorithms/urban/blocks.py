"""The block model of a building tree: flat roofs, vertical walls and the ground, as one crack-free surface.

Every square of the grid belongs to the deepest region of the tree that
holds it (:attr:`BuildingTree.owner`); those own-square sets are the faces
of the model (where two squares of a face meet only at a corner, one of
the other two squares joins it, :func:`tinsmith.kernels.contour.fill_pinches`,
so that no two blocks touch along a mere line): the ground (the roots) and one flat roof per building region
at its height.  The outlines of the faces are traced once for all of them
(:func:`tinsmith.kernels.contour.trace`), keeping the corners and every
point where three faces meet, so that neighbouring faces share every
point of their common edge.  Then:

- each face is triangulated by the constrained Delaunay kernel of greedy
  insertion, its outline as constraints, keeping the triangles inside it:
  a roof flat at its height, the ground at the height of the ground model
  at each point (held below the lowest roof it meets there);
- each edge between a roof and a lower face (a lower roof, the ground, or
  the outside of the data) gets a vertical wall from the lower face to the
  roof, split at every height that another face brings to its ends, so that
  walls meeting at a corner share their vertical edges; walls face the
  lower side.

The result has no cracks: every edge is shared by two triangles, except
along the outline of the data (the edge of the ground and the foot of the
walls there).  Roofs and ground face up.  ``mesh.triangle_attributes["face"]``
and ``mesh.triangle_attributes["kind"]`` (0 ground, 1 roof, 2 wall) say what
each triangle is.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from ...core import Heightfield, TerrainMesh
from ...kernels import contour as kc
from ...triangulation.delaunay import delaunay
from ...triangulation.grid import filled
from ...triangulation.outline import signed_area

__all__ = ["KINDS", "block_model", "wall_triangles"]

#: Names of the kinds of triangle of an urban mesh, by ``triangle_attributes["kind"]``.
KINDS = ("ground", "roof", "wall")

#: (dx, dy) of the four directions of :mod:`tinsmith.kernels.contour`.
_STEP = {(1, 0): 0, (0, 1): 1, (-1, 0): 2, (0, -1): 3}


def _left_square(x: int, y: int, d: int) -> tuple[int, int]:
    """The square (row, col) on the left of the unit edge leaving point (x, y) in direction ``d``."""
    return [(y - 1, x), (y, x), (y, x - 1), (y - 1, x - 1)][d]


class _Vertices:
    """Vertices keyed by (grid point, height): shared by every face and wall that meets there."""

    def __init__(self):
        self.index: dict = {}
        self.xyz: list = []

    def __call__(self, x: int, y: int, z: float) -> int:
        key = (x, y, z)
        i = self.index.get(key)
        if i is None:
            i = self.index[key] = len(self.xyz)
            self.xyz.append(key)
        return i


def block_model(hf: Heightfield, tree, ground: Heightfield, *, tolerance: float = 0.0, ground_points=None) -> TerrainMesh:
    """One mesh of the ground and the buildings of ``tree`` (a :class:`BuildingTree` of ``hf``).

    ``ground`` gives the height of the ground faces and of the foot of the
    walls (a DTM, or :func:`tinsmith.algorithms.urban.urban.estimate_ground`);
    where it has no data the surface model's height is used.  With a
    ``tolerance`` (world units) the outlines are simplified first
    (:func:`_simplified`): the staircase of a round or diagonal building
    becomes straight diagonal edges.  ``ground_points`` ((K, 2) grid
    points (col, row), optional) are added inside the ground faces, at the
    height of ``ground``: the caller picks them (greedy insertion on the
    ground) and keeps them off the outlines.  The mesh is a 3-D surface,
    not a 2.5-D TIN: its walls are vertical.
    """
    height = np.array([r.height for r in tree.regions] + [np.nan])
    is_ground = np.array([r.level == 0 for r in tree.regions] + [True])  # index -1: the outside
    owner = tree.owner.copy()
    rank = np.r_[-np.inf, np.where(is_ground[:-1], -np.inf, height[:-1])]  # by face + 1: the outside first
    kc.fill_pinches(owner, rank)
    labels = np.ascontiguousarray((owner + 1).astype(np.int32))
    n_faces = len(tree.regions)
    keep = kc.junctions(labels)
    ring_label, ring_start, xy, _ = kc.trace(labels, n_faces, keep)
    g = _ground_heights(hf, ground, owner, is_ground, height)
    hs, ws = labels.shape

    def face_at(row, col):
        if row < 0 or col < 0 or row >= hs or col >= ws:
            return -1
        return int(owner[row, col])

    def z_of(face, x, y):
        return float(g[y, x]) if is_ground[face] else float(height[face])

    def heights_at(x, y):
        """Every height a face brings to grid point (x, y)."""
        return {z_of(face_at(row, col), x, y) for row, col in ((y - 1, x - 1), (y - 1, x), (y, x - 1), (y, x))}

    faces = _face_rings(ring_label, ring_start, xy, face_at)
    if tolerance > 0:
        a, b, _, d, e, _ = hf.transform
        faces = _simplified(faces, keep, tolerance / np.sqrt(abs(a * e - b * d)))

    extra = _ground_points_by_face(ground_points, owner, is_ground)
    vertices = _Vertices()
    triangles: list = []
    labels_of: list = []  # per triangle: (face, kind) with kind 0 ground, 1 roof, 2 wall
    for face, face_rings in faces.items():
        # the face: a constrained Delaunay triangulation of its outline, the triangles inside it
        pts = np.concatenate([ring for ring, _ in face_rings] + ([extra[face]] if face in extra else []))
        offsets = np.cumsum([0] + [len(ring) for ring, _ in face_rings])  # the extra points come after the rings
        edges = np.concatenate([
            np.column_stack([np.arange(a, b), np.r_[np.arange(a + 1, b), a]]) for a, b in pairwise(offsets)
        ])
        cdt = delaunay(pts.astype(np.float64), constraints=edges)
        inside = _inside(cdt.triangles, cdt.constrained, len(pts))
        ids = [vertices(int(x), int(y), z_of(face, int(x), int(y))) for x, y in pts]
        for t in cdt.triangles[inside]:
            triangles.append((ids[t[0]], ids[t[1]], ids[t[2]]))
            labels_of.append((face, 0 if is_ground[face] else 1))
        if is_ground[face]:
            continue
        # walls down from this roof to every lower neighbour
        top = float(height[face])
        for ring, neighbours in face_rings:
            for k, other in enumerate(neighbours):
                if not is_ground[other] and height[other] >= top:
                    continue  # the higher (or equal) neighbour builds it
                (px, py), (qx, qy) = ring[k], ring[(k + 1) % len(ring)]
                sides = []
                for x, y in ((int(px), int(py)), (int(qx), int(qy))):
                    low = z_of(other, x, y)
                    lo, hi = min(low, top), max(low, top)
                    levels = sorted(h for h in heights_at(x, y) | {low, top} if lo <= h <= hi)
                    sides.append([vertices(x, y, h) for h in levels])
                outward = np.array([qy - py, px - qx], dtype=np.float64)  # left of the edge: the neighbour's side
                wall = wall_triangles(sides[0], sides[1], vertices.xyz, outward)
                triangles += wall
                labels_of += [(face, 2)] * len(wall)
    xyz = np.array(vertices.xyz, dtype=np.float64).reshape(-1, 3)
    tri = np.array(triangles, dtype=np.int64).reshape(-1, 3)
    x, y = hf.pixel_to_world(xyz[:, 1], xyz[:, 0])
    if hf.handedness < 0:
        tri = tri[:, [0, 2, 1]]  # counter-clockwise in (col, row) is clockwise in the world
    labels_arr = np.array(labels_of, dtype=np.int64).reshape(-1, 2)
    mesh = TerrainMesh(np.column_stack([x, y, xyz[:, 2]]), tri, crs=hf.crs, info={"surface": "3d"},
                       # face: the region of a roof or ground triangle, the roof of a wall; kind: 0 ground, 1 roof, 2 wall
                       triangle_attributes={"face": labels_arr[:, 0], "kind": labels_arr[:, 1]},
                       labels={"kind": dict(enumerate(KINDS))})
    return mesh


def _ground_heights(hf: Heightfield, ground: Heightfield, owner, is_ground, height) -> np.ndarray:
    """The ground's height at every grid point: ``ground`` where it has data, else the surface model's, else the
    nearest; never above a roof it meets."""
    g = np.where(ground.valid, ground.z, hf.z).astype(np.float64)
    missing = np.isnan(g)
    if missing.any():  # no data in either (a survey's canal): the nearest height, for the foot of walls there
        g = filled(Heightfield(np.where(missing, 0.0, g), transform=hf.transform, nodata_mask=missing))
    # the ground never rises above a roof it meets (an estimate on a slope can): its height at a point is
    # held at the lowest roof around, so no wall turns over or crosses its roof's edge
    roof = np.pad(np.where(is_ground[owner], np.inf, height[owner]), 1, constant_values=np.inf)
    return np.minimum(g, np.minimum(np.minimum(roof[:-1, :-1], roof[:-1, 1:]), np.minimum(roof[1:, :-1], roof[1:, 1:])))


def _face_rings(ring_label, ring_start, xy, face_at) -> dict:
    """{face: [(ring, the face on the left of each of its edges), ...]} from the traced rings."""
    faces: dict = {}
    for r, lab in enumerate(ring_label):
        ring = xy[ring_start[r]:ring_start[r + 1]]
        neighbours = []
        for k in range(len(ring)):
            (px, py), (qx, qy) = ring[k], ring[(k + 1) % len(ring)]
            d = _STEP[(int(np.sign(qx - px)), int(np.sign(qy - py)))]
            neighbours.append(face_at(*_left_square(int(px), int(py), d)))
        faces.setdefault(int(lab) - 1, []).append((ring, neighbours))
    return faces


def _ground_points_by_face(ground_points, owner, is_ground) -> dict:
    """{ground face: its (K, 2) grid points (col, row)} of ``ground_points``; points on roofs are left out."""
    extra: dict = {}
    if ground_points is not None and len(ground_points):
        hs, ws = owner.shape
        gp = np.asarray(ground_points, dtype=np.int64)
        at = owner[np.clip(gp[:, 1], 0, hs - 1), np.clip(gp[:, 0], 0, ws - 1)]
        for face in np.unique(at):
            if face >= 0 and is_ground[face]:
                extra[int(face)] = gp[at == face]
    return extra


def _inside(triangles: np.ndarray, constrained: np.ndarray, n_points: int) -> np.ndarray:
    """The triangles inside the rings: parity of the constrained edges crossed from the outside (flood fill)."""
    t = len(triangles)
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    key = edges[:, 0] * n_points + edges[:, 1]
    owner = np.tile(np.arange(t), 3)
    walls = set((constrained[:, 0] * n_points + constrained[:, 1]).tolist()) if len(constrained) else set()
    by_edge: dict = {}
    for k, tri in zip(key.tolist(), owner.tolist(), strict=True):
        by_edge.setdefault(k, []).append(tri)
    parity = np.full(t, -1, np.int8)
    stack = []
    for k, tris in by_edge.items():
        if len(tris) == 1 and parity[tris[0]] < 0:  # on the hull: outside unless the hull edge is a ring edge
            parity[tris[0]] = 1 if k in walls else 0
            stack.append(tris[0])
    neighbours: dict = {}
    for k, tris in by_edge.items():
        if len(tris) == 2:
            crossing = k in walls
            neighbours.setdefault(tris[0], []).append((tris[1], crossing))
            neighbours.setdefault(tris[1], []).append((tris[0], crossing))
    while stack:
        a = stack.pop()
        for b, crossing in neighbours.get(a, ()):
            if parity[b] < 0:
                parity[b] = parity[a] ^ crossing
                stack.append(b)
    return parity == 1


def _douglas_peucker(pts: np.ndarray, tol: float) -> np.ndarray:
    """Kept points of an open polyline (both ends kept), the same whichever way it is walked.

    Ties of the largest distance go to the smallest (x, y), so that the two
    faces that share a chain, which walk it in opposite directions, keep the
    same points.
    """
    n = len(pts)
    kept = np.zeros(n, bool)
    kept[0] = kept[-1] = True
    stack = [(0, n - 1)]
    p = pts.astype(np.float64)
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        a, b = p[i], p[j]
        mid = p[i + 1:j]
        ab = b - a
        length = np.hypot(*ab)
        dist = (np.hypot(*(mid - a).T) if length == 0
                else np.abs(ab[0] * (mid[:, 1] - a[1]) - ab[1] * (mid[:, 0] - a[0])) / length)
        far = dist.max()
        if far <= tol:
            continue
        ties = np.flatnonzero(dist == far)
        k = i + 1 + ties[np.lexsort((mid[ties, 1], mid[ties, 0]))[0]]
        kept[k] = True
        stack += [(i, k), (k, j)]
    return kept


def _chains(ring: np.ndarray, nodes: np.ndarray):
    """Split a closed ring at its node vertices.

    Returns ``(start, stop)`` index ranges into the ring walked from a node, stop inclusive.
    """
    n = len(ring)
    at = np.flatnonzero(nodes)
    if len(at) == 0:  # no node: the smallest point and the point furthest from it, the same either way round
        first = int(np.lexsort((ring[:, 1], ring[:, 0]))[0])
        dist = np.hypot(*(ring - ring[first]).T.astype(np.float64))
        far = np.flatnonzero(dist == dist.max())
        second = int(far[np.lexsort((ring[far, 1], ring[far, 0]))[0]])
        at = np.sort([first, second])
    return [(int(at[k]), int(at[k + 1]) if k + 1 < len(at) else int(at[0]) + n) for k in range(len(at))]


def _simplified(faces: dict, keep: np.ndarray, tol: float) -> dict:
    """The rings with every chain between junctions simplified (Douglas-Peucker, ``tol`` in cells), shared chains alike.

    A chain whose simplification crosses or touches another segment, or
    leaves a ring without area, is kept whole, and the check is repeated
    until none does.
    """
    whole: set = set()
    while True:
        masks: dict = {}
        out: dict = {}
        chain_of_segment = []
        segments = []
        for face, face_rings in faces.items():
            new_rings = []
            for ring, neighbours in face_rings:
                n = len(ring)
                nodes = keep[ring[:, 1], ring[:, 0]]
                kept = np.zeros(n, bool)
                keys = np.empty(n, object)
                for start, stop in _chains(ring, nodes):
                    idx = np.arange(start, stop + 1) % n
                    pts = ring[idx]
                    key = tuple(map(tuple, pts.tolist()))
                    canonical = min(key, key[::-1])
                    if canonical not in masks:
                        masks[canonical] = (
                            np.ones(len(pts), bool) if canonical in whole else _douglas_peucker(np.array(canonical), tol)
                        )
                    mask = masks[canonical] if canonical == key else masks[canonical][::-1]
                    kept[idx[mask]] = True
                    keys[idx[:-1]] = [canonical] * (len(idx) - 1)
                at = np.flatnonzero(kept)
                new_ring = ring[at]
                new_neighbours = [neighbours[i] for i in at]
                new_rings.append((new_ring, new_neighbours, [keys[i] for i in at]))
            out[face] = new_rings
        bad = set()
        for new_rings in out.values():
            for ring, _, keys in new_rings:
                if len(ring) < 3 or signed_area(ring) == 0:
                    bad.update(keys)
                for k in range(len(ring)):
                    a, b = tuple(ring[k]), tuple(ring[(k + 1) % len(ring)])
                    segments.append((min(a, b), max(a, b)))
                    chain_of_segment.append(keys[k])
        bad |= _crossing_chains(segments, chain_of_segment)
        bad -= whole
        if not bad:
            return {face: [(ring, neighbours) for ring, neighbours, _ in rings] for face, rings in out.items()}
        whole |= bad


def _crossing_chains(segments: list, chains: list) -> set:
    """The chains of segments that cross, overlap or touch another segment anywhere but at shared end points."""
    unique = {}
    for seg, chain in zip(segments, chains, strict=True):
        unique.setdefault(seg, chain)
    segs = list(unique)
    if not segs:
        return set()
    arr = np.array(segs, dtype=np.float64).reshape(-1, 4)
    cell = max(1.0, float(np.median(np.hypot(arr[:, 2] - arr[:, 0], arr[:, 3] - arr[:, 1]))))
    buckets: dict = {}
    for s, (x0, y0, x1, y1) in enumerate(arr):
        for bx in range(int(min(x0, x1) // cell), int(max(x0, x1) // cell) + 1):
            for by in range(int(min(y0, y1) // cell), int(max(y0, y1) // cell) + 1):
                buckets.setdefault((bx, by), []).append(s)
    bad = set()
    tested = set()
    for members in buckets.values():
        for i in range(len(members)):
            for j in range(i + 1, len(members)):
                a, b = members[i], members[j]
                if (a, b) in tested:
                    continue
                tested.add((a, b))
                if _conflict(arr[a], arr[b]):
                    bad.add(unique[segs[a]])
                    bad.add(unique[segs[b]])
    return bad


def _orient(ax, ay, bx, by, cx, cy) -> float:
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


def _on_segment(ax, ay, bx, by, px, py) -> bool:
    """Point p strictly inside segment a-b (collinear and between, not at an end)."""
    if _orient(ax, ay, bx, by, px, py) != 0 or (px, py) in ((ax, ay), (bx, by)):
        return False
    return min(ax, bx) <= px <= max(ax, bx) and min(ay, by) <= py <= max(ay, by)


def _conflict(s: np.ndarray, t: np.ndarray) -> bool:
    """Whether two segments (whole-number coordinates: exact) meet anywhere but at a shared end point."""
    ax, ay, bx, by = s
    cx, cy, dx, dy = t
    if _on_segment(ax, ay, bx, by, cx, cy) or _on_segment(ax, ay, bx, by, dx, dy):
        return True
    if _on_segment(cx, cy, dx, dy, ax, ay) or _on_segment(cx, cy, dx, dy, bx, by):
        return True
    d1, d2 = _orient(cx, cy, dx, dy, ax, ay), _orient(cx, cy, dx, dy, bx, by)
    d3, d4 = _orient(ax, ay, bx, by, cx, cy), _orient(ax, ay, bx, by, dx, dy)
    return d1 * d2 < 0 and d3 * d4 < 0


def wall_triangles(left: list, right: list, xyz: list, outward: np.ndarray) -> list:
    """Triangles of a vertical wall between two vertical sides (vertex lists, bottom to top), facing ``outward`` (col, row)."""
    out = []
    i = j = 0
    while i < len(left) - 1 or j < len(right) - 1:
        up_left = j == len(right) - 1 or (i < len(left) - 1 and xyz[left[i + 1]][2] <= xyz[right[j + 1]][2])
        if up_left:
            t = (left[i], right[j], left[i + 1])
            i += 1
        else:
            t = (left[i], right[j], right[j + 1])
            j += 1
        a, b, c = (np.array(xyz[v], dtype=np.float64) for v in t)
        normal = np.cross(b - a, c - a)
        if normal[0] * outward[0] + normal[1] * outward[1] < 0:
            t = (t[0], t[2], t[1])
        out.append(t)
    return out
