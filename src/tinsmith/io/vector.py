"""Vector files: every layer of any format GDAL reads (GeoPackage, Shapefile, GeoJSON, FlatGeobuf, ...), and GeoParquet.

Read with pyogrio and shapely (extra ``vector``); GeoParquet (the form in
which Overture Maps and others publish building footprints: Apache Parquet
with the geometry as WKB and the CRS as PROJJSON in the file's ``geo``
metadata, https://geoparquet.org/releases/v1.1.0/) with
``geopandas.read_parquet`` and pyarrow (extra ``gis``), since GDAL builds
rarely carry its Parquet driver.  Coordinates are returned in
the file's CRS, features that cannot be built are counted, not raised; what
is done with them (reprojected, cleaned, clipped to the data) is
:mod:`tinsmith.io.geometry`, the one path of every geometry option.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputNotFoundError, InvalidInputError, NoDataError, require
from .crs import to_wkt

__all__ = ["VectorLayer", "is_parquet", "read_layers", "read_polygons"]


def _decode(shapely, wkb):
    """Shapely geometries of the WKB column; a feature GEOS cannot build (a line of one point, a ring of three)
    or with non-finite coordinates is missing in the result."""
    geoms = shapely.from_wkb(wkb, on_invalid="ignore")
    for i in np.flatnonzero(~shapely.is_missing(geoms)):
        if not np.isfinite(shapely.get_coordinates(geoms[i])).all():
            geoms[i] = None
    return geoms


@dataclass
class VectorLayer:
    """The features of one layer of a vector file: geometries, their attribute columns, and the CRS (WKT)."""

    name: str
    geometries: np.ndarray  #: shapely geometries, one per feature (missing and empty ones left out)
    fields: dict = field(default_factory=dict)  #: attribute name -> array of values, one per feature
    crs: str | None = None
    skipped: int = 0  #: features left out: empty, missing, or not buildable (a line of one point, NaN coordinates)


def read_layers(path, what: str = "land use", keep_z: bool = False) -> list[VectorLayer]:
    """Every layer of a vector file with its attributes (a GeoPackage may hold several; most formats hold one).

    Empty features and those GEOS cannot build are left out and counted in ``skipped``; a file with no
    feature at all is a :class:`NoDataError`.  ``keep_z`` keeps 3-D coordinates (else 2-D).
    """
    path = Path(path)
    if not path.exists():
        raise InputNotFoundError(f"{what} file {str(path)!r} does not exist")
    if is_parquet(path):
        return [_parquet_layer(path, what, keep_z)]
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
        geoms = _decode(shapely, wkb)
        keep = ~shapely.is_missing(geoms) & ~shapely.is_empty(geoms)
        fields = {str(f): np.asarray(col)[keep] for f, col in zip(meta["fields"], columns, strict=True)}
        crs = meta.get("crs")
        geoms = geoms[keep] if keep_z else shapely.force_2d(geoms[keep])
        layers.append(VectorLayer(name, geoms, fields, to_wkt(crs) if crs else None, int((~keep).sum())))
    if not any(len(layer.geometries) + layer.skipped for layer in layers):
        raise NoDataError(f"{str(path)!r} holds no {what} features")
    return layers


def is_parquet(path) -> bool:
    """Whether ``path`` is an Apache Parquet file: its suffix (.parquet, .geoparquet) or, for another suffix, its
    first four bytes ("PAR1", the format's magic number)."""
    path = Path(path)
    if path.suffix.lower() in (".parquet", ".geoparquet"):
        return True
    if not path.is_file():
        return False
    with open(path, "rb") as f:
        return f.read(4) == b"PAR1"


def _parquet_layer(path: Path, what: str, keep_z: bool) -> VectorLayer:
    """The features of a GeoParquet file (its primary geometry column) as one layer named after the file.

    A file whose metadata gives no CRS is in OGC:CRS84 (longitude, latitude on WGS 84), as the GeoParquet
    specification says and geopandas reads it.
    """
    require("pyarrow", "gis", f"reading {what} from GeoParquet")
    geopandas = require("geopandas", "gis", f"reading {what} from GeoParquet")
    shapely = require("shapely", "vector", f"reading {what}")
    try:
        frame = geopandas.read_parquet(path)
    except Exception as exc:
        raise FormatError(f"cannot read {str(path)!r} as a GeoParquet file of {what}: {exc}") from exc
    geoms = np.asarray(frame.geometry.to_numpy(), dtype=object)
    ok = ~shapely.is_missing(geoms)
    ok[ok] = ~shapely.is_empty(geoms[ok])
    for i in np.flatnonzero(ok):  # as GEOS-decoded WKB in the other formats: no feature with NaN coordinates
        if not np.isfinite(shapely.get_coordinates(geoms[i])).all():
            ok[i] = False
    fields = {str(c): np.asarray(frame[c].to_numpy(), dtype=object)[ok] for c in frame.columns
              if c != frame.geometry.name}
    geoms = geoms[ok] if keep_z else shapely.force_2d(geoms[ok])
    if not len(geoms) + int((~ok).sum()):
        raise NoDataError(f"{str(path)!r} holds no {what} features")
    return VectorLayer(path.stem, geoms, fields, to_wkt(frame.crs), int((~ok).sum()))


def read_polygons(path) -> tuple[np.ndarray, str | None]:
    """Every polygon of a vector file (the parts of multipolygons apart) as 2-D shapely polygons, and the file's
    CRS (WKT), as they are in the file."""
    import shapely

    layers = read_layers(path, "polygons")
    geoms = np.concatenate([layer.geometries for layer in layers])
    parts = shapely.get_parts(geoms)
    parts = parts[shapely.get_type_id(parts) == 3]
    if len(parts) == 0:
        raise InvalidInputError(f"{str(path)!r} holds no polygons")
    return parts, next((layer.crs for layer in layers if layer.crs), None)
