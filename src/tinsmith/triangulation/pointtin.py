"""The TIN of a point cloud: the 2.5-D Delaunay triangulation of its points, cut to their concave outline.

``tinsmith.tin(cloud)`` is what lidR's ``tin()``, PDAL's
``filters.delaunay``, LAStools' ``las2tin`` and startinpy give: every kept
point a vertex, no gridding, so sparse ground under a canopy stays covered.
It runs on the robust incremental kernel of :mod:`tinsmith.kernels.tin`
(exact predicates, biased randomised insertion order).

The outline is a concave hull by edge length (the "chi-shape" of Duckham et
al. 2008, with holes): every triangle with an edge longer than ``max_edge``
is removed.  Removing them peels the convex hull's long border triangles
from the border inwards and opens every gap wider than ``max_edge`` inside
(a lake, a building footprint in a ground class), while the triangles of
sparse patches, whose edges are shorter, stay.

``max_edge="auto"`` is :data:`AUTO_EDGE_FACTOR` times the median edge length
of the full triangulation, the typical spacing of the points where they are
dense; see :func:`auto_max_edge` for how it was chosen.

Constraints come from vectors (:mod:`.pointconstraints`): breaklines (3-D,
or 2-D lines draped on the TIN) and polygons that are holes or flat water
surfaces.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import _checks
from .._threads import thread_map
from ..core import PointCloud, TerrainMesh
from ..core.pointcloud import class_codes
from ..errors import InvalidInputError, InvalidOptionError, NoDataError
from ..kernels import ahead
from ..resources import check_memory, release_free_memory
from .strips import Triangles, n_strips, triangles_of, triangulate_unique

kpt = ahead.load("tinsmith.kernels.pointtin")
ks = ahead.load("tinsmith.kernels.strips")

__all__ = [
    "PointTin", "auto_max_edge", "auto_max_edge_of", "build_point_tin", "checked_points", "is_hull", "kept_points",
    "point_tin", "prepare_points", "tin",
]

#: ``max_edge="auto"``: this many times the median edge length of the full triangulation.
AUTO_EDGE_FACTOR = 12.0
#: Peak bytes per kept point of :func:`build_point_tin` (what greedy starts from: vertices, twins, flags,
#: labels, then the outline's cut).  Measured peak growth on Delft AHN3's 849k points: 172 bytes a point on
#: one worker, 205 on two (threads keep some freed memory each), with a margin on top; :func:`tin` without
#: constraints takes far less (:func:`tin_mesh_bytes`).
TIN_BYTES_PER_POINT = 240
DUPLICATE_RULES = ("lowest", "highest", "mean")


def kept_points(cloud: PointCloud, classes=None, needs=None) -> np.ndarray:
    """(N, 3) the points of the kept classes, after checking that their TIN fits in memory.

    ``needs(n)``: the peak bytes of the TIN of ``n`` points (default
    :data:`TIN_BYTES_PER_POINT` a point, that of :func:`build_point_tin`).
    """
    if not isinstance(cloud, PointCloud):
        raise InvalidInputError(f"tin needs a PointCloud, got {type(cloud).__name__}")
    codes = class_codes(classes)
    if codes is not None:
        cloud = cloud.filter_classes(codes)
    xyz = cloud.xyz
    needed = TIN_BYTES_PER_POINT * len(xyz) if needs is None else needs(len(xyz))
    check_memory(needed, f"the TIN of {len(xyz):,} points",
                 "keep fewer points (classes), or mesh the survey in tiles with 'tinsmith tile'")
    return xyz


def tin_mesh_bytes(n_points: int, workers: int | None = 1) -> float:
    """Peak bytes of :func:`tin_mesh` on ``n_points`` points, beyond the points, with a fifth on top.

    The int32 triangles (24 bytes a point) and the duplicates map and border
    marks (5) are held throughout; on top come first the triangulations of
    the strips that run at once (about 136 bytes a point of a strip each),
    then, once they are freed, the mesh's own coordinates (24) and the marks
    of the kept triangles (about 8).  Measured (docs/lidar.md), on two
    workers: 59 bytes a point on Delft AHN3's 849k points (this gives 76),
    43 on the 4.5M of a survey's file (73), 155 on the 37,657 of lidR's
    MixedConifer, in 2 strips at once (198).
    """
    k = n_strips(n_points)
    running = min(_checks.workers(workers), k) / k
    return 1.2 * n_points * max(29 + 136 * running, 24 + 5 + 24 + 8)


def prepare_points(cloud: PointCloud, classes=None, duplicates: str = "lowest") -> tuple[np.ndarray, int]:
    """The points a TIN answers for: the kept classes, one point per x-y (``duplicates`` picks its z).

    Returns ``(xyz, merged)``: (N, 3) float64 points sorted by x then y, and
    the number of points merged into others.  (:func:`build_point_tin` merges
    the same way while it triangulates, from the triangulation's own
    detection of points at one place, without this sort.)
    """
    duplicates = _checks.choice("duplicates", duplicates, DUPLICATE_RULES)
    xyz = kept_points(cloud, classes)
    order = np.lexsort((xyz[:, 1], xyz[:, 0]))
    s = xyz[order]
    new = np.r_[True, (s[1:, 0] != s[:-1, 0]) | (s[1:, 1] != s[:-1, 1])]
    if new.all():
        return s, 0
    starts = np.flatnonzero(new)
    z = s[:, 2]
    if duplicates == "lowest":
        zz = np.minimum.reduceat(z, starts)
    elif duplicates == "highest":
        zz = np.maximum.reduceat(z, starts)
    else:
        zz = np.add.reduceat(z, starts) / np.diff(np.r_[starts, len(z)])
    out = s[starts].copy()
    out[:, 2] = zz
    return out, int(len(s) - len(out))


def auto_max_edge(median_edge: float) -> float:
    """``max_edge="auto"``: :data:`AUTO_EDGE_FACTOR` x the median edge length.

    The median edge is the spacing of the points where they are dense (open
    ground), whatever the share of sparse or empty area.  The factor was
    chosen on the ground class of the shared clouds (lidR Topography and
    MixedConifer, Autzen, Delft AHN3): it keeps the sparse ground under a
    closed canopy covered (gaps up to about 12 spacings) and opens lakes and
    building footprints, which are wider (figures in docs/lidar.md).
    """
    return AUTO_EDGE_FACTOR * median_edge


def is_hull(max_edge) -> bool:
    """Whether the ``max_edge`` option keeps the convex hull (None or "none"): no outline to cut."""
    return max_edge is None or (isinstance(max_edge, str) and max_edge.lower() == "none")


def max_edge_value(max_edge, median_edge: float) -> float | None:
    """The ``max_edge`` option as a length (None: keep the convex hull)."""
    if is_hull(max_edge):
        return None
    if isinstance(max_edge, str):
        if max_edge.lower() != "auto":
            raise InvalidOptionError(f"max_edge must be 'auto', a length > 0 or 'none', got {max_edge!r}")
        return auto_max_edge(median_edge)
    return _checks.number("max_edge", max_edge, minimum=0.0, exclusive_min=True)


#: :meth:`PointTin.to_mesh` and :func:`tin_mesh` hand freed memory back to the system for triangulations of
#: this many triangles or more, before the mesh's coordinates are made (Delft AHN3's 849k points: 43 MB less
#: peak for the first, 11 bytes a point for the second on one worker).  Below, the strips' buffers are a few
#: MB and handing them back costs more than they weigh: the call, and the mesh's arrays then made on fresh
#: pages (a page's first touch costs about 2 us here), took 2.1 ms of lidR's MixedConifer's 22 ms TIN on two
#: workers (37,657 points, 75k triangles), 1.5 of 33 on one.
RELEASE_TRIANGLES = 1 << 17


def _release_after(n_triangles: int) -> None:
    """Hand freed memory back to the system after a triangulation of ``n_triangles`` (from :data:`RELEASE_TRIANGLES`)."""
    if n_triangles >= RELEASE_TRIANGLES:
        release_free_memory()


@dataclass
class PointTin:
    """A full TIN of points with its kept region: what :func:`tin` returns as a mesh and greedy starts from.

    ``m`` is the kernel's triangulation tuple (vertex ``i`` is point ``i``
    of ``xyz``; constraint vertices follow the points); ``keep`` marks the
    triangles inside the outline; ``constrained`` lists (E, 2) vertex pairs
    that must stay edges (breaklines, shores, hole rims); ``median_edge`` is
    the median edge of the full TIN, before any constraint (None where not
    measured).
    """

    xyz: np.ndarray
    m: tuple
    keep: np.ndarray
    max_edge: float | None
    merged: int
    constrained: np.ndarray = field(default_factory=lambda: np.empty((0, 2), np.int64))
    info: dict = field(default_factory=dict)
    median_edge: float | None = None

    @property
    def n_triangles(self) -> int:
        return int(self.m[9][1])

    @property
    def triangles(self) -> np.ndarray:
        return self.m[2][: 3 * self.n_triangles].reshape(-1, 3)

    def outline_edges(self) -> np.ndarray:
        """(E, 2) vertex pairs (a, b) of the outline, the kept side on the left of a -> b."""
        n = self.n_triangles
        twin = self.m[3][: 3 * n]
        keep3 = np.repeat(self.keep, 3)
        across = np.zeros(3 * n, bool)
        joined = twin >= 0
        across[joined] = keep3[twin[joined]]
        e = np.flatnonzero(keep3 & ~across)
        tri = self.m[2]
        nxt = e - e % 3 + (e + 1) % 3
        return np.column_stack([tri[e], tri[nxt]]).astype(np.int64)

    def to_mesh(self, crs=None, *, release: bool = False) -> TerrainMesh:
        """The kept triangles as a mesh over the points they use; ``release`` frees the triangulation first
        (the PointTin is spent: what :func:`tin` does, whose peak memory is then that of the mesh, not both)."""
        tri = self.m[2]
        if release:
            n_triangles = self.n_triangles
            self.m = None
            _release_after(n_triangles)
        triangles = np.empty((int(np.count_nonzero(self.keep)), 3), np.int32)
        used, _ = kpt.kept_mesh(tri, self.keep, len(self.xyz), triangles)
        del tri
        cons = self.constrained
        vertices = self.xyz if used.all() else self.xyz[used]
        if len(cons) and not used.all():
            cons = (np.cumsum(used) - 1)[cons[used[cons].all(axis=1)]]
        info = _mesh_info(self.max_edge, len(self.xyz), self.merged, len(vertices), self.info)
        return TerrainMesh(vertices, triangles, crs=crs, info=info, constrained_edges=cons)


def _mesh_info(max_edge, points: int, merged: int, vertices: int, more: dict) -> dict:
    """The ``info`` of a TIN's mesh (see :func:`tin`)."""
    return {"max_edge": max_edge, "points": int(points), "duplicates_merged": merged,
            "points_outside": int(points - vertices), **more}


#: Points whose spread across their main direction is below this share of the spread along it lie
#: on one line (up to the rounding of their coordinates): their TIN would be slivers of no area.
MIN_SPREAD = 1e-7


def _check_spread(xyz: np.ndarray) -> None:
    sxx, sxy, syy = kpt.xy_covariance(xyz)
    low, high = np.linalg.eigvalsh(np.array([[sxx, sxy], [sxy, syy]]))
    if high <= 0:
        raise NoDataError(f"a TIN needs at least 3 points with distinct x-y; all {len(xyz):,} points lie at one x-y")
    if np.sqrt(max(low, 0.0)) < MIN_SPREAD * np.sqrt(high):
        raise InvalidInputError(f"the {len(xyz):,} points lie on one line (in x-y); a TIN needs points that span an area")


def auto_max_edge_of(xyz: np.ndarray, *, duplicates: str = "lowest", workers: int | None = 1) -> float:
    """``max_edge="auto"`` of (N, 3) points: :func:`auto_max_edge` of the median edge of their full TIN."""
    return auto_max_edge(build_point_tin(xyz, duplicates=duplicates, max_edge=None, workers=workers).median_edge)


def build_point_tin(xyz: np.ndarray, *, duplicates: str = "lowest", max_edge="auto", constraints=None,
                    workers: int | None = 1) -> PointTin:
    """The full TIN of (N, 3) points and its kept region (see :class:`PointTin`).

    Points at one x-y become one vertex whose height the ``duplicates`` rule
    picks; the vertices keep the order of the points.  ``constraints``, when
    given, is a :class:`.pointconstraints.Constraints` whose breaklines and
    polygons go into the triangulation before the outline is cut.  The
    triangulation is the unique Delaunay one (ties broken by perturbation),
    made in strips on ``workers`` threads (:mod:`.strips`): the same on any
    number of them.
    """
    rule = DUPLICATE_RULES.index(_checks.choice("duplicates", duplicates, DUPLICATE_RULES))
    if constraints is not None:
        xyz = constraints.prepare(xyz)
    _checked_count(xyz)
    m, same, made = triangulate_unique(np.ascontiguousarray(xyz[:, :2]), workers)
    merged = int(ks.merged_count(same))
    if merged:
        z = np.array(xyz[:, 2], np.float64)
        _, kept = kpt.merge_duplicates(m, same, z, rule)
        xyz = np.column_stack([m[0][:kept], m[1][:kept], z[:kept]])
    median = edge_median(m[0], m[1], triangles_of(m), _checks.workers(workers))
    tin_ = PointTin(xyz, m, np.ones(0, bool), None, merged, info={"strips": made["strips"]}, median_edge=median)
    limit = max_edge_value(max_edge, median)
    if constraints is not None:
        constraints.apply(tin_, median)
    keep = _short(tin_.m[0], tin_.m[1], tin_.m[2], tin_.n_triangles, limit)
    if constraints is not None:  # flat polygons keep their triangles whatever their edges
        keep = constraints.cut(tin_, keep, limit)
    tin_.keep = _any_kept(keep, limit)
    tin_.max_edge = limit
    return tin_


#: The median edge is counted in parts of at least this many triangles, a part a worker.
PART_TRIANGLES = 1 << 15
#: Its bins span the squared edge lengths of a sample of about this many triangles (the span decides how
#: fast the median is found, not its value).
SAMPLED_TRIANGLES = 1024


def edge_median(px: np.ndarray, py: np.ndarray, t: Triangles, workers: int = 1) -> float:
    """The median horizontal length of the edges of the triangles ``t`` over the points ``px``, ``py``.

    The same value as ``np.median`` of every edge's length once, without a
    lengths array: the squared lengths of the halfedges and of the hull's
    edges once more (each edge twice, which leaves the median as it is) are
    counted in :data:`.kernels.pointtin.MEDIAN_BINS` even bins between the
    1st and 99th percentiles of a sample's (the rest in the outer bins),
    parts of the triangles on ``workers`` threads, and only the values in
    the bins that hold the middle are gathered and sorted.
    """
    tri = t.tri[: 3 * t.n].reshape(-1, 3)
    corners = tri[:: max(1, t.n // SAMPLED_TRIANGLES)]
    ends = np.roll(corners, -1, axis=1)  # each corner's edge runs to the next corner
    sample = np.sort(((px[corners] - px[ends]) ** 2 + (py[corners] - py[ends]) ** 2).ravel())
    low, high = sample[len(sample) // 100], sample[-1 - len(sample) // 100]
    if not high > low:
        low, high = sample[0], sample[-1]
    scale = (kpt.MEDIAN_BINS - 1) / (high - low) if high > low else 0.0
    k = max(1, min(workers, t.n // PART_TRIANGLES))
    # part p: a slice of the triangles, and the hull's edges for the first (the whole array with bounds, or the
    # hull shared out too, made LLVM's code for the triangles' loop 6-25% slower on Delft)
    parts = []
    for p in range(k):
        a, b = p * t.n // k, (p + 1) * t.n // k
        parts.append((px, py, t.tri[3 * a:3 * b], b - a, t.hull if p == 0 else t.hull[:0], float(low), scale))
    counts = thread_map(lambda part: kpt.edge_counts(*part), parts, workers)
    below = np.cumsum(np.sum(counts, axis=0))  # values in the bins up to each
    n = int(below[-1])
    first, last = np.searchsorted(below, [(n - 1) // 2, n // 2], side="right")  # the bins of the middle value(s)
    skipped = int(below[first - 1]) if first else 0
    middle = np.sort(np.concatenate(thread_map(
        lambda p: kpt.edge_middle(*parts[p], first, last, int(counts[p][first:last + 1].sum())), range(k), workers)))
    return float((np.sqrt(middle[(n - 1) // 2 - skipped]) + np.sqrt(middle[n // 2 - skipped])) / 2)


def _short(px, py, tri, n_tri: int, limit: float | None) -> np.ndarray:
    """(n_tri,) bool: the triangles with no edge longer than ``limit`` (all of them for None)."""
    return np.ones(n_tri, bool) if limit is None else kpt.short_triangles(px, py, tri, n_tri, limit)


def _any_kept(keep: np.ndarray, limit: float | None) -> np.ndarray:
    """``keep``, refused when it keeps no triangle."""
    if not keep.any():
        raise NoDataError(
            f"every triangle has an edge longer than max_edge {limit:g}; the points are too sparse for it "
            "(raise max_edge, or pass max_edge=None for the convex hull)"
        )
    return keep


def _checked_count(xyz: np.ndarray) -> None:
    if len(xyz) < 3:
        raise NoDataError(f"a TIN needs at least 3 points with distinct x-y, got {len(xyz)}")
    _check_spread(xyz)


def tin_mesh(xyz: np.ndarray, *, duplicates: str = "lowest", max_edge="auto", workers: int | None = 1,
             crs=None) -> TerrainMesh:
    """The mesh of :func:`build_point_tin` without constraints, made from the triangles alone.

    The same mesh as ``build_point_tin(...).to_mesh()`` (the same
    triangulation, duplicates, median edge and outline), in less memory:
    no twins, no copy of the coordinates, the median edge counted from the
    triangles, the kept triangles compacted in place into the mesh's int32
    ones.  Peak memory growth is measured in docs/lidar.md.
    """
    rule = DUPLICATE_RULES.index(_checks.choice("duplicates", duplicates, DUPLICATE_RULES))
    _checked_count(xyz)
    t, same, made = triangulate_unique(xyz[:, :2], workers, twins=False)
    merged = int(ks.merged_count(same))
    # merged points are left unused by the triangles: their group's lowest index stands for them
    groups = kpt.folded_heights(same, xyz[:, 2], rule) if merged else (np.empty(0, np.int64), np.empty(0))
    del same
    _release_after(t.n)  # the strips' freed buffers, before the mesh's coordinates are made
    px, py = xyz[:, 0], xyz[:, 1]
    median = edge_median(px, py, t, _checks.workers(workers))
    limit = max_edge_value(max_edge, median)
    keep = _any_kept(_short(px, py, t.tri, t.n, limit), limit)
    rows = t.tri[: 3 * t.n].reshape(-1, 3)
    used, count = kpt.kept_mesh(t.tri, keep, len(xyz), rows)
    del keep, t
    vertices = xyz if used.all() else kpt.used_points(xyz, used, *groups)
    info = _mesh_info(limit, len(xyz) - merged, merged, len(vertices), {"strips": made["strips"]})
    return TerrainMesh(vertices, rows[:count], crs=crs, info=info)


def tin(cloud: PointCloud, *, classes=None, duplicates: str = "lowest", max_edge="auto", breaklines=None,
        holes=None, flat=None, workers: int | None = None) -> TerrainMesh:
    """The 2.5-D Delaunay TIN of the points of a cloud, cut to their concave outline.

    A triangulation, not a registered method: every point is a vertex, so it
    takes no stop rule (:func:`tinsmith.methods` does not list it).  The
    method on the points is :func:`tinsmith.greedy`, which starts from this
    TIN's outline and takes the same outline options.

    Parameters
    ----------
    cloud : PointCloud
    classes : iterable of int, optional
        ASPRS classes to keep (``[2]`` for ground); default every point.
    duplicates : {"lowest", "highest", "mean"}
        Points with the same x-y become one vertex with the lowest, highest or
        mean height (a ground TIN wants the lowest).
    max_edge : "auto", float or None
        Triangles with an edge longer than this are removed, from the border
        inwards and around every wider gap (see the module notes).  "auto":
        :data:`AUTO_EDGE_FACTOR` x the median edge length.  None keeps the
        convex hull.
    breaklines : list of (K, 2) or (K, 3) array_like, optional
        Polylines kept as edges: 3-D lines keep their heights; 2-D lines are
        draped on the TIN (densified at the median edge length first).
    holes : list of polygons, optional
        Areas left open.  A polygon is a shapely (Multi)Polygon or a (K, 2)
        ring in world coordinates.
    flat : list of polygons, optional
        Areas meshed as one flat surface at the level of their shore (a lake,
        a river): the rim is constrained at the low percentile of the heights
        of the points along the shore, and the points inside are left out.
    workers : int or None
        Threads that triangulate (None: every core).  The points are cut into
        strips by their number alone, triangulated apart and merged exactly,
        so the mesh is the same, triangle for triangle and in the same order,
        on any number of workers (:mod:`tinsmith.triangulation.strips`).

    Returns
    -------
    TerrainMesh
        Every kept point inside the outline is a vertex.  ``info`` holds
        ``max_edge`` (the length used), ``points``, ``duplicates_merged``,
        ``points_outside`` (points only removed triangles used) and
        ``constrained_edges``.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> rng = np.random.default_rng(1)
    >>> xy = rng.uniform(0.0, 100.0, size=(1000, 2))
    >>> cloud = tinsmith.PointCloud(np.column_stack([xy, 0.05 * xy.sum(axis=1)]))
    >>> mesh = tinsmith.tin(cloud)
    >>> mesh.n_vertices  # every point inside the outline is a vertex
    1000
    >>> mesh.check()
    []
    >>> hull = tinsmith.tin(cloud, max_edge=None)  # the convex hull, nothing cut
    >>> hull.n_triangles >= mesh.n_triangles
    True
    """
    if breaklines is None and holes is None and flat is None:
        xyz = kept_points(cloud, classes, lambda n: tin_mesh_bytes(n, workers))
        return tin_mesh(xyz, duplicates=duplicates, max_edge=max_edge, workers=workers, crs=cloud.crs)
    return point_tin(cloud, classes=classes, duplicates=duplicates, max_edge=max_edge, breaklines=breaklines,
                     holes=holes, flat=flat, workers=workers).to_mesh(cloud.crs, release=True)


def point_tin(cloud: PointCloud, *, classes=None, duplicates: str = "lowest", max_edge="auto", breaklines=None,
              holes=None, flat=None, control_points=None, workers: int | None = 1) -> PointTin:
    """The :class:`PointTin` of a cloud with its options (what :func:`tin` meshes and greedy starts from)."""
    xyz = kept_points(cloud, classes)
    constraints = None
    if any(v is not None for v in (breaklines, holes, flat, control_points)):
        from .pointconstraints import Constraints  # here: a TIN without constraints does not import it

        constraints = Constraints(breaklines, holes=holes, flat=flat, points=control_points)
    return build_point_tin(xyz, duplicates=duplicates, max_edge=max_edge, constraints=constraints, workers=workers)


def checked_points(cloud: PointCloud, duplicates: str = "lowest", *, holes=None, flat=None) -> np.ndarray:
    """(N, 3) the points a point TIN or greedy run answers for: one a x-y (``duplicates``), none inside holes or flat polygons."""
    xyz, _ = prepare_points(cloud, None, duplicates)
    if holes is not None or flat is not None:
        from .pointconstraints import Constraints

        xyz = Constraints(holes=holes, flat=flat).prepare(xyz)
    return xyz
