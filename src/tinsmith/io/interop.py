"""The Python GIS stack at both ends: its objects in, tinsmith's out, with no file in between.

In (:func:`as_data`, which every registered method applies to its input):

- an ``xarray.DataArray`` of heights (2-D, or 3-D with one band): the
  transform, CRS and nodata from rioxarray's ``.rio`` accessor when
  rioxarray is installed and the array carries them, else the transform
  from evenly spaced ``x``/``y`` (or ``lon``/``lat``) coordinates; NaN is
  xarray's missing value and is nodata here;
- an open rasterio dataset (band 1, its transform, CRS and nodata);
- a laspy ``LasData`` (a :class:`~tinsmith.core.PointCloud` with its class
  codes, attributes and CRS, as :func:`tinsmith.read` gives);
- a numpy array with a transform is :class:`~tinsmith.core.Heightfield`
  ``(z, transform=...)`` itself.

Geometry options (breaklines, control points, land use, footprints,
regions) take shapely geometries and GeoDataFrames too, through the one
path of :mod:`tinsmith.io.geometry`.

Out: :meth:`TerrainMesh.to_trimesh`, ``.to_pyvista``, ``.to_geodataframe``
and ``.to_xarray`` call :func:`to_trimesh`, :func:`to_pyvista`,
:func:`to_geodataframe` and :func:`to_xarray` (through :mod:`tinsmith._hooks`:
the data model sits a layer below io); ``_repr_html_`` shows a mesh in a
notebook.  xarray, rioxarray, geopandas and pyvista stay optional:
each is imported only when its object is met or asked for.
"""

from __future__ import annotations

import base64
import html
import io as _io
import math

import numpy as np

from ..core import Heightfield, TerrainMesh
from ..errors import InvalidInputError, require
from .boundaries import triangle_regions
from .crs import to_wkt
from .gis_formats import triangle_wkb
from .points import las_cloud
from .raster import heightfield_from_dataset


def _family(obj) -> str:
    """The top-level package an object's class comes from ("xarray", "rasterio", ...)."""
    return type(obj).__module__.split(".", 1)[0]


def as_data(obj):
    """A tinsmith data object for ``obj``: data-model objects pass through, GIS-stack objects are converted."""
    family = _family(obj)
    if family == "xarray" and hasattr(obj, "dims"):
        return heightfield_from_xarray(obj)
    if family == "rasterio" and hasattr(obj, "read") and hasattr(obj, "transform"):
        return heightfield_from_rasterio(obj)
    if family == "laspy" and hasattr(obj, "header") and hasattr(obj, "x"):  # as tinsmith.read makes of the file
        return las_cloud(obj)
    return obj


def heightfield_from_xarray(da) -> Heightfield:
    """A Heightfield from a DataArray of heights (see the module docstring for what is read)."""
    if da.ndim == 3 and 1 in da.shape:
        da = da.squeeze(drop=True)
    if da.ndim != 2:
        raise InvalidInputError(f"an xarray DataArray of heights must be 2-D (or one band), got dims {da.dims}")
    transform = crs = nodata = None
    rio = _rio(da)
    if rio is not None:
        transform = tuple(rio.transform())[:6]
        crs = to_wkt(rio.crs)
        nodata = rio.nodata if rio.nodata is not None else rio.encoded_nodata
    if transform is None:
        transform = _transform_from_coords(da)
    z = np.asarray(da.values)
    missing = ~np.isfinite(z) if np.issubdtype(z.dtype, np.floating) else np.zeros(z.shape, bool)
    if nodata is not None and not (isinstance(nodata, float) and math.isnan(nodata)):
        missing |= z == nodata
    return Heightfield(z, transform=transform, crs=crs, nodata_mask=missing, source_dtype=str(z.dtype))


def _rio(da):
    """rioxarray's accessor when rioxarray is installed and the array is georeferenced by it, else None."""
    try:
        import rioxarray  # noqa: F401  (registers the .rio accessor)
    except ImportError:
        return None
    try:
        return da.rio if (da.rio.crs is not None or "spatial_ref" in da.coords) else None
    except Exception:  # rioxarray could not read the array's dims as x/y
        return None


def _transform_from_coords(da) -> tuple[float, ...]:
    """(a, 0, c, 0, e, f) from evenly spaced cell-centre coordinates of the array's last two dims."""
    ydim, xdim = da.dims[-2], da.dims[-1]
    if xdim not in da.coords or ydim not in da.coords:
        raise InvalidInputError(
            f"an xarray DataArray needs coordinates on {ydim!r} and {xdim!r} (or rioxarray's transform) to place "
            "its cells"
        )
    x, y = np.asarray(da[xdim].values, np.float64), np.asarray(da[ydim].values, np.float64)
    for name, v in ((xdim, x), (ydim, y)):
        steps = np.diff(v)
        if len(v) < 2 or not np.allclose(steps, steps[0], rtol=1e-6, atol=0) or steps[0] == 0:
            raise InvalidInputError(f"coordinate {name!r} must be evenly spaced to place the cells of a grid")
    dx, dy = x[1] - x[0], y[1] - y[0]
    return (dx, 0.0, x[0] - dx / 2, 0.0, dy, y[0] - dy / 2)


def heightfield_from_rasterio(ds) -> Heightfield:
    """A Heightfield from band 1 of an open rasterio dataset, by the rules of the file reader
    (:func:`tinsmith.io.raster.heightfield_from_dataset`)."""
    if ds.closed:
        raise InvalidInputError(f"the rasterio dataset {ds.name!r} is closed; open it again")
    return heightfield_from_dataset(ds, ds.name)


# -- out -------------------------------------------------------------------------------------------------------


def to_trimesh(mesh: TerrainMesh):
    """A ``trimesh.Trimesh`` with the same vertices and faces (not merged or reordered), the mesh's attributes
    as its ``vertex_attributes`` and ``face_attributes``."""
    import trimesh

    return trimesh.Trimesh(vertices=mesh.vertices.copy(), faces=mesh.triangles.copy(), process=False,
                           vertex_attributes=mesh.vertex_attributes.copied(),
                           face_attributes=mesh.triangle_attributes.copied())


def to_pyvista(mesh: TerrainMesh):
    """A ``pyvista.PolyData`` with the same vertices and triangles, the height as point data ``z`` and the
    mesh's attributes as point and cell data."""
    pyvista = require("pyvista", "pyvista", "TerrainMesh.to_pyvista")
    faces = np.column_stack([np.full(mesh.n_triangles, 3, np.int64), mesh.triangles]).ravel()
    poly = pyvista.PolyData(mesh.vertices.copy(), faces)
    poly.point_data["z"] = mesh.vertices[:, 2]
    for name, values in mesh.vertex_attributes.items():
        poly.point_data[name] = values
    for name, values in mesh.triangle_attributes.items():
        poly.cell_data[name] = values
    return poly


def to_geodataframe(mesh: TerrainMesh):
    """A GeoDataFrame with one 3-D polygon per triangle (as the GeoPackage writer), its CRS, and the region of
    every triangle when the method recorded regions."""
    geopandas = require("geopandas", "gis", "TerrainMesh.to_geodataframe")
    import shapely

    region, names = triangle_regions(mesh)
    data = {"region": np.asarray(names, dtype=object)[region]} if len(names) > 1 else {}
    return geopandas.GeoDataFrame(data, geometry=shapely.from_wkb(triangle_wkb(mesh)), crs=mesh.crs)


def to_xarray(mesh: TerrainMesh, grid):
    """The mesh re-rasterised on ``grid`` (a Heightfield or a georeferenced DataArray) as a DataArray.

    Heights at the cell centres (NaN where no triangle covers one), ``x``/``y`` coordinates of the centres on a
    north-up grid, and rioxarray's CRS and transform when rioxarray is installed.
    """
    xr = require("xarray", "gis", "TerrainMesh.to_xarray")
    from ..triangulation.sampling import rasterize  # numba: imported when a mesh is rasterised

    hf = grid if isinstance(grid, Heightfield) else as_data(grid)
    if not isinstance(hf, Heightfield):
        raise InvalidInputError(f"to_xarray needs a grid (a Heightfield or a DataArray), got {type(grid).__name__}")
    heights = rasterize(mesh, hf)
    h, w = hf.shape
    a, b, c, d, e, f = hf.transform
    coords = {}
    if b == 0 and d == 0:
        coords = {"y": f + e * (np.arange(h) + 0.5), "x": c + a * (np.arange(w) + 0.5)}
    out = xr.DataArray(heights, dims=("y", "x"), coords=coords, name="height",
                       attrs={"source": "tinsmith", "method": str(mesh.info.get("method", ""))})
    try:
        import rioxarray  # noqa: F401
        from affine import Affine
    except ImportError:
        return out
    out = out.rio.write_transform(Affine(a, b, c, d, e, f))
    crs = hf.crs or mesh.crs
    return out.rio.write_crs(crs) if crs else out


def repr_html(mesh: TerrainMesh) -> str:
    """A notebook's view of a mesh: counts, method, error, CRS and a small plan-view picture."""
    rows = [("vertices", f"{mesh.n_vertices:,}"), ("triangles", f"{mesh.n_triangles:,}")]
    if mesh.info.get("method"):
        rows.append(("method", str(mesh.info["method"])))
    error = mesh.info.get("error") or {}
    if isinstance(error, dict) and error.get("max") is not None:
        rows.append(("max vertical error", f"{error['max']:.6g}"))
    x0, y0, z0, x1, y1, z1 = mesh.bounds if mesh.n_vertices else (0.0,) * 6
    rows.append(("extent", f"x {x0:.6g}..{x1:.6g}, y {y0:.6g}..{y1:.6g}, z {z0:.6g}..{z1:.6g}"))
    if mesh.crs:
        rows.append(("CRS", mesh.crs.split('"')[1] if '"' in mesh.crs else mesh.crs[:60]))
    table = "".join(f"<tr><th style='text-align:left'>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>"
                    for k, v in rows)
    return f"<div><b>TerrainMesh</b><table>{table}</table>{_picture(mesh)}</div>"


def _picture(mesh: TerrainMesh, size: float = 3.0) -> str:
    """An <img> of the mesh in plan view coloured by height (empty without matplotlib or triangles)."""
    if mesh.n_triangles == 0:
        return ""
    try:  # an Agg canvas of its own, outside pyplot: the notebook's backend is never switched
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        return ""
    v, t = mesh.vertices, mesh.triangles
    if mesh.n_triangles > 200_000:  # a picture, not a record: a sample of the triangles
        t = t[:: mesh.n_triangles // 200_000 + 1]
    fig = Figure(figsize=(size, size))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.tripcolor(v[:, 0], v[:, 1], t, v[:, 2], shading="gouraud", cmap="terrain")
    if mesh.n_triangles <= 5_000:
        ax.triplot(v[:, 0], v[:, 1], t, color="black", linewidth=0.2)
    ax.set_aspect("equal")
    ax.set_axis_off()
    buf = _io.BytesIO()
    fig.savefig(buf, format="png", dpi=72, bbox_inches="tight")
    return f"<img src='data:image/png;base64,{base64.b64encode(buf.getvalue()).decode()}'/>"
