"""Greedy insertion (HFPR): refine a Delaunay TIN by inserting the worst cell, again and again.

Seed 002, section 3.2 (the HFPR baseline cCVT is compared with) and seed 000,
section 2.4 ("refinement"); the engine follows the design of delatin and hmm:
halfedges, Lawson flips after each insertion, an indexed max-heap of
triangles keyed on their worst cell, and a rescan of only the triangles an
insertion changed.

The run starts from the four corners of the grid (two triangles).  Each step
takes the triangle whose worst cell has the largest vertical error, inserts
that cell (splitting the triangle, or the edge it lies on), restores the
Delaunay property with robust predicates, and rescans the new triangles.  It
stops at the first stop rule reached; the error bound is exact: the kernel
measures the mesh height with the same expression as :mod:`tinsmith.metrics`.
"""

from __future__ import annotations

import numpy as np

from ..core import Heightfield, StopCriteria, TerrainMesh
from ..errors import InvalidInputError
from ..kernels import greedy as kg
from .registry import register

__all__ = ["GreedyEngine", "greedy"]

_NO_LIMIT = np.iinfo(np.int64).max
_REASONS = {
    kg.STOP_ERROR: "max_error",
    kg.STOP_VERTICES: "max_vertices",
    kg.STOP_TRIANGLES: "max_triangles",
    kg.STOP_EXHAUSTED: "exact",
}


class GreedyEngine:
    """Incremental greedy refinement of one heightfield; refine in stages, read meshes between.

    >>> engine = GreedyEngine(hf)
    >>> engine.refine(max_error=20); coarse = engine.to_mesh()
    >>> engine.refine(max_error=5); finer = engine.to_mesh()   # continues, nothing recomputed

    Parameters
    ----------
    hf : Heightfield
        Every cell must be valid (nodata support: see the method docs).
    """

    def __init__(self, hf: Heightfield):
        if not isinstance(hf, Heightfield):
            raise InvalidInputError(f"greedy needs a Heightfield, got {type(hf).__name__}")
        if hf.nodata_mask.any():
            raise InvalidInputError(
                f"greedy cannot mesh nodata yet: {hf.n_cells - hf.n_valid} nodata cells; "
                "use method 'grid' or fill them"
            )
        self.hf = hf
        h, w = hf.shape
        # float32 heights where that loses nothing: half the memory traffic of the scans
        lossless32 = np.can_cast(np.dtype(hf.source_dtype), np.float32, casting="safe")
        self._z = np.ascontiguousarray(hf.z, dtype=np.float32 if lossless32 else np.float64).ravel()
        self._valid = np.ascontiguousarray(hf.valid, dtype=np.uint8).ravel()
        self._width = w
        self._all_valid = bool(self._valid.all())
        self._allocate(1024, 2048)
        corners = [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)]
        for i, (c, r) in enumerate(corners):
            self._px[i], self._py[i] = c, r
        self._cnt[0] = 4
        # (p0, p1, p3) and (p0, p3, p2): counter-clockwise in (col, row) coordinates
        self._tri[:6] = [0, 1, 3, 0, 3, 2]
        self._half[:6] = [-1, -1, 3, 2, -1, -1]
        self._cnt[1] = 2
        self._dirty[:2] = [0, 1]
        self._is_dirty[:2] = 1
        self._cnt[2] = 2
        self._stack = np.empty(64, dtype=np.int32)
        self.stop_reason = None
        kg.flush(*self._scan_buffers())

    # -- buffers ---------------------------------------------------------------------------
    def _allocate(self, cap_v: int, cap_t: int) -> None:
        old = getattr(self, "_px", None)
        fresh = {
            "_px": np.zeros(cap_v),
            "_py": np.zeros(cap_v),
            "_tri": np.zeros(3 * cap_t, np.int32),
            "_half": np.full(3 * cap_t, -1, np.int32),
            "_cons": np.zeros(3 * cap_t, np.uint8),
            "_cand": np.full(cap_t, -1, np.int64),
            "_err": np.zeros(cap_t),
            "_heap": np.zeros(cap_t, np.int32),
            "_qpos": np.full(cap_t, -1, np.int32),
            "_dirty": np.zeros(cap_t, np.int32),
            "_is_dirty": np.zeros(cap_t, np.uint8),
        }
        if old is not None:
            for name, arr in fresh.items():
                prev = getattr(self, name)
                arr[: len(prev)] = prev
        else:
            self._cnt = np.zeros(4, np.int64)
        for name, arr in fresh.items():
            setattr(self, name, arr)

    def _scan_buffers(self):
        return (
            self._px, self._py, self._tri, self._z, self._valid, self._width, self._all_valid,
            self._cand, self._err,
            self._heap, self._qpos, self._dirty, self._is_dirty, self._cnt,
        )

    # -- running -----------------------------------------------------------------------------
    @property
    def n_vertices(self) -> int:
        return int(self._cnt[0])

    @property
    def n_triangles(self) -> int:
        return int(self._cnt[1])

    @property
    def max_error(self) -> float:
        """Largest vertical error of the current mesh over the valid cells."""
        return float(self._err[self._heap[0]]) if self._cnt[3] else 0.0

    def refine(self, max_error=None, max_vertices=None, max_triangles=None) -> str:
        """Insert cells until the first stop rule holds; return its name.

        With no rule at all the run goes on until every cell is exact
        (``"exact"``).  Calling again with a stricter rule continues.
        """
        stop = StopCriteria(max_error, max_vertices, max_triangles)
        limit_e = -1.0 if stop.max_error is None else stop.max_error
        limit_v = _NO_LIMIT if stop.max_vertices is None else stop.max_vertices
        limit_t = _NO_LIMIT if stop.max_triangles is None else stop.max_triangles
        while True:
            code, self._stack = kg.refine(
                self._px, self._py, self._tri, self._half, self._cons, self._z, self._valid,
                self._width, self._all_valid, self._cand, self._err, self._heap, self._qpos, self._dirty, self._is_dirty,
                self._cnt, self._stack, limit_e, limit_v, limit_t,
            )
            if code != kg.NEED_SPACE:
                self.stop_reason = _REASONS[code]
                return self.stop_reason
            self._allocate(2 * len(self._px), 2 * len(self._err))

    def to_mesh(self) -> TerrainMesh:
        """The current mesh in world coordinates, counter-clockwise seen from +z."""
        hf = self.hf
        n, m = self.n_vertices, self.n_triangles
        cols = self._px[:n].astype(np.int64)
        rows = self._py[:n].astype(np.int64)
        x, y = hf.pixel_to_world(rows, cols)
        vertices = np.column_stack([x, y, hf.z[rows, cols]])
        triangles = self._tri[: 3 * m].reshape(-1, 3).astype(np.int64)
        if hf.handedness < 0:  # counter-clockwise in (col, row) is clockwise in the world
            triangles = triangles[:, [0, 2, 1]]
        info = {"error": {"max": self.max_error}, "stop_reason": self.stop_reason, "grid": hf.grid_spec()}
        return TerrainMesh(vertices, triangles, crs=hf.crs, info=info)


def default_max_error(hf: Heightfield) -> float:
    """The error bound used when no stop rule is given: 1/1000 of the height range."""
    lo, hi = hf.z_range
    return (hi - lo) / 1000.0


@register(
    "greedy",
    description="greedy insertion: Delaunay TIN refined at the worst cell until the error bound holds",
    paper="seed 002, section 3.2 (HFPR); seed 000, section 2.4",
)
def greedy(hf: Heightfield, *, stop: StopCriteria, progress=None) -> TerrainMesh:
    """Greedy insertion (HFPR) with an exact vertical error bound.

    Without any stop rule, ``max_error`` is 1/1000 of the height range.
    """
    engine = GreedyEngine(hf)
    if not stop.is_set:
        stop = StopCriteria(max_error=default_max_error(hf))
    engine.refine(stop.max_error, stop.max_vertices, stop.max_triangles)
    mesh = engine.to_mesh()
    mesh.info["max_error_used"] = stop.max_error
    return mesh

