"""A city model from a surface model: buildings found (or given as footprints), roofs, and the terrain, in one mesh.

The Salt Lake City thesis contours a whole surface model; on a leafy district its regions
are blocks of houses fused with the trees between them.  :func:`city`
builds what wind and heat engineers ask of a city (the anchors of the
field being City4CFD, 3dfier and roofer, all of which need footprints):

1. **the ground**: a DTM given on the grid, or found in the surface model by
   a progressive morphological filter (:func:`tinsmith.algorithms.urban.ground.ground`);
2. **the buildings**: either the cells that are buildings
   (:func:`tinsmith.algorithms.urban.buildings.building_cells`: high enough
   above the ground, planar, or classed as building by the LiDAR), split
   where the roofs jump (:func:`tinsmith.algorithms.urban.buildings.split_buildings`),
   with outlines straightened to their dominant directions
   (:func:`tinsmith.algorithms.urban.regularize.regularize`); or, when
   ``footprints`` are given (a cadastre), exactly those polygons, each a
   prism with the surface model's height inside it;
3. **roofs**: flat at a percentile of the heights inside each building, or
   planar facets (:mod:`tinsmith.algorithms.urban.roofs`);
4. **the mesh** (:func:`tinsmith.algorithms.urban.citymesh.city_mesh`): the
   ground refined by greedy insertion to ``ground_error``, the buildings
   welded into it with vertical walls, and with ``solid=True`` sides down
   to ``base`` and a bottom: a watertight volume for a CFD mesher.

Overlapping buildings are made disjoint before meshing: a higher roof
keeps its outline and a lower one loses what the higher one covers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ... import _checks
from ...core import Heightfield, PointCloud, TerrainMesh
from ...core.heightfield import pixel_to_world, world_to_pixel
from ...errors import InvalidInputError, InvalidOptionError, NoDataError, require
from ...io.geometry import Region, prepare_features
from ...kernels.seam import simplify_profile
from ...resources import check_memory, estimate_method
from ...triangulation.grid import filled
from ...triangulation.pointtin import tin
from ...triangulation.sampling import rasterize
from ..greedy.greedy import greedy
from ..registry import register
from .buildings import (
    MIN_HEIGHT,
    building_cells,
    class_shares,
    metres_per_unit,
    plane_fits,
    row_cuts,
    split_buildings,
)
from .citymesh import city_mesh, with_vertices
from .ground import DH0
from .ground import ground as find_ground
from .regularize import building_direction
from .regularize import regularize as straighten
from .roofs import flat_roofs, parse_statistic, roof_planes
from .urban import GROUND_WINDOW, UrbanModel, require_metres, urban_model

__all__ = ["LEVELS_OPTIONS", "Building", "CityModel", "building_height", "city", "city_model", "city_options",
           "default_ground",
           "ground_from_cloud", "top_surface"]

#: Default vertical error of the ground between the buildings (m).
GROUND_ERROR = 0.5
#: Default error of planar roofs' sampling (m): points are added inside a roof until its facets are within it.
ROOF_ERROR = 0.1
#: Least wall (m): a roof is held at least this far above the ground at every point.
MIN_WALL = 0.1
#: A footprint matches the surface model when a tenth of its valid cells or more stand at least this far (m) above
#: the ground; one without (an empty lot, a demolished building) or with no valid cell is left out and reported.
MATCH_HEIGHT = 1.0
#: The options of the Salt Lake City thesis' block model (:func:`city_model` with ``roofs="levels"``) and their defaults there.
LEVELS_OPTIONS = {"lod": 4, "noise_factor": 10, "min_width": None, "max_roughness": None, "relative_to_ground": False,
                  "simplify_tolerance": 0.0}


@dataclass
class Building:
    """One building of a :class:`CityModel`."""

    id: int
    outline: object  #: shapely Polygon (world coordinates)
    height: float  #: the flat roof's height (the roof statistic over its cells)
    ground: float  #: the ground's median height under it
    n_cells: int  #: cells of the surface model inside it
    n_facets: int = 0  #: planar roof facets (``roofs="planes"``)
    footprint: int = -1  #: the footprint it was made of (its position in the input, across layers); -1 when found

    @property
    def measured_height(self) -> float:
        """Roof above ground (CityGML's measuredHeight)."""
        return self.height - self.ground


@dataclass
class CityModel:
    """What :func:`city` returns."""

    buildings: list
    mesh: TerrainMesh
    ground: Heightfield
    labels: np.ndarray  #: (H, W) the building of every cell, -1 for none
    stats: dict


def bilinear(transform, shape, cells, x, y) -> np.ndarray:
    """Heights at world (x, y) on a grid of ``shape`` and affine ``transform``: bilinear between cell centres, held at
    the edge outside; ``cells(rows, cols)`` gives the heights of cells (an array's, or tiles' read on demand)."""
    h, w = shape
    r, c = world_to_pixel(transform, np.asarray(x, np.float64), np.asarray(y, np.float64))
    r, c = np.clip(r, 0, h - 1), np.clip(c, 0, w - 1)
    r0, c0 = np.minimum(np.floor(r).astype(np.int64), h - 2), np.minimum(np.floor(c).astype(np.int64), w - 2)
    u, v = r - r0, c - c0
    return ((1 - u) * (1 - v) * cells(r0, c0) + (1 - u) * v * cells(r0, c0 + 1)
            + u * (1 - v) * cells(r0 + 1, c0) + u * v * cells(r0 + 1, c0 + 1))


def _bilinear(z: np.ndarray, hf: Heightfield):
    """A vectorised (x, y) -> height of the array ``z`` on the grid of ``hf`` (see :func:`bilinear`)."""
    return lambda x, y: bilinear(hf.transform, z.shape, lambda rows, cols: z[rows, cols], x, y)


def centres_box(transform, shape, margin: float = 0.0):
    """The shapely box of a grid's cell centres, grown by ``margin``."""
    import shapely

    h, w = shape
    x, y = pixel_to_world(transform, np.array([0, 0, h - 1, h - 1]), np.array([0, w - 1, 0, w - 1]))
    return shapely.box(x.min() - margin, y.min() - margin, x.max() + margin, y.max() + margin)


def _rasterize(polygons, hf: Heightfield) -> np.ndarray:
    """(H, W) the index of the polygon holding each cell centre, -1 for none (later polygons over earlier)."""
    from rasterio import features
    from rasterio.transform import Affine

    if not len(polygons):
        return np.full(hf.shape, -1, np.int64)
    shapes = [(p, i) for i, p in enumerate(polygons) if not p.is_empty]
    return features.rasterize(shapes, out_shape=hf.shape, transform=Affine(*hf.transform[:6]), fill=-1,
                              dtype="int32").astype(np.int64)


def _cell_polygons(labels: np.ndarray, hf: Heightfield, shapely) -> list:
    """The polygon of the cells of every label 0..n-1 (its largest part)."""
    from rasterio import features
    from rasterio.transform import Affine

    n = int(labels.max()) + 1 if labels.size else 0
    parts: list = [[] for _ in range(n)]
    for geom, value in features.shapes(labels.astype(np.int32), mask=labels >= 0, transform=Affine(*hf.transform[:6])):
        parts[int(value)].append(shapely.geometry.shape(geom))
    return [max(p, key=lambda g: g.area) if p else shapely.Polygon() for p in parts]


def _cut(shapely, polygon, lines) -> list:
    """The parts of ``polygon`` between the cut ``lines`` (the polygon itself without lines)."""
    if not lines or polygon.is_empty:
        return [polygon]
    from shapely.ops import split

    parts = split(polygon, shapely.MultiLineString([list(line) for line in lines]))
    return [g for g in shapely.get_parts(parts) if g.geom_type == "Polygon" and g.area > 0]


def make_disjoint(polygons, order, shapely, min_area: float, grid: float) -> tuple[list, list]:
    """The polygons made disjoint in ``order`` (earlier ones keep their outline), on a precision grid; kept indices."""
    out, kept, boxes = [], [], []
    for i in order:
        p = shapely.set_precision(shapely.make_valid(polygons[i]), grid)
        if p.is_empty:
            continue
        x0, y0, x1, y1 = p.bounds
        near = [out[k] for k, (a, b, c, d) in enumerate(boxes) if a <= x1 and c >= x0 and b <= y1 and d >= y0]
        if near:  # only the kept polygons whose boxes meet this one's: linear in the city, not quadratic
            p = shapely.set_precision(p.difference(shapely.set_precision(shapely.union_all(near), grid)), grid)
        parts = [g for g in shapely.get_parts(p) if g.geom_type == "Polygon" and g.area >= min_area]
        if not parts:
            continue
        p = max(parts, key=lambda g: g.area)
        out.append(p)
        kept.append(i)
        boxes.append(p.bounds)
    return out, kept


def ground_from_cloud(cloud, hf: Heightfield) -> Heightfield | None:
    """The ground on the grid of ``hf`` from a cloud's ground and water points (ASPRS 2 and 9), or None without them.

    Their TIN (:func:`tinsmith.tin`, without an edge limit: under a
    building the ground spans it) sampled at the cell centres, as the DTMs
    of the AHN are made; cells outside the points' hull take the nearest
    sampled cell.
    """
    cls = getattr(cloud, "classification", None)
    if cls is None or np.count_nonzero((cls == 2) | (cls == 9)) < 3:
        return None
    z = rasterize(tin(cloud, classes=[2, 9], max_edge=None), hf)
    inside = np.isfinite(z)
    if not inside.any():
        return None
    return Heightfield(filled(Heightfield(np.where(inside, z, 0.0), transform=hf.transform, crs=hf.crs,
                                          nodata_mask=~inside)), transform=hf.transform, crs=hf.crs)


def city(hf: Heightfield, *, ground: Heightfield | None = None, ground_window: float = GROUND_WINDOW,
         footprints=None, shares=None, mask=None, min_height: float | None = None, max_residual: float | None = None,
         step: float | None = None, min_area: float | None = None, roofs: str = "flat", roof_height: str = "p70",
         regularize: bool = True, min_edge: float | None = None, split_rows: bool = True,
         ground_error: float | None = None,
         roof_error: float | None = None, solid: bool = False, base: float | None = None,
         margin: float = 0.0) -> CityModel:
    """The city model of a surface model (module docstring): buildings, roofs and the ground, and their mesh.

    Not a registered method (:func:`tinsmith.methods` does not list it): it
    returns a :class:`CityModel`, the mesh with the buildings, the ground
    and the cell labels it was made of, and takes a ground raster, footprints
    and cell shares that no method option carries.  The mesh alone is
    ``city(dsm, ...).mesh``; ``tinsmith city`` on the command line.  (Method
    ``urban``, its mesh through :func:`tinsmith.simplify`, is deprecated.)

    Parameters
    ----------
    hf : Heightfield
        The surface model (DSM).
    ground : Heightfield, optional
        The ground on the same grid (a DTM); default :func:`tinsmith.ground` with ``ground_window`` its widest window.
    footprints : vector file, GeoDataFrame, or sequence of shapely Polygon, optional
        Building outlines: one building each, instead of finding them.  A file (GeoPackage, GeoJSON, Shapefile,
        FlatGeobuf, GeoParquet, ...) or a GeoDataFrame is reprojected to the CRS of ``hf``; polygons are taken
        in it.  Footprints are cut to the surface model's box of cell centres (those entirely outside are
        counted and left out: one warning); a footprint with no valid cell, or with fewer than a tenth of its cells
        :data:`MATCH_HEIGHT` above the ground, has no building in the surface model: it is left out and listed
        in ``stats["footprints"]["unmatched"]`` (positions in the input, as :attr:`Building.footprint`).
    shares, mask, min_height, max_residual
        Of :func:`tinsmith.algorithms.urban.buildings.building_cells`; without ``ground``, ``min_height``
        defaults to 2.2 m (:func:`building_height`).
    step, min_area
        Of :func:`tinsmith.algorithms.urban.buildings.split_buildings` (``min_area`` also drops small footprints).
    roofs : {"flat", "planes"}
        "flat": LoD 1.2, one height per building (``roof_height``); "planes": LoD 2.2, planar roof faces
        found in the cells inside each building (:func:`tinsmith.algorithms.urban.roofs.roof_planes`).
    roof_height : str
        Statistic of the cells inside a building that gives its height (the flat roof, and the
        ``measuredHeight`` of both kinds): "median", "max" or "pNN" (default "p70", the 3D BAG's LoD 1.2).
    regularize : bool
        Straighten found outlines (:func:`tinsmith.algorithms.urban.regularize.regularize`); ``min_edge`` its shortest wall.
    split_rows : bool
        Part rows of houses under one roof where the roof steps or falls into a valley across the row
        (:func:`tinsmith.algorithms.urban.buildings.row_cuts`): each part a building, cut by a straight line.
    ground_error, roof_error : float, optional
        Vertical error of the ground between buildings and of planar roofs (z units; defaults 0.5 m and 0.1 m).
    solid : bool
        Close the mesh into a watertight volume with sides down to ``base``.
    base : float, optional
        The bottom's height; default the lowest ground less a tenth of the height range (at least 1 m).
    margin : float
        Grow the domain by this much on every side (world units), the ground held at its edge height.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> z = np.zeros((60, 80))  # flat ground at 0, 0.5 m cells
    >>> z[10:30, 10:40] = 12.0  # a building 10 x 15 m, 12 m high
    >>> z[15:25, 15:25] = 20.0  # a tower on its roof
    >>> z[40:55, 50:75] = 8.0  # a lower building
    >>> dsm = tinsmith.Heightfield(z, cell_size=0.5)
    >>> ground = tinsmith.Heightfield(np.zeros((60, 80)), cell_size=0.5)
    >>> model = tinsmith.city(dsm, ground=ground)
    >>> sorted(float(building.height) for building in model.buildings)  # the tower is a building of its own
    [8.0, 12.0, 20.0]
    >>> solid = tinsmith.city(dsm, ground=ground, solid=True).mesh
    >>> len(solid.boundary_edges())  # a watertight volume
    0
    """
    shapely = require("shapely", "vector", "city models")
    if not isinstance(hf, Heightfield):
        raise InvalidInputError(f"city needs a Heightfield (a surface model), got {type(hf).__name__}")
    require_metres(hf.crs, hf.bounds, min(hf.cell_size), ground_window)
    check_memory(estimate_method("urban", hf.n_cells), f"a city model of {hf.shape[0]:,} x {hf.shape[1]:,} cells",
                 "'tinsmith city --tile-size 2048' (tinsmith.tiles.city.city_tiles) finds the buildings window by window")
    roofs = _checks.choice("roofs", roofs, ("flat", "planes"))
    parse_statistic(roof_height)
    margin = _checks.number("margin", margin, minimum=0.0)
    unit = 1.0 / metres_per_unit(hf.crs)
    ground_error = GROUND_ERROR * unit if ground_error is None else _checks.number(
        "ground_error", ground_error, minimum=0.0, exclusive_min=True)
    roof_error = ROOF_ERROR * unit if roof_error is None else _checks.number(
        "roof_error", roof_error, minimum=0.0, exclusive_min=True)
    a, b, _, d, e, _ = hf.transform
    cell = float(np.sqrt(abs(a * e - b * d)))
    box = centres_box(hf.transform, hf.shape)  # the domain
    source = None
    if footprints is not None:  # a file, a GeoDataFrame, shapely polygons: in the DSM's CRS, cut to its box
        # (not to the data's outline: a footprint over a gap in the data stays whole)
        given = prepare_features("polygons", footprints, hf, "footprints", within=Region(box, hf.crs, cell))
        footprints, index = footprint_outlines(shapely.force_2d(given.geometries), box, shapely)
        source, footprint_counts = given.feature[index], given.counts
    min_height = building_height(min_height, hf.crs, estimated=ground is None)
    if ground is None:
        ground = default_ground(hf, ground_window)
    elif not isinstance(ground, Heightfield) or ground.shape != hf.shape or tuple(ground.transform) != tuple(hf.transform):
        raise InvalidInputError("ground must be a Heightfield on the grid of the surface model (same shape and transform)")
    if not (hf.valid & ground.valid).any():
        raise NoDataError("the ground has no data where the surface model has")
    g = filled(ground)
    g_at = _bilinear(g, ground)
    min_area_w = (10.0 * unit * unit) if min_area is None else _checks.number("min_area", min_area, minimum=0.0)

    fits = plane_fits(hf) if footprints is None or roofs == "planes" else None  # once for every step that needs it
    outlines, labels, heights, counts = find_buildings(
        hf, ground, footprints=footprints, shares=shares, mask=mask, min_height=min_height, max_residual=max_residual,
        step=step, min_area=min_area, roof_height=roof_height, regularize=regularize, min_edge=min_edge,
        split_rows=split_rows, fits=fits)
    if footprints is not None:
        matched, unmatched = footprint_match(hf, g, labels, outlines, MATCH_HEIGHT * unit)
        outlines, heights, source = [outlines[i] for i in matched], heights[matched], source[matched]
        remap = np.full(len(matched) + len(unmatched) + 1, -1, np.int64)
        remap[matched] = np.arange(len(matched))
        labels = remap[labels]
        # a footprint the cut parted (or a multipolygon) is unmatched when none of its parts matches
        unmatched = sorted(set(given.feature[index][unmatched].tolist()) - set(source.tolist()))
    n = len(outlines)
    order = np.argsort(-heights, kind="stable")
    outlines, kept = make_disjoint(outlines, order, shapely, min_area_w if footprints is None else 0.0, cell / 256.0)
    # the precision grid may move a corner on the domain's edge a hair outside it (a grid whose origin is no multiple
    # of it): back onto the edge, or the solid's bottom spans outside its sides
    outlines = [p if box.covers(p) else max(shapely.get_parts(shapely.set_precision(p, 0.0).intersection(box)),
                                            key=lambda g: g.area) for p in outlines]
    heights = heights[kept]
    if source is not None:
        covered = sorted(set(source.tolist()) - set(source[kept].tolist()))
        source = source[kept]
    remap = np.full(n + 1, -1, np.int64)
    remap[np.array(kept, dtype=np.int64)] = np.arange(len(kept))
    labels = remap[labels]
    n = len(kept)
    ground_under = flat_roofs(ground, labels, n, "median") if n else np.empty(0)
    ground_under = np.where(np.isnan(ground_under), heights, ground_under)

    planes = None
    roof_points = None
    if roofs == "planes" and n:
        planes = roof_planes(hf, labels, n, flat=heights, fits=fits)
        roof_points = _roof_points(hf, labels, planes, outlines, cell, roof_error, shapely)
    roof_at = _roof_function(hf, labels, heights, planes, g_at, MIN_WALL * unit)
    if planes is not None:  # where a ridge or a valley meets a wall (a gable's apex), the wall's top follows it
        outlines = wall_tops(outlines, roof_at, cell, roof_error, shapely)
    ground_points = greedy_ground_points(ground, g, outlines, box, ground_error, cell, shapely)
    domain = centres_box(hf.transform, hf.shape, margin)
    if margin > 0:
        ground_points = np.concatenate([ground_points, np.asarray(box.exterior.coords)[:-1]])
    if solid:
        base = base_height(base, float(g.min()), float(np.nanmax(np.where(hf.valid, hf.z, np.nan))), unit)
    mesh, outlines = city_mesh(outlines, domain, g_at, roof_at, ground_points=ground_points, roof_points=roof_points,
                     solid=solid, base=base, crs=hf.crs, pinch_size=cell / 2.0)
    mesh.info["method"] = "city"
    mesh.info["lod"] = "2.2" if roofs == "planes" else "1.2"
    mesh.info["roof_height"] = roof_height
    buildings = [
        Building(id=i, outline=outlines[i], height=float(heights[i]), ground=float(ground_under[i]),
                 n_cells=int(np.count_nonzero(labels == i)),
                 n_facets=int(np.count_nonzero(planes.building == i)) if planes is not None else 0,
                 footprint=int(source[i]) if source is not None else -1)
        for i in range(n)
    ]
    rmse, n_roof = roof_rmse(mesh, hf, labels)
    mesh.tables["building"] = {"height": np.array([bld.measured_height for bld in buildings])}
    stats = {
        "n_buildings": n, "roofs": roofs, "lod": mesh.info["lod"], "roof_height": roof_height, "cells": counts,
        "roof_rmse": rmse, "roof_cells": n_roof,
        "footprints": footprints is not None, "solid": solid, "base": base,
        "n_vertices": mesh.n_vertices, "n_triangles": mesh.n_triangles,
        "points_kept": mesh.n_vertices / hf.n_valid,
    }
    if footprints is not None:
        stats["footprints"] = {
            "read": int(footprint_counts.get("total", len(given.geometries))),
            "outside": int(footprint_counts.get("outside", 0)), "cut": int(footprint_counts.get("cut", 0)),
            "skipped": int(footprint_counts.get("invalid", 0) + footprint_counts.get("other", 0)
                           + footprint_counts.get("unprojectable", 0)),
            "modelled": n, "unmatched": unmatched, "covered": covered}
    if n == 0:
        stats["note"] = "no building found: the model is the terrain alone"
    return CityModel(buildings=buildings, mesh=mesh, ground=ground, labels=labels, stats=stats)


def city_options(*, roofs: str = "flat", solid: bool = False, base: float | None = None, footprints=None,
                 roof_height: str = "p70", **options) -> dict:
    """Check which options of :func:`city_model` go together, before any data is read.

    The block model (``roofs="levels"``) has options of its own
    (:data:`LEVELS_OPTIONS`) and is a surface: no ``solid``, ``base`` or
    ``footprints``; ``base`` is the bottom of a ``solid``.  Returns the block
    model's settings (its defaults for those not given, or given as None)
    for ``roofs="levels"``, else ``{}``.
    """
    roofs = _checks.choice("roofs", roofs, ("flat", "planes", "levels"))
    levels = {k: options[k] for k in LEVELS_OPTIONS if options.get(k) is not None}
    if roofs != "levels" and levels:
        raise InvalidOptionError(f"{next(iter(levels))} is an option of roofs 'levels' (the Salt Lake City thesis' block model)")
    if roofs == "levels":
        for name, value in (("solid", solid or None), ("footprints", footprints), ("base", base)):
            if value is not None:
                raise InvalidOptionError(f"{name} needs roofs 'flat' or 'planes' (the levels model is a surface)")
    if base is not None and not solid:
        raise InvalidOptionError("base is the height of a solid's bottom: it goes with solid")
    parse_statistic(roof_height)
    return {**LEVELS_OPTIONS, **levels} if roofs == "levels" else {}


def city_model(dsm: Heightfield, *, cloud: PointCloud | None = None, roofs: str = "flat",
               ground: Heightfield | None = None, ground_window: float = GROUND_WINDOW, mask=None,
               min_height: float | None = None, max_residual: float | None = None, ground_error: float | None = None,
               **options) -> CityModel | UrbanModel:
    """The city model of a surface model (or of the LiDAR survey gridded into it), with flat, planar or stepped roofs.

    ``roofs="flat"`` or ``"planes"``: :func:`city` (``options`` are its
    others: ``footprints``, ``roof_height``, ``step``, ``min_area``,
    ``regularize``, ``split_rows``, ``solid``, ``base``, ``margin``, ...).
    ``roofs="levels"``: the Salt Lake City thesis' block model (:func:`tinsmith.urban`, a
    :class:`UrbanModel`) over the cells that are buildings, with the options
    of :data:`LEVELS_OPTIONS`; the ground passed to it only with
    ``relative_to_ground``.  Which options go together is checked first
    (:func:`city_options`).

    Parameters
    ----------
    dsm : Heightfield
        The surface model.
    cloud : PointCloud, optional
        The cloud ``dsm`` was gridded from (``cloud.to_heightfield(cell, statistic="max")``): its classes and
        returns tell trees from roofs, and its ground and water points (2, 9) give the ground when ``ground`` is
        None (:func:`ground_from_cloud`).
    ground : Heightfield, optional
        The ground on the grid of the surface model; default: the cloud's, or
        :func:`tinsmith.ground` with ``ground_window`` its widest window.
    mask : Heightfield or (H, W) bool array, optional
        Where buildings may be: a raster on the grid (its valid non-zero cells), or the cells themselves.
    min_height, max_residual
        Of :func:`tinsmith.algorithms.urban.buildings.building_cells`.
    ground_error : float, optional
        Vertical error of the ground between the buildings (z units).
    """
    levels = city_options(roofs=roofs, **options)
    if not isinstance(dsm, Heightfield):
        raise InvalidInputError(f"a city model needs a Heightfield (a surface model), got {type(dsm).__name__}")
    shares = None
    if cloud is not None:
        shares = class_shares(cloud, dsm)
        ground = ground_from_cloud(cloud, dsm) if ground is None else ground
    if isinstance(mask, Heightfield):
        mask = mask.valid & (mask.z != 0)
    if roofs != "levels":
        return city(dsm, roofs=roofs, ground=ground, ground_window=ground_window, shares=shares, mask=mask,
                    min_height=min_height, max_residual=max_residual, ground_error=ground_error,
                    **{k: v for k, v in options.items() if k not in LEVELS_OPTIONS})
    min_height = building_height(min_height, dsm.crs, estimated=ground is None)
    if ground is None:
        ground = default_ground(dsm, ground_window)
    cells, _ = building_cells(dsm, ground,
                              min_height=min_height, max_residual=max_residual, shares=shares, mask=mask)
    return urban_model(dsm, ground=ground if levels["relative_to_ground"] else None, ground_window=ground_window,
                 ground_error=ground_error, mask=cells, **levels)


def base_height(base, lowest: float, highest: float, unit: float = 1.0) -> float:
    """The solid's bottom: ``base`` checked below the ``lowest`` ground, or by default that less a tenth of the range (>= 1 m)."""
    if base is None:
        return lowest - max(1.0 * unit, 0.1 * (highest - lowest))
    base = _checks.number("base", base)
    if base >= lowest:
        raise InvalidInputError(
            f"base height {base:g} is not below the lowest ground ({lowest:g}): the solid needs a bottom under the terrain")
    return base


def find_buildings(hf: Heightfield, ground: Heightfield, *, footprints=None, shares=None, mask=None,
                   min_height=None, max_residual=None, step=None, min_area=None, roof_height: str = "p70",
                   regularize: bool = True, min_edge=None, split_rows: bool = True, fits=None):
    """The buildings of ``hf`` (steps 2-6 of :func:`city`), before they are made disjoint.

    ``fits`` is :func:`tinsmith.algorithms.urban.buildings.plane_fits` of ``hf`` when the caller has it.

    Returns ``(outlines, labels, heights, counts)``: shapely polygons, the
    (H, W) building of every cell (-1 for none), the flat roof of each,
    and how many cells each rule kept.
    """
    shapely = require("shapely", "vector", "city models")
    a, b, _, d, e, _ = hf.transform
    cell = float(np.sqrt(abs(a * e - b * d)))
    box = centres_box(hf.transform, hf.shape)
    counts: dict = {}
    if footprints is not None:
        # none inside (said by the warning of tinsmith.io.geometry): the terrain alone
        outlines, _ = footprint_outlines(footprints, box, shapely)
        labels = _rasterize(outlines, hf)
        counts["footprints"] = len(footprints)
    else:
        fits = plane_fits(hf) if fits is None else fits
        cells, counts = building_cells(hf, ground, min_height=min_height, max_residual=max_residual, shares=shares,
                                       mask=mask, fits=fits)
        labels = split_buildings(hf, cells, step=step, min_area=min_area, max_residual=max_residual, fits=fits)
        outlines = _cell_polygons(labels, hf, shapely)
        cuts = None
        if split_rows:
            cuts = row_cuts(hf, labels, len(outlines), [building_direction(p, cell) for p in outlines])
        if regularize:
            outlines = [straighten(p, cell=cell, min_edge=min_edge) for p in outlines]
        outlines = [p.intersection(box) for p in outlines]
        if cuts is not None and any(cuts):
            outlines = [part for p, lines in zip(outlines, cuts, strict=True) for part in _cut(shapely, p, lines)]
            labels = np.where(labels >= 0, _rasterize(outlines, hf), -1)
        counts["rows_cut"] = int(sum(len(c) for c in cuts)) if cuts is not None else 0
    heights = flat_roofs(hf, labels, len(outlines), roof_height)
    # a building with no cell (a footprint thinner than a cell) takes the surface model at its centre
    missing = np.flatnonzero(np.isnan(heights))
    if len(missing):
        centres = [outlines[i].representative_point() for i in missing]
        heights[missing] = _bilinear(filled(hf), hf)([c.x for c in centres], [c.y for c in centres])
    return outlines, labels, heights, counts


def building_height(min_height, crs, estimated: bool):
    """The height above the ground a building's cells stand: ``min_height`` as given; by default
    :data:`~tinsmith.algorithms.urban.buildings.MIN_HEIGHT` (a storey), less the ground filter's ``DH0`` when the
    ground is estimated from the surface model (:func:`default_ground`): the filter may leave the ground that much
    high (it is what its first window may cut), so a roof a storey above the true ground stands at least this much
    above the estimate.  ``None`` (the buildings module's default) for a given ground."""
    if min_height is not None or not estimated:
        return min_height
    return (MIN_HEIGHT - DH0) / metres_per_unit(crs)


def default_ground(hf: Heightfield, ground_window: float) -> Heightfield:
    """The ground of a surface model when no DTM is given: :func:`tinsmith.ground` with ``ground_window`` its
    widest window (checked under that name)."""
    return find_ground(hf, max_window=_checks.number("ground_window", ground_window, minimum=0.0, exclusive_min=True))


def footprint_outlines(footprints, box, shapely) -> tuple[list, np.ndarray]:
    """The footprints made valid and cut to ``box`` (the grid's cell centres), each its largest part; and the
    index of the footprint each outline is (those outside the box, or without area there, are left out)."""
    outlines, index = [], []
    for i, p in enumerate(footprints):
        p = shapely.make_valid(p)
        if not p.intersects(box):
            continue
        p = p.intersection(box)
        if p.area > 0:
            outlines.append(max(shapely.get_parts(p), key=lambda q: q.area))
            index.append(i)
    return outlines, np.array(index, dtype=np.int64)


def footprint_match(hf: Heightfield, ground: np.ndarray, labels: np.ndarray, outlines,
                    min_height: float) -> tuple[np.ndarray, np.ndarray]:
    """Which footprints the surface model holds a building in, and which not: (matched, unmatched) indices.

    A footprint matches when the 90th percentile of its valid cells' heights above the ``ground`` (an (H, W)
    array without gaps) is ``min_height`` or more: a tenth of its cells at that height, so that one stray
    cell (a lamp post, a bird) does not make an empty lot a building.  One thinner than a cell is judged by
    the cell at its representative point.
    """
    n = len(outlines)
    above = Heightfield(np.where(hf.valid, hf.z - ground, 0.0), transform=hf.transform, nodata_mask=~hf.valid)
    rise = flat_roofs(above, labels, n, "p90")  # NaN: no valid cell
    thin = np.flatnonzero(np.bincount(labels[labels >= 0], minlength=n)[:n] == 0)
    if len(thin):
        points = [outlines[i].representative_point() for i in thin]
        r, c = hf.world_to_pixel(np.array([p.x for p in points]), np.array([p.y for p in points]))
        r = np.clip(np.round(r).astype(np.int64), 0, hf.shape[0] - 1)
        c = np.clip(np.round(c).astype(np.int64), 0, hf.shape[1] - 1)
        rise[thin] = np.where(hf.valid[r, c], above.z[r, c], np.nan)
    with np.errstate(invalid="ignore"):
        ok = rise >= min_height
    return np.flatnonzero(ok), np.flatnonzero(~ok)


def top_surface(mesh: TerrainMesh) -> TerrainMesh:
    """The ground and roofs of a city mesh (what a height raster sees: patches ``ground`` and ``buildings``), or the
    mesh itself when it has no patches."""
    patch = mesh.triangle_attributes.get("patch")
    if patch is None:
        return mesh
    return TerrainMesh(mesh.vertices, mesh.triangles[np.asarray(patch) <= 1], crs=mesh.crs)


def roof_rmse(mesh: TerrainMesh, hf: Heightfield, labels: np.ndarray) -> tuple[float, int]:
    """RMSE of the mesh's top (ground and roofs) minus the surface model over the building cells one cell in, and
    their number: the cells whose 3 x 3 neighbours are all of the same building, so no cell of a wall counts
    (a wall half a cell off would put a storey's error on its cells); NaN without such a cell.

    The figure the LoD 2.2 literature gives for roofs against the point cloud (e.g. the 3D BAG's
    per-building RMSE, Peters et al. 2022, "Automated 3D reconstruction of LoD2 and LoD1 models for all
    10 million buildings of the Netherlands", PE&RS 88(3)), here against the cells.
    """
    h, w = labels.shape
    inner = labels >= 0
    padded = np.pad(labels, 1, constant_values=-1)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            inner &= padded[1 + dr:1 + dr + h, 1 + dc:1 + dc + w] == labels
    inner &= hf.valid
    if not inner.any():
        return float("nan"), 0
    z = rasterize(top_surface(mesh), hf)
    sel = inner & np.isfinite(z)
    if not sel.any():
        return float("nan"), 0
    e = z[sel] - hf.z[sel]
    return float(np.sqrt(np.mean(e * e))), int(sel.sum())


def _roof_function(hf, labels, heights, planes, g_at, min_wall):
    """(b, x, y) -> the roof of building ``b``: flat, or the plane of its nearest facet cell; held above the ground."""
    h, w = labels.shape

    def roof(b, x, y):
        x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
        z = np.full(len(x), heights[b])
        if planes is not None:
            r, c = hf.world_to_pixel(x, y)
            best = np.full(len(x), np.inf)
            for dr in range(-3, 4):
                for dc in range(-3, 4):
                    rr = np.clip(np.round(r).astype(np.int64) + dr, 0, h - 1)
                    cc = np.clip(np.round(c).astype(np.int64) + dc, 0, w - 1)
                    f = planes.facet[rr, cc]
                    ok = (labels[rr, cc] == b) & (f >= 0)
                    dist = (rr - r) ** 2 + (cc - c) ** 2
                    better = ok & (dist < best)
                    if better.any():
                        p = planes.planes[f[better]]
                        z[better] = p[:, 0] + p[:, 1] * c[better] + p[:, 2] * r[better]
                        best[better] = dist[better]
        return np.maximum(z, g_at(x, y) + min_wall)

    return roof


def _clear_of(points: np.ndarray, outlines, clearance: float, shapely) -> np.ndarray:
    """Which points lie farther than ``clearance`` from every outline (and outside them)."""
    if not len(points) or not outlines:
        return np.ones(len(points), bool)
    zone = shapely.union_all([p.buffer(clearance) for p in outlines])
    return ~shapely.contains_xy(zone, points[:, 0], points[:, 1])


def greedy_ground_points(ground: Heightfield, g: np.ndarray, outlines, box, max_error: float, cell: float, shapely) -> np.ndarray:
    """(K, 2) points of greedy insertion on the ground, clear of the buildings and of the domain's outline."""
    mesh = greedy(Heightfield(g, transform=ground.transform, crs=ground.crs), max_error=max_error)
    xy = mesh.vertices[:, :2]
    inner = box.buffer(-cell)
    keep = shapely.contains_xy(inner, xy[:, 0], xy[:, 1]) & _clear_of(xy, outlines, cell, shapely)
    return xy[keep]


def _roof_points(hf, labels, planes, outlines, cell, max_error, shapely) -> np.ndarray:
    """(K, 2) points of greedy insertion on the planar roofs, well inside their buildings."""
    surface = np.where(labels >= 0, planes.z, np.nan)
    if not np.isfinite(surface).any():
        return np.empty((0, 2))
    z = np.where(np.isfinite(surface), surface, np.nanmin(surface))
    mesh = greedy(Heightfield(z, transform=hf.transform, crs=hf.crs, nodata_mask=~np.isfinite(surface)),
                  max_error=max_error)
    xy = mesh.vertices[:, :2]
    keep = np.zeros(len(xy), bool)
    for p in outlines:
        inner = p.buffer(-cell)
        if not inner.is_empty:
            keep |= shapely.contains_xy(inner, xy[:, 0], xy[:, 1])
    return xy[keep]


def _profile_points(t: np.ndarray, z: np.ndarray, max_error: float) -> np.ndarray:
    """Indices of the samples (t, z) along a segment, ends excluded, that its top must pass through to stay within
    ``max_error`` of them (Douglas and Peucker 1973: :func:`tinsmith.kernels.seam.simplify_profile`)."""
    keep = np.zeros(len(t), np.uint8)
    keep[[0, -1]] = 1
    simplify_profile(np.ascontiguousarray(z, np.float64), np.ones(len(t), np.uint8), keep, float(max_error),
                     np.ascontiguousarray(t, np.float64))
    return np.flatnonzero(keep)[1:-1]


def wall_tops(outlines, roof_at, cell: float, max_error: float, shapely) -> list:
    """The outlines with vertices where their planar roofs need them along the walls: each wall sampled every
    cell, and vertices added until the straight top between them is within ``max_error`` of the roof (a
    gable's apex, a valley's foot).  A vertex goes into every outline it lies on (a shared wall); none within
    a quarter cell of another vertex (two walls' samples along a shared wall, a corner).  Used where the roofs
    are planes: a ridge's ends lie on the walls, where greedy insertion inside the roof cannot put them."""
    from scipy.spatial import cKDTree

    points = []
    for b, p in enumerate(outlines):
        walls = []  # (samples' positions along the wall, their xy) of every wall of at least two cells
        for ring in (p.exterior, *p.interiors):
            xy = np.asarray(ring.coords)[:, :2]
            for a, c in zip(xy[:-1], xy[1:], strict=True):
                length = float(np.hypot(*(c - a)))
                if length >= 2.0 * cell:
                    t = np.linspace(0.0, length, int(length // cell) + 1)
                    walls.append((t, a + (t / length)[:, None] * (c - a)))
        if not walls:
            continue
        at = np.concatenate([w[1] for w in walls])
        z = np.asarray(roof_at(b, at[:, 0], at[:, 1]), dtype=np.float64)  # one call a building
        start = 0
        for t, xy in walls:
            points.extend(xy[k] for k in _profile_points(t, z[start:start + len(t)], max_error))
            start += len(t)
    if not points:
        return outlines
    points = np.array(points)
    corners = [shapely.get_coordinates(p) for p in outlines]
    counts = [len(c) for c in corners]
    corners = np.concatenate(corners)
    points = points[cKDTree(corners).query(points)[0] > cell / 4.0]
    keep = np.ones(len(points), bool)
    for i, j in sorted(cKDTree(points).query_pairs(cell / 4.0)):
        if keep[i]:
            keep[j] = False
    points = points[keep]
    if not len(points):
        return outlines
    # every corner too, into the walls it lies on: a neighbour's corner on a wall (a T-junction) stays exactly on it
    # once the wall has new vertices (else the plan would put a point a rounding error away from it)
    owner = np.concatenate([np.full(len(points), -1), np.repeat(np.arange(len(outlines)), counts)])
    points = np.concatenate([points, corners])
    near = shapely.STRtree(outlines).query(shapely.points(points), predicate="dwithin", distance=cell * 1e-3)
    near = near[:, owner[near[0]] != near[1]]  # not a polygon's own corners
    out = list(outlines)
    for i in np.unique(near[1]):
        out[i] = with_vertices(shapely, [out[i]], np.unique(points[near[0][near[1] == i]], axis=0))[0]
    return out


@register("urban")
def _registered(hf, *, footprints, roofs, roof_height, min_height, min_area, ground_window, ground_error, solid, margin,
                progress=None) -> TerrainMesh:
    """Deprecated method ``urban``: the mesh of :func:`city` (``tinsmith.simplify(dsm, method="urban")``), its
    statistics in ``info["city"]``; use ``tinsmith.city(dsm, ...).mesh``."""
    model = city(hf, footprints=footprints, roofs=roofs, roof_height=roof_height, min_height=min_height,
                 min_area=min_area, ground_window=ground_window, ground_error=ground_error, solid=solid, margin=margin)
    if progress is not None:
        progress(1.0)
    return model.mesh
