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
  at each point;
- each edge between a roof and a lower face (a lower roof, the ground, or
  the outside of the data) gets a vertical wall from the lower face to the
  roof, split at every height that another face brings to its ends, so that
  walls meeting at a corner share their vertical edges; walls face the
  lower side.

The result has no cracks: every edge is shared by two triangles, except
along the outline of the data (the edge of the ground and the foot of the
walls there).  Roofs and ground face up.
"""

from __future__ import annotations

import numpy as np

from ..core import Heightfield, TerrainMesh
from ..kernels import contour as kc
from .delaunay import delaunay

__all__ = ["block_model"]

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


def block_model(hf: Heightfield, tree, ground: Heightfield) -> TerrainMesh:
    """One mesh of the ground and the buildings of ``tree`` (a :class:`BuildingTree` of ``hf``).

    ``ground`` gives the height of the ground faces and of the foot of the
    walls (a DTM, or :func:`tinsmith.algorithms.urban.estimate_ground`);
    where it has no data the surface model's height is used.  The mesh is a
    3-D surface, not a 2.5-D TIN: its walls are vertical.
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
    g = np.where(ground.valid, ground.z, hf.z).astype(np.float64)
    hs, ws = labels.shape

    def face_at(row, col):
        if row < 0 or col < 0 or row >= hs or col >= ws:
            return -1
        return int(owner[row, col])

    def z_of(face, x, y):
        return float(g[y, x]) if is_ground[face] else float(height[face])

    def heights_at(x, y):
        """Every height a face brings to grid point (x, y)."""
        out = set()
        for row, col in ((y - 1, x - 1), (y - 1, x), (y, x - 1), (y, x)):
            out.add(z_of(face_at(row, col), x, y))
        return out

    vertices = _Vertices()
    triangles: list = []
    rings: dict = {}
    for r, lab in enumerate(ring_label):
        rings.setdefault(int(lab) - 1, []).append(xy[ring_start[r]:ring_start[r + 1]])
    for face, face_rings in rings.items():
        # the face: a constrained Delaunay triangulation of its outline, the triangles inside it
        pts = np.concatenate(face_rings)
        offsets = np.cumsum([0] + [len(p) for p in face_rings])
        edges = np.concatenate([
            np.column_stack([np.arange(a, b), np.r_[np.arange(a + 1, b), a]]) for a, b in zip(offsets[:-1], offsets[1:])
        ])
        cdt = delaunay(pts.astype(np.float64), constraints=edges)
        centre = pts[cdt.triangles].mean(axis=1)
        rows = np.floor(centre[:, 1] + 1e-9).astype(int)
        cols = np.floor(centre[:, 0] + 1e-9).astype(int)
        inside = owner[np.clip(rows, 0, hs - 1), np.clip(cols, 0, ws - 1)] == face
        ids = [vertices(int(x), int(y), z_of(face, int(x), int(y))) for x, y in pts]
        for t in cdt.triangles[inside]:
            triangles.append((ids[t[0]], ids[t[1]], ids[t[2]]))
        if is_ground[face]:
            continue
        # walls down from this roof to every lower neighbour
        for ring in face_rings:
            for k in range(len(ring)):
                (px, py), (qx, qy) = ring[k], ring[(k + 1) % len(ring)]
                d = _STEP[(int(np.sign(qx - px)), int(np.sign(qy - py)))]
                lrow, lcol = _left_square(int(px), int(py), d)
                other = face_at(lrow, lcol)
                top = float(height[face])
                if not is_ground[other] and height[other] >= top:
                    continue  # the higher (or equal) neighbour builds it, or there is none
                sides = []
                for x, y in ((int(px), int(py)), (int(qx), int(qy))):
                    low = z_of(other, x, y)
                    lo, hi = min(low, top), max(low, top)
                    levels = sorted(h for h in heights_at(x, y) if lo <= h <= hi)
                    sides.append([vertices(x, y, h) for h in levels])
                outward = np.array([lcol + 0.5 - (px + qx) / 2.0, lrow + 0.5 - (py + qy) / 2.0])
                triangles += _wall(sides[0], sides[1], vertices.xyz, outward)
    xyz = np.array(vertices.xyz, dtype=np.float64).reshape(-1, 3)
    tri = np.array(triangles, dtype=np.int64).reshape(-1, 3)
    x, y = hf.pixel_to_world(xyz[:, 1], xyz[:, 0])
    if hf.handedness < 0:
        tri = tri[:, [0, 2, 1]]  # counter-clockwise in (col, row) is clockwise in the world
    mesh = TerrainMesh(np.column_stack([x, y, xyz[:, 2]]), tri, crs=hf.crs)
    mesh.info["surface"] = "3d"
    return mesh


def _wall(left: list, right: list, xyz: list, outward: np.ndarray) -> list:
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
