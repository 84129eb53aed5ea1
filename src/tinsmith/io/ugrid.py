"""UGRID NetCDF: the unstructured-mesh file of climate, ocean and flood models.

The UGRID 1.0 conventions (ugrid-conventions.github.io) put a mesh in a
NetCDF file as variables that xarray, xugrid, uxarray, QGIS (MDAL) and the
models themselves (D-Flow FM, SCHISM, ICON, MPAS) read.  Written with
xarray and netCDF4 (``pip install 'tinsmith[ugrid]'``); :func:`to_dataset`
is the file as an ``xarray.Dataset``, and :func:`to_xugrid` wraps it in
xugrid's ``UgridDataset``.

What a file written here holds, the topology variable ``mesh2d`` naming the
rest:

- ``mesh2d_node_x``, ``mesh2d_node_y`` (node coordinates) and
  ``mesh2d_node_z`` (elevation, ``standard_name = "altitude"``);
- ``mesh2d_face_nodes``: ``face_node_connectivity``, counter-clockwise,
  ``start_index = 0``; ``mesh2d_face_x``, ``mesh2d_face_y``: the centroids;
- the CRS as a CF grid mapping ``crs`` named by every variable on the mesh
  (``grid_mapping``): pyproj's CF attributes with ``crs_wkt``, GDAL's
  ``spatial_ref``, MDAL's ``wkt`` and the ``epsg`` code where there is one;
- the mesh's attributes of one number a face or a node
  (``mesh2d_region``: the areas of :func:`.boundaries.triangle_regions`),
  coded ones with their names as CF ``flag_values``/``flag_meanings``;
- ``mesh2d_boundary_nodes``: ``boundary_node_connectivity``, every border
  edge once, along the loops; ``mesh2d_boundary_name`` (on the boundary)
  names each: the mesh's own node strings where they run (an inflow, a
  wall: :func:`.boundaries.segment_outline`), else the loop, ``outline_1``
  ...;
- ``mesh2d_constrained_edges``: the edges the method kept as breaklines.

:func:`read_ugrid` reads such a file back, and the 2-D meshes other tools
write (the first 2-D topology; quadrilaterals and other polygons cut into
triangles, fill values honoured); ``.nc`` files that hold no mesh topology
stay rasters (GDAL).
"""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import numpy as np

from .._version import __version__
from ..core import TerrainMesh
from ..errors import FormatError, InvalidInputError, require
from .boundaries import named_boundaries, triangle_regions
from .crs import is_geographic, linear_unit, to_epsg, to_wkt
from .mesh_formats import data_arrays, mesh_from_arrays
from .registry import reader, writer

__all__ = ["from_dataset", "is_ugrid", "read_ugrid", "to_dataset", "to_xugrid", "write_ugrid"]

#: The topology variable and the prefix of every variable on it.
MESH = "mesh2d"
#: The grid-mapping variable.
CRS = "crs"
_NODES, _FACES, _CORNERS = f"{MESH}_nNodes", f"{MESH}_nFaces", f"{MESH}_nMax_face_nodes"
_BOUNDARIES, _CONSTRAINED = f"{MESH}_nBoundary_edges", f"{MESH}_nConstrained_edges"
#: Variables of the topology itself; every other one-column variable on the nodes or faces is an attribute.
_OWN = {f"{MESH}_node_x", f"{MESH}_node_y", f"{MESH}_node_z", f"{MESH}_face_x", f"{MESH}_face_y"}
#: standard_name values read as the nodes' elevation (else a node variable named ``*node_z``).
_HEIGHTS = ("altitude", "height_above_reference_ellipsoid", "surface_altitude", "height")


def _xarray():
    return require("xarray", "ugrid", "UGRID NetCDF")


# -- writing --------------------------------------------------------------------------------------


def _crs_attrs(wkt: str) -> dict:
    """The grid mapping's attributes: CF (pyproj), GDAL's ``spatial_ref``, MDAL's ``wkt``, the EPSG code."""
    from pyproj import CRS as ProjCRS

    crs = ProjCRS.from_wkt(wkt)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pyproj: "you will likely lose important projection information"
            attrs = dict(crs.to_cf())
    except Exception:  # a CRS CF cannot describe: the WKT alone
        attrs = {}
    attrs["crs_wkt"] = wkt
    attrs["spatial_ref"] = wkt
    attrs["wkt"] = wkt
    epsg = to_epsg(wkt)
    if epsg:
        attrs["epsg"] = np.int32(epsg)
    return {k: v for k, v in attrs.items() if isinstance(v, (str, int, float, np.number, list, tuple))}


def _udunits(name: str) -> str:
    """A CRS's linear unit as CF spells units (UDUNITS): metre -> m, US survey foot -> US_survey_foot."""
    known = {"metre": "m", "meter": "m", "foot": "ft", "us survey foot": "US_survey_foot", "kilometre": "km"}
    return known.get(name.strip().lower(), re.sub(r"\s+", "_", name.strip()))


def _meanings(names: dict[int, str]) -> dict:
    """CF ``flag_values`` and ``flag_meanings`` (one word each: blanks become underscores), and the names as they
    are in ``flag_names`` (JSON), which :func:`read_ugrid` prefers."""
    codes = sorted(names)
    return {"flag_values": np.asarray(codes, np.int32),
            "flag_meanings": " ".join(re.sub(r"\s+", "_", str(names[k]).strip()) or f"code_{k}" for k in codes),
            "flag_names": json.dumps({str(k): str(names[k]) for k in codes})}


def _boundary(mesh: TerrainMesh) -> tuple[np.ndarray, np.ndarray, dict[int, str]]:
    """Every border edge once, the code of its name, and the names (1, 2, ...).

    The edges of each of the mesh's node strings come first, in the string's
    order (the border edges among them), then the rest of each loop of the
    outline, ``outline_1``, ... in the loop's order: a named run reads back
    as the string it was.
    """
    loops = named_boundaries(mesh)["outline"]
    if not loops:
        return np.empty((0, 2), np.int64), np.empty(0, np.int32), {}
    border = {}
    for k, lp in enumerate(loops):
        border.update({(int(a), int(b)): k for a, b in zip(lp[:-1], lp[1:], strict=True)})
    edges, code, names = [], [], {}
    for name, ids in mesh.node_strings.items():
        mine = [(int(a), int(b)) for a, b in zip(ids[:-1], ids[1:], strict=True)]
        mine = [e for e in mine if border.pop(e, None) is not None or border.pop(e[::-1], None) is not None]
        if mine:
            names[len(names) + 1] = name
            edges += mine
            code += [len(names)] * len(mine)
    for k in range(len(loops)):
        rest = [e for e, loop in border.items() if loop == k]
        if rest:
            names[len(names) + 1] = f"outline_{k + 1}"
            edges += rest
            code += [len(names)] * len(rest)
    return np.asarray(edges, np.int64).reshape(-1, 2), np.asarray(code, np.int32), names


def to_dataset(mesh: TerrainMesh):
    """The mesh as a UGRID 1.0 ``xarray.Dataset`` (what :func:`write_ugrid` writes; see the module)."""
    xr = _xarray()
    if mesh.n_triangles == 0:
        raise InvalidInputError("the mesh has no triangles; UGRID needs faces")
    v, t = mesh.vertices, mesh.triangles
    geographic = False
    on_mesh = {"mesh": MESH}
    if mesh.crs:
        geographic = is_geographic(mesh.crs)
        on_mesh["grid_mapping"] = CRS
    unit = _udunits(linear_unit(mesh.crs)) if mesh.crs and not geographic else None  # no CRS: no units said
    axis = ("longitude", "latitude") if geographic else ("projection_x_coordinate", "projection_y_coordinate")
    units = ("degrees_east", "degrees_north") if geographic else (unit, unit)
    centroid = v[t].mean(axis=1)
    variables = {
        MESH: ((), np.int32(0), {
            "cf_role": "mesh_topology", "long_name": "Topology data of 2D mesh", "topology_dimension": np.int32(2),
            "node_coordinates": f"{MESH}_node_x {MESH}_node_y", "node_dimension": _NODES,
            "face_node_connectivity": f"{MESH}_face_nodes", "face_dimension": _FACES,
            "max_face_nodes_dimension": _CORNERS, "face_coordinates": f"{MESH}_face_x {MESH}_face_y"}),
        f"{MESH}_face_nodes": ((_FACES, _CORNERS), t.astype(np.int32), {
            "cf_role": "face_node_connectivity", "mesh": MESH, "location": "face", "start_index": np.int32(0),
            "long_name": "vertex nodes of every face, counter-clockwise"}),
    }
    for k, (name, column) in enumerate((("x", v[:, 0]), ("y", v[:, 1]))):
        variables[f"{MESH}_node_{name}"] = (_NODES, column, {
            "standard_name": axis[k], "units": units[k], "location": "node", **on_mesh,
            "long_name": f"{name}-coordinate of the mesh nodes"})
        variables[f"{MESH}_face_{name}"] = (_FACES, centroid[:, k], {
            "standard_name": axis[k], "units": units[k], "location": "face", **on_mesh,
            "long_name": f"{name}-coordinate of the face centroids"})
    variables[f"{MESH}_node_z"] = (_NODES, v[:, 2], {
        "standard_name": "altitude", "long_name": "elevation of the mesh nodes", "units": "m" if geographic else unit,
        "location": "node", "coordinates": f"{MESH}_node_x {MESH}_node_y", **on_mesh})
    region, region_names = triangle_regions(mesh)
    faces = {**data_arrays(mesh.triangle_attributes), "region": region.astype(np.int32)}
    labels = {**mesh.labels, "region": dict(enumerate(region_names))}
    for where, dim, arrays in (("face", _FACES, faces), ("node", _NODES, data_arrays(mesh.vertex_attributes))):
        for name, values in arrays.items():
            var = f"{MESH}_{name}"
            if var in variables or var in _OWN:
                continue
            attrs = {"location": where, "tinsmith_attribute": name, "coordinates": f"{MESH}_{where}_x {MESH}_{where}_y",
                     **on_mesh}
            if name in labels and values.dtype.kind in "iu":
                attrs.update(_meanings(labels[name]))
            variables[var] = (dim, values, attrs)
    edges, code, names = _boundary(mesh)
    if len(edges):
        variables[MESH][2]["boundary_node_connectivity"] = f"{MESH}_boundary_nodes"
        variables[f"{MESH}_boundary_nodes"] = ((_BOUNDARIES, "Two"), edges.astype(np.int32), {
            "cf_role": "boundary_node_connectivity", "mesh": MESH, "location": "boundary", "start_index": np.int32(0),
            "long_name": "the two nodes of every border edge, along the border loops"})
        variables[f"{MESH}_boundary_name"] = (_BOUNDARIES, code, {
            "mesh": MESH, "location": "boundary", "long_name": "the named boundary each border edge belongs to",
            **_meanings(names)})
    if len(mesh.constrained_edges):
        variables[f"{MESH}_constrained_edges"] = ((_CONSTRAINED, "Two"), mesh.constrained_edges.astype(np.int32), {
            "long_name": "edges kept as breaklines (node indices, start index 0)", "start_index": np.int32(0)})
    if mesh.crs:
        variables[CRS] = ((), np.int32(0), _crs_attrs(to_wkt(mesh.crs)))
    title = str(mesh.info.get("name") or mesh.info.get("method") or "tin")
    return xr.Dataset(
        {name: xr.Variable(dims, data, {k: a for k, a in attrs.items() if a is not None})
         for name, (dims, data, attrs) in variables.items()},
        attrs={"Conventions": "CF-1.8 UGRID-1.0", "title": title, "source": f"tinsmith {__version__}"},
    )


@writer([".nc"], description="UGRID 1.0 NetCDF mesh (xugrid, uxarray, QGIS, D-Flow FM; CRS as a CF grid mapping, "
                              "elevation, face attributes, named boundary edges)", carries_crs=True, named=True)
def write_ugrid(mesh: TerrainMesh, path, *, grid=None) -> None:
    """:func:`to_dataset` written as NetCDF-4 (zlib-compressed) by netCDF4."""
    require("netCDF4", "ugrid", "writing UGRID NetCDF")
    ds = to_dataset(mesh)
    encoding = {name: {"zlib": True, "complevel": 1, "_FillValue": None} for name in ds.variables if ds[name].ndim}
    ds.to_netcdf(path, engine="netcdf4", format="NETCDF4", encoding=encoding)


def to_xugrid(mesh: TerrainMesh):
    """The mesh as an ``xugrid.UgridDataset`` (xugrid installed): elevation and attributes on its topology."""
    xu = require("xugrid", "ugrid", "TerrainMesh.to_xugrid")
    return xu.UgridDataset(to_dataset(mesh))


# -- reading --------------------------------------------------------------------------------------


def is_ugrid(path) -> bool:
    """Whether a ``.nc`` file holds a UGRID mesh topology (netCDF4 installed; else it is left to GDAL)."""
    try:
        import netCDF4
    except ImportError:
        return False
    try:
        with netCDF4.Dataset(path) as ds:
            return any(getattr(var, "cf_role", None) == "mesh_topology" for var in ds.variables.values())
    except Exception:
        return False


def _topology(ds, path):
    """The first 2-D mesh topology variable's name."""
    found = [name for name, var in ds.variables.items() if var.attrs.get("cf_role") == "mesh_topology"]
    two_d = [name for name in found if int(ds[name].attrs.get("topology_dimension", 0)) == 2]
    if not two_d:
        raise InvalidInputError(f"{str(path)!r} holds no 2-D UGRID mesh (topologies: {', '.join(found) or 'none'})")
    return two_d[0]


def _connectivity(ds, name: str) -> np.ndarray:
    """An index array 0-based, fill values as -1."""
    var = ds[name]
    a = np.asarray(var.values)
    fill = var.attrs.get("_FillValue", var.encoding.get("_FillValue"))
    missing = ~np.isfinite(a) if a.dtype.kind == "f" else np.zeros(a.shape, bool)
    if fill is not None:
        missing |= a == fill
    a = np.where(missing, 0, a).astype(np.int64) - int(var.attrs.get("start_index", 0))
    a[missing] = -1
    return a


def _triangles(faces: np.ndarray, path) -> tuple[np.ndarray, np.ndarray]:
    """Polygons (rows of node indices, -1 filling) cut into triangles, a fan from each first corner; and the
    face of each triangle.  Triangles alone come back as they are."""
    corners = (faces >= 0).sum(axis=1)
    if (corners < 3).any():
        raise FormatError(f"{str(path)!r} has a face with fewer than 3 nodes")
    face = [np.flatnonzero(corners >= k + 2) for k in range(1, faces.shape[1] - 1)]
    triangles = [faces[f][:, [0, k + 1, k + 2]] for k, f in enumerate(face)]
    return np.concatenate(triangles), np.concatenate(face)


def _crs_of(ds, names) -> str | None:
    """The WKT of the grid mapping the topology's variables name."""
    from pyproj import CRS as ProjCRS

    mapping = {ds[n].attrs.get("grid_mapping") for n in names if n in ds.variables} - {None}
    for name in mapping:
        if name not in ds.variables:
            continue
        attrs = {k.lower(): v for k, v in ds[name].attrs.items()}
        for key in ("crs_wkt", "spatial_ref", "wkt"):
            if attrs.get(key):
                return to_wkt(str(attrs[key]))
        if "grid_mapping_name" in attrs:
            return ProjCRS.from_cf(attrs).to_wkt()
        for key in ("epsg", "epsg_code"):
            if attrs.get(key):
                return to_wkt(f"EPSG:{str(attrs[key]).split(':')[-1]}")
    return None


def _codes(var) -> dict[int, str]:
    """code -> name of a coded variable: ``flag_names`` (tinsmith's, exact), else ``flag_values``/``flag_meanings``."""
    if "flag_names" in var.attrs:
        try:
            return {int(k): str(v) for k, v in json.loads(var.attrs["flag_names"]).items()}
        except (ValueError, AttributeError):
            pass
    values = np.atleast_1d(var.attrs.get("flag_values", []))
    meanings = str(var.attrs.get("flag_meanings", "")).split()
    return {int(k): m for k, m in zip(values, meanings, strict=False)}


def from_dataset(ds, path="<dataset>") -> TerrainMesh:
    """A :class:`TerrainMesh` from a UGRID ``xarray.Dataset`` (a file's, or :func:`to_dataset`'s)."""
    topo = _topology(ds, path)
    attrs = ds[topo].attrs
    x_name, y_name = str(attrs["node_coordinates"]).split()[:2]
    x, y = np.asarray(ds[x_name].values, np.float64), np.asarray(ds[y_name].values, np.float64)
    connectivity = attrs["face_node_connectivity"]
    node_dim, face_dim = ds[x_name].dims[0], attrs.get("face_dimension", ds[connectivity].dims[0])
    faces = _connectivity(ds, connectivity)
    if ds[connectivity].dims[0] != face_dim:
        faces = faces.T  # UGRID lets the corners come first
    on_nodes = [n for n, var in ds.variables.items() if var.dims == (node_dim,) and n not in (x_name, y_name)]
    on_faces = [n for n, var in ds.variables.items() if var.dims == (face_dim,)]
    z_name = next((n for n in on_nodes if ds[n].attrs.get("standard_name") in _HEIGHTS), None)
    z_name = z_name or next((n for n in on_nodes if n.lower().endswith("node_z")), None)
    z = np.asarray(ds[z_name].values, np.float64) if z_name else np.zeros(len(x))
    triangles, per_face = _triangles(faces, path)
    face_x = str(attrs.get("face_coordinates", "")).split()
    triangle_attributes, vertex_attributes, labels = {}, {}, {}
    for names, target, index, skip in ((on_faces, triangle_attributes, per_face, set(face_x)),
                                       (on_nodes, vertex_attributes, slice(None), {z_name})):
        for n in names:
            var = ds[n]
            if n in skip or n in _OWN or var.dtype.kind not in "biuf":
                continue
            label = str(var.attrs.get("tinsmith_attribute") or (n[len(topo) + 1:] if n.startswith(f"{topo}_") else n))
            target[label] = np.asarray(var.values)[index]
            if "flag_meanings" in var.attrs:
                labels[label] = _codes(var)
    if "region" in labels and "region" in triangle_attributes:
        region = triangle_attributes["region"]
        if not region.size or region.max() == 0:
            del triangle_attributes["region"], labels["region"]
        else:
            labels["region"].pop(0, None)
    node_strings = _boundary_strings(ds, attrs)
    constrained = f"{topo}_constrained_edges"
    edges = _connectivity(ds, constrained) if constrained in ds.variables else np.empty((0, 2), np.int64)
    return mesh_from_arrays(
        path, np.column_stack([x, y, z]), triangles,
        crs=_crs_of(ds, [x_name, y_name, *on_nodes, *on_faces]),
        info={"name": str(ds.attrs.get("title", ""))} if ds.attrs.get("title") else None,
        triangle_attributes=triangle_attributes, vertex_attributes=vertex_attributes, labels=labels,
        node_strings=node_strings, constrained_edges=edges,
    )


def _boundary_strings(ds, attrs) -> dict[str, np.ndarray]:
    """The named boundaries other than the loops themselves (``outline_N``), as node strings: each run of
    consecutive edges of one name that meet end to start, in the file's order."""
    name = attrs.get("boundary_node_connectivity")
    if not name or name not in ds.variables:
        return {}
    edges = _connectivity(ds, name)
    dim = ds[name].dims[0]
    tags = next((var for var in ds.variables.values() if var.dims == (dim,) and "flag_meanings" in var.attrs), None)
    if tags is None or not len(edges):
        return {}
    code = np.asarray(tags.values)
    cut = np.flatnonzero((code[1:] != code[:-1]) | (edges[1:, 0] != edges[:-1, 1])) + 1
    names = _codes(tags)
    runs: dict[str, list[np.ndarray]] = {}
    for start, stop in zip(np.r_[0, cut], np.r_[cut, len(edges)], strict=True):
        label = names.get(int(code[start]), f"boundary_{int(code[start])}")
        if not re.fullmatch(r"outline_\d+", label):
            runs.setdefault(label, []).append(np.r_[edges[start:stop, 0], edges[stop - 1, 1]])
    strings = {}
    for label, parts in runs.items():
        strings.update({label: parts[0]} if len(parts) == 1 else {f"{label}_{j + 1}": p for j, p in enumerate(parts)})
    return strings


@reader([".nc"], kind="mesh", description="UGRID NetCDF mesh (the first 2-D topology; polygons cut into triangles)",
        claims=is_ugrid)
def read_ugrid(path) -> TerrainMesh:
    """Read a UGRID NetCDF file's first 2-D mesh (see the module)."""
    xr = _xarray()
    path = Path(path)
    with xr.open_dataset(path, engine="netcdf4", mask_and_scale=False, decode_times=False) as ds:
        return from_dataset(ds.load(), path)
