"""Vector files: every layer of any format GDAL reads (GeoPackage, Shapefile, GeoJSON, FlatGeobuf, ...).

Read with pyogrio and shapely (extra ``vector``).  Coordinates are returned in
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

__all__ = ["VectorLayer", "read_layers", "read_polygons"]


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
