"""The engine of greedy insertion (HFPR): refine a Delaunay TIN by inserting the worst cell, again and again.

Duan et al. (2016), section 3.2 (the HFPR baseline cCVT is compared with) and the Salt Lake City thesis,
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

from ...core import Heightfield, StopCriteria, TerrainMesh
from ...errors import InvalidInputError, NoDataError
from ...kernels import greedy as kg
from ...kernels import tin
from ...triangulation.breaklines import breakline_segments, snap_to_cells
from ...triangulation.delaunay import component_centroids, inside_part, morton, unique_edges
from ...triangulation.outline import boundary_segments, covered

__all__ = ["GreedyEngine"]

_NO_LIMIT = np.iinfo(np.int64).max
#: Vertex capacity a grid engine starts with (a smaller grid's cells: at most a vertex a cell); it doubles when
#: full.  Capacity is address space until used: only the heap positions and dirty flags are filled up front
#: (5 bytes a triangle), and a run that stays within it never copies its buffers.
_START_VERTICES = 1 << 20
_REASONS = {
    kg.STOP_ERROR: "max_error",
    kg.STOP_VERTICES: "max_vertices",
    kg.STOP_TRIANGLES: "max_triangles",
    kg.STOP_EXHAUSTED: "exact",
}


class GreedyEngine:
    """Incremental greedy refinement of one heightfield; refine in stages, read meshes between.

    Nodata cells are cut out: the outline of the covered region (see
    :mod:`tinsmith.triangulation.outline`) is inserted as constrained edges before refinement, the
    triangles outside it are labelled and never scanned, and no vertex is ever
    placed on a nodata cell.

    Parameters
    ----------
    hf : Heightfield
    breaklines : list of (K, 2) array_like, optional
        Polylines in world coordinates that must be edges of the mesh (ridges,
        channels, road edges).  Their vertices are snapped to the nearest cell
        centre, which must hold data; where two breaklines cross, the nearest
        cell to the crossing becomes a vertex of both.
    control_points : (K, 2) array_like, optional
        World points whose nearest cells are always vertices.
    nodes : (K, 2) int array_like, optional
        Cells (row, col) that are always vertices, each holding data: the
        way other methods (feature points) get the Delaunay triangulation of
        the cells they chose, with the holes of the data cut out.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> engine = tinsmith.GreedyEngine(dem)
    >>> engine.refine(max_error=20.0)
    'max_error'
    >>> coarse = engine.to_mesh()
    >>> engine.refine(max_error=5.0)  # goes on from there: nothing is recomputed
    'max_error'
    >>> finer = engine.to_mesh()
    >>> coarse.n_vertices < finer.n_vertices, engine.max_error <= 5.0
    (True, True)
    """

    def __init__(self, hf: Heightfield, *, breaklines=None, control_points=None, nodes=None):
        if not isinstance(hf, Heightfield):
            raise InvalidInputError(f"greedy needs a Heightfield, got {type(hf).__name__}")
        self.hf = hf
        h, w = hf.shape
        # the heightfield's own (read-only, contiguous) arrays: no copy of the grid
        z = hf.z.ravel()
        self._all_valid = not hf.nodata_mask.any()
        valid = np.ones(1, np.uint8) if self._all_valid else hf.valid.view(np.uint8).ravel()
        self._grid = kg.make_grid(z, valid, self._all_valid, h, w)
        segments = np.empty((0, 2, 2), np.int64) if self._all_valid else boundary_segments(hf.valid)
        if not self._all_valid and len(segments) == 0:
            raise NoDataError(
                "the data covers no area: no three neighbouring cells of a 2 x 2 square hold data"
            )
        self._cells = h * w + 16
        start = min(self._cells, _START_VERTICES)
        self._allocate(start, 2 * start + 32)
        self._stack = np.empty(64, dtype=np.int32)
        self.stop_reason = None
        # counter-clockwise in (col, row) is clockwise in the world: the output reverses each triangle
        self._swap = hf.handedness < 0
        m = self._m
        px, py, tri, half, vedge, cnt = m[0], m[1], m[2], m[3], m[5], m[9]
        for i, (c, r) in enumerate([(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)]):
            px[i], py[i] = c, r
        cnt[0] = 4
        # (p0, p1, p3) and (p0, p3, p2): counter-clockwise in (col, row) coordinates
        tri[:6] = [0, 1, 3, 0, 3, 2]
        half[:6] = [-1, -1, 3, 2, -1, -1]
        m[4][:6] = 0  # no constrained edge
        m[6][:2] = 0  # both inside the data
        vedge[:4] = [0, 1, 5, 2]  # an outgoing halfedge of each corner
        cnt[1] = 2
        if len(segments):
            self._cut_holes(segments)
        #: vertex ids of the control points (empty without them): vertices that must stay
        self.control_vertices = np.empty(0, np.int64)
        if control_points is not None:
            self.control_vertices = self._insert_nodes(self._snap("control_points", control_points))
        if nodes is not None:
            self._insert_nodes(self._check_nodes(nodes))
        if breaklines is not None:
            self._insert_breaklines(breaklines)
        m = self._m
        cnt = m[9]
        m[7][: cnt[1]] = np.arange(cnt[1])
        m[8][: cnt[1]] = 1
        cnt[2] = cnt[1]
        kg.flush(*self._scan_args())

    def _cut_holes(self, segments: np.ndarray) -> None:
        """Insert the outline as constrained edges and label what lies outside it."""
        if self._insert_segments(segments.reshape(-1, 4)) >= 0:  # pragma: no cover - outlines never cross
            raise RuntimeError("the outline of the data crosses itself")
        m = self._m
        # one triangle of each component decides for all of it: is its centroid in the data?
        labels, cx, cy = component_centroids(m)
        valid = self.hf.valid
        inside = np.array([covered(valid, y, x) for x, y in zip(cx, cy, strict=True)])
        m[6][: len(labels)] = ~inside[labels]

    def _snap(self, name: str, xy) -> np.ndarray:
        return snap_to_cells(self.hf, name, xy)

    def _check_nodes(self, nodes) -> np.ndarray:
        """(K, 2) (row, col) cells holding data, in Z-order (short point-location walks)."""
        rc = np.asarray(nodes)
        if rc.ndim != 2 or rc.shape[1] != 2 or not np.issubdtype(rc.dtype, np.integer):
            raise InvalidInputError(f"nodes must be a (K, 2) integer array of (row, col) cells, got {rc.dtype} {rc.shape}")
        h, w = self.hf.shape
        inside = (rc[:, 0] >= 0) & (rc[:, 0] < h) & (rc[:, 1] >= 0) & (rc[:, 1] < w)
        if not inside.all():
            raise InvalidInputError(f"nodes: cell {tuple(rc[~inside][0])} lies outside the {h} x {w} grid")
        holds = self.hf.valid[rc[:, 0], rc[:, 1]]
        if not holds.all():
            raise InvalidInputError(f"nodes: cell {tuple(rc[~holds][0])} has no data")
        if len(rc) == 0:
            return rc.astype(np.int64)
        return rc[np.argsort(morton(rc.astype(np.float64)), kind="stable")].astype(np.int64)

    def _reserve(self, n_vertices: int) -> None:
        """Make room for n more vertices (and the triangles they bring)."""
        cnt = self._m[9]
        need_v = int(cnt[0]) + n_vertices + 16
        need_t = int(cnt[1]) + 2 * n_vertices + 32
        if need_v > len(self._m[0]) or need_t > len(self._cand):
            self._allocate(max(need_v, len(self._m[0]) * 2), max(need_t, len(self._cand) * 2))

    def _grow(self, bound: int | None = None) -> None:
        """Double the buffers (a kernel asked for space), to no more than ``bound`` vertices when one is known.

        Doubling, not a smaller factor: each growth copies every buffer and
        restarts the kernel, and a smaller factor grows more often
        (docs/design.md has the figures).
        """
        cap_v = len(self._m[0]) * 2
        if bound is not None:
            cap_v = max(min(cap_v, bound), len(self._m[0]) + 1)
        self._allocate(cap_v, max(len(self._cand) * 2, 2 * cap_v + 32))

    def _insert_nodes(self, rc: np.ndarray) -> np.ndarray:
        """Insert grid nodes (row, col); return their vertex ids."""
        self._reserve(len(rc))
        rc = np.asarray(rc, dtype=np.float64).reshape(-1, 2)
        ids, self._stack = tin.insert_points(self._m, rc[:, 1].copy(), rc[:, 0].copy(), self._stack)
        return ids

    def _insert_breaklines(self, lines) -> None:
        """Snap the polylines to cell centres, split them where they cross, insert them as constraints."""
        segments = breakline_segments(self.hf, lines)
        if not len(segments):
            return
        failed = self._insert_segments(segments)
        if failed >= 0:
            x, y = self.hf.pixel_to_world(segments[failed, 0::2], segments[failed, 1::2])
            raise InvalidInputError(
                f"breakline segment ({x[0]:.10g}, {y[0]:.10g})-({x[1]:.10g}, {y[1]:.10g}) "
                "crosses the edge of the data (a nodata area); split or shorten it there"
            )

    def _insert_segments(self, segments: np.ndarray) -> int:
        """Insert (S, 4) grid segments (r0, c0, r1, c1) as constraints; index of the first that crosses one, or -1."""
        nodes, index = np.unique(segments.reshape(-1, 2), axis=0, return_inverse=True)
        ids = self._insert_nodes(nodes)[index.reshape(-1, 2)]
        failed, self._stack, _ = tin.insert_segments(
            self._m, ids[:, 0].copy(), ids[:, 1].copy(), self._stack, np.empty(64, dtype=np.int32)
        )
        return int(failed)

    # -- buffers ---------------------------------------------------------------------------
    # (name, size, dtype, fill): the triangulation tuple's arrays in order, then
    # the scan and heap arrays.  Only the slots the kernels read before they
    # write them are filled (is_dirty 0: not yet listed; qpos -1: not in the
    # heap); the others are written before use, so fresh capacity stays
    # untouched memory until it is needed.
    _BUFFERS = (
        ("px", "v", np.float64, None), ("py", "v", np.float64, None), ("tri", "3t", np.int32, None),
        ("half", "3t", np.int32, None), ("cons", "3t", np.uint8, None), ("vedge", "v", np.int32, None),
        ("region", "t", np.uint8, None), ("dirty", "t", np.int32, None), ("is_dirty", "t", np.uint8, 0),
        ("_cand", "t", np.int64, None), ("_heap", "t", np.int32, None), ("_qpos", "t", np.int32, -1),
        ("_key", "t", np.float64, None),
    )

    def _allocate(self, cap_v: int, cap_t: int) -> None:
        """(Re)allocate every buffer with the given capacities, keeping the contents."""
        sizes = {"v": cap_v, "3t": 3 * cap_t, "t": cap_t}
        old = getattr(self, "_m", None)
        cnt = old[9] if old is not None else np.zeros(4, np.int64)
        arrays = []
        for i, (name, size, dtype, fill) in enumerate(self._BUFFERS):
            arr = np.empty(sizes[size], dtype=dtype)
            prev = (old[i] if i < 9 else getattr(self, name)) if old is not None else None
            n_prev = 0 if prev is None else len(prev)
            if n_prev:
                arr[:n_prev] = prev
            if fill is not None:
                arr[n_prev:] = fill
            arrays.append(arr)
        self._m = (*arrays[:9], cnt)
        for (name, *_), arr in zip(self._BUFFERS[9:], arrays[9:], strict=True):
            setattr(self, name, arr)

    def _scan_args(self):
        return (self._m, self._grid, self._cand, (self._heap, self._qpos, self._key))

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
        return float(self._key[0]) if self._m[9][3] else 0.0

    def refine(self, max_error=None, max_vertices=None, max_triangles=None, progress=None) -> str:
        """Insert cells until the first stop rule holds; return its name.

        The count rules apply to the output mesh (what :meth:`to_mesh` returns).
        With no rule at all the run goes on until every cell is exact
        (``"exact"``).  Calling again with a stricter rule continues.
        ``progress(fraction)`` is called between chunks of insertions with the
        share of the way to the nearest stop rule (by error on a log scale, or
        by count).
        """
        stop = StopCriteria(max_error, max_vertices, max_triangles)
        extra_v, extra_t = self._outside_counts()
        limit_e = -1.0 if stop.max_error is None else stop.max_error
        limit_v = _NO_LIMIT if stop.max_vertices is None else stop.max_vertices + extra_v
        limit_t = _NO_LIMIT if stop.max_triangles is None else stop.max_triangles + extra_t
        start_error = self.max_error
        done = 0.0  # reported share; the error itself may rise a little after a flip
        while True:
            # insert in chunks so that progress can be reported between them
            chunk = min(limit_v, self.n_vertices + max(20_000, self.n_vertices // 4))
            code = self._run(limit_e, chunk, limit_t)
            if code != kg.STOP_VERTICES or chunk == limit_v:
                self.stop_reason = _REASONS[code]
                if progress is not None:
                    progress(1.0)
                return self.stop_reason
            if progress is not None:
                done = max(done, self._fraction(start_error, limit_e, limit_v, limit_t))
                progress(done)

    def step(self, n: int = 1) -> int:
        """Insert up to ``n`` cells (the worst first); return how many were inserted.

        Fewer than ``n`` when every valid cell is exact already.
        """
        before = self.n_vertices
        self._run(-1.0, before + n, _NO_LIMIT)
        return self.n_vertices - before

    def _run(self, limit_e: float, limit_v: int, limit_t: int) -> int:
        """The kernel's refinement up to the given internal limits, growing the buffers as it asks."""
        while True:
            self._stack = tin.reserve(self._stack, len(self._cand))  # the kernel allocates nothing
            code, self._stack = kg.refine(*self._scan_args(), self._stack, limit_e, limit_v, limit_t)
            if code != kg.NEED_SPACE:
                return code
            self._grow(self._cells)

    def levels(self, max_errors) -> list[TerrainMesh]:
        """One mesh per error bound, from this one run (bounds taken from the largest down)."""
        meshes = {}
        for bound in sorted({float(b) for b in max_errors}, reverse=True):
            self.refine(max_error=bound)
            meshes[bound] = self.to_mesh()
        return [meshes[float(b)] for b in max_errors]

    def _fraction(self, start_error: float, limit_e: float, limit_v: int, limit_t: int) -> float:
        """How far the run is towards its nearest stop rule, 0..1."""
        shares = [0.0]
        if limit_e > 0 and start_error > limit_e and self.max_error > 0:
            shares.append(np.log(start_error / self.max_error) / np.log(start_error / limit_e))
        if limit_v != _NO_LIMIT:
            shares.append(self.n_vertices / limit_v)
        if limit_t != _NO_LIMIT:
            shares.append(self.n_triangles / limit_t)
        return float(min(1.0, max(shares)))

    def _outside_counts(self) -> tuple[int, int]:
        """Vertices and triangles that the output leaves out (outside the data)."""
        m = self._m
        if (m[6][: self.n_triangles] == 0).all():
            return 0, 0
        used, triangles, _ = kg.inside_part(m, False)
        return self.n_vertices - len(used), self.n_triangles - len(triangles)

    def output_cells(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The output as grid cells: ``rows``, ``cols`` (int64), triangles and constrained edges.

        Triangles index ``rows``/``cols`` and are counter-clockwise seen from
        +z in the world; constrained edges (breaklines, the outline of the
        data) are (E, 2) vertex pairs.  Vertices only triangles outside the
        data use (grid corners on nodata) are left out.
        """
        used, triangles, constrained = inside_part(self._m, self._swap)
        m = self._m
        return m[1][used].astype(np.int64), m[0][used].astype(np.int64), triangles, constrained

    def to_mesh(self) -> TerrainMesh:
        """The current mesh in world coordinates, counter-clockwise seen from +z."""
        hf = self.hf
        vertices, triangles, ends = kg.output_mesh(self._m, self._grid[0], self._grid[2], hf.transform, self._swap)
        info = {
            "error": {"max": self.max_error},
            "stop_reason": self.stop_reason,
            "grid": hf.grid_spec(),
        }
        return TerrainMesh(vertices, triangles, crs=hf.crs, info=info, constrained_edges=unique_edges(ends))
