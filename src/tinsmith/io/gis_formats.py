"""GIS outputs: triangles as 3-D polygons (GeoJSON, GeoPackage) and the mesh re-rasterised (GeoTIFF)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..core import Heightfield, TerrainMesh
from ..errors import InvalidInputError, UnsupportedFormatError, require
from ._atomic import atomic_paths
from .registry import writer

__all__ = [
    "triangle_wkb", "write_buildings", "write_city_outlines", "write_footprints",
    "write_geojson", "write_geopackage", "write_geotiff", "write_grid",
]

#: Layer name of the polygon outputs.
LAYER = "tin"

#: One ISO WKB PolygonZ with one closed ring of 4 points, little-endian: 109 bytes.
_WKB_POLYGON_Z = np.dtype(
    [("order", "u1"), ("type", "<u4"), ("rings", "<u4"), ("points", "<u4"), ("xyz", "<f8", (4, 3))]
)
_WKB_POLYGON_Z_TYPE = 1003  # ISO: Polygon (3) + 1000 for Z


def triangle_wkb(mesh: TerrainMesh) -> np.ndarray:
    """Every triangle as ISO WKB ``POLYGON Z`` (closed ring: corners 0, 1, 2, 0).

    Returns
    -------
    (M,) ndarray of object
        ``bytes`` of 109 bytes each, the ring counter-clockwise seen from above
        (the exterior-ring orientation of the OGC simple-features rules).
    """
    records = np.empty(mesh.n_triangles, dtype=_WKB_POLYGON_Z)
    records["order"] = 1
    records["type"] = _WKB_POLYGON_Z_TYPE
    records["rings"] = 1
    records["points"] = 4
    records["xyz"] = mesh.vertices[mesh.triangles[:, [0, 1, 2, 0]]]
    size = _WKB_POLYGON_Z.itemsize
    buf = records.tobytes()
    out = np.empty(mesh.n_triangles, dtype=object)
    out[:] = [buf[i : i + size] for i in range(0, len(buf), size)]
    return out


def _write_polygons(mesh: TerrainMesh, path, driver: str, purpose: str) -> None:
    require("pyogrio", "vector", purpose)
    import pyogrio.raw

    zmean = mesh.vertices[:, 2][mesh.triangles].mean(axis=1) if mesh.n_triangles else np.empty(0)
    with warnings.catch_warnings():
        # a mesh without CRS is written without one; pyogrio's warning adds nothing
        warnings.filterwarnings("ignore", message="'crs' was not provided")
        pyogrio.raw.write(
            str(path),
            geometry=triangle_wkb(mesh),
            field_data=[np.arange(mesh.n_triangles, dtype=np.int64), zmean],
            fields=["id", "zmean"],
            geometry_type="Polygon Z",
            crs=mesh.crs,
            driver=driver,
            layer=LAYER,
        )


@writer(
    [".geojson"],
    description="GeoJSON: one 3-D polygon per triangle (fields id, zmean); a non-WGS84 CRS goes in a 'crs' member",
    carries_crs=True,
    named=True,  # GDAL's vector drivers remove and recreate the path
)
def write_geojson(mesh: TerrainMesh, path, *, grid=None) -> None:
    """GeoJSON through pyogrio/GDAL, in the mesh's CRS (no reprojection).

    GDAL writes the pre-RFC 7946 ``"crs"`` member (``urn:ogc:def:crs:EPSG::...``)
    when the CRS is not WGS 84; coordinates keep float64 precision.
    """
    _write_polygons(mesh, path, "GeoJSON", "writing GeoJSON")


@writer(
    [".gpkg"],
    description="GeoPackage layer 'tin': one 3-D polygon per triangle (fields id, zmean)",
    carries_crs=True,
    named=True,  # GDAL's vector drivers remove and recreate the path; SQLite keeps a journal beside it
)
def write_geopackage(mesh: TerrainMesh, path, *, grid=None) -> None:
    """GeoPackage through pyogrio/GDAL (SQLite, rollback journal: no -wal/-shm files left)."""
    _write_polygons(mesh, path, "GPKG", "writing GeoPackage")


def _raster_dtype(source_dtype: str):
    """float32 when it holds every value of the source type exactly (int16, uint8, float32, ...), else float64."""
    try:
        return np.float32 if np.can_cast(np.dtype(source_dtype), np.float32, casting="safe") else np.float64
    except TypeError:
        return np.float64


@writer(
    [".tif", ".tiff"],
    description="GeoTIFF of the mesh re-rasterised on the input grid (NaN where no triangle covers a cell)",
    carries_crs=True,
    needs_grid=True,
)
def write_geotiff(mesh: TerrainMesh, path, *, grid: Heightfield) -> None:
    """Heights of the mesh at the cell centres of ``grid`` as a tiled, deflate-compressed GeoTIFF.

    float32, or float64 when the grid came from a type float32 cannot hold
    exactly (float64, int32, ...); nodata is NaN.  CRS and transform are the
    grid's (the mesh's CRS when the grid has none).  A mesh with a vertex on
    every valid cell centre (the grid mesh) reproduces the source heights.
    """
    from ..triangulation.sampling import rasterize  # numba: imported when a raster is written

    heights = rasterize(mesh, grid)
    _write_tiff(heights.astype(_raster_dtype(grid.source_dtype)), path, grid, crs=grid.crs or mesh.crs, nodata=float("nan"))


def _write_tiff(array: np.ndarray, path, grid: Heightfield, *, crs, nodata) -> None:
    """One band on ``grid``'s transform: tiled, deflate-compressed, no .aux.xml beside it."""
    import affine
    import rasterio

    h, w = array.shape
    profile = {
        "driver": "GTiff",
        "width": w,
        "height": h,
        "count": 1,
        "dtype": array.dtype.name,
        "crs": crs,
        "transform": affine.Affine(*grid.transform),
        "nodata": nodata,
        "tiled": True,
        "blockxsize": 256,
        "blockysize": 256,
        "compress": "deflate",
        "predictor": 3 if array.dtype.kind == "f" else 2,
        "BIGTIFF": "IF_SAFER",
    }
    # no .aux.xml beside the (temporary) file: everything goes into the TIFF tags
    with rasterio.Env(GDAL_PAM_ENABLED="NO"), rasterio.open(path, "w", **profile) as ds:
        ds.write(array, 1)


def write_grid(array: np.ndarray, path, grid: Heightfield, *, nodata=None) -> None:
    """An (H, W) array on the grid of ``grid`` (heights, class codes, ...) as a GeoTIFF, written atomically.

    Float arrays are written as float32 (float64 kept when given) with NaN
    where ``grid`` has no data, unless ``nodata`` says otherwise; integer
    arrays as they are.
    """
    array = np.asarray(array)
    if array.shape != grid.shape:
        raise InvalidInputError(f"write_grid: the array is {array.shape}, the grid {grid.shape}")
    if array.dtype.kind == "f":
        array = np.where(grid.valid, array, np.nan).astype(array.dtype if array.dtype == np.float64 else np.float32)
        nodata = float("nan") if nodata is None else nodata
    with atomic_paths(path) as (temp,):
        _write_tiff(array, temp, grid, crs=grid.crs, nodata=nodata)


#: Suffixes :func:`write_buildings` takes, and their GDAL drivers.
BUILDING_DRIVERS = {".geojson": "GeoJSON", ".gpkg": "GPKG"}


def write_buildings(tree, path, *, crs: str | None = None) -> None:
    """The regions of a building tree as polygons with holes (GeoJSON or GeoPackage layer 'buildings'), written atomically.

    Fields: ``id``, ``parent`` (-1 for a root), ``level`` (0 for the
    outline of the data), ``threshold``, ``height`` (NaN for a region whose
    squares all belong to its children), ``area``, ``width``, ``n_points``
    and ``n_children``.
    """
    shapely = require("shapely", "vector", "writing building outlines")
    regions = tree.regions
    fields = {
        "id": np.array([r.id for r in regions], np.int64),
        "parent": np.array([-1 if r.parent is None else r.parent for r in regions], np.int64),
        "level": np.array([r.level for r in regions], np.int64),
        "threshold": np.array([r.threshold for r in regions], np.float64),
        "height": np.array([r.height for r in regions], np.float64),
        "area": np.array([r.area for r in regions], np.float64),
        "width": np.array([r.width for r in regions], np.float64),
        "n_points": np.array([r.n_points for r in regions], np.int64),
        "n_children": np.array([len(r.children) for r in regions], np.int64),
    }
    _write_outlines([shapely.Polygon(r.outline, r.holes) for r in regions], fields, path, crs)


def write_city_outlines(model, path, *, crs: str | None = None) -> None:
    """The outlines of a city model (:func:`tinsmith.city`): the regions of the block model's tree (roofs
    ``levels``), or the buildings' footprints with their heights."""
    if hasattr(model, "tree"):
        write_buildings(model.tree, path, crs=crs)
    else:
        write_footprints(model.buildings, path, crs=crs, statistic=model.stats["roof_height"])


def write_footprints(buildings, path, *, crs: str | None = None, statistic: str | None = None) -> None:
    """The buildings of a city model (:func:`tinsmith.city`) as polygons (GeoJSON or GeoPackage layer 'buildings'), atomically.

    Fields: ``id``, ``footprint`` (the input footprint it was made of, its
    position in the input; -1 for a building found), ``roof`` (the flat
    roof's height), with ``statistic`` a ``roof_stat`` field naming the
    statistic that gave it (e.g. "p70"), ``ground`` (the ground's median
    under it), ``height`` (roof above ground, CityGML's measuredHeight),
    ``area``, ``n_cells`` and ``n_facets`` (planar roof facets).
    """
    fields = {
        "id": np.array([b.id for b in buildings], np.int64),
        "footprint": np.array([getattr(b, "footprint", -1) for b in buildings], np.int64),
        "roof": np.array([b.height for b in buildings], np.float64),
        "ground": np.array([b.ground for b in buildings], np.float64),
        "height": np.array([b.measured_height for b in buildings], np.float64),
        "area": np.array([b.outline.area for b in buildings], np.float64),
        "n_cells": np.array([b.n_cells for b in buildings], np.int64),
        "n_facets": np.array([b.n_facets for b in buildings], np.int64),
    }
    if statistic is not None:
        fields["roof_stat"] = np.array([str(statistic)] * len(buildings), dtype=object)
    _write_outlines([b.outline for b in buildings], fields, path, crs)


def _write_outlines(polygons, fields: dict, path, crs) -> None:
    path = Path(path)
    driver = BUILDING_DRIVERS.get(path.suffix.lower())
    if driver is None:
        raise UnsupportedFormatError(
            f"cannot write buildings to {path.name!r}: use one of {', '.join(sorted(BUILDING_DRIVERS))}"
        )
    require("shapely", "vector", "writing building outlines")
    require("pyogrio", "vector", "writing building outlines")
    import pyogrio.raw

    geometry = np.empty(len(polygons), dtype=object)
    geometry[:] = [p.wkb for p in polygons]
    with atomic_paths(path, named=True) as (temp,), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="'crs' was not provided")
        pyogrio.raw.write(
            str(temp), geometry=geometry, field_data=list(fields.values()), fields=list(fields),
            geometry_type="Polygon", crs=crs, driver=driver, layer="buildings",
        )
