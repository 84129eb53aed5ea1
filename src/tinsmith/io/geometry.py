"""Every geometry option, from whatever the user has, fitted to the data: one path for the API and the CLI.

Breaklines, control points, holes, flat polygons, quality regions, building
footprints and land use all come here (:func:`prepare`, and :func:`fit` for
land use, whose attributes ride along), given as a vector file (anything GDAL
reads), a GeoDataFrame or GeoSeries, shapely geometries, or arrays in the
data's coordinates.  What a GIS tool does to vectors before an overlay is done
here, and said:

1. **Reprojected.** A layer with a CRS other than the data's is transformed
   by pyproj, datum shifts included, with one ``note`` line saying from what
   to what.  When one side has no CRS the coordinates are taken as they are,
   and refused only when they do not meet the data (the message gives both
   extents).
2. **Cleaned.** Multi-part features are split; empty features, features with
   non-finite coordinates and lines without length are skipped; polygons that
   cross themselves are repaired (GEOS ``make_valid``); vertices closer than a
   tenth of a cell (of the point spacing, for a cloud; of the median edge, for
   a mesh) are merged, across features too (they are snapped to a grid of
   that size); crossing lines get a shared vertex at the crossing (GEOS
   noding); 3-D lines whose Z is missing or null are draped (their Z is left
   to the method, which drapes 2-D lines).
3. **Clipped** to the data's outline: the region the valid cells cover (not the
   raster's box), the occupied area of a point cloud, or the triangles of a
   mesh.  A line that leaves and enters again becomes several lines; points
   outside are dropped; polygons are cut (land use is kept whole and only the
   features entirely outside are dropped, since cutting a water polygon would
   make a shoreline of the data's edge).

One ``warning`` line per option counts what was clipped, what fell entirely
outside and what was skipped or repaired.  Nothing left inside is not an
error: the option is then left out (the warning says so); nothing usable at
all (every feature empty, invalid or of another type) is.
"""

from __future__ import annotations

import contextlib
import os
import warnings
import weakref
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import core
from ..errors import InvalidInputError, NoDataError, TinsmithNote, TinsmithWarning, require
from ..triangulation.outline import boundary_segments, covered
from .crs import describe, to_wkt
from .vector import read_layers

__all__ = ["Features", "Region", "data_outline", "fit", "load", "mask_polygons", "prepare", "prepare_features", "say"]

#: What each kind of option keeps: shapely type ids (0 point, 1 line, 2 ring, 3 polygon).
_KEEPS = {"lines": (1, 2, 3), "points": (0, 1, 2, 3), "polygons": (3,), "regions": (3,), "landuse": (0, 1, 2, 3)}
_WORDS = {"lines": "lines", "points": "points", "polygons": "polygons", "regions": "polygons", "landuse": "features"}


@dataclass
class Features:
    """Geometries with their attribute columns, their CRS (WKT or None) and a label for messages."""

    geometries: np.ndarray  #: shapely geometries, one per feature
    fields: dict = field(default_factory=dict)  #: column name -> array of values, one per feature
    crs: str | None = None
    label: str = ""
    feature: np.ndarray | None = None  #: index of the input feature each geometry came from
    skipped: int = 0  #: features the reader could not build (a line of one point, a ring of three)
    outside: int = 0  #: after :func:`fit`: input features that lie entirely outside the data
    full_z: frozenset = frozenset()  #: after :func:`fit`, lines: the input features whose every Z is given
    unprojectable: int = 0  #: features whose coordinates lie outside their CRS's range (no place in the data's)
    counts: dict = field(default_factory=dict)  #: after :func:`fit`: "total" input features, and those "cut", "outside", ...

    def take(self, index) -> Features:
        index = np.asarray(index)
        return Features(self.geometries[index], {k: np.asarray(v, dtype=object)[index] for k, v in self.fields.items()},
                        self.crs, self.label, None if self.feature is None else self.feature[index], self.skipped)


@dataclass(frozen=True)
class Region:
    """Data known only by its outline: a shapely polygon in ``crs``, whose cell (for merging close vertices) is
    ``unit``.  What a job over a raster too large to load fits its geometry options to (a pyramid's bounds)."""

    outline: object
    crs: str | None
    unit: float


# -- what users give ----------------------------------------------------------------------------------------------

def _is_frame(value) -> bool:
    return hasattr(value, "geometry") and hasattr(value, "columns")


def _is_series(value) -> bool:
    return type(value).__name__ == "GeoSeries"


def _crs_text(crs) -> str | None:
    return to_wkt(crs) if crs is not None else None


def load(value, name: str, kind: str) -> list[Features]:
    """The features of ``value`` (a file path, a GeoDataFrame or GeoSeries, shapely geometries, arrays, or
    (polygon, max_area[, name]) items for regions), one :class:`Features` per layer, not yet fitted."""
    shapely = require("shapely", "vector", f"the {name} option")
    if isinstance(value, (str, os.PathLike)):
        path = Path(value)
        layers = read_layers(path, name, keep_z=True)
        label = f"{name} {str(path)!r}"
        return [Features(layer.geometries, dict(layer.fields), layer.crs, label, skipped=layer.skipped)
                for layer in layers]
    if _is_frame(value):
        columns = {str(c): np.asarray(value[c].to_numpy(), dtype=object) for c in value.columns
                   if c != value.geometry.name}
        return [Features(np.asarray(value.geometry.to_numpy(), dtype=object), columns, _crs_text(value.crs),
                         f"{name} (GeoDataFrame)")]
    if _is_series(value):
        return [Features(np.asarray(value.to_numpy(), dtype=object), {}, _crs_text(value.crs), f"{name} (GeoSeries)")]
    if isinstance(value, shapely.Geometry):
        return [Features(np.array([value], dtype=object), {}, None, name)]
    if kind == "regions" and isinstance(value, (list, tuple)):
        return [_regions(shapely, name, value)]
    return [_arrays(shapely, name, kind, value)]


def _ring_or_geometry(shapely, name: str, i: int, item):
    if isinstance(item, shapely.Geometry) or item is None:
        return item
    try:
        ring = np.asarray(item, dtype=np.float64)
    except (TypeError, ValueError):
        ring = np.empty(0)
    if ring.ndim != 2 or ring.shape[1] not in (2, 3):
        raise InvalidInputError(f"{name}[{i}] must be a polygon (shapely, or a (K, 2) ring), got {type(item).__name__} "
                                f"{item!r:.40}")
    return shapely.Polygon(ring) if len(ring) >= 3 and np.isfinite(ring).all() else None


def _regions(shapely, name: str, items) -> Features:
    geoms, areas, names = [], [], []
    for i, item in enumerate(items):
        if not isinstance(item, (list, tuple)) or len(item) not in (2, 3):
            raise InvalidInputError(f"{name}[{i}] must be a (polygon, max_area) or (polygon, max_area, name) item")
        geoms.append(_ring_or_geometry(shapely, name, i, item[0]))
        areas.append(item[1])
        names.append(item[2] if len(item) == 3 else None)
    return Features(np.array(geoms, dtype=object), {"max_area": np.array(areas, dtype=object),
                                                    "name": np.array(names, dtype=object)}, None, name)


def _arrays(shapely, name: str, kind: str, value) -> Features:
    """Features of array input: (K, 2|3) polylines, an (N, 2|3) array of points, (K, 2) rings or shapely items."""
    if kind == "points":
        if isinstance(value, (list, tuple)) and value and all(isinstance(g, shapely.Geometry) for g in value):
            return Features(np.asarray(list(value), dtype=object), {}, None, name)
        pts = np.asarray(value, dtype=np.float64)
        if pts.ndim == 1 and pts.shape[0] in (2, 3):
            pts = pts[None]
        if pts.ndim != 2 or pts.shape[1] not in (2, 3):
            raise InvalidInputError(f"{name} must be (N, 2) or (N, 3) world coordinates, got shape {pts.shape}")
        geoms = shapely.points(pts)
        geoms[~np.isfinite(pts).all(axis=1)] = None
        return Features(np.asarray(geoms, dtype=object), {}, None, name)
    if isinstance(value, np.ndarray) and value.ndim == 2 and kind == "lines":
        value = [value]
    if not isinstance(value, (list, tuple, np.ndarray)):
        raise InvalidInputError(f"{name} must be a vector file, a GeoDataFrame, shapely geometries or a list of "
                                f"(K, 2) arrays, got {type(value).__name__}")
    geoms = []
    for i, item in enumerate(value):
        if kind != "lines":
            geoms.append(_ring_or_geometry(shapely, name, i, item))
            continue
        if isinstance(item, shapely.Geometry) or item is None:
            geoms.append(item)
            continue
        line = np.asarray(item, dtype=np.float64)
        if line.ndim != 2 or line.shape[1] not in (2, 3):
            raise InvalidInputError(f"{name}[{i}] must be a (K, 2) or (K, 3) polyline, got shape {line.shape}")
        finite = np.isfinite(line[:, :2]).all() and len(line) >= 2
        geoms.append(shapely.linestrings(line) if finite else None)
    return Features(np.array(geoms, dtype=object), {}, None, name)


# -- the data's outline --------------------------------------------------------------------------------------------

_OUTLINES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: data -> the options already fitted to it (kept while the data lives)
_FITTED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def data_outline(data):
    """The region of the plane the data covers, as one shapely (multi)polygon in its coordinates (cached).

    A Heightfield: the union of the full-resolution grid triangles between valid cell centres (what every method
    meshes; see :mod:`tinsmith.triangulation.outline`).  A PointCloud: the cells of a grid of twice the mean
    spacing that hold a point, gaps of up to about 12 spacings closed.  A TerrainMesh: its triangles seen from above
    (the convex hull of its plan view where they overlap: a closed surface).
    """
    try:
        return _OUTLINES[data]
    except (KeyError, TypeError):
        pass
    if isinstance(data, Region):
        return data.outline
    if isinstance(data, core.Heightfield):
        outline = _grid_outline(data)
    elif isinstance(data, core.PointCloud):
        outline = _cloud_outline(np.asarray(data.xyz)[:, :2])
    else:
        outline = _mesh_outline(data)
    with contextlib.suppress(TypeError):  # a data object without weak references
        _OUTLINES[data] = outline
    return outline


def _grid_outline(hf):
    import shapely

    valid = np.asarray(hf.valid, dtype=bool)
    h, w = valid.shape
    if valid.all():
        region = shapely.box(0.0, 0.0, w - 1.0, h - 1.0)  # x = col, y = row
    else:
        segments = boundary_segments(valid)
        if not len(segments):
            return shapely.Polygon()
        faces = shapely.get_parts(shapely.polygonize(shapely.linestrings(segments[:, :, ::-1].astype(np.float64))))
        inside = [covered(valid, float(p.y), float(p.x)) for p in shapely.point_on_surface(faces)]
        region = shapely.coverage_union_all(faces[np.asarray(inside, dtype=bool)])

    def to_world(cr):
        x, y = hf.pixel_to_world(cr[:, 1], cr[:, 0])
        return np.column_stack([x, y])

    return shapely.transform(region, to_world)


def mask_polygons(mask: np.ndarray, transform) -> list:
    """Shapely polygons of the True cells of a boolean grid, placed by its affine ``transform`` (6 numbers)."""
    import shapely
    from rasterio import features
    from rasterio.transform import Affine

    return [shapely.geometry.shape(g) for g, v in features.shapes(mask.astype(np.uint8), mask=mask,
                                                                  transform=Affine(*transform[:6])) if v]


def _cloud_outline(xy: np.ndarray):
    import shapely
    from scipy import ndimage

    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    step = max(2.0 * _mean_spacing(xy), span.max() / 4096.0)  # at most about 4096 cells a side
    pad = 4
    cols = np.floor((xy[:, 0] - lo[0]) / step).astype(np.int64) + pad
    rows = np.floor((xy[:, 1] - lo[1]) / step).astype(np.int64) + pad
    grid = np.zeros((rows.max() + pad + 1, cols.max() + pad + 1), bool)
    grid[rows, cols] = True
    disk = np.add.outer(np.arange(-3, 4) ** 2, np.arange(-3, 4) ** 2) <= 9  # closes gaps of about 6 cells
    grid = ndimage.binary_closing(grid, structure=disk)
    polys = mask_polygons(grid, (step, 0, lo[0] - pad * step, 0, step, lo[1] - pad * step))
    return shapely.coverage_union_all(np.asarray(polys, dtype=object)) if polys else shapely.Polygon()


def _mesh_outline(mesh):
    import shapely

    xy = np.asarray(mesh.vertices, dtype=np.float64)[:, :2]
    tris = np.asarray(mesh.triangles)
    polys = shapely.polygons(xy[np.concatenate([tris, tris[:, :1]], axis=1)])
    try:
        region = shapely.coverage_union_all(polys)
        if shapely.is_valid(region):
            return region
    except shapely.errors.GEOSException:
        pass
    # not a height field seen from above (folds, a closed surface): the convex hull of its plan view
    return shapely.MultiPoint(xy).convex_hull


def _unit_length(data) -> float:
    """A cell of the data: a raster's cell, a cloud's mean spacing, a mesh's median edge (plan view)."""
    if isinstance(data, Region):
        return data.unit
    if isinstance(data, core.Heightfield):
        a, b, _, d, e, _ = data.transform
        return float(np.sqrt(abs(a * e - b * d)))
    if isinstance(data, core.PointCloud):
        return _mean_spacing(np.asarray(data.xyz)[:, :2])
    corners = np.asarray(data.vertices)[np.asarray(data.triangles)][:, :, :2]
    edges = corners[:, [1, 2, 0]] - corners
    return float(np.median(np.hypot(edges[..., 0], edges[..., 1]))) if len(edges) else 1.0


def _mean_spacing(xy: np.ndarray) -> float:
    """The mean spacing of points spread over their bounding box (a line of points: over a sliver of it)."""
    span = np.ptp(xy, axis=0)
    return float(np.sqrt(max(span[0] * span[1], span.max() ** 2 * 1e-6) / max(len(xy), 1)))


# -- fitting -------------------------------------------------------------------------------------------------------

def _extent(bounds) -> str:
    return "(" + ", ".join(f"{v:.10g}" for v in bounds) + ")"


def _reproject(shapely, feats: Features, target: str | None) -> tuple[Features, str | None]:
    """The features in ``target`` (a note when they move); (features, the note)."""
    from pyproj import CRS, Transformer
    from pyproj.exceptions import ProjError

    if not feats.crs or not target:
        return feats, None
    src, dst = CRS.from_user_input(feats.crs), CRS.from_user_input(target)
    if src.equals(dst, ignore_axis_order=True):
        return feats, None
    try:
        move = Transformer.from_crs(src, dst, always_xy=True)
    except ProjError as exc:
        raise InvalidInputError(f"{feats.label}: cannot transform from {describe(feats.crs)} to the data's "
                                f"{describe(target)}: {exc}") from exc

    def moved(coords):  # x, y moved; a Z kept as it is (a vertical datum is the DEM's business)
        out = coords.copy()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            out[:, 0], out[:, 1] = move.transform(coords[:, 0], coords[:, 1], errcheck=False)
        return out

    present = ~shapely.is_missing(feats.geometries)
    geoms = feats.geometries.copy()
    for has_z in (False, True):
        these = present.copy()
        these[present] = shapely.has_z(geoms[present]) == has_z
        if these.any():
            geoms[these] = shapely.transform(geoms[these], moved, include_z=has_z)
    lost = 0
    for i in np.flatnonzero(present):  # out of the CRS's range: nothing to place
        if not np.isfinite(shapely.get_coordinates(geoms[i])).all():
            geoms[i], lost = None, lost + 1
    note = f"{feats.label} reprojected from {describe(feats.crs)} to {describe(target)}"
    moved_feats = Features(geoms, feats.fields, target, feats.label, feats.feature, feats.skipped)
    moved_feats.unprojectable = lost
    return moved_feats, note


def _check_overlap(shapely, feats: Features, outline, data_crs) -> None:
    """Without a CRS on one side, coordinates that do not meet the data are refused (both extents given)."""
    if feats.crs and data_crs:
        return
    present = feats.geometries[~shapely.is_missing(feats.geometries) & ~shapely.is_empty(feats.geometries)]
    if not len(present):
        return
    coords = shapely.get_coordinates(present)
    coords = coords[np.isfinite(coords).all(axis=1)]
    if not len(coords) or outline.is_empty:
        return
    theirs = (*coords.min(axis=0), *coords.max(axis=0))
    ours = outline.bounds
    if theirs[0] > ours[2] or theirs[2] < ours[0] or theirs[1] > ours[3] or theirs[3] < ours[1]:
        side = "they have no CRS" if not feats.crs else "the data has no CRS"
        raise InvalidInputError(
            f"{feats.label} do not overlap the data and {side} to reproject them by: their extent "
            f"{_extent(theirs)}, the data's {_extent(ours)}; give both a CRS, or check the coordinates")


def _clean(shapely, feats: Features, kind: str, unit: float) -> tuple[Features, dict]:
    """Split multi-parts, skip empty, non-finite and lineless features, repair polygons, merge close vertices."""
    n = len(feats.geometries)
    counts = {"invalid": 0, "other": 0, "repaired": 0}
    geoms = feats.geometries
    ok = ~shapely.is_missing(geoms)
    ok[ok] = ~shapely.is_empty(geoms[ok])
    for i in np.flatnonzero(ok):
        if not np.isfinite(shapely.get_coordinates(geoms[i])).all():
            ok[i] = False
    counts["invalid"] += int(n - ok.sum())
    feats = feats.take(np.flatnonzero(ok))
    feats.feature = np.flatnonzero(ok) if feats.feature is None else feats.feature
    parts, index = shapely.get_parts(feats.geometries, return_index=True)
    feats = Features(parts, {k: np.asarray(v, dtype=object)[index] for k, v in feats.fields.items()}, feats.crs,
                     feats.label, feats.feature[index])
    types = shapely.get_type_id(feats.geometries)
    keep = np.isin(types, _KEEPS[kind])
    counts["other"] = len(np.unique(feats.feature[~keep])) if (~keep).any() else 0
    if (~keep).any():
        counts["other_types"] = sorted({str(g.geom_type) for g in feats.geometries[~keep]})
    feats = feats.take(np.flatnonzero(keep))
    geoms = feats.geometries
    if kind in ("polygons", "regions", "landuse"):
        bad = ~shapely.is_valid(geoms)
        if bad.any():
            counts["repaired"] = int(len(np.unique(feats.feature[bad])))
            fixed = [_polygon_parts(shapely, g) if b else g for g, b in zip(geoms, bad, strict=True)]
            geoms = np.array([p for p in fixed], dtype=object)
    if kind == "lines":
        types = shapely.get_type_id(geoms)
        rings = types == 3
        if rings.any():  # polygon rings are lines (closed)
            geoms = geoms.copy()
            geoms[rings] = [shapely.multilinestrings(shapely.get_rings(g)) for g in geoms[rings]]
        geoms = shapely.remove_repeated_points(_merge_close(shapely, geoms, unit / 10.0), 0.0)
    if kind == "points":  # every vertex a point (of points, lines or polygons alike)
        coords, index = shapely.get_coordinates(geoms, return_index=True)
        parts = shapely.points(coords)
    else:
        parts, index = shapely.get_parts(geoms, return_index=True)
    feats = Features(parts, {k: np.asarray(v, dtype=object)[index] for k, v in feats.fields.items()}, feats.crs,
                     feats.label, feats.feature[index])
    if kind == "lines":
        good = shapely.length(feats.geometries) > 0
    elif kind in ("polygons", "regions"):
        good = shapely.area(feats.geometries) > 0
    else:
        good = ~shapely.is_empty(feats.geometries)
    lost = set(feats.feature[~good].tolist()) - set(feats.feature[good].tolist())
    counts["invalid"] += len(lost)
    return feats.take(np.flatnonzero(good)), counts


def _merge_close(shapely, geoms: np.ndarray, tolerance: float) -> np.ndarray:
    """Vertices closer than ``tolerance`` (across geometries too) moved onto one: each cluster of vertices
    joined by such pairs takes the position of its first vertex."""
    from scipy.spatial import cKDTree

    if not len(geoms):
        return geoms
    xyz = shapely.get_coordinates(geoms, include_z=True)
    xy = xyz[:, :2]
    pairs = cKDTree(xy).query_pairs(tolerance, output_type="ndarray")
    if not len(pairs):
        return geoms
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(xy)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    first = np.full(label.max() + 1, n)
    np.minimum.at(first, label, np.arange(n))
    xyz[:, :2] = xy[first[label]]
    flat = ~shapely.has_z(geoms)
    out = shapely.set_coordinates(geoms.copy(), xyz)
    out[flat] = shapely.force_2d(out[flat])
    return out


def _polygon_parts(shapely, geom):
    fixed = shapely.make_valid(geom)
    polys = [p for p in shapely.get_parts(fixed) if p.geom_type in ("Polygon", "MultiPolygon")]
    return shapely.multipolygons(polys) if polys else shapely.Polygon()


def _node(shapely, feats: Features) -> Features:
    """Lines that cross share a vertex at the crossing (GEOS noding), merged again between crossings."""
    if len(feats.geometries) < 1:
        return feats
    noded = shapely.line_merge(shapely.node(shapely.multilinestrings(feats.geometries)))
    parts = shapely.get_parts(noded)
    tree = shapely.STRtree(feats.geometries)
    # each piece keeps the feature it lies on (for the counts): the first input line that covers its middle
    mids = shapely.line_interpolate_point(parts, 0.5, normalized=True)
    hits = tree.query_nearest(mids, all_matches=False)
    owner = np.empty(len(parts), np.int64)
    owner[hits[0]] = feats.feature[hits[1]]
    return Features(parts, {}, feats.crs, feats.label, owner)


def _clip(shapely, feats: Features, outline, kind: str, unit: float) -> tuple[Features, int, int]:
    """Cut to the outline; (features inside, features cut, features entirely outside) counted per input feature."""
    geoms = feats.geometries
    if not len(geoms):
        return feats, 0, 0
    shapely.prepare(outline)
    meets = shapely.intersects(outline, geoms)
    inside = np.zeros(len(geoms), bool)
    inside[meets] = shapely.covers(outline, geoms[meets])
    cut_ids = set()
    if kind == "landuse" or kind == "points":
        kept = feats.take(np.flatnonzero(meets))
        if kind == "points":  # a feature some of whose vertices lie outside is clipped
            cut_ids = set(feats.feature[~meets].tolist()) & set(feats.feature[meets].tolist())
    else:
        out = list(geoms)
        for i in np.flatnonzero(meets & ~inside):
            out[i] = shapely.intersection(geoms[i], outline)
        out = np.array(out, dtype=object)
        parts, index = shapely.get_parts(out[meets], return_index=True)
        owners = feats.feature[np.flatnonzero(meets)][index]
        if kind == "lines":
            parts = shapely.line_merge(parts)
            parts, sub = shapely.get_parts(parts, return_index=True)
            owners = owners[sub]
            good = (shapely.get_type_id(parts) == 1) & (shapely.length(parts) > unit * 1e-6)
        else:
            good = (shapely.get_type_id(parts) == 3) & (shapely.area(parts) > unit * unit * 1e-9)
        fields = {k: np.asarray(v, dtype=object)[np.flatnonzero(meets)][index] for k, v in feats.fields.items()}
        if kind == "lines":
            fields = {k: v[sub] for k, v in fields.items()}
        kept = Features(parts[good], {k: v[good] for k, v in fields.items()}, feats.crs, feats.label, owners[good])
        # a feature is clipped when the cut takes a measurable part (not the rounding of an earlier cut)
        measure = shapely.length if kind == "lines" else shapely.area
        scale = unit if kind == "lines" else unit * unit
        before = np.bincount(feats.feature, measure(geoms), minlength=feats.feature.max() + 1)
        after = np.bincount(kept.feature, measure(kept.geometries), minlength=len(before))
        cut_ids = set(np.flatnonzero(before - after > 1e-6 * scale).tolist())
    out_ids = set(feats.feature.tolist()) - set(kept.feature.tolist())
    cut_ids -= out_ids
    return kept, len(cut_ids), len(out_ids)


def fit(layers: list[Features], data, name: str, kind: str) -> tuple[Features, list[str], str | None]:
    """Reproject, clean, node and clip ``layers`` to ``data``; (the features, notes, the warning or None).

    ``kind`` is one of "lines", "points", "polygons", "regions" or "landuse" (polygons kept whole, see the
    module notes).  Raises :class:`NoDataError` when no feature is usable at all.
    """
    shapely = require("shapely", "vector", f"the {name} option")
    target = getattr(data, "crs", None) or None
    outline = data_outline(data)
    unit = _unit_length(data)
    notes, pieces, counts = [], [], {"invalid": 0, "other": 0, "repaired": 0, "cut": 0, "outside": 0,
                                     "unprojectable": 0}
    total, other_types, label, offset, full_z = 0, set(), layers[0].label if layers else name, 0, set()
    for feats in layers:
        total += len(feats.geometries) + feats.skipped
        counts["invalid"] += feats.skipped
        feats = Features(feats.geometries, feats.fields, feats.crs, feats.label,
                         np.arange(len(feats.geometries)) + offset)
        offset += len(feats.geometries)
        feats, note = _reproject(shapely, feats, target)
        if note and note not in notes:
            notes.append(note)
        counts["unprojectable"] += feats.unprojectable
        counts["invalid"] -= feats.unprojectable  # counted apart, below
        if kind == "lines":
            full_z |= {int(i) for i, g in zip(feats.feature, feats.geometries, strict=True) if g is not None and
                       shapely.has_z(g) and np.isfinite(shapely.get_coordinates(g, include_z=True)[:, 2]).all()}
        _check_overlap(shapely, feats, outline, target)
        feats, c = _clean(shapely, feats, kind, unit)
        for k in ("invalid", "other", "repaired"):
            counts[k] += c[k]
        other_types.update(c.get("other_types", ()))
        pieces.append(feats)
    feats = _concat(pieces, layers[0].crs if layers else None, label)
    if kind == "lines":
        feats = _node(shapely, feats)
    if len(feats.geometries) == 0:
        found = f" (found {', '.join(sorted(other_types))})" if other_types else ""
        why = f"{counts['invalid']} of {total} features empty or invalid"
        if counts["unprojectable"]:
            why += (f", {counts['unprojectable']} out of the range of their CRS ({describe(layers[0].crs)}): is the "
                    "file's CRS right?")
        raise NoDataError(f"{label} hold no usable {_WORDS[kind]}{found}: {why}")
    feats, cut, outside = _clip(shapely, feats, outline, kind, unit)
    counts["cut"], counts["outside"] = cut, outside
    feats.outside, feats.full_z = outside, frozenset(full_z)
    feats.counts = {"total": total, **{k: v for k, v in counts.items() if isinstance(v, int)}}
    return feats, notes, _warning(label, total, counts, kind, len(feats.geometries) == 0)


def _concat(pieces: list[Features], crs, label: str) -> Features:
    if len(pieces) == 1:
        return pieces[0]
    keys = sorted(set().union(*(p.fields for p in pieces)))
    fields = {k: np.concatenate([np.asarray(p.fields.get(k, [None] * len(p.geometries)), dtype=object)
                                 for p in pieces]) for k in keys}
    return Features(np.concatenate([p.geometries for p in pieces]), fields, crs, label,
                    np.concatenate([p.feature for p in pieces]))


def _warning(label: str, total: int, counts: dict, kind: str, nothing_left: bool) -> str | None:
    phrases = (("cut", f"{{}} of {total} features clipped to the data's outline"), ("outside", "{} entirely outside it"),
               ("invalid", "{} empty or invalid skipped"), ("other", f"{{}} not {_WORDS[kind]} skipped"),
               ("unprojectable", "{} out of their CRS's range skipped"), ("repaired", "{} self-intersecting repaired"))
    said = [phrase.format(counts[key]) for key, phrase in phrases if counts[key]]
    if not said:
        return None
    text = f"{label}: " + ", ".join(said)
    return text + ("; none is left inside the data" if nothing_left else "")


def say(notes: list[str], warning: str | None) -> None:
    for note in notes:
        warnings.warn(note, TinsmithNote, stacklevel=3)
    if warning:
        warnings.warn(warning, TinsmithWarning, stacklevel=3)


# -- the method's form ---------------------------------------------------------------------------------------------

def _as_option(shapely, kind: str, feats: Features, data):
    geoms = feats.geometries
    if kind == "points":
        xy = shapely.get_coordinates(geoms)
        return np.unique(xy, axis=0) if len(xy) else None
    if kind == "lines":
        on_cloud = isinstance(data, core.PointCloud)  # a raster's or a mesh's methods take heights from the data
        out = []
        for g, owner in zip(geoms, feats.feature, strict=True):
            if not (on_cloud and int(owner) in feats.full_z):  # 2-D, or a missing or null Z: the method drapes it
                out.append(shapely.get_coordinates(g))
                continue
            xyz = shapely.get_coordinates(g, include_z=True)
            known = np.isfinite(xyz[:, 2])  # a vertex made by a cut or a crossing: Z along the line
            if not known.all():
                along = np.r_[0.0, np.cumsum(np.hypot(*np.diff(xyz[:, :2], axis=0).T))]
                xyz[~known, 2] = np.interp(along[~known], along[known], xyz[known, 2]) if known.any() else np.nan
            out.append(xyz if np.isfinite(xyz[:, 2]).all() else xyz[:, :2])
        return out or None
    if kind == "regions":
        fields = {str(k).lower(): v for k, v in feats.fields.items()}
        areas, names = fields.get("max_area"), fields.get("name")
        items, named = [], {}
        for i, g in enumerate(geoms):
            area = None if areas is None else areas[i]
            if area is not None and isinstance(area, float) and not np.isfinite(area):
                area = None
            label = names[i] if names is not None else None
            label = None if label is None or (isinstance(label, float) and not np.isfinite(label)) else str(label)
            label = label or named.setdefault(int(feats.feature[i]), f"region_{len(named) + 1}")
            items.append((shapely.force_2d(g), area, label))
        return items or None
    return [shapely.force_2d(g) for g in geoms] or None


def prepare(kind: str, value, data, name: str):
    """A geometry option in the form its method takes, from whatever the user gave (see the module notes).

    Parameters
    ----------
    kind : {"lines", "points", "polygons", "regions"}
        What the option takes.
    value : path, GeoDataFrame, GeoSeries, shapely geometries, arrays, or (polygon, max_area[, name]) items
        The user's geometries; arrays and shapely geometries are in the data's coordinates.
    data : Heightfield, PointCloud or TerrainMesh
        What the method meshes: its CRS is the target, its outline the clip.
    name : str
        The option's name, for messages.

    Returns
    -------
    list of (K, 2) or (K, 3) arrays (lines), an (N, 2) array (points), a list of shapely polygons (polygons), a
    list of (polygon, max_area, name) items (regions), or None when nothing is left inside the data.
    """
    if value is None or any(value is done for done in _FITTED.get(data, ())):
        return value
    try:
        import shapely  # noqa: F401
    except ImportError:  # pragma: no cover - without the vector extra arrays reach the method as they are
        if isinstance(value, (str, os.PathLike)):
            require("shapely", "vector", f"reading {name}")
        return value
    import shapely

    feats, notes, warning = fit(load(value, name, kind), data, name, kind)
    say(notes, warning)
    option = _as_option(shapely, kind, feats, data)
    if option is not None:
        # fitted once: the methods a method calls, and the CLI's measures, take it as it is (a data object
        # without weak references is not remembered)
        with contextlib.suppress(TypeError):
            _FITTED.setdefault(data, []).append(option)
    return option


def prepare_features(kind: str, value, data, name: str, *, within: Region | None = None) -> Features:
    """What :func:`prepare` does, returning the fitted :class:`Features` rather than the method's form: each
    geometry with the input feature it came from (``feature``: its position in the input, across layers), its
    attribute columns, and the counts of what was cut, left outside or skipped (``counts``).

    ``within`` clips to that region rather than to the data's outline (a city model's footprints to the
    grid's box: a building over a gap in the data keeps its outline).  A list of polygons :func:`prepare`
    already fitted to ``data`` is taken as it is, its items the features.
    """
    if kind == "polygons" and any(value is done for done in _FITTED.get(data, ())):
        geoms = np.empty(len(value), dtype=object)
        geoms[:] = list(value)
        feats = Features(geoms, {}, getattr(data, "crs", None), name, np.arange(len(geoms)))
        feats.counts = {"total": len(geoms)}
        return feats
    feats, notes, warning = fit(load(value, name, kind), data if within is None else within, name, kind)
    say(notes, warning)
    return feats
