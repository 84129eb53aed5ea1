"""Constraints of a point-cloud TIN from vectors: breaklines, polygons left open, flat water polygons.

Used by :func:`tinsmith.tin` and greedy insertion on points
(:mod:`.pointtin`, :mod:`tinsmith.algorithms.greedy.greedy_points`):

- **breaklines**: 3-D lines keep their heights; 2-D lines are densified at
  the median edge length of the TIN and draped on it (linear interpolation
  in the triangle under each new vertex).  Their segments become
  constrained edges (Sloan's flips, :mod:`tinsmith.kernels.tin`).
- **holes**: the points inside are dropped, the rim is draped and
  constrained, and the triangles inside are cut out of the mesh.
- **flat**: a lake or a river.  The points inside are dropped; the rim gets
  one height, the :data:`SHORE_PERCENTILE` percentile of the points in a band
  :data:`SHORE_BAND` edge lengths wide outside it (the water line is the
  low side of the shore); the inside is meshed from the rim alone, so it is
  flat, and it is never cut by ``max_edge``.
- **points** (control points): draped and kept as vertices.

Geometry is clipped to the convex hull of the points first; a polygon
that does not reach the points is skipped, and when none of a kind does,
that is an error naming it.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from ..errors import InvalidInputError, NoDataError, require
from ..kernels import ahead
from .delaunay import buffers

ktin = ahead.load("tinsmith.kernels.tin")
_greedy_points = ahead.load("tinsmith.kernels.greedy_points")

__all__ = ["Constraints"]

#: Flat polygons: the level is this percentile of the shore points' heights ...
SHORE_PERCENTILE = 10.0
#: ... in a band this many median edge lengths wide outside the rim.
SHORE_BAND = 3.0


def _as_polygons(shapely, name: str, items):
    """Shapely polygons from a list of polygons or (K, 2) rings."""
    if items is None:
        return []
    if isinstance(items, np.ndarray) or not isinstance(items, (list, tuple)):
        items = [items]
    out = []
    for i, item in enumerate(items):
        geom = item if hasattr(item, "geom_type") else None
        if geom is None:
            ring = np.asarray(item, dtype=np.float64)
            if ring.ndim != 2 or ring.shape[1] < 2 or len(ring) < 3 or not np.isfinite(ring).all():
                raise InvalidInputError(f"{name}[{i}] must be a polygon or a finite (K, 2) ring of 3 points or more")
            geom = shapely.Polygon(ring[:, :2])
        parts = shapely.get_parts(shapely.make_valid(shapely.force_2d(geom)))
        out += [p for p in parts if p.geom_type == "Polygon" and p.area > 0]
    return out


def _dissolve(shapely, polygons: list, minus=()) -> list:
    """The polygons merged where they overlap or touch (less ``minus``), as separate polygons again."""
    if len(polygons) < 2 and not minus:
        return polygons
    merged = shapely.union_all(polygons)
    if minus:
        merged = shapely.difference(merged, shapely.union_all(minus))
    return [p for p in shapely.get_parts(merged) if p.geom_type == "Polygon" and p.area > 0]


def _as_lines(name: str, items):
    if items is None:
        return []
    if isinstance(items, np.ndarray) and items.ndim == 2:
        items = [items]
    lines = []
    for i, line in enumerate(items):
        arr = np.asarray(line, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[1] not in (2, 3) or len(arr) < 2 or not np.isfinite(arr).all():
            raise InvalidInputError(f"{name}[{i}] must be a finite (K, 2) or (K, 3) polyline of 2 points or more")
        lines.append(arr)
    return lines


def _densify(xy: np.ndarray, step: float) -> np.ndarray:
    """The polyline with extra vertices so that no segment is longer than ``step``."""
    out = [xy[:1]]
    for a, b in pairwise(xy):
        k = max(1, int(np.ceil(np.hypot(*(b - a)[:2]) / step)))
        t = np.arange(1, k + 1)[:, None] / k
        out.append(a + t * (b - a))
    return np.concatenate(out)


class Constraints:
    """Breaklines, holes, flat polygons and control points for a point TIN (see the module notes)."""

    def __init__(self, breaklines=None, *, holes=None, flat=None, points=None):
        self.shapely = require("shapely", "vector", "constraints of a point TIN")
        self.lines = _as_lines("breaklines", breaklines)
        # overlapping polygons of a kind are one area (their rims would cross); a hole wins over water
        self.holes = _dissolve(self.shapely, _as_polygons(self.shapely, "holes", holes))
        self.flat = _dissolve(self.shapely, _as_polygons(self.shapely, "flat", flat), self.holes)
        self.points = None
        if points is not None:
            pts = np.asarray(points, dtype=np.float64)
            if pts.ndim != 2 or pts.shape[1] < 2 or not np.isfinite(pts).all():
                raise InvalidInputError(f"control_points must be finite (K, 2) world coordinates, got shape {pts.shape}")
            self.points = pts[:, :2]
        self._levels: list[float] = []

    # -- before the triangulation ------------------------------------------------------------
    def prepare(self, xyz: np.ndarray) -> np.ndarray:
        """Drop the points inside holes and flat polygons; fix the flat polygons' levels (needs the points)."""
        shapely = self.shapely
        hull = shapely.MultiPoint(xyz[:, :2]).convex_hull
        # strictly inside the hull, so that every constraint vertex falls on a triangle
        self._inner = inner = hull.buffer(-1e-9 * max(1.0, np.sqrt(hull.area)))
        for name, polys in (("holes", self.holes), ("flat", self.flat)):
            if polys and not any(p.intersects(inner) for p in polys):
                raise InvalidInputError(f"no polygon of {name} overlaps the points (they lie within {_box(xyz)})")
        self.holes = [g for p in self.holes if p.intersects(inner)
                      for g in shapely.get_parts(p.intersection(inner)) if g.geom_type == "Polygon"]
        self.flat = [g for p in self.flat if p.intersects(inner)
                     for g in shapely.get_parts(p.intersection(inner)) if g.geom_type == "Polygon"]
        polys = self.holes + self.flat
        if not polys:
            return xyz
        inside = np.zeros(len(xyz), bool)
        for p in polys:
            inside |= shapely.contains_xy(p, xyz[:, 0], xyz[:, 1])
        return xyz[~inside]

    # -- on the triangulation ------------------------------------------------------------------
    def apply(self, tin_, spacing: float) -> None:
        """Insert every constraint into ``tin_.m`` (growing ``tin_.xyz``), recording ``tin_.constrained``."""
        self._spacing = spacing
        chains = []  # (name, (K, 3) vertices)
        for i, line in enumerate(self.lines):
            chains += [(f"breaklines[{i}]", c) for c in self._line_chains(tin_, line)]
        for name, polys in (("holes", self.holes), ("flat", self.flat)):
            for i, poly in enumerate(polys):
                level = self._shore_level(tin_, poly) if name == "flat" else None
                for ring in [poly.exterior, *poly.interiors]:
                    xy = _densify(np.asarray(ring.coords)[:, :2], spacing)
                    z = np.full(len(xy), level) if level is not None else self._drape(tin_, xy)
                    chains.append((f"{name}[{i}]", np.column_stack([xy, z])))
        singles = []
        if self.points is not None:
            pts = self.points
            inside = self.shapely.contains_xy(self._inner, pts[:, 0], pts[:, 1])
            if not inside.any():
                raise InvalidInputError(f"no control point lies on the points (they lie within {_box(tin_.xyz)})")
            pts = pts[inside]
            singles.append(np.column_stack([pts, self._drape(tin_, pts)]))
        segments, names = [], []
        for name, chain in chains:
            ids = self._insert(tin_, chain)
            keep = np.r_[True, ids[1:] != ids[:-1]]
            ids = ids[keep]
            segments += list(pairwise(ids.tolist()))
            names += [name] * (len(ids) - 1)
        for pts in singles:
            self._insert(tin_, pts)
        if segments:
            seg = np.asarray(segments, np.int64)
            m = tin_.m
            stack = np.empty(64, np.int32)
            failed, _, _ = ktin.insert_segments(m, seg[:, 0].copy(), seg[:, 1].copy(), stack, np.empty(64, np.int32))
            if failed >= 0:
                x, y = tin_.xyz[seg[failed, 0], :2]
                raise InvalidInputError(
                    f"{names[failed]} crosses another breakline or polygon rim near ({x:.10g}, {y:.10g}) away from "
                    "their vertices; split them where they cross"
                )
            tin_.constrained = np.unique(np.sort(seg, axis=1), axis=0)

    def _line_chains(self, tin_, line: np.ndarray) -> list[np.ndarray]:
        """The parts of a breakline inside the points' hull, (K, 3), 2-D lines densified and draped."""
        shapely = self.shapely
        geom = shapely.LineString(line)
        clipped = geom.intersection(self._inner)
        out = []
        for part in shapely.get_parts(clipped):
            if part.geom_type != "LineString" or part.length == 0:
                continue
            c = np.asarray(part.coords)
            if line.shape[1] == 3:
                out.append(c if c.shape[1] == 3 else np.column_stack([c, self._drape(tin_, c)]))
            else:
                xy = _densify(c[:, :2], self._spacing)
                out.append(np.column_stack([xy, self._drape(tin_, xy)]))
        return out

    def _shore_level(self, tin_, poly) -> float:
        """The level of a flat polygon: a low percentile of the points in a band outside its rim."""
        shapely = self.shapely
        band = poly.buffer(SHORE_BAND * self._spacing).difference(poly)
        xyz = tin_.xyz
        x0, y0, x1, y1 = band.bounds
        near = np.flatnonzero((xyz[:, 0] >= x0) & (xyz[:, 0] <= x1) & (xyz[:, 1] >= y0) & (xyz[:, 1] <= y1))
        near = near[shapely.contains_xy(band, xyz[near, 0], xyz[near, 1])]
        if len(near) == 0:
            raise NoDataError(
                f"flat polygon at {poly.representative_point().coords[0]} has no points along its shore "
                f"(within {SHORE_BAND * self._spacing:g} of its rim) to take its level from"
            )
        return float(np.percentile(xyz[near, 2], SHORE_PERCENTILE))

    def _drape(self, tin_, xy: np.ndarray) -> np.ndarray:
        """Heights of the TIN at (K, 2) points (the nearest vertex's outside the hull)."""
        m, xyz = tin_.m, tin_.xyz
        tri = m[2]
        z = np.empty(len(xy))
        t = 0
        for k, (x, y) in enumerate(xy[:, :2].tolist()):
            s = ktin.locate(m, x, y, t)
            if s < 0:
                z[k] = xyz[np.argmin(np.hypot(xyz[:, 0] - x, xyz[:, 1] - y)), 2]
                continue
            t = s
            a, b, c = tri[3 * s], tri[3 * s + 1], tri[3 * s + 2]
            z[k] = _greedy_points.plane_height(xyz[a, 0], xyz[a, 1], xyz[a, 2], xyz[b, 0], xyz[b, 1], xyz[b, 2],
                                               xyz[c, 0], xyz[c, 1], xyz[c, 2], x, y)
        return z

    def _insert(self, tin_, pts: np.ndarray) -> np.ndarray:
        """Insert (K, 3) points as vertices (growing the buffers); their vertex ids.

        A point on an existing vertex takes that vertex and gives it its height.
        """
        m = tin_.m
        n0 = int(m[9][0])
        need = n0 + len(pts) + 16
        if need > len(m[0]):
            tin_.m = m = _grow(m, max(need, len(m[0]) * 3 // 2))
        ids, _ = ktin.insert_points(m, pts[:, 0].copy(), pts[:, 1].copy(), np.empty(64, np.int32))
        if (ids < 0).any():
            k = int(np.flatnonzero(ids < 0)[0])
            raise InvalidInputError(f"constraint vertex ({pts[k, 0]:.10g}, {pts[k, 1]:.10g}) lies outside the points")
        n1 = int(m[9][0])
        xyz = np.empty((n1, 3))
        xyz[: len(tin_.xyz)] = tin_.xyz
        xyz[ids] = pts  # new vertices, and old ones a constraint passes through
        xyz[len(tin_.xyz):, :2] = np.column_stack([m[0][len(tin_.xyz): n1], m[1][len(tin_.xyz): n1]])
        tin_.xyz = xyz
        return ids

    # -- after the triangulation ------------------------------------------------------------
    def cut(self, tin_, keep: np.ndarray, limit) -> np.ndarray:
        """Remove the triangles inside holes; keep those inside flat polygons whatever their edges."""
        if not (self.holes or self.flat):
            return keep
        shapely = self.shapely
        tri = tin_.triangles
        c = tin_.xyz[tri].mean(axis=1)
        keep = keep.copy()
        for polys, value in ((self.flat, True), (self.holes, False)):
            for p in polys:
                x0, y0, x1, y1 = p.bounds
                near = np.flatnonzero((c[:, 0] >= x0) & (c[:, 0] <= x1) & (c[:, 1] >= y0) & (c[:, 1] <= y1))
                inside = near[shapely.contains_xy(p, c[near, 0], c[near, 1])]
                keep[inside] = value
        return keep


def _grow(m, cap_v: int):
    """The triangulation tuple with room for ``cap_v`` vertices (contents kept)."""
    new = buffers(cap_v)
    for old, arr in zip(m[:9], new[:9], strict=True):
        arr[: len(old)] = old
    new[9][:] = m[9]
    return new


def _box(xyz: np.ndarray) -> str:
    lo, hi = xyz[:, :2].min(axis=0), xyz[:, :2].max(axis=0)
    return f"x {lo[0]:.10g}..{hi[0]:.10g}, y {lo[1]:.10g}..{hi[1]:.10g}"
