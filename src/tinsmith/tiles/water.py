"""Water for terrain tiles: where it is (polygons, or the DEM's flat lakes), and each tile's water mask.

Cesium draws water (waves, reflections) where a tile's water mask says so:
the quantized-mesh ``watermask`` extension holds one byte (0 all land, 255
all water) or 256 x 256 bytes from the tile's north-west corner, rows north
to south (https://github.com/CesiumGS/quantized-mesh, "Water Mask").

The water comes from

- polygons (any vector file GDAL reads, a GeoDataFrame, shapely geometries),
  in any CRS: reprojected to longitude and latitude and clipped to the DEM's
  bounds by the one path of every geometry option
  (:func:`tinsmith.io.geometry.fit`); or
- the water class (ASPRS 9) of point clouds, for the pyramid of a tiled
  point run (:func:`tinsmith.tiles.points.cloud_pyramid` with
  ``water="class"``): the area the water points cover;
- ``"flat"``: the DEM's flat areas.  Lakes and reservoirs in published DEMs
  are hydro-flattened (every cell of the water surface at one height), which
  land hardly ever is over many cells; a connected region of cells of one
  height (to a millimetre) of at least :data:`FLAT_MIN_CELLS` cells and
  :data:`FLAT_MIN_AREA` square metres, with no more than
  :data:`SHORE_BELOW` of its shore lower than it, is taken as water.

A mask pixel is water when its centre lies in the water (no anti-aliasing).
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..errors import InvalidInputError, InvalidOptionError, NoDataError
from ..io.crs import M_PER_DEGREE, metres_per_unit

__all__ = ["FLAT_MAX_CELLS", "FLAT_MIN_AREA", "FLAT_MIN_CELLS", "FLAT_TOLERANCE", "SHORE_BELOW", "Water", "flat_water",
           "tile_water_mask", "water_of"]

#: A flat region is water when it holds at least this many cells ...
FLAT_MIN_CELLS = 64
#: ... and covers at least this many square metres (a quarter of a hectare).
FLAT_MIN_AREA = 2_500.0
#: Neighbouring cells this close in height (metres) are on one flat surface.
FLAT_TOLERANCE = 1e-3
#: A flat region is a lake when at most this share of the cells round it lie lower (its outlet).
SHORE_BELOW = 0.05
#: water="flat" reads the DEM whole: at most this many cells.
FLAT_MAX_CELLS = 16_000_000


class Water:
    """The water of a pyramid in longitude and latitude (WGS84): a shapely geometry, prepared, picklable."""

    def __init__(self, geometry, source: str):
        import shapely

        self.geometry = geometry
        self.source = source
        shapely.prepare(self.geometry)

    def __getstate__(self):
        import shapely

        return {"wkb": shapely.to_wkb(self.geometry), "source": self.source}

    def __setstate__(self, state):
        import shapely

        self.__init__(shapely.from_wkb(state["wkb"]), state["source"])

    @property
    def empty(self) -> bool:
        return bool(self.geometry.is_empty)


def water_of(value, raster, lonlat_bounds, cell_m: float) -> Water:
    """The water the ``water`` option names, in longitude and latitude, clipped to the pyramid's bounds.

    ``value`` is ``"flat"`` or polygons (a path, GeoDataFrame, shapely
    geometries in the DEM's CRS); ``raster`` the DEM's
    :class:`~tinsmith.io.raster.RasterInfo`.
    """
    import shapely

    from ..io.geometry import Region, fit, load, say

    w, s, e, n = lonlat_bounds
    region = Region(shapely.box(w, s, e, n), "EPSG:4326", cell_m / M_PER_DEGREE)
    if isinstance(value, str) and value == "class":
        raise InvalidOptionError("water='class' takes the water points of point clouds; for a DEM give water "
                                 "polygons or 'flat'")
    if isinstance(value, str) and value == "flat":
        polygons = flat_water(raster)
        label = "the DEM's flat areas"
        if not polygons:
            return Water(shapely.Polygon(), label)
        value = shapely.MultiPolygon(polygons)
        layers = load(value, "water", "polygons")
        layers[0].crs = raster.crs
    else:
        if isinstance(value, str) and not value.strip():
            raise InvalidOptionError("water must be a vector file of polygons or 'flat', got an empty string")
        layers = load(value, "water", "polygons")
        for layer in layers:  # shapely geometries and arrays are in the DEM's coordinates, as every geometry option
            if layer.crs is None and not isinstance(value, (str, os.PathLike)):
                layer.crs = raster.crs
        label = layers[0].label if layers[0].label != "water" else "water polygons"
    try:
        feats, notes, warning = fit(layers, region, "water", "polygons")
    except NoDataError as exc:
        raise InvalidInputError(str(exc)) from None
    say(notes, warning)
    geoms = [g for g in feats.geometries if g is not None and not g.is_empty]
    return Water(shapely.union_all(np.asarray(geoms, dtype=object)) if geoms else shapely.Polygon(), label)


def flat_water(raster) -> list:
    """Polygons (in the DEM's CRS) of its flat lakes (see the module notes).

    A connected region of cells of one height (within
    :data:`FLAT_TOLERANCE`) is a lake when it is large enough and its shore
    is not below it: at most :data:`SHORE_BELOW` of the cells round it lie
    lower (a lake's outlet).  The last test sets lakes apart from the plateaus
    that a DEM of whole metres makes on gentle slopes, which are flat too but
    have lower land on their downhill side.
    """
    from scipy import sparse
    from scipy.sparse import csgraph

    from ..io.geometry import mask_polygons
    from ..io.raster import read_window

    H, W = raster.shape
    if H * W > FLAT_MAX_CELLS:
        raise InvalidOptionError(f"water='flat' reads the whole DEM at once, which holds {H * W:,} cells (at most "
                                 f"{FLAT_MAX_CELLS:,}); give water polygons instead")
    a, b, c, d, e, f = raster.transform
    min_cells = max(FLAT_MIN_CELLS, math.ceil(FLAT_MIN_AREA / (abs(a * e - b * d) * metres_per_unit(raster.crs) ** 2)))
    z, valid = read_window(raster, (0, H - 1), (0, W - 1))
    same_x = valid[:, 1:] & valid[:, :-1] & (np.abs(np.diff(z, axis=1)) <= FLAT_TOLERANCE)
    same_y = valid[1:] & valid[:-1] & (np.abs(np.diff(z, axis=0)) <= FLAT_TOLERANCE)
    # regions: cells joined through neighbours of the same height (not merely through flat cells, which would
    # join the terraces of a stair)
    index = np.arange(H * W).reshape(H, W)
    pairs = np.concatenate([np.column_stack([index[:, :-1][same_x], index[:, 1:][same_x]]),
                            np.column_stack([index[:-1][same_y], index[1:][same_y]])])
    if not len(pairs):
        return []
    graph = sparse.coo_matrix((np.ones(len(pairs), np.int8), (pairs[:, 0], pairs[:, 1])), shape=(H * W, H * W))
    _, comp = csgraph.connected_components(graph, directed=False)
    flat = np.zeros(H * W, bool)
    flat[pairs.ravel()] = True
    # region numbers 1..count on flat cells, 0 elsewhere
    labels = np.unique(np.r_[0, np.where(flat, comp + 1, 0)], return_inverse=True)[1][1:].reshape(H, W)
    flat = flat.reshape(H, W)
    count = int(labels.max())
    sizes = np.bincount(labels.ravel(), minlength=count + 1)
    level = np.bincount(labels.ravel(), weights=np.where(flat, z, 0.0).ravel(), minlength=count + 1) / np.maximum(sizes, 1)
    shore = np.zeros(count + 1)
    lower = np.zeros(count + 1)
    for axis in (0, 1):  # each region's neighbours across its edges, both ways
        for here, there in ((slice(None, -1), slice(1, None)), (slice(1, None), slice(None, -1))):
            cut = (slice(None), here) if axis else (here, slice(None))
            nxt = (slice(None), there) if axis else (there, slice(None))
            lab, other, ok = labels[cut], labels[nxt], valid[nxt]
            edge = (lab > 0) & (other != lab) & ok
            shore += np.bincount(lab[edge].ravel(), minlength=count + 1)
            below = edge & (z[nxt] < level[lab] - FLAT_TOLERANCE)
            lower += np.bincount(lab[below].ravel(), minlength=count + 1)
    keep = (sizes >= min_cells) & (lower <= SHORE_BELOW * np.maximum(shore, 1))
    keep[0] = False
    mask = keep[labels]
    if not mask.any():
        return []
    return mask_polygons(mask, raster.transform)


def tile_water_mask(water: Water | None, bounds, size: int = 256):
    """The tile's water mask: None (no water option), 0 or 255 (all land, all water), or (size, size) uint8."""
    import shapely

    if water is None:
        return None
    w, s, e, n = bounds
    box = shapely.box(w, s, e, n)
    if water.empty or not water.geometry.intersects(box):
        return 0
    if water.geometry.contains(box):
        return 255
    step_x, step_y = (e - w) / size, (n - s) / size
    lon = w + (np.arange(size) + 0.5) * step_x
    lat = n - (np.arange(size) + 0.5) * step_y  # rows north to south
    LON, LAT = np.meshgrid(lon, lat)
    inside = shapely.contains_xy(water.geometry, LON, LAT)
    if not inside.any():
        return 0
    if inside.all():
        return 255
    return np.where(inside, 255, 0).astype(np.uint8)
