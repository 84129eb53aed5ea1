"""Areas with a size of their own (a river channel finer than its floodplain), for :mod:`.quality`.

A region is a polygon in world coordinates with a largest triangle area (or
none: the region is only named, a material for the solver).  Its boundary
is clipped to the area the data covers (the grid less its nodata, as the
mesh's outline bounds it), snapped to cell centres (as breaklines are),
and becomes a constrained edge of the mesh (where it does not run along the
outline), so every triangle lies in one
region; where regions overlap, the later one wins.  The mesh records which
triangle lies in which region (``triangle_attributes["region"]``, 0 outside
every region), which the 2DM and Gmsh writers turn into materials and
physical groups (:mod:`tinsmith.io.boundaries`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...core import Heightfield
from ...errors import InvalidInputError
from ...triangulation.edges import edge_twins
from ...triangulation.outline import boundary_segments, covered


@dataclass
class Regions:
    """Regions snapped to the grid: pixel-space polygons (x = column, y = row), sizes, names, boundaries."""

    polygons: list  #: shapely polygons in pixel coordinates, their vertices on cell centres
    max_areas: np.ndarray  #: float64, world units squared; inf: no limit
    names: list  #: one per region
    boundaries: list  #: (2, 2) world polylines, one per boundary segment not on the edge of the grid

    def area_map(self, shape: tuple[int, int]) -> np.ndarray:
        """The largest triangle area at every cell (flat, row-major): the limit of the last region holding the
        cell's centre, inf outside every region."""
        from rasterio import features
        from rasterio.transform import Affine

        # cell (row r, col c) spans [c - 0.5, c + 0.5] x [r - 0.5, r + 0.5] in pixel coordinates
        shapes = [(p, k + 1) for k, p in enumerate(self.polygons)]
        ids = features.rasterize(shapes, out_shape=shape, transform=Affine.translation(-0.5, -0.5), fill=0,
                                 dtype="int32")
        return np.r_[np.inf, self.max_areas][ids].ravel()

    def tag(self, cols: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """The region (1, 2, ...; 0 none) of points in pixel coordinates: the last region holding each."""
        import shapely

        out = np.zeros(len(cols), np.int64)
        for k, poly in enumerate(self.polygons):
            out[shapely.contains_xy(poly, cols, rows)] = k + 1
        return out

    def tag_mesh(self, cols: np.ndarray, rows: np.ndarray, triangles: np.ndarray, constrained: np.ndarray):
        """The region of every triangle: the pieces of the mesh that constrained edges bound each take the
        region holding most of their area (by triangle centroids), so regions follow the mesh's edges even
        where snapping a crossing with a breakline bent a boundary by up to half a cell."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        n, m = len(cols), len(triangles)
        first, second, key = edge_twins(triangles, n)
        cons = np.sort(np.asarray(constrained, np.int64).reshape(-1, 2), axis=1)
        joined = ~np.isin(key, cons[:, 0] * (n + 1) + cons[:, 1])  # triangles joined across an unconstrained edge
        graph = coo_matrix((np.ones(int(joined.sum())), (first[joined] // 3, second[joined] // 3)), shape=(m, m))
        k, piece = connected_components(graph, directed=False)
        x, y = cols[triangles], rows[triangles]
        tags = self.tag(x.mean(axis=1), y.mean(axis=1))
        area = 0.5 * np.abs((x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0]))
        votes = np.bincount(piece * (len(self.polygons) + 1) + tags, weights=area,
                            minlength=k * (len(self.polygons) + 1)).reshape(k, -1)
        return votes.argmax(axis=1)[piece]


def prepare_regions(hf: Heightfield, regions) -> Regions | None:
    """Check and snap ``regions``: (polygon, max_area) or (polygon, max_area, name) items.

    A polygon is a shapely (multi)polygon or a (K, 2) ring of world
    coordinates; ``max_area`` a number > 0 (world units squared) or None.
    """
    if regions is None:
        return None
    import shapely

    if isinstance(regions, tuple) and len(regions) in (2, 3) and not isinstance(regions[0], tuple):
        regions = [regions]
    data = _data_area(hf)
    edge = data.boundary
    polygons, areas, names, boundaries = [], [], [], []
    for k, item in enumerate(regions):
        if not isinstance(item, (tuple, list)) or len(item) not in (2, 3):
            raise InvalidInputError(f"regions[{k}] must be (polygon, max_area) or (polygon, max_area, name), "
                                    f"got {type(item).__name__}")
        geom, max_area = _polygon(k, item[0]), _area(k, item[1])
        name = str(item[2]) if len(item) == 3 and item[2] is not None else f"region_{k + 1}"

        def to_pixel(xy):
            rows, cols = hf.world_to_pixel(xy[:, 0], xy[:, 1])
            return np.column_stack([cols, rows])

        clipped = shapely.intersection(shapely.transform(geom, to_pixel), data)
        snapped = shapely.make_valid(shapely.transform(clipped, np.rint))
        parts = [p for p in shapely.get_parts(snapped) if shapely.get_type_id(p) == 3 and p.area > 0]
        if not parts:
            raise InvalidInputError(f"regions[{k}] covers no cell with data (after snapping to cell centres)")
        for part in parts:
            polygons.append(part)
            areas.append(max_area)
            names.append(name)
            boundaries += _boundary_lines(hf, part, edge)
    return Regions(polygons, np.asarray(areas, np.float64), names, boundaries)


def _polygon(k: int, geom):
    import shapely

    if isinstance(geom, shapely.Geometry):
        if shapely.get_type_id(geom) not in (3, 6):
            raise InvalidInputError(f"regions[{k}] must be a polygon, got a {geom.geom_type}")
        return shapely.force_2d(geom)
    ring = np.asarray(geom, dtype=np.float64) if not isinstance(geom, str) else np.empty(0)
    if ring.ndim != 2 or ring.shape[1] < 2 or len(ring) < 3 or not np.isfinite(ring[:, :2]).all():
        raise InvalidInputError(f"regions[{k}] must be a polygon or a (K >= 3, 2) ring of finite world "
                                f"coordinates, got shape {ring.shape}")
    return shapely.Polygon(ring[:, :2])


def _area(k: int, value) -> float:
    """max_area of region k: None or NaN (a null field of a vector file) is no limit."""
    if value is None:
        return math.inf
    try:
        area = float(value)
    except (TypeError, ValueError):
        area = -1.0
    if math.isnan(area):
        return math.inf
    if not (area > 0 and math.isfinite(area)):
        raise InvalidInputError(f"regions[{k}]: max_area must be a number > 0 or None, got {value!r}")
    return area


def _data_area(hf: Heightfield):
    """The area the data covers in pixel coordinates (x = column, y = row): the faces of the nodata outline
    (:mod:`tinsmith.triangulation.outline`) that hold data, or the grid's frame."""
    import shapely

    h, w = hf.shape
    if hf.valid.all():
        return shapely.box(0.0, 0.0, w - 1.0, h - 1.0)
    segments = boundary_segments(hf.valid)[:, :, ::-1].astype(np.float64)  # (col, row)
    faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(shapely.union_all(shapely.linestrings(segments)))))
    inside = [f for f in faces if covered(hf.valid, f.representative_point().y, f.representative_point().x)]
    return shapely.union_all(inside) if inside else shapely.Polygon()


def _boundary_lines(hf: Heightfield, polygon, edge) -> list[np.ndarray]:
    """The segments of a pixel-space polygon's rings that do not run along ``edge`` (the outline), as world
    lines."""
    import shapely

    out = []
    for ring in [polygon.exterior, *polygon.interiors]:
        xy = np.asarray(ring.coords)
        a, b = xy[:-1], xy[1:]
        keep = np.any(a != b, axis=1) & (shapely.distance(edge, shapely.points(0.5 * (a + b))) > 1e-9)
        for (c0, r0), (c1, r1) in zip(a[keep].tolist(), b[keep].tolist(), strict=True):
            x, y = hf.pixel_to_world(np.array([r0, r1]), np.array([c0, c1]))
            out.append(np.column_stack([x, y]))
    return out
