"""Quality meshes with an error bound: Delaunay refinement (Ruppert, Üngör's off-centres) plus the exact vertical error.

METHODS.md section 12.  The run starts from the grid's corners, the nodata
outline, breaklines and control points as constraints
(:class:`.greedy.GreedyEngine`) and the vertices of greedy insertion at
``SEED_ERROR`` times the bound (seeds: the cells where the error is
largest; those near a breakline left out), then refines
(:mod:`tinsmith.kernels.quality`)
until every triangle inside the data has

- a vertical error of at most ``max_error`` at every valid cell it covers;
- a smallest plan-view angle of at least ``min_angle``;
- an area of at most ``max_area`` (or its region's) and, when it is made,
  of at most ``grading**2`` times each neighbour's (not tested again when a
  neighbour is made smaller later: enforced exactly, ratios below about 3
  make the refinement cascade; docs/methods/quality.md).

Then ``improve`` passes (:mod:`tinsmith.kernels.quality_opt`) remove and move vertices
wherever every triangle the change makes still passes these tests: refinement never takes a
point back, and this takes back 27-43% of them on the benchmark's terrains
(``benchmarks/RESULTS_quality.md``).

A bad triangle gets its circumcentre or off-centre, with the DEM's bilinear
height there (over the valid cells of its 2 x 2 block); a triangle over
the error bound whose shortest edge is below ``CELL_EDGE`` cells gets its
worst cell instead, with the cell's own height.

Segments (outline, breaklines, the grid's edge) encroached by a vertex are
split at their midpoints, as in Ruppert (1995) and Shewchuk (2002, "Delaunay
refinement algorithms for triangular mesh generation"); off-centres follow
Üngör (2004).  Near input angles below 60 degrees the angle bound cannot
always be met; those triangles (the smallest angle between two segments, or
across an edge joining two segments that meet below 60 degrees, as far from
both ends) are left and reported in
``mesh.info["quality"]``, as are triangles whose shortest edge is below
``min_edge`` cells.

``min_angle`` is accepted up to 33 degrees.  Ruppert's refinement is proven to end up to
about 20.7 degrees and works in practice to about 33.8 (Shewchuk 2002); here, with the error
points mixed in, 34 cascaded on a smooth 300 x 300 bowl, Big Tujunga and the Delft DTM
(each generation of Steiner points making shorter edges than the last) while 33.8
converged on all of them.  Two guards end a refinement that does not converge with an error
naming ``min_angle``: the vertex budget (``VERTEX_BUDGET`` vertices per valid cell) and the
stall guard (too many Steiner points for shape or size in triangles under ``CELL_EDGE``
cells across).

Cells need only be square within ``SQUARE_TOLERANCE`` (1%): the triangulation is Delaunay
in cell units, angles, areas and Steiner points are computed in world units, and a point
that would miss its triangle's circumcircle in cell units is replaced by the circumcentre
in cell units, so every bound holds in world units.
"""

from __future__ import annotations

import math

import numpy as np

from ...core import Heightfield, StopCriteria, TerrainMesh
from ...core.stop import default_max_error
from ...errors import InvalidInputError, InvalidOptionError
from ...kernels import quality as kq
from ...kernels import quality_opt as kqo
from ...kernels import tin
from ...metrics.quality import triangle_angles
from ...triangulation.breaklines import breakline_segments
from ...triangulation.delaunay import inside_part
from ..greedy.engine import GreedyEngine
from ..registry import register
from .regions import Regions, prepare_regions

#: The shortest edge (in cells) a triangle is refined for its shape or size; below it the triangle is kept.
MIN_EDGE = 0.05
#: Below this shortest edge (in cells), a triangle over the error bound gets its worst cell, not a Steiner point.
CELL_EDGE = 0.1
#: Refinement starts from greedy insertion's vertices at this many times ``max_error``: the cells where the error
#: is largest.  Measured against starting from the outline alone (vertices at the same bounds, geometric mean of
#: 1% and 5% of the cells): -7.4% on St. Helens, Big Tujunga and the Delft DTM (factors 1.5-5 tried; 2 and 2.5
#: best), -3.0% on the Delft DSM, the CODEM DSM and the Grand Canyon terrarium tile, not tuned on.
SEED_ERROR = 2.0
#: Seeds nearer than this (in cells) to a breakline are left out (refinement puts its own points there).
SEED_CLEARANCE = 1.0
#: The guards against a refinement that does not converge (past about 33.8 degrees Delaunay refinement can cascade:
#: each generation of Steiner points makes shorter edges than the last).  Either ends the run with an error naming
#: ``min_angle`` (docs/methods/quality.md).  The vertex budget: at most this many vertices per valid cell (plus the
#: starting vertices).  The densest finished run measured: 3.4 per cell (the Delft DTM at its default max_error of
#: 2.9 mm and 33 degrees, 823,074 vertices before improvement; at max_error 0.001 it needed 5.3 per cell).
VERTEX_BUDGET = 8.0
#: The stall guard: at most ``STALL_POINTS + STALL_SHARE * valid cells`` Steiner points for shape or size in
#: triangles whose shortest edge is below ``CELL_EDGE`` cells.  Finished runs: 14 on St. Helens and 13,910 (5.7% of
#: the cells) on the Delft DTM at their default max_error and 33 degrees; the Delft DTM at max_error 0.001 needs
#: 22.6% and is stopped.  Cascades at 34 degrees (the bowl of issue 42, the Delft DTM and Big Tujunga at 5% of
#: their cells) reach the limit at 112,778 / 315,374 / 479,394 vertices, in 1.3-12.3 s (RESULTS_quality.md).
STALL_POINTS = 1000
STALL_SHARE = 0.1
#: Cells are accepted when the transform's longest to shortest stretch is at most 1 + this (1%: a resampled
#: 4.0037 x 4.0139 m cell); the refinement works in cell units and measures angles and areas in world units.
SQUARE_TOLERANCE = 0.01
_NO_LIMIT = np.iinfo(np.int64).max


class QualityEngine(GreedyEngine):
    """Greedy insertion's triangulation, then Delaunay refinement under an error, angle and size bound."""

    _BUFFERS = GreedyEngine._BUFFERS + (("_pz", "v", np.float64, None), ("_marks", "t", np.int64, 0))

    def quality_refine(self, *, max_error, min_angle, max_area, grading, area_map=None, floor_map=None,
                       max_vertices=None, max_triangles=None) -> str:
        """Refine until every bound holds (``stop_reason`` "quality") or a stop rule or guard ends it.

        ``area_map``: the largest triangle area at each cell (flat; the regions' sizes); ``floor_map``: the
        smallest inradius (world units) a triangle over the error bound is refined to at each cell (flat; the
        flood method's time-step floor, :data:`.kernels.quality.FLOOR_SPLIT`).
        """
        hf = self.hf
        h, w = hf.shape
        m = self._m
        n = int(m[9][0])
        cols, rows = m[0][:n].astype(np.int64), m[1][:n].astype(np.int64)
        self._pz[:n] = hf.z[rows, cols]
        # the heap now holds badness: start it afresh with every triangle dirty
        t = int(m[9][1])
        self._qpos[:] = -1
        m[9][3] = 0
        m[7][:t] = np.arange(t)
        m[8][:t] = 1
        m[9][2] = t
        a, b, _, d, e, _ = hf.transform
        lin = np.array([a, b, d, e], np.float64)
        det = a * e - b * d
        inv = np.array([e / det, -b / det, -d / det, a / det], np.float64)
        prm = np.array([
            max_error, math.cos(math.radians(min_angle)), np.inf if max_area is None else max_area,
            0.0 if grading is None else grading * grading, MIN_EDGE * MIN_EDGE, CELL_EDGE * CELL_EDGE,
        ])
        extra_v, extra_t = self._outside_counts()
        n_valid = hf.n_valid
        self.budget = int(VERTEX_BUDGET * n_valid) + n  # the guards against a refinement that does not converge
        self.stall = int(STALL_POINTS + STALL_SHARE * n_valid)
        limits = np.array([
            _NO_LIMIT if max_vertices is None else max_vertices + extra_v,
            _NO_LIMIT if max_triangles is None else max_triangles + extra_t,
            self.budget, self.stall,
        ], np.int64)
        grid = self._grid
        g = (grid[0], grid[1], grid[3], h, w)
        amap = np.full(1, np.inf) if area_map is None else np.ascontiguousarray(area_map, np.float64)
        fmap = np.zeros(1) if floor_map is None else np.ascontiguousarray(floor_map, np.float64)
        self._tests = (g, prm, amap, fmap, lin)  # what optimise() checks every change against
        segq = np.empty(4096, np.int64)
        self.stats = np.zeros(2, np.int64)
        work = np.empty(4096, np.int64)
        while True:
            self._stack = tin.reserve(self._stack, len(self._cand))
            code = kq.refine_quality(
                self._m, self._pz, g, prm, amap, fmap, lin, inv, (self._heap, self._qpos, self._key), self._cand,
                self._stack, segq, self._marks, work, limits, self.stats,
            )
            if code != kq.NEED_SPACE:
                break
            self._grow()
        self.stop_reason = {kq.DONE: "quality", kq.STOP_VERTICES: "max_vertices", kq.STOP_TRIANGLES: "max_triangles",
                            kq.STOP_BUDGET: "vertex_budget", kq.STOP_STALLED: "stalled"}[code]
        return self.stop_reason

    def optimise(self, passes: int, fixed_vertices=()) -> dict:
        """Remove and move vertices while every bound of the refinement holds (:mod:`.kernels.quality_opt`).

        Run after :meth:`quality_refine` has finished (``stop_reason`` "quality").  ``fixed_vertices``: ids of
        vertices that stay (the control points, :attr:`control_vertices`).  Returns the counts of the kernel.
        """
        m = self._m
        fixed = np.zeros(len(m[0]), np.uint8)
        fixed[np.asarray(fixed_vertices, np.int64)] = 1
        g, prm, amap, fmap, lin = self._tests
        removed, moved, done = kqo.optimise(m, self._pz, g, prm, amap, fmap, lin, fixed, passes)
        return {"removed": int(removed), "moved": int(moved), "passes": int(done)}

    def off_grid_vertices(self) -> int:
        """Vertices off the cell centres (Steiner points of the refinement)."""
        n = self.n_vertices
        px, py, alive = self._m[0][:n], self._m[1][:n], self._m[5][:n] >= 0  # removed vertices: vedge -1
        return int((((px != np.floor(px)) | (py != np.floor(py))) & alive).sum())

    def to_mesh(self, regions: Regions | None = None) -> TerrainMesh:
        """The current mesh in world coordinates, Steiner points with their bilinear heights; with ``regions``,
        the region of every triangle in ``triangle_attributes["region"]`` (:meth:`.Regions.tag_mesh`), named in
        ``labels["region"]``."""
        hf = self.hf
        m = self._m
        n = self.n_vertices
        used, triangles, constrained = inside_part(m, self._swap)
        cols, rows = m[0][:n][used], m[1][:n][used]
        info = {"stop_reason": self.stop_reason, "grid": hf.grid_spec()}
        attributes, labels = {}, {}
        if regions is not None:
            attributes["region"] = regions.tag_mesh(cols, rows, triangles, constrained)
            labels["region"] = dict(enumerate(regions.names, start=1))
        x, y = hf.pixel_to_world(rows, cols)
        vertices = np.column_stack([x, y, self._pz[:n][used]])
        return TerrainMesh(vertices, triangles, crs=hf.crs, info=info, constrained_edges=constrained,
                           triangle_attributes=attributes, labels=labels)


def cell_stretch(hf: Heightfield) -> float:
    """How far from square the cells are: the ratio of the longest to the shortest world step of a unit pixel step
    (the singular values of the transform's 2 x 2 part); 1.0 for square cells, rotated or not."""
    a, b, _, d, e, _ = hf.transform
    s = np.linalg.svd(np.array([[a, b], [d, e]], np.float64), compute_uv=False)
    return float(s[0] / s[1]) if s[1] > 0 else math.inf


def check_grid(hf, method: str) -> None:
    """Refuse what Delaunay refinement in cell units cannot mesh: anything but a Heightfield, cells not square."""
    if not isinstance(hf, Heightfield):
        raise InvalidInputError(f"{method} needs a Heightfield, got {type(hf).__name__}")
    stretch = cell_stretch(hf)
    if stretch > 1.0 + SQUARE_TOLERANCE:
        dx, dy = hf.cell_size
        raise InvalidInputError(
            f"{method} needs square cells (within {SQUARE_TOLERANCE:.0%}: it refines in cell units), got {dx:g} x "
            f"{dy:g} (stretch {stretch:.4g}); resample the DEM to square cells first"
        )


def _guard_message(engine: QualityEngine, min_angle: float, max_error: float) -> str:
    """The one line of a refinement stopped by a guard."""
    n = engine.n_vertices
    if engine.stop_reason == "vertex_budget":
        why = (f"the vertex budget stopped it at {n:,} vertices ({VERTEX_BUDGET:g} per valid cell of "
               f"{engine.hf.n_valid:,})")
    else:
        why = (f"the stall guard stopped it at {n:,} vertices: {int(engine.stats[1]):,} Steiner points went into "
               f"triangles under {CELL_EDGE:g} cell across (at most {engine.stall:,} allowed)")
    return (f"min_angle: quality refinement at {min_angle:g} degrees with max_error {max_error:.4g} refines below the "
            f"DEM's resolution and may not converge: {why}; use a smaller min_angle or a larger max_error")


def _seeds(hf: Heightfield, error: float, segments, stop: StopCriteria) -> np.ndarray:
    """(K, 2) (row, col): greedy insertion's vertices at ``error``, less those within ``SEED_CLEARANCE`` cells of
    a breakline (or region boundary) segment, which would only make refinement split it into tiny pieces."""
    def half(n):  # a budget leaves room for the refinement
        return None if n is None else max(n // 2, 4)

    seed = GreedyEngine(hf)
    seed.refine(max_error=error, max_vertices=half(stop.max_vertices), max_triangles=half(stop.max_triangles))
    rows, cols, _, _ = seed.output_cells()
    if segments is None or len(segments) == 0:
        return np.column_stack([rows, cols])
    import shapely

    lines = shapely.linestrings(segments.reshape(-1, 2, 2)[:, :, ::-1].astype(np.float64))  # (col, row)
    near = shapely.STRtree(lines).query(shapely.points(cols.astype(np.float64), rows.astype(np.float64)),
                                        predicate="dwithin", distance=SEED_CLEARANCE)
    keep = np.ones(len(rows), bool)
    keep[near[0]] = False
    return np.column_stack([rows[keep], cols[keep]])


#: Under a time-step floor, seeds keep at least this many times the floor (world units) apart: the side of an
#: equilateral triangle at that inradius is 2 sqrt(3) = 3.46 times it.
SEED_SPACING = 4.0


def _thin(hf: Heightfield, seeds: np.ndarray, floor_map, breaklines) -> np.ndarray:
    """The seeds, less those nearer than ``SEED_SPACING`` times the floor at them to a seed kept before them, to the
    edge of the data or to a breakline: greedy insertion ignores the floor, and a vertex closer than that to
    another vertex, the outline or a breakline makes triangles below it (Delaunay refinement grades the mesh
    down to the distance between such features)."""
    import shapely
    from scipy.spatial import cKDTree

    from .regions import _data_area

    if len(seeds) == 0:
        return seeds
    h, w = hf.shape
    gap = SEED_SPACING * np.asarray(floor_map, np.float64).reshape(h, w)[seeds[:, 0], seeds[:, 1]]
    if not (gap > 0).any():
        return seeds
    cell = min(abs(float(v)) for v in hf.cell_size)
    x, y = hf.pixel_to_world(seeds[:, 0].astype(np.float64), seeds[:, 1].astype(np.float64))
    xy = np.column_stack([x, y])
    features = [shapely.boundary(shapely.transform(_data_area(hf), lambda p: np.column_stack(
        hf.pixel_to_world(p[:, 1], p[:, 0]))))]
    if breaklines is not None:
        lines = [breaklines] if isinstance(breaklines, np.ndarray) else list(breaklines)
        features += [shapely.linestrings(np.asarray(line, np.float64)[:, :2]) for line in lines if len(line) >= 2]
    near = shapely.distance(shapely.union_all(features), shapely.points(xy)) < np.maximum(gap, cell)
    keep = ~near | (gap <= 0)
    tree = cKDTree(xy)
    for i in np.flatnonzero(keep & (gap > 0)):
        if keep[i]:
            close = np.asarray(tree.query_ball_point(xy[i], gap[i]), np.int64)
            keep[close[close > i]] = False
    return seeds[keep]


@register("quality")
def quality(hf, *, min_angle, max_area, grading, improve, regions, breaklines, control_points, stop: StopCriteria,
            progress=None) -> TerrainMesh:
    """A mesh with the exact vertical error bound of greedy insertion *and* a minimum plan-view angle.

    ``max_error`` (default: greedy's, 1/1000 of the height range) bounds
    ``|mesh - DEM|`` at every valid cell; ``min_angle`` (degrees, default 30,
    at most 33) bounds every plan-view angle, except where an input angle
    of the outline or the breaklines is smaller (reported in
    ``mesh.info["quality"]``); ``max_area`` and ``grading`` bound the size.
    ``regions``: (polygon, max_area[, name]) items, areas meshed with
    their own largest triangle area (or only named, max_area None), their
    boundaries kept as edges and every triangle's region recorded in
    ``mesh.triangle_attributes["region"]`` (:mod:`.regions`), named in ``mesh.labels["region"]``.
    ``max_vertices`` / ``max_triangles`` stop the refinement early (the
    bounds then need not hold; ``stop_reason`` says so).

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> mesh = tinsmith.quality(dem, max_error=5.0, min_angle=30.0)
    >>> bool(tinsmith.vertical_error(mesh, dem)["max"] <= 5.0)
    True
    >>> bool(mesh.info["quality"]["min_plan_angle"] >= 30.0)  # every angle seen from above
    True
    """
    check_grid(hf, "quality")
    max_error = stop.max_error if stop.max_error is not None else default_max_error(hf)
    snapped = prepare_regions(hf, regions)
    if snapped is not None and snapped.boundaries:
        lines = [] if breaklines is None else [breaklines] if isinstance(breaklines, np.ndarray) else list(breaklines)
        breaklines = lines + snapped.boundaries
    mesh = refine(hf, max_error=max_error, min_angle=min_angle, max_area=max_area, grading=grading, improve=improve,
                  breaklines=breaklines, control_points=control_points, stop=stop, regions=snapped)
    if progress is not None:
        progress(1.0)
    return mesh


def refine(hf, *, max_error, min_angle, max_area, grading, improve, breaklines, control_points, stop: StopCriteria,
           regions: Regions | None = None, floor_map=None) -> TerrainMesh:
    """The quality method's run on a checked grid: seeds, refinement (under ``floor_map``, the flood method's
    time-step floor, if given), improvement, the mesh with ``info["quality"]``."""
    seeds = _seeds(hf, SEED_ERROR * max_error, breakline_segments(hf, breaklines) if breaklines is not None else None,
                   stop)
    if floor_map is not None:
        seeds = _thin(hf, seeds, floor_map, breaklines)
    engine = QualityEngine(hf, breaklines=breaklines, control_points=control_points, nodes=seeds)
    engine.quality_refine(max_error=max_error, min_angle=min_angle, max_area=max_area, grading=grading,
                          area_map=None if regions is None else regions.area_map(hf.shape), floor_map=floor_map,
                          max_vertices=stop.max_vertices, max_triangles=stop.max_triangles)
    if engine.stop_reason in ("vertex_budget", "stalled"):
        raise InvalidOptionError(_guard_message(engine, min_angle, max_error))
    improved = {"removed": 0, "moved": 0, "passes": 0}
    if improve and engine.stop_reason == "quality":  # a budget stop leaves bounds unmet: nothing to keep
        improved = engine.optimise(improve, engine.control_vertices)
    mesh = engine.to_mesh(regions)
    angles_2d = triangle_angles(mesh, dims=2).min(axis=1) if mesh.n_triangles else np.zeros(0)
    below = int((angles_2d < min_angle - 1e-6).sum())
    mesh.info.update(
        max_error_used=max_error,
        quality={
            "min_angle": min_angle,
            "min_plan_angle": float(angles_2d.min()) if len(angles_2d) else float("nan"),
            "below_min_angle": below,
            "off_grid_vertices": engine.off_grid_vertices(),
            "improvement": improved,
            # the stall guard's count (Steiner points in triangles under CELL_EDGE cells) and its limit
            "stall_points": int(engine.stats[1]), "stall_limit": engine.stall,
        },
    )
    return mesh
