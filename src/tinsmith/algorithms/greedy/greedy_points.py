"""Greedy insertion on a point cloud: the error is exact at every kept input point, no gridding.

The grid method (:mod:`.engine`) measures a triangle against the cells under
it; here each triangle holds the input points inside it (Garland & Heckbert
1995, section 4.2) and the worst of them is inserted, until the stop rule
holds (kernel: :mod:`tinsmith.kernels.greedy_points`).

The run starts from the outline of :func:`tinsmith.tin` (the concave hull
of the points at ``max_edge``, with its holes): the outline's points and its
edges, as constraints, together with breaklines and polygon rims; triangles
outside the outline are never refined, and the points there (isolated
points in a gap) are not part of the result.  Every other point of the TIN
is a candidate, so when the run stops on ``max_error`` the mesh is within
the bound at every one of them (points inside a "flat" polygon are left
out: the water surface is flat by request).
"""

from __future__ import annotations

import numpy as np

from ...core import StopCriteria, TerrainMesh
from ...kernels import greedy as kg
from ...kernels import greedy_points as kp
from ...kernels import tin as ktin
from ...triangulation.delaunay import component_centroids, inside_part, morton, triangulate_points
from ...triangulation.pointtin import PointTin
from .engine import GreedyEngine

__all__ = ["PointGreedyEngine", "default_point_max_error"]

#: The stop on ``max_error`` leaves room for this much relative rounding, times the largest |z|:
#: another evaluation of the same plane (the metrics', another triangle's on a shared edge)
#: then never exceeds the bound.
ROUNDING = 1e-13


class PointGreedyEngine(GreedyEngine):
    """Greedy refinement of the TIN of a point cloud; refine in stages and read meshes between (as :class:`GreedyEngine`).

    Parameters
    ----------
    ptin : PointTin
        The full TIN and its kept region (:func:`tinsmith.triangulation.pointtin.build_point_tin`).
    crs : str, optional
        The CRS of the output meshes.
    """

    _BUFFERS = GreedyEngine._BUFFERS + (("_head", "t", np.int32, -1), ("_vz", "v", np.float64, None))

    def __init__(self, ptin: PointTin, crs: str | None = None):
        self.crs = crs
        self.ptin = ptin
        xyz = ptin.xyz
        outline = ptin.outline_edges()
        segments = np.concatenate([outline, ptin.constrained]) if len(ptin.constrained) else outline
        fixed = np.unique(segments)
        covered = np.zeros(len(xyz), bool)
        covered[ptin.triangles[ptin.keep].ravel()] = True
        candidate = covered
        candidate[fixed] = False
        ids = np.flatnonzero(candidate)
        ids = ids[np.argsort(morton(xyz[ids, :2]), kind="stable")] if len(ids) else ids
        self.candidates = ids
        self.stop_reason = None
        # the start: the outline's (and constraints') vertices, triangulated, the segments inserted
        m, _, stack = triangulate_points(xyz[fixed, :2], len(fixed) + 16)
        self._m = m
        local = np.full(len(xyz), -1, np.int64)
        local[fixed] = np.arange(len(fixed))
        seg = local[segments]
        failed, stack, _ = ktin.insert_segments(m, seg[:, 0].copy(), seg[:, 1].copy(), stack,
                                                np.empty(64, np.int32))
        if failed >= 0:  # pragma: no cover - edges of one triangulation never cross
            raise RuntimeError("the outline of the TIN crosses itself")
        self._stack = stack
        n_tri = int(m[9][1])
        cap_t = len(m[6])
        self._cand = np.empty(cap_t, np.int64)
        self._heap = np.empty(cap_t, np.int32)
        self._qpos = np.full(cap_t, -1, np.int32)
        self._key = np.empty(cap_t)
        self._head = np.full(cap_t, -1, np.int32)
        self._vz = np.empty(len(m[0]))
        self._vz[: len(fixed)] = xyz[fixed, 2]
        self._fixed = fixed
        self._label_outside(ptin)
        n = len(ids)
        self._points = (
            xyz[ids, 0].copy(), xyz[ids, 1].copy(), xyz[ids, 2].copy(), np.full(n, -1, np.int32),
            None, np.zeros(n, np.uint8), None, np.empty(n, np.int32), np.zeros(1, np.int64),
        )
        self._slack = ROUNDING * float(np.abs(xyz[:, 2]).max()) + 1e-300
        self._reserve(min(n, 4096))
        kp.distribute(self._m, self._P(), np.arange(n, dtype=np.int64))
        self._check_lost()
        m = self._m
        m[7][:n_tri] = np.arange(n_tri)
        m[8][:n_tri] = 1
        m[9][2] = n_tri
        kp.flush(m, self._P(), self._cand, (self._heap, self._qpos, self._key), False)

    def _label_outside(self, ptin: PointTin) -> None:
        """Label the triangles outside the outline: one triangle of each component, located in the full TIN, decides."""
        m = self._m
        labels, cx, cy = component_centroids(m)
        inside = np.zeros(len(cx), bool)
        t = 0
        for k, (x, y) in enumerate(zip(cx.tolist(), cy.tolist(), strict=True)):
            s = ktin.locate(ptin.m, x, y, t)
            if s >= 0:
                inside[k] = ptin.keep[s]
                t = s
        m[6][: len(labels)] = ~inside[labels]

    def _P(self):
        X, Y, Z, nxt, _, used, _, gather, lost = self._points
        return (X, Y, Z, nxt, self._head, used, self._vz, gather, lost)

    def _check_lost(self) -> None:
        lost = int(self._points[8][0])
        if lost:  # pragma: no cover - exact predicates place every point
            raise RuntimeError(f"greedy insertion on points lost {lost} points")

    def _run(self, limit_e: float, limit_v: int, limit_t: int) -> int:
        while True:
            self._stack = ktin.reserve(self._stack, len(self._cand))
            code, self._stack = kp.refine(self._m, self._P(), self._cand, (self._heap, self._qpos, self._key),
                                          self._stack, limit_e, limit_v, limit_t, self._slack)
            self._check_lost()
            if code != kg.NEED_SPACE:
                return code
            self._grow()

    def to_mesh(self) -> TerrainMesh:
        """The current mesh in world coordinates, counter-clockwise seen from +z."""
        m = self._m
        n = self.n_vertices
        used, triangles, constrained = inside_part(m)
        vertices = np.column_stack([m[0][:n][used], m[1][:n][used], self._vz[:n][used]])
        info = {
            "error": {"max": self.max_error},
            "stop_reason": self.stop_reason,
            "max_edge": self.ptin.max_edge,
            "points": int(len(self.ptin.xyz)),
            "duplicates_merged": self.ptin.merged,
            "points_checked": int(len(self.candidates) + len(self._fixed)),
        }
        return TerrainMesh(vertices, triangles, crs=self.crs, info=info, constrained_edges=constrained)


def default_point_max_error(xyz: np.ndarray) -> float:
    """The bound used when no stop rule is given: 1/1000 of the height range, as on grids."""
    z = xyz[:, 2]
    return float(z.max() - z.min()) / 1000.0


def point_greedy(ptin: PointTin, stop: StopCriteria, crs=None, progress=None) -> TerrainMesh:
    """Run :class:`PointGreedyEngine` to the stop rule (default: 1/1000 of the height range)."""
    engine = PointGreedyEngine(ptin, crs)
    if not stop.is_set:
        stop = StopCriteria(max_error=default_point_max_error(ptin.xyz))
    engine.refine(stop.max_error, stop.max_vertices, stop.max_triangles, progress=progress)
    mesh = engine.to_mesh()
    mesh.info["max_error_used"] = stop.max_error
    return mesh
