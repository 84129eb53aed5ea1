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
from ..kernels import tin
from .outline import boundary_segments, covered
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

    Nodata cells are cut out: the outline of the covered region (see
    :mod:`.outline`) is inserted as constrained edges before refinement, the
    triangles outside it are labelled and never scanned, and no vertex is ever
    placed on a nodata cell.

    Parameters
    ----------
    hf : Heightfield
    """

    def __init__(self, hf: Heightfield):
        if not isinstance(hf, Heightfield):
            raise InvalidInputError(f"greedy needs a Heightfield, got {type(hf).__name__}")
        self.hf = hf
        h, w = hf.shape
        # float32 heights where that loses nothing: half the memory traffic of the scans
        lossless32 = np.can_cast(np.dtype(hf.source_dtype), np.float32, casting="safe")
        self._z = np.ascontiguousarray(hf.z, dtype=np.float32 if lossless32 else np.float64).ravel()
        self._valid = np.ascontiguousarray(hf.valid, dtype=np.uint8).ravel()
        self._width = w
        self._all_valid = bool(self._valid.all())
        segments = np.empty((0, 2, 2), np.int64) if self._all_valid else boundary_segments(hf.valid)
        self._allocate(4 + 2 * len(segments) + 1024, 2 * (4 + 2 * len(segments)) + 2048)
        self._stack = np.empty(64, dtype=np.int32)
        self.stop_reason = None
        m = self._m
        px, py, tri, half, vedge, cnt = m[0], m[1], m[2], m[3], m[5], m[9]
        for i, (c, r) in enumerate([(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)]):
            px[i], py[i] = c, r
        cnt[0] = 4
        # (p0, p1, p3) and (p0, p3, p2): counter-clockwise in (col, row) coordinates
        tri[:6] = [0, 1, 3, 0, 3, 2]
        half[:6] = [-1, -1, 3, 2, -1, -1]
        vedge[:4] = [0, 1, 2, 5]
        cnt[1] = 2
        if len(segments):
            self._cut_holes(segments)
        m[7][: cnt[1]] = np.arange(cnt[1])
        m[8][: cnt[1]] = 1
        cnt[2] = cnt[1]
        kg.flush(*self._scan_args())

    def _cut_holes(self, segments: np.ndarray) -> None:
        """Insert the outline as constrained edges and label what lies outside it."""
        m = self._m
        ids = {}
        for r, c in np.unique(segments.reshape(-1, 2), axis=0).tolist():
            vid, self._stack = tin.insert_point(m, float(c), float(r), 0, self._stack)
            ids[(r, c)] = vid
        work = np.empty(64, dtype=np.int32)
        for (r0, c0), (r1, c1) in segments.tolist():
            code, self._stack, work = tin.insert_segment(m, ids[(r0, c0)], ids[(r1, c1)], self._stack, work)
            if code != tin.SEGMENT_OK:  # pragma: no cover - outlines never cross
                raise RuntimeError("the nodata outline crosses itself")
        labels = tin.label_components(m)
        n = int(m[9][1])
        centroid_x = m[0][m[2][: 3 * n].reshape(-1, 3)].mean(axis=1)
        centroid_y = m[1][m[2][: 3 * n].reshape(-1, 3)].mean(axis=1)
        valid = self.hf.valid
        first = np.unique(labels, return_index=True)[1]
        inside = np.array([covered(valid, centroid_y[t], centroid_x[t]) for t in first])
        m[6][:n] = ~inside[labels]

    # -- buffers ---------------------------------------------------------------------------
    _FIELDS = (
        ("px", "v", np.float64, 0), ("py", "v", np.float64, 0), ("tri", "3t", np.int32, 0),
        ("half", "3t", np.int32, -1), ("cons", "3t", np.uint8, 0), ("vedge", "v", np.int32, -1),
        ("region", "t", np.uint8, 0), ("dirty", "t", np.int32, 0), ("is_dirty", "t", np.uint8, 0),
    )

    def _allocate(self, cap_v: int, cap_t: int) -> None:
        """(Re)allocate every buffer with the given capacities, keeping the contents."""
        sizes = {"v": cap_v, "3t": 3 * cap_t, "t": cap_t}
        old = getattr(self, "_m", None)
        arrays = []
        for i, (_, size, dtype, fill) in enumerate(self._FIELDS):
            arr = np.full(sizes[size], fill, dtype=dtype)
            if old is not None:
                arr[: len(old[i])] = old[i]
            arrays.append(arr)
        cnt = old[9] if old is not None else np.zeros(4, np.int64)
        self._m = (*arrays, cnt)
        for name, fill, dtype in (("_cand", -1, np.int64), ("_err", 0, np.float64), ("_heap", 0, np.int32), ("_qpos", -1, np.int32)):
            arr = np.full(cap_t, fill, dtype=dtype)
            prev = getattr(self, name, None)
            if prev is not None:
                arr[: len(prev)] = prev
            setattr(self, name, arr)

    def _scan_args(self):
        return (self._m, self._z, self._valid, self._width, self._all_valid, self._cand, self._err, self._heap, self._qpos)

    # -- running -----------------------------------------------------------------------------
    @property
    def n_vertices(self) -> int:
        """Vertices inserted so far (including grid corners outside the data, if any)."""
        return int(self._m[9][0])

    @property
    def n_triangles(self) -> int:
        """Triangles so far (including those outside the data, if any)."""
        return int(self._m[9][1])

    @property
    def max_error(self) -> float:
        """Largest vertical error of the current mesh over the valid cells it covers."""
        return float(self._err[self._heap[0]]) if self._m[9][3] else 0.0

    def refine(self, max_error=None, max_vertices=None, max_triangles=None) -> str:
        """Insert cells until the first stop rule holds; return its name.

        The count rules apply to the output mesh (what :meth:`to_mesh` returns).
        With no rule at all the run goes on until every cell is exact
        (``"exact"``).  Calling again with a stricter rule continues.
        """
        stop = StopCriteria(max_error, max_vertices, max_triangles)
        extra_v, extra_t = self._outside_counts()
        limit_e = -1.0 if stop.max_error is None else stop.max_error
        limit_v = _NO_LIMIT if stop.max_vertices is None else stop.max_vertices + extra_v
        limit_t = _NO_LIMIT if stop.max_triangles is None else stop.max_triangles + extra_t
        while True:
            code, self._stack = kg.refine(*self._scan_args(), self._stack, limit_e, limit_v, limit_t)
            if code != kg.NEED_SPACE:
                self.stop_reason = _REASONS[code]
                return self.stop_reason
            self._allocate(2 * len(self._m[0]), 2 * len(self._err))

    def _outside_counts(self) -> tuple[int, int]:
        """Vertices and triangles that the output leaves out (outside the data)."""
        m = self._m
        n = int(m[9][1])
        inside = m[6][:n] == 0
        if inside.all():
            return 0, 0
        used = np.unique(m[2][: 3 * n].reshape(-1, 3)[inside])
        return int(m[9][0]) - len(used), int((~inside).sum())

    def to_mesh(self) -> TerrainMesh:
        """The current mesh in world coordinates, counter-clockwise seen from +z."""
        hf = self.hf
        m = self._m
        n, t = self.n_vertices, self.n_triangles
        triangles = m[2][: 3 * t].reshape(-1, 3)[m[6][:t] == 0].astype(np.int64)
        used, triangles = np.unique(triangles, return_inverse=True)
        triangles = triangles.reshape(-1, 3)
        cols = m[0][:n][used].astype(np.int64)
        rows = m[1][:n][used].astype(np.int64)
        x, y = hf.pixel_to_world(rows, cols)
        vertices = np.column_stack([x, y, hf.z[rows, cols]])
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

