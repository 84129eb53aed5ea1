"""Land use from GIS polygons: roles of features and the grid points they make important.

After Goebbels and Pohle-Fröhlich 2015, section 5.

A land-use file (any vector format pyogrio reads: GeoPackage, Shapefile,
GeoJSON, the BGT's SQLite tables, ...) is turned into a :class:`LandUse`: its
features, each with a *role*.  ``roles`` maps a key to a role; a key is

- ``"name"``: every feature of the layer ``name``, or whose ``attribute``
  (the usage column, when given) has the value ``name``;
- ``"field=value"``: every feature whose column ``field`` holds ``value``
  (``"bgt_type=kademuur"``; numbers compare as written, ``1`` matches 1.0).

Keys compare without regard to case.  A feature matched by several keys has
every role they give.  The roles are those of the paper's class 1 and of
water (:data:`ROLES`):

``water``
    a water polygon: flattened to its mean height; its outline is a shoreline.
``shoreline``
    a shoreline of a river or lake (a quay wall, a bank line, ...).
``embankment``
    a railway embankment or similar; its interior points are extra strict.
``bridge``
    a bridge deck; extended by ``bridge_extension`` so that it meets its ramps.
``street``
    a street: important where it touches a (extended) bridge, as ramps do.
``forest``
    wooded land: class 2 points inside use the forest thresholds of Table 1.

:func:`landuse_classes` rasterises the features onto the heightfield's grid:
a grid point is *near* (class 1) when a square ``window`` of grid points
centred on it holds a point of a shoreline, an embankment, an extended bridge
or a street that touches one.  The paper gives the window's size only as
found by experiment (the number is lost in our copy); 9 points is our
default.  Features in another CRS are reprojected to the grid's; features
outside the grid are counted and reported by a warning.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from ... import _checks
from ...core import Heightfield
from ...errors import InvalidInputError, InvalidOptionError, TinsmithWarning, require
from ...io.geometry import Features, fit, say
from ...io.vector import VectorLayer, read_layers
from .wavelet_table import ROLES

__all__ = ["BGT_ROLES", "ROLES", "LandUse", "LandUseClasses", "landuse_classes", "read_landuse"]

_AREA_ROLES = ("water", "bridge", "street", "forest")  # these need polygons

#: Roles for the Dutch large-scale topography (BGT): its layers by their BGT
#: names and table names, the ``bgt_layer`` column of merged extracts, and the
#: attributes that mark quay walls, slopes (talud), railways and woods.
BGT_ROLES = {
    **{key: "water" for key in ("waterdeel", "bgt_layer=bgt_waterdeel")},
    **{key: "bridge" for key in ("overbruggingsdeel", "bridgeconstructionelement", "bgt_layer=bgt_overbruggingsdeel")},
    **{key: "street" for key in ("wegdeel", "trafficarea", "bgt_layer=bgt_wegdeel")},
    **{key: "embankment" for key in (
        "kunstwerkdeel", "bgt_layer=bgt_kunstwerkdeel", "function=spoorbaan", "bgt_functie=spoorbaan",
        "wegdeeloptalud=1", "onbegroeidterreindeeloptalud=1", "begroeidterreindeeloptalud=1",
    )},
    "bgt_type=kademuur": "shoreline",
    **{f"{field}={kind}": "forest" for field in ("class", "bgt_fysiekvoorkomen")
       for kind in ("loofbos", "naaldbos", "gemengd bos")},
}


@dataclass
class LandUse:
    """Land-use features with their roles, in world coordinates of ``crs`` (WKT; None when unknown).

    ``geometries`` holds shapely geometries; ``roles[i]`` is the role of
    ``geometries[i]`` (a feature with two roles is listed twice).

    Examples
    --------
    >>> import shapely
    >>> import tinsmith
    >>> landuse = tinsmith.LandUse([shapely.box(0, 0, 10, 50), shapely.LineString([(10, 0), (10, 50)])],
    ...                            ["water", "shoreline"], crs="EPSG:28992")
    >>> list(landuse.roles)
    ['water', 'shoreline']
    >>> tinsmith.LandUse([shapely.box(0, 0, 10, 50)], ["lake"])
    Traceback (most recent call last):
    ...
    tinsmith.errors.InvalidOptionError: land use: unknown role 'lake'; roles are ...
    """

    geometries: np.ndarray
    roles: np.ndarray
    crs: str | None = None
    source: str = "land use"
    outside: int = 0  #: features dropped for lying entirely outside the DEM's data (:meth:`fitted`)
    skipped: int = 0  #: features of the file left out as empty or not buildable (told by :meth:`fitted`)

    def __post_init__(self):
        self.geometries = np.asarray(self.geometries, dtype=object).ravel()
        self.roles = np.asarray(self.roles, dtype=object).ravel()
        if len(self.geometries) != len(self.roles):
            raise InvalidInputError(
                f"land use: {len(self.geometries)} geometries but {len(self.roles)} roles; give one role per geometry"
            )
        unknown = sorted({str(r) for r in self.roles} - set(ROLES))
        if unknown:
            raise InvalidOptionError(f"land use: unknown role {unknown[0]!r}; roles are {', '.join(ROLES)}")
        shapely = require("shapely", "vector", "land-use classes")
        for role in _AREA_ROLES:
            these = self.geometries[self.roles == role]
            if len(these) and not np.isin(shapely.get_type_id(these), (3, 6)).all():
                raise InvalidInputError(f"{self.source}: features with the role {role!r} must be polygons")

    def fitted(self, hf: Heightfield) -> LandUse:
        """The features in the DEM's CRS, those entirely outside its data dropped (whole features kept: a water
        polygon cut at the DEM's edge would make a shoreline of it), said in one note and one warning line, as
        every geometry option (:func:`tinsmith.io.geometry.fit`)."""
        if not len(self.geometries) and not self.skipped:
            return self
        label = self.source if self.source.startswith("land use") else f"land use {self.source!r}"
        feats = Features(self.geometries, {"role": self.roles}, self.crs, label, skipped=self.skipped)
        feats, notes, warning = fit([feats], hf, "land use", "landuse")
        say(notes, warning)
        fitted = LandUse(feats.geometries, feats.fields["role"], hf.crs or self.crs, self.source)
        fitted.outside = feats.outside
        return fitted


def _text(values) -> np.ndarray:
    """Column values as lower-case text; whole floats as integers (1.0 -> "1"), missing as ""."""
    def one(v):
        if v is None or (isinstance(v, float) and not np.isfinite(v)):
            return ""
        if isinstance(v, (float, np.floating)) and float(v).is_integer():
            return str(int(v))
        return str(v).strip().lower()

    return np.array([one(v) for v in np.asarray(values, dtype=object)], dtype=object)


def read_landuse(path, roles: dict | None = None, attribute: str | None = None) -> LandUse:
    """The features of a vector file (or a GeoDataFrame) that have a role (see the module docstring), as :class:`LandUse`.

    ``roles`` defaults to :data:`BGT_ROLES`; ``attribute`` names the usage
    column whose values keys without ``=`` match besides layer names.  A file
    whose features match no key gives a warning and an empty land use.  A
    GeoDataFrame is one layer; with a column ``role`` and no ``roles``, that
    column gives every feature its role.

    Examples
    --------
    >>> import geopandas
    >>> import shapely
    >>> import tinsmith
    >>> frame = geopandas.GeoDataFrame({"usage": ["canal", "road", "park"]},
    ...                                geometry=[shapely.box(0, 0, 4, 50), shapely.box(4, 0, 9, 50),
    ...                                          shapely.box(9, 0, 30, 50)])
    >>> landuse = tinsmith.read_landuse(frame, roles={"canal": "water", "road": "street"}, attribute="usage")
    >>> list(landuse.roles)  # the park has no role: left out
    ['water', 'street']
    """
    if hasattr(path, "geometry") and hasattr(path, "columns"):  # a GeoDataFrame
        frame, path = path, "GeoDataFrame"
        crs = frame.crs.to_wkt() if frame.crs is not None else None
        if roles is None and "role" in frame.columns:
            return LandUse(np.asarray(frame.geometry.to_numpy(), dtype=object),
                           np.asarray(frame["role"].to_numpy(), dtype=object), crs, path)
        fields = {str(c): frame[c].to_numpy() for c in frame.columns if c != frame.geometry.name}
        layers = [VectorLayer("layer", np.asarray(frame.geometry.to_numpy(), dtype=object), fields, crs)]
    else:
        layers = None
    roles = BGT_ROLES if roles is None else roles
    if not isinstance(roles, dict) or not roles:
        raise InvalidOptionError("roles must be a dict from a layer name, usage value or 'field=value' to a role")
    for key, role in roles.items():
        if role not in ROLES:
            raise InvalidOptionError(f"roles: {key!r} maps to {role!r}, which is not a role; roles are {', '.join(ROLES)}")
    layers = read_layers(path) if layers is None else layers
    if attribute is not None and not any(attribute.lower() in {f.lower() for f in layer.fields} for layer in layers):
        fields = sorted({f for layer in layers for f in layer.fields})
        raise InvalidOptionError(f"attribute {attribute!r} is not a column of {str(path)!r}; its columns: {', '.join(fields)}")
    crs = {layer.crs for layer in layers if len(layer.geometries)}
    if len(crs) > 1:
        raise InvalidInputError(f"{str(path)!r}: its layers are in different CRS; give one layer per file")
    geoms, found = _with_roles(layers, roles, attribute)
    if not geoms:
        warnings.warn(
            f"no feature of {str(path)!r} has a role: its layers are {', '.join(layer.name for layer in layers)}; "
            "map a layer name, usage value or 'field=value' to a role",
            TinsmithWarning,
            stacklevel=2,
        )
    return LandUse(np.array(geoms, dtype=object), np.array(found, dtype=object),
                   crs.pop() if crs else None, Path(path).name, skipped=sum(layer.skipped for layer in layers))



def _with_roles(layers: list, roles: dict, attribute: str | None) -> tuple[list, list]:
    """(geometries, their roles): every feature of ``layers`` a key of ``roles`` matches, once per role, in the
    order of the layers and the keys."""
    geoms, found, seen = [], [], set()
    for layer in layers:
        columns = {name.lower(): col for name, col in layer.fields.items()}
        text = {}
        for key, role in roles.items():
            key = key.strip().lower()
            if "=" in key:
                field, value = (s.strip() for s in key.split("=", 1))
                if field not in columns:
                    continue
                hit = (text.setdefault(field, _text(columns[field])) == value)
            else:
                hit = np.full(len(layer.geometries), key == layer.name.lower())
                if attribute is not None and attribute.lower() in columns:
                    hit |= text.setdefault(attribute.lower(), _text(columns[attribute.lower()])) == key
            for i in np.flatnonzero(hit):
                if (layer.name, i, role) not in seen:
                    seen.add((layer.name, i, role))
                    geoms.append(layer.geometries[i])
                    found.append(role)
    return geoms, found

@dataclass
class LandUseClasses:
    """What land use says about every grid point (H, W): the input of the class rules of section 5."""

    near: np.ndarray  #: bool: class 1, a shoreline, embankment, extended bridge or ramp street in the window
    embankment: np.ndarray  #: bool: inside an embankment (the extra strict points of class 1)
    forest: np.ndarray  #: bool: inside a forest
    water: np.ndarray  #: int32: 1, 2, ... the water body (4-connected cells of water polygons), 0 no water
    decks: np.ndarray  #: int32: 1, 2, ... the bridge (its polygon as given, not extended), 0 none
    sources: dict  #: role -> bool grid of the points that make their neighbours class 1
    outside: int  #: features that lie outside the grid


def _burn(geometries, hf: Heightfield, *, all_touched: bool, labels=None) -> np.ndarray:
    """Rasterise onto the grid of ``hf``: a cell is in when its centre is in a polygon (or any part of it
    touches a geometry, with ``all_touched``)."""
    from rasterio import features
    from rasterio.transform import Affine

    if len(geometries) == 0:
        return np.zeros(hf.shape, np.int32 if labels is not None else bool)
    values = np.ones(len(geometries), np.int32) if labels is None else labels
    shapes = list(zip(geometries, (int(v) for v in values), strict=True))
    out = features.rasterize(shapes, out_shape=hf.shape, transform=Affine(*hf.transform[:6]), fill=0,
                             all_touched=all_touched, dtype="int32")
    return out if labels is not None else out > 0


def landuse_classes(hf: Heightfield, landuse: LandUse, *, window: int = 9, bridge_extension: float = 2.0) -> LandUseClasses:
    """Rasterise ``landuse`` onto ``hf``'s grid (see the module docstring).

    Parameters
    ----------
    hf : Heightfield
        The grid; its CRS is the target of a reprojection.
    landuse : LandUse
        Features with roles (:func:`read_landuse`).
    window : int
        Side of the square of grid points around a point that makes it near
        (odd, at least 1).
    bridge_extension : float
        Bridges are grown by this much (world units) before they are
        rasterised and streets are tested against them.
    """
    window = _checks.integer("window", window, minimum=1)
    if window % 2 == 0:
        raise InvalidOptionError(f"window must be odd (a square centred on the point), got {window}")
    bridge_extension = _checks.number("bridge_extension", bridge_extension, minimum=0.0)
    shapely = require("shapely", "vector", "land-use classes")
    landuse = landuse.fitted(hf)
    geoms, roles, outside = landuse.geometries, landuse.roles, landuse.outside

    def role(name):
        return geoms[roles == name]

    bridges = role("bridge")
    if bridge_extension > 0 and len(bridges):
        bridges = shapely.buffer(bridges, bridge_extension)
    streets = role("street")
    if len(streets) and len(bridges):
        hit = shapely.STRtree(bridges).query(streets, predicate="intersects")[0]
        ramps = streets[np.unique(hit)]
    else:
        ramps = streets[:0]
    water = role("water")
    sources = {
        # a shoreline is where water meets land: the outline of water polygons, and shoreline features
        "shoreline": _burn(np.concatenate([shapely.boundary(water), role("shoreline")]), hf, all_touched=True),
        "embankment": _burn(role("embankment"), hf, all_touched=True),
        "bridge": _burn(bridges, hf, all_touched=True),
        "street": _burn(ramps, hf, all_touched=True),
    }
    any_source = np.zeros(hf.shape, np.uint8)
    for mask in sources.values():
        any_source |= mask
    near = ndimage.maximum_filter(any_source, size=window, mode="constant") > 0
    labels, _ = ndimage.label(_burn(water, hf, all_touched=False))
    decks = role("bridge")
    valid = hf.valid
    return LandUseClasses(
        near=near & valid,
        embankment=_burn(role("embankment"), hf, all_touched=False) & valid,
        forest=_burn(role("forest"), hf, all_touched=False) & valid,
        water=np.where(valid, labels, 0).astype(np.int32),
        decks=np.where(valid, _burn(decks, hf, all_touched=False, labels=np.arange(1, len(decks) + 1)), 0),
        sources=sources,
        outside=outside,
    )
