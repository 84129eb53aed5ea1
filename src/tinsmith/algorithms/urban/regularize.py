"""Building outlines people accept: staircases of grid cells made into straight walls at right angles.

A building traced from a raster has an outline of cell edges: a staircase
wherever its walls are not parallel to the grid.  :func:`regularize` turns
it into the outline a cadastre would draw, in the spirit of the
"dominant direction" regularisation of building footprints from LiDAR
(e.g. Sampath and Shan 2007; Zhou and Neumann 2008):

1. the staircase is straightened by Douglas-Peucker within
   :data:`STRAIGHTEN` (1.5) cells (its inner and outer corners lie on two
   lines up to about a cell apart);
2. the building's **dominant direction** is the length-weighted circular
   mean of the straightened edges' directions modulo 90 degrees;
3. every edge within ``angle_tolerance`` of the dominant direction or of
   its perpendicular is turned to it, about the length-weighted centre of
   the cell edges it replaces (so the wall stays where the data put it);
   other edges (a diagonal wing, a rounded corner) keep their direction;
4. consecutive edges of one direction are merged into one wall, and the
   corners are the intersections of consecutive walls, so right angles are
   exact;
5. walls shorter than ``min_edge`` are removed: a short wall between two
   walls that meet is dropped and its neighbours extended; a short jog
   between two parallel walls is removed by merging them into one wall at
   their length-weighted mean offset;
6. the result must be a valid polygon (no self-touching or crossing ring)
   and stay close to the cells (symmetric difference below
   ``max_change`` of the area), else the straightened outline of step 1
   is returned, and if that fails too, the cells' own outline.

Holes (courtyards) are regularised the same way with the building's
dominant direction.  Needs shapely (the ``vector`` extra).
"""

from __future__ import annotations

import numpy as np

from ... import _checks
from ...errors import require

__all__ = ["STRAIGHTEN", "building_direction", "dominant_direction", "regularize"]

#: Douglas-Peucker tolerance (cells) that straightens a staircase: its inner and outer corners lie on two
#: lines up to about one cell apart (at 30 to 60 degrees to the grid), so 1.5 cells leaves one line.
STRAIGHTEN = 1.5


def dominant_direction(rings) -> float:
    """The direction (radians, in [0, pi/2)) most walls of ``rings`` ((N, 2) closed or open coordinate arrays) follow."""
    total = np.zeros(2)
    for ring in rings:
        d = np.diff(np.asarray(ring, dtype=np.float64)[:, :2], axis=0)
        length = np.hypot(d[:, 0], d[:, 1])
        angle = np.arctan2(d[:, 1], d[:, 0])
        # modulo 90 degrees: four times the angle on the circle
        total += np.array([np.sum(length * np.cos(4 * angle)), np.sum(length * np.sin(4 * angle))])
    return float(np.mod(np.arctan2(total[1], total[0]) / 4.0, np.pi / 2))


def building_direction(polygon, cell: float) -> float:
    """The dominant direction (radians, in [0, pi/2)) of a building of grid cells (its straightened rings')."""
    import shapely

    rings = [polygon.exterior, *polygon.interiors] if not polygon.is_empty else []
    return dominant_direction([np.asarray(shapely.LineString(r.coords).simplify(STRAIGHTEN * cell).coords) for r in rings])


def _line_through(points: np.ndarray, direction: float) -> tuple[np.ndarray, float]:
    """(unit normal, offset) of the line of ``direction`` through the length-weighted centre of the polyline ``points``."""
    u = np.array([np.cos(direction), np.sin(direction)])
    n = np.array([-u[1], u[0]])
    seg = np.diff(points, axis=0)
    w = np.hypot(seg[:, 0], seg[:, 1])
    mid = (points[:-1] + points[1:]) / 2.0
    centre = (mid * w[:, None]).sum(axis=0) / w.sum() if w.sum() > 0 else points.mean(axis=0)
    return n, float(n @ centre)


def _intersect(l1, l2):
    """Intersection of two lines (normal, offset); None when (nearly) parallel."""
    (n1, c1), (n2, c2) = l1, l2
    det = n1[0] * n2[1] - n1[1] * n2[0]
    if abs(det) < 1e-9:
        return None
    return np.array([(c1 * n2[1] - c2 * n1[1]) / det, (n1[0] * c2 - n2[0] * c1) / det])


def _walls(ring: np.ndarray, straight, theta: float, tolerance: float):
    """The walls of a ring: [direction, (normal, offset), length, source points] per straightened edge, merged by direction."""
    # index of each straightened corner in the cell ring
    points = list(map(tuple, ring[:-1].tolist()))  # simplification keeps input points exactly, in order
    idx = []
    j = 0
    for p in map(tuple, straight[:-1].tolist()):
        while points[j % len(points)] != p:
            j += 1
        idx.append(j % len(points))
    walls = []
    n = len(idx)
    for k in range(n):
        a, b = idx[k], idx[(k + 1) % n]
        src = ring[a:b + 1] if b > a else np.concatenate([ring[a:-1], ring[:b + 1]])
        d = src[-1] - src[0]
        phi = np.arctan2(d[1], d[0])
        for target in (theta, theta + np.pi / 2):
            diff = np.mod(phi - target + np.pi / 2, np.pi) - np.pi / 2
            if abs(diff) <= tolerance:
                phi = target
                break
        phi = float(np.mod(phi, np.pi))
        walls.append([phi, _line_through(src, phi), float(np.hypot(*d)), src])
    return _merge_parallel_neighbours(walls)


def _same(a: float, b: float) -> bool:
    return abs(np.mod(a - b + np.pi / 2, np.pi) - np.pi / 2) < 1e-9


def _merge(w1, w2):
    src = np.concatenate([w1[3], w2[3][1:]])
    return [w1[0], _line_through(src, w1[0]), w1[2] + w2[2], src]


def _merge_parallel_neighbours(walls):
    changed = True
    while changed and len(walls) > 1:
        changed = False
        for k in range(len(walls)):
            nxt = (k + 1) % len(walls)
            if nxt != k and _same(walls[k][0], walls[nxt][0]):
                merged = _merge(walls[k], walls[nxt]) if nxt > k else _merge(walls[nxt], walls[k])
                walls[k] = merged
                del walls[nxt]
                changed = True
                break
    return walls


def _corners(walls) -> np.ndarray | None:
    out = []
    for k in range(len(walls)):
        prev, cur = walls[k - 1], walls[k]
        p = _intersect(prev[1], cur[1])
        if p is None:
            return None
        out.append(p)
    return np.array(out)


def _regular_ring(ring: np.ndarray, theta: float, cell: float, min_edge: float, tolerance: float, shapely):
    """The regularised ring (closed coordinate array), or None when regularisation fails."""
    # start at a corner (the point farthest from the centre), which simplification keeps whatever it does
    start = int(np.argmax(np.hypot(*(ring[:-1] - ring[:-1].mean(axis=0)).T)))
    ring = np.vstack([ring[start:-1], ring[:start + 1]])
    straight = np.asarray(shapely.LineString(ring).simplify(STRAIGHTEN * cell, preserve_topology=False).coords)
    if len(straight) < 4:
        return None
    walls = _walls(ring, straight, theta, tolerance)
    while len(walls) >= 3:
        corners = _corners(walls)
        if corners is None:
            return None
        lengths = np.hypot(*(np.roll(corners, -1, axis=0) - corners).T)  # wall k runs from corner k to corner k+1
        k = int(np.argmin(lengths))
        if lengths[k] >= min_edge or len(walls) <= 4:
            break
        prev, nxt = (k - 1) % len(walls), (k + 1) % len(walls)
        if _same(walls[prev][0], walls[nxt][0]):  # a jog between parallel walls: one wall at their mean offset
            walls = walls[prev:] + walls[:prev]  # prev, k, nxt first
            src = np.concatenate([walls[0][3], walls[1][3][1:], walls[2][3][1:]])
            phi = walls[0][0]
            walls = [[phi, _line_through(src, phi), walls[0][2] + walls[1][2] + walls[2][2], src]] + walls[3:]
        else:
            del walls[k]
        walls = _merge_parallel_neighbours(walls)
    if len(walls) < 3:
        return None
    corners = _corners(walls)
    if corners is None:
        return None
    return np.vstack([corners, corners[:1]])


def regularize(polygon, *, cell: float, min_edge: float | None = None, angle_tolerance: float = 20.0,
               max_change: float = 0.25):
    """The outline of ``polygon`` (a shapely Polygon of grid cells) with straight walls at right angles (module docstring).

    Parameters
    ----------
    polygon : shapely Polygon
        The cells of one building, in world coordinates.
    cell : float
        The grid's cell size (world units).
    min_edge : float, optional
        Shortest wall kept (world units); default two cells.
    angle_tolerance : float
        Degrees: walls this close to the dominant direction or its perpendicular are turned to it.
    max_change : float
        Largest symmetric difference to the cells, as a share of their area.
    """
    shapely = require("shapely", "vector", "regularising building outlines")
    cell = _checks.number("cell", cell, minimum=0.0, exclusive_min=True)
    min_edge = 2.0 * cell if min_edge is None else _checks.number("min_edge", min_edge, minimum=0.0)
    tolerance = np.radians(_checks.number("angle_tolerance", angle_tolerance, minimum=0.0, maximum=45.0))
    if polygon.is_empty or polygon.area == 0:
        return polygon
    rings = [np.asarray(polygon.exterior.coords)[:, :2]] + [np.asarray(r.coords)[:, :2] for r in polygon.interiors]
    theta = building_direction(polygon, cell)
    out = [_regular_ring(ring, theta, cell, min_edge, tolerance, shapely) for ring in rings]
    candidates = []
    if out[0] is not None:
        holes = [h for h in out[1:] if h is not None and shapely.Polygon(h).area >= min_edge * min_edge]
        candidates.append(shapely.Polygon(out[0], holes))
    candidates.append(polygon.simplify(STRAIGHTEN * cell, preserve_topology=True))
    for candidate in candidates:
        if (candidate.geom_type == "Polygon" and candidate.is_valid and not candidate.is_empty
                and candidate.symmetric_difference(polygon).area <= max_change * polygon.area):
            return shapely.orient_polygons(candidate) if hasattr(shapely, "orient_polygons") else candidate
    return polygon
