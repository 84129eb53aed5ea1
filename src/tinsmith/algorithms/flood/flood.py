"""A mesh for an explicit shallow-water solver: quality refinement under a time-step floor, streams as breaklines.

An explicit finite-volume solver (ANUGA, TUFLOW's HPC, BASEMENT, ...) takes steps of at most the CFL limit,
``dt = CFL * min over triangles of r / (|u| + sqrt(g h))`` with ``r`` the inradius (Courant, Friedrichs & Lewy
1928; ANUGA's user manual, "the time step"): the smallest triangle under the deepest, fastest water sets the pace
of the whole run.  An error-driven mesh puts its smallest triangles where the terrain bends most, in the
channels, where the water is.  This method is :mod:`..quality.quality` (the error bound at every cell and the
plan-view angle bound, Ruppert 1995, Shewchuk 2002, Üngör 2004) with three changes:

1. **A time-step floor.**  The expected wave speed ``c = u + sqrt(g h)`` at every cell comes from
   :func:`tinsmith.hydrology.normal_depth` (steady flow of the contributing area's rain, Manning's formula) or
   from a depth raster the user gives; the floor is ``time_step * c``, the smallest inradius that keeps a
   triangle's step at or above ``time_step``, spread over the 3 x 3 cells round each cell.  A triangle over the
   error bound is refined only while its inradius is at least
   :data:`tinsmith.kernels.quality.FLOOR_SPLIT` (3) times the largest floor over the cells it covers, so its
   pieces stay at or above the floor, and a segment is split for the error bound only while it is at least
   :data:`~tinsmith.kernels.quality.SEGMENT_FLOOR` (6.9) times the floor long; greedy insertion's seeds keep
   ``SEED_SPACING`` (4) times the floor from one another, the outline and the streams.  Where the bound and the
   floor disagree, the floor wins, and ``mesh.info["flood"]["relaxed"]`` says where and by how much (the
   triangles over the bound, their area, the worst cell).  Shape and size are refined as in ``quality``,
   whatever the floor: slivers are what make a solver's reconstruction fail.
2. **The stream network as breaklines.**  Stream lines (given, or :func:`tinsmith.hydrology.stream_lines` above
   ``stream_area``, simplified to within one cell) are kept as mesh edges through the cell centres of the
   thalweg, at the DEM's heights: the channel is a connected trough of the mesh, not a chain of pits and dams
   between vertices that miss it.
3. **The outline cut for the solver.**  :func:`tinsmith.segment_outline` with the same streams names the border
   ``outflow_N`` where a stream leaves the domain (``inflow_N`` where one enters), ``wall_N`` elsewhere, so the
   solver formats (2DM, Gmsh, ADCIRC, SELAFIN, :meth:`~tinsmith.TerrainMesh.to_anuga`) carry the boundaries.

``time_step`` ``"auto"`` (default): the step of a uniform mesh of equilateral triangles with as many triangles as
greedy insertion needs for the bound, at the fastest expected water: the floor then keeps every triangle at
least as slow to step as such a mesh's smallest, and the error bound takes what is left.  ``max_area`` (default
``AREA_CAP`` = 2 times such a mesh's triangle) keeps the smooth slopes from being meshed with a few large
triangles, whose runoff then reaches the streams late: on St. Helens it raised the outflow hydrograph's
Nash-Sutcliffe efficiency against the full grid from 0.79-0.83 to 0.88-0.92 (ANUGA, benchmarks/flood_solver.py).

What it does not do: triangles are not stretched along the channels beyond what the angle bound allows (at 30
degrees, an aspect ratio of about 2); the 30-degree bound holds everywhere but at small input angles of the
outline and the streams (reported in ``mesh.info["quality"]``, as in ``quality``).
"""

from __future__ import annotations

import math

import numpy as np

from ... import _checks
from ...core import Heightfield, StopCriteria, TerrainMesh
from ...core.stop import default_max_error
from ...errors import InvalidInputError
from ...hydrology import GRAVITY, normal_depth, stream_lines
from ...io.crs import refuse_geographic
from ..greedy.engine import GreedyEngine
from ..quality.quality import check_grid, refine
from ..registry import register

#: The inradius of an equilateral triangle of area a is this times sqrt(a): 1 / sqrt(3 sqrt(3)).
EQUILATERAL_INRADIUS = 1.0 / math.sqrt(3.0 * math.sqrt(3.0))
#: The least depth of the expected flow (m) when it is estimated: a rain-on-grid run carries a film of about this
#: much on the hillslopes (1.3 cm at 1.8 m/s measured in ANUGA on St. Helens, where the steady normal depth is
#: 3 mm), and its speed sets the time step there.
SHEET_DEPTH = 0.01
#: The default largest triangle area, as a multiple of a uniform mesh's triangle at the count the bound needs: on
#: St. Helens (ANUGA, benchmarks/flood_solver.py's event) caps of 1.4x and 2.7x raised the outflow NSE from 0.79-0.81
#: to 0.93-0.96, a cap of 6.8x did nothing.
AREA_CAP = 2.0
#: Stream breaklines keep their vertices at least this many times the floor apart (2 sqrt(3) = 3.46: the side of
#: an equilateral triangle at the floor's inradius).
STREAM_SPACING = 4.0
#: The relaxed-bound report counts a triangle as over the bound when its error exceeds it by more than this
#: share of it (the error of a vertex's own cell is a rounding error, not a relaxation).
REPORT_TOLERANCE = 1e-9


@register("flood")
def flood(hf, *, min_angle, max_area, grading, improve, time_step, depth, rain, manning, streams, stream_area, breaklines,
          control_points, stop: StopCriteria, progress=None) -> TerrainMesh:
    """A quality mesh sized for an explicit shallow-water solver: time-step floor, stream breaklines, segments.

    ``max_error`` (default: greedy's, 1/1000 of the height range) bounds ``|mesh - DEM|`` at every valid cell
    except where the time-step floor stops the refinement (reported in ``mesh.info["flood"]["relaxed"]``);
    ``min_angle`` (default 30) bounds every plan-view angle as in ``quality``; ``max_area`` the triangles' area
    (default: the module's description).  ``time_step``: seconds, or
    "auto" (the module's description); ``depth``: the expected water depth (a Heightfield on the DEM's grid, m),
    instead of :func:`tinsmith.hydrology.normal_depth` with ``rain`` (mm/h) and ``manning``; ``streams``: the
    stream lines (world polylines or a vector file), instead of those of the DEM's flow above ``stream_area``
    (world units squared; default 1000 cells).

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[150:250, 100:200], cell_size=30.0, crs=hf.crs)  # a 100 x 100 window
    >>> mesh = tinsmith.flood(dem, max_error=10.0)
    >>> report = mesh.info["flood"]
    >>> bool(report["min_step"] > 0), report["relaxed"]["triangles"] >= 0
    (True, True)
    >>> sorted({name.split("_")[0] for name in mesh.node_strings})  # the outline cut where the streams leave
    ['outflow', 'wall']
    """
    check_grid(hf, "flood")
    refuse_degrees(hf.crs, hf.bounds)
    max_error = stop.max_error if stop.max_error is not None else default_max_error(hf)
    speed = wave_speed(hf, depth, rain, manning)
    derived = streams is None
    auto = time_step is None or time_step == "auto"
    if not auto:
        step = _checks.number("time_step", time_step, minimum=0, exclusive_min=True)
    uniform = uniform_count(hf, max_error) if auto or max_area is None else None
    if auto:
        step = auto_time_step(hf, uniform, speed)
    if max_area is None:  # no triangle much larger than a uniform mesh's: hillslopes keep their runoff paths
        dx, dy = (abs(float(v)) for v in hf.cell_size)
        max_area = AREA_CAP * hf.n_valid * dx * dy / uniform
    floor = floor_map(speed, step)
    network = stream_lines(hf, stream_area) if derived else list(streams)  # prepared: (K, 2) or (K, 3) polylines
    lines = stream_breaklines(hf, network, floor)
    given = [] if breaklines is None else [breaklines] if isinstance(breaklines, np.ndarray) else list(breaklines)
    mesh = refine(hf, max_error=max_error, min_angle=min_angle, max_area=max_area, grading=grading, improve=improve,
                  breaklines=given + lines if (given or lines) else None, control_points=control_points, stop=stop,
                  floor_map=floor.ravel())
    if progress is not None:
        progress(1.0)
    mesh.info["flood"] = {
        "time_step": step, "time_step_auto": auto, "max_area": max_area,
        **step_report(mesh, hf, speed, step),
        "relaxed": relaxed_report(mesh, hf, max_error),
        "streams": len(network), "stream_breaklines": len(lines), "streams_derived": derived,
        "depth": "given" if depth is not None else f"normal depth, rain {rain:g} mm/h, Manning's n {manning:g}",
    }
    from ...io.boundaries import segment_outline

    # a derived stream ends on its outlet cell, a given one is clipped to the data: carried past the outline
    return segment_outline(mesh, [_extended(hf, line, both=not derived) for line in network])


def refuse_degrees(crs, bounds) -> None:
    """Refuse a DEM in a geographic CRS in one line naming the UTM zone: the expected flow and the time step are
    metres (the command line calls this on the file's header, before reading it)."""
    refuse_geographic(crs, bounds, "flood", "the expected flow (Manning's formula, the wave speed) and the time "
                      "step's inradii would mix metres and degrees")


def wave_speed(hf: Heightfield, depth, rain: float, manning: float) -> np.ndarray:
    """The expected wave speed ``|u| + sqrt(g h)`` at every cell (m/s, 0 at nodata): from ``depth`` (a Heightfield
    on ``hf``'s grid, still water) or :func:`tinsmith.hydrology.normal_depth`."""
    if depth is None:
        rain = _checks.number("rain", rain, minimum=0, exclusive_min=True)
        h, u = normal_depth(hf, rain=rain / 1000.0 / 3600.0, manning=manning)
    else:
        if not isinstance(depth, Heightfield) or depth.shape != hf.shape or \
                not np.allclose(depth.transform[:6], hf.transform[:6]):
            raise InvalidInputError("depth must be a raster on the DEM's grid (same shape and transform), in metres")
        h = np.where(depth.valid, np.maximum(np.asarray(depth.z, np.float64), 0.0), 0.0)
        u = np.zeros_like(h)
    h = np.nan_to_num(h, nan=0.0)
    u = np.nan_to_num(u, nan=0.0)
    if depth is None:  # a film of at least SHEET_DEPTH, faster by Manning's h^(2/3) at the same slope
        thin = (h > 0) & (h < SHEET_DEPTH)
        u[thin] *= (SHEET_DEPTH / h[thin]) ** (2.0 / 3.0)
        h = np.maximum(h, SHEET_DEPTH)
    c = u + np.sqrt(GRAVITY * h)
    c[~hf.valid] = 0.0
    return c


def uniform_count(hf: Heightfield, max_error: float) -> int:
    """The triangles of a uniform mesh as fine as the bound needs: twice greedy insertion's vertices at
    ``max_error``."""
    engine = GreedyEngine(hf)
    engine.refine(max_error=max_error)
    return max(2 * engine.n_vertices, 2)


def auto_time_step(hf: Heightfield, triangles: int, speed: np.ndarray) -> float:
    """The CFL step (CFL 1) of a uniform mesh of ``triangles`` equilateral triangles under the fastest expected
    water as such a triangle sees it: the wave speed averaged over a square of the triangle's area (a river one
    cell wide does not fill a triangle three cells across)."""
    from scipy.ndimage import uniform_filter

    dx, dy = (abs(float(v)) for v in hf.cell_size)
    area = hf.n_valid * dx * dy / triangles
    k = max(int(round(math.sqrt(area / (dx * dy)))), 1)
    valid = hf.valid.astype(np.float64)
    share = uniform_filter(valid, size=k, mode="constant")
    with np.errstate(invalid="ignore", divide="ignore"):
        seen = np.where(hf.valid & (share > 0), uniform_filter(speed * valid, size=k, mode="constant") / share, 0.0)
    fastest = float(seen.max())
    if fastest <= 0.0:  # no water expected anywhere
        return math.inf
    return EQUILATERAL_INRADIUS * math.sqrt(area) / fastest


def floor_map(speed: np.ndarray, step: float) -> np.ndarray:
    """The smallest inradius (world units) at every cell that keeps a triangle's step at ``step``: ``step * c``,
    the largest over the 3 x 3 cells round it (a triangle's worst cell may lie beside the channel's)."""
    from scipy.ndimage import maximum_filter

    if not math.isfinite(step):
        return np.zeros(speed.shape)
    return maximum_filter(step * speed, size=3, mode="nearest")


def triangle_steps(mesh: TerrainMesh, hf: Heightfield, speed: np.ndarray) -> np.ndarray:
    """Each triangle's expected CFL step (CFL 1): its plan-view inradius over the largest wave speed ``speed`` holds
    at the cells of its corners and centroid (inf where no water is expected)."""
    tri = mesh.vertices[mesh.triangles][:, :, :2]
    sides = np.linalg.norm(tri - np.roll(tri, -1, axis=1), axis=2).sum(axis=1)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    r = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) / np.maximum(sides, 1e-300)
    h, w = hf.shape
    pts = np.concatenate([tri, tri.mean(axis=1, keepdims=True)], axis=1).reshape(-1, 2)
    rows, cols = hf.world_to_pixel(pts[:, 0], pts[:, 1])
    rows = np.clip(np.rint(rows), 0, h - 1).astype(np.int64)
    cols = np.clip(np.rint(cols), 0, w - 1).astype(np.int64)
    fastest = speed[rows, cols].reshape(-1, 4).max(axis=1)
    with np.errstate(divide="ignore"):
        return np.where(fastest > 0, r / np.where(fastest > 0, fastest, 1.0), np.inf)


def step_report(mesh: TerrainMesh, hf: Heightfield, speed: np.ndarray, step: float) -> dict:
    """The smallest of :func:`triangle_steps`, and how many fall below ``step``."""
    if not mesh.n_triangles:
        return {"min_step": math.nan, "below_step": 0}
    steps = triangle_steps(mesh, hf, speed)
    below = int((steps < step * (1 - 1e-9)).sum()) if math.isfinite(step) else 0
    return {"min_step": float(steps.min()), "below_step": below}


def relaxed_report(mesh: TerrainMesh, hf: Heightfield, max_error: float) -> dict:
    """Where the floor relaxed the error bound: the triangles whose largest error over the valid cells they
    cover exceeds ``max_error``, their count, plan-view area (and its share) and the worst cell."""
    err, at = _triangle_errors(mesh, hf)
    w = hf.shape[1]
    over = err > max_error * (1 + REPORT_TOLERANCE)
    xy = mesh.vertices[mesh.triangles][:, :, :2]
    e1, e2 = xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    report = {"bound": max_error, "triangles": int(over.sum()), "area": float(area[over].sum()),
              "area_share": float(area[over].sum() / area.sum()) if area.sum() > 0 else 0.0,
              "max_error": float(err.max()) if len(err) else 0.0, "worst_cell": None}
    if over.any():
        k = int(np.argmax(err))
        r, c = divmod(int(at[k]), w)
        x, y = hf.pixel_to_world(np.array([float(r)]), np.array([float(c)]))
        report["worst_cell"] = {"row": r, "col": c, "x": float(x[0]), "y": float(y[0]), "error": float(err[k])}
    return report


def _triangle_errors(mesh: TerrainMesh, hf: Heightfield) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle: the largest |mesh - DEM| over the valid cells it covers, and that cell (flat index, -1: none)."""
    from ...kernels.raster import triangle_errors
    from ...triangulation.sampling import _snap

    rows, cols = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    h, w = hf.shape
    return triangle_errors(_snap(cols), _snap(rows), mesh.vertices[:, 2].copy(), mesh.triangles,
                           np.ascontiguousarray(hf.z, np.float64).ravel(), np.ascontiguousarray(hf.valid).ravel(), h, w)


def stream_breaklines(hf: Heightfield, lines: list[np.ndarray], floor: np.ndarray) -> list[np.ndarray]:
    """The stream lines as breaklines that leave room for triangles at the floor.

    Each line's clearance is :data:`STREAM_SPACING` times the largest floor along it (at least one cell; an
    equilateral triangle with inradius r has sides of 2 sqrt(3) r).  Longest first, each line keeps the parts
    farther than its clearance from the lines kept before it and from the edge of the data, simplified to
    within one cell (Douglas-Peucker: a D8 staircase becomes straight runs), its vertices at least the
    clearance apart.  So a tributary stops short of the stream it joins and a stream short of the outline:
    segments meeting at a small angle, or running close together, would make refinement cut ever smaller
    triangles between them, whatever the floor.  What is left out is still meshed under the error bound.
    """
    import shapely

    from ..quality.regions import _data_area

    cell = min(abs(float(v)) for v in hf.cell_size)
    h, w = hf.shape

    def to_world(xy):  # pixel (col, row) -> world
        x, y = hf.pixel_to_world(xy[:, 1], xy[:, 0])
        return np.column_stack([x, y])

    data = shapely.transform(_data_area(hf), to_world)
    items = []
    for line in lines:
        xy = np.asarray(line, np.float64)[:, :2]
        rows, cols = hf.world_to_pixel(xy[:, 0], xy[:, 1])
        r = np.clip(np.rint(rows), 0, h - 1).astype(np.int64)
        c = np.clip(np.rint(cols), 0, w - 1).astype(np.int64)
        items.append((shapely.linestrings(xy), max(float(STREAM_SPACING * floor[r, c].max()), cell)))
    items.sort(key=lambda item: -shapely.length(item[0]))
    kept, taken = [], shapely.Polygon()
    for line, gap in items:
        part = shapely.intersection(shapely.difference(line, shapely.buffer(taken, gap)), shapely.buffer(data, -gap))
        for piece in shapely.get_parts(shapely.line_merge(part) if shapely.get_type_id(part) == 5 else part):
            if shapely.get_type_id(piece) != 1 or shapely.length(piece) < 2 * gap:
                continue
            xy = shapely.get_coordinates(shapely.simplify(piece, cell))
            keep = [0]
            for i in range(1, len(xy) - 1):
                if np.hypot(*(xy[i] - xy[keep[-1]])) >= gap:
                    keep.append(i)
            if len(keep) > 1 and np.hypot(*(xy[-1] - xy[keep[-1]])) < gap:
                keep.pop()
            keep.append(len(xy) - 1)
            kept.append(xy[keep])
            taken = shapely.union(taken, shapely.linestrings(xy[keep]))
    return kept


def _extended(hf: Heightfield, line: np.ndarray, both: bool = False) -> np.ndarray:
    """A stream carried 1.5 cells on past its last vertex (``both``: and back past its first), so that a stream
    that ends on the outline (a derived stream at its outlet cell, a given one clipped to the data) crosses it."""
    line = np.asarray(line, np.float64)[:, :2]
    cell = max(abs(float(v)) for v in hf.cell_size)

    def beyond(a, b):  # the point 1.5 cells past b, from a
        step = b - a
        length = float(np.hypot(*step))
        return None if length == 0.0 else b + step * (1.5 * cell / length)

    end = beyond(line[-2], line[-1])
    start = beyond(line[1], line[0]) if both else None
    return np.vstack([p for p in (start, *line, end) if p is not None])
