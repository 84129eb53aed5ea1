"""Vector inputs: lines (breaklines), points (control points) and polygons (reference footprints) from GIS files.

Read with pyogrio and shapely (extra ``vector``): any format GDAL reads
(GeoPackage, Shapefile, GeoJSON, FlatGeobuf, ...).  Coordinates are returned
in the file's CRS; :func:`check_same_crs` refuses a file whose CRS differs
from the DEM's rather than mixing coordinate systems silently.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputNotFoundError, InvalidInputError, NoDataError, require
from .crs import describe, to_wkt

__all__ = ["VectorLayer", "check_same_crs", "read_layers", "read_lines", "read_points", "read_polygons", "reproject"]


def _decode(shapely, wkb, path: Path, what: str, layer: str | None = None):
    """Shapely geometries of the WKB column; a feature GEOS cannot build (a line of one point,
    a ring of three) or with non-finite coordinates is an :class:`InvalidInputError` naming it."""
    geoms = shapely.from_wkb(wkb, on_invalid="ignore")
    where = f"{str(path)!r}" + (f" (layer {layer!r})" if layer else "")
    broken = np.flatnonzero(shapely.is_missing(geoms) & np.array([w is not None for w in wkb], dtype=bool))
    if len(broken):
        raise InvalidInputError(
            f"{where}: feature {int(broken[0]) + 1} of {len(geoms)} is not a valid geometry "
            f"(a line needs 2 points or more, a ring 4 or more); {len(broken)} such feature(s) in the {what}"
        )
    coords = shapely.get_coordinates(geoms)
    if not np.isfinite(coords).all():
        raise InvalidInputError(f"{where}: the {what} have NaN or infinite coordinates")
    return geoms


def _geometries(path, what: str):
    path = Path(path)
    if not path.exists():
        raise InputNotFoundError(f"{what} file {str(path)!r} does not exist")
    pyogrio = require("pyogrio", "vector", f"reading {what}")
    shapely = require("shapely", "vector", f"reading {what}")
    try:
        meta, _, wkb, _ = pyogrio.raw.read(str(path), read_geometry=True, columns=[])
    except Exception as exc:
        raise FormatError(f"cannot read {str(path)!r} as a vector file of {what}: {exc}") from exc
    geoms = _decode(shapely, wkb, path, what)
    geoms = geoms[~shapely.is_missing(geoms) & ~shapely.is_empty(geoms)]
    if len(geoms) == 0:
        raise NoDataError(f"{str(path)!r} holds no {what}")
    crs = meta.get("crs")
    return shapely, geoms, (to_wkt(crs) if crs else None)


def read_lines(path) -> tuple[list[np.ndarray], str | None]:
    """Every line of a vector file as an (K, 2) array of x, y, and the file's CRS (WKT).

    LineStrings and the parts of MultiLineStrings are lines; polygon rings
    are lines too (closed).  Points are refused.
    """
    shapely, geoms, crs = _geometries(path, "breaklines")
    parts = shapely.get_parts(geoms)
    rings = shapely.get_type_id(parts) == 3  # polygons: their rings
    if rings.any():
        parts = np.concatenate([parts[~rings], shapely.get_rings(parts[rings])])
    if (shapely.get_type_id(parts) == 0).any():
        raise InvalidInputError(f"{str(path)!r}: breaklines must be lines or polygons, found points")
    lines = []
    for i, part in enumerate(parts):
        xy = shapely.get_coordinates(part)
        xy = xy[np.r_[True, (np.diff(xy, axis=0) != 0).any(axis=1)]]  # repeated points add nothing
        if len(xy) < 2:
            raise InvalidInputError(f"{str(path)!r}: breakline {i + 1} has no length (all its points coincide)")
        lines.append(xy)
    return lines, crs


def read_points(path) -> tuple[np.ndarray, str | None]:
    """Every point (vertex) of a vector file as (N, 2) x, y, and the file's CRS (WKT)."""
    shapely, geoms, crs = _geometries(path, "control points")
    return shapely.get_coordinates(geoms), crs


def check_same_crs(name: str, crs: str | None, dem_crs: str | None) -> None:
    """Refuse geometry whose CRS differs from the DEM's (both must be known to compare)."""
    if not crs or not dem_crs:
        return
    from pyproj import CRS

    if not CRS.from_user_input(crs).equals(CRS.from_user_input(dem_crs), ignore_axis_order=True):
        raise InvalidInputError(
            f"{name} are in {describe(crs)} but the DEM is in {describe(dem_crs)}; reproject them first"
        )


def reproject(geoms, crs: str | None, target: str | None):
    """Shapely geometries from ``crs`` to ``target`` (unchanged when either is unknown or they are equal)."""
    if not crs or not target:
        return geoms
    from pyproj import CRS, Transformer

    src, dst = CRS.from_user_input(crs), CRS.from_user_input(target)
    if src.equals(dst, ignore_axis_order=True):
        return geoms
    import shapely

    move = Transformer.from_crs(src, dst, always_xy=True)
    return shapely.transform(geoms, lambda xy: np.column_stack(move.transform(xy[:, 0], xy[:, 1])))


def read_polygons(path) -> tuple[np.ndarray, str | None]:
    """Every polygon of a vector file (the parts of multipolygons apart) as shapely geometries, and the CRS (WKT)."""
    shapely, geoms, crs = _geometries(path, "polygons")
    parts = shapely.get_parts(geoms)
    parts = parts[shapely.get_type_id(parts) == 3]
    if len(parts) == 0:
        raise InvalidInputError(f"{str(path)!r} holds no polygons")
    return shapely.force_2d(parts), crs


def read_regions(path) -> tuple[list[tuple], str | None]:
    """The polygons of a vector file as (polygon, max_area, name) regions, and the CRS (WKT).

    ``max_area`` from a field of that name (any case; a null value: no
    limit; no such field: every region only named), ``name`` from a field
    ``name`` (else ``region_K``).  The parts of a multipolygon share their
    feature's size and name.
    """
    import shapely

    out, crs = [], None
    for layer in read_layers(path, "regions"):
        fields = {k.lower(): v for k, v in layer.fields.items()}
        areas, names = fields.get("max_area"), fields.get("name")
        crs = crs or layer.crs
        for i, geom in enumerate(layer.geometries):
            if shapely.get_type_id(geom) not in (3, 6):
                continue
            area = None if areas is None or areas[i] is None else areas[i]
            name = None if names is None or names[i] is None else str(names[i])
            out.append((geom, area, name or f"region_{len(out) + 1}"))
    if not out:
        raise InvalidInputError(f"{str(path)!r} holds no polygons")
    return out, crs


@dataclass
class VectorLayer:
    """The features of one layer of a vector file: geometries, their attribute columns, and the CRS (WKT)."""

    name: str
    geometries: np.ndarray  #: shapely geometries, one per feature (missing and empty ones left out)
    fields: dict = field(default_factory=dict)  #: attribute name -> array of values, one per feature
    crs: str | None = None


def read_layers(path, what: str = "land use") -> list[VectorLayer]:
    """Every layer of a vector file with its attributes (a GeoPackage may hold several; most formats hold one)."""
    path = Path(path)
    if not path.exists():
        raise InputNotFoundError(f"{what} file {str(path)!r} does not exist")
    pyogrio = require("pyogrio", "vector", f"reading {what}")
    shapely = require("shapely", "vector", f"reading {what}")
    try:
        names = [str(row[0]) for row in pyogrio.list_layers(str(path))]
    except Exception as exc:
        raise FormatError(f"cannot read {str(path)!r} as a vector file of {what}: {exc}") from exc
    layers = []
    for name in names:
        try:
            meta, _, wkb, columns = pyogrio.raw.read(str(path), layer=name, read_geometry=True)
        except Exception as exc:
            raise FormatError(f"cannot read layer {name!r} of {str(path)!r}: {exc}") from exc
        if wkb is None:  # a table without geometry
            continue
        geoms = _decode(shapely, wkb, path, what, name)
        keep = ~shapely.is_missing(geoms) & ~shapely.is_empty(geoms)
        fields = {str(f): np.asarray(col)[keep] for f, col in zip(meta["fields"], columns)}
        crs = meta.get("crs")
        layers.append(VectorLayer(name, shapely.force_2d(geoms[keep]), fields, to_wkt(crs) if crs else None))
    if not any(len(layer.geometries) for layer in layers):
        raise NoDataError(f"{str(path)!r} holds no {what} features")
    return layers
