"""The Python GIS stack at both ends (tinsmith.io.interop): its objects in, tinsmith's out, round trips."""

import numpy as np
import pytest
import rasterio
import shapely

import tinsmith
from tinsmith.errors import InvalidInputError
from tinsmith.io.interop import as_data

from .conftest import shared

SAMPLE = tinsmith.sample_path("st-helens")
TOPOGRAPHY = "terrain/lidR_forest_lakes/Topography.laz"


@pytest.fixture(scope="module")
def hf():
    return tinsmith.read_heightfield(SAMPLE)


@pytest.fixture(scope="module")
def mesh(hf):
    return tinsmith.simplify(hf, max_error=10.0)


def _same_grid(a, b):
    assert a.shape == b.shape and a.transform == pytest.approx(b.transform, rel=0, abs=1e-9)
    np.testing.assert_array_equal(a.nodata_mask, b.nodata_mask)
    np.testing.assert_array_equal(a.z[a.valid], b.z[b.valid])


def _same_mesh(a, b):
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.triangles, b.triangles)


# -- in -----------------------------------------------------------------------------------------------------


def test_rioxarray_dataarray_in(hf, mesh):
    import rioxarray

    da = rioxarray.open_rasterio(SAMPLE)  # (band, y, x), nodata -32767 as a value, the CRS on .rio
    got = as_data(da)
    _same_grid(got, hf)
    assert got.crs and rasterio.crs.CRS.from_wkt(got.crs) == rasterio.crs.CRS.from_wkt(hf.crs)
    _same_mesh(tinsmith.simplify(da, max_error=10.0), mesh)


def test_plain_dataarray_with_coordinates_and_nan_in(hf):
    import xarray as xr

    a, _, c, _, e, f = hf.transform
    da = xr.DataArray(
        np.where(hf.valid, hf.z, np.nan), dims=("y", "x"),
        coords={"y": f + e * (np.arange(hf.shape[0]) + 0.5), "x": c + a * (np.arange(hf.shape[1]) + 0.5)},
    )
    _same_grid(as_data(da), hf)  # NaN, xarray's missing value, is nodata


def test_dataarray_that_cannot_be_placed_gives_one_line():
    import xarray as xr

    with pytest.raises(InvalidInputError, match="needs coordinates") as info:
        tinsmith.simplify(xr.DataArray(np.zeros((5, 5)), dims=("y", "x")))
    assert "\n" not in str(info.value)
    with pytest.raises(InvalidInputError, match="2-D"):
        tinsmith.simplify(xr.DataArray(np.zeros((2, 5, 5)), dims=("band", "y", "x")))
    uneven = xr.DataArray(np.zeros((3, 3)), dims=("y", "x"), coords={"y": [0.0, 1.0, 3.0], "x": [0.0, 1.0, 2.0]})
    with pytest.raises(InvalidInputError, match="evenly spaced"):
        tinsmith.simplify(uneven)


def test_open_rasterio_dataset_in(hf, mesh):
    with rasterio.open(SAMPLE) as ds:
        _same_grid(as_data(ds), hf)
        _same_mesh(tinsmith.simplify(ds, max_error=10.0), mesh)
    with pytest.raises(InvalidInputError, match="closed"):
        tinsmith.simplify(ds)


def test_numpy_array_with_a_transform_in(hf, mesh):
    raw = tinsmith.Heightfield(np.where(hf.valid, hf.z, np.nan), transform=hf.transform, crs=hf.crs, nodata=float("nan"))
    _same_mesh(tinsmith.simplify(raw, max_error=10.0), mesh)


def test_laspy_lasdata_in():
    import laspy

    topography = shared(TOPOGRAPHY)
    read = tinsmith.read(topography)
    got = as_data(laspy.read(topography))
    np.testing.assert_array_equal(got.xyz, read.xyz)
    np.testing.assert_array_equal(got.classification, read.classification)
    assert got.crs == read.crs and set(got.attributes) == set(read.attributes)
    _same_mesh(tinsmith.simplify(laspy.read(topography), max_error=0.5), tinsmith.simplify(read, max_error=0.5))


def test_shapely_and_geodataframe_geometry_options(hf):
    import geopandas as gpd

    x0, y0, _, _ = hf.bounds
    line = np.array([[x0 + 3020.0, y0 + 3020.0], [x0 + 7030.0, y0 + 9020.0]])  # a third of a cell off centres
    points = np.array([[x0 + 5020.0, y0 + 5020.0]])
    ref = tinsmith.simplify(hf, max_error=10.0, breaklines=[line], control_points=points)
    for lines, pts in [
        (shapely.LineString(line), shapely.MultiPoint(points)),
        ([shapely.LineString(line)], [shapely.Point(points[0])]),
        (gpd.GeoDataFrame(geometry=[shapely.LineString(line)], crs=hf.crs),
         gpd.GeoDataFrame(geometry=[shapely.Point(points[0])], crs=hf.crs)),
        # another CRS: reprojected to the DEM's (the points move by less than a millimetre, the cells stay)
        (gpd.GeoDataFrame(geometry=[shapely.LineString(line)], crs=hf.crs).to_crs(4326),
         gpd.GeoDataFrame(geometry=[shapely.Point(points[0])], crs=hf.crs).to_crs(4326)),
    ]:
        _same_mesh(tinsmith.simplify(hf, max_error=10.0, breaklines=lines, control_points=pts), ref)
    band = shapely.LineString(line).buffer(300.0)
    frame = gpd.GeoDataFrame({"max_area": [5000.0], "name": ["channel"]}, geometry=[band], crs=hf.crs)
    a = tinsmith.simplify(hf, method="quality", max_error=20.0, regions=frame)
    b = tinsmith.simplify(hf, method="quality", max_error=20.0, regions=[(band, 5000.0, "channel")])
    _same_mesh(a, b)
    assert a.labels["region"] == {1: "channel"}


# -- out ----------------------------------------------------------------------------------------------------


def test_to_trimesh_and_pyvista(mesh):
    tm = mesh.to_trimesh()
    np.testing.assert_array_equal(tm.vertices, mesh.vertices)
    np.testing.assert_array_equal(tm.faces, mesh.triangles)
    pytest.importorskip("pyvista", reason="pyvista (VTK) does not load on this machine")
    poly = mesh.to_pyvista()
    np.testing.assert_array_equal(np.asarray(poly.points), mesh.vertices)
    np.testing.assert_array_equal(np.asarray(poly.faces).reshape(-1, 4)[:, 1:], mesh.triangles)
    assert poly.n_cells == mesh.n_triangles


def test_to_trimesh_and_pyvista_carry_the_attributes(mesh):
    labelled = mesh.copy()
    labelled.triangle_attributes["region"] = np.arange(mesh.n_triangles) % 2
    labelled.vertex_attributes["w"] = mesh.vertices[:, 0] * 2
    tm = labelled.to_trimesh()
    np.testing.assert_array_equal(tm.face_attributes["region"], labelled.triangle_attributes["region"])
    np.testing.assert_array_equal(tm.vertex_attributes["w"], labelled.vertex_attributes["w"])
    pytest.importorskip("pyvista", reason="pyvista (VTK) does not load on this machine")
    poly = labelled.to_pyvista()
    np.testing.assert_array_equal(poly.cell_data["region"], labelled.triangle_attributes["region"])
    np.testing.assert_array_equal(poly.point_data["w"], labelled.vertex_attributes["w"])


def test_to_geodataframe(mesh, hf):
    frame = mesh.to_geodataframe()
    assert len(frame) == mesh.n_triangles and frame.crs is not None
    np.testing.assert_allclose(frame.area.to_numpy(), np.abs(mesh.signed_areas_2d()), rtol=1e-9)
    assert frame.geometry.iloc[0].has_z
    quality = tinsmith.simplify(hf, method="quality", max_error=20.0,
                                regions=[(shapely.box(*hf.bounds).centroid.buffer(2000.0), None, "crater")])
    assert set(quality.to_geodataframe()["region"]) == {"terrain", "crater"}


def test_to_xarray_round_trip(mesh, hf):
    from tinsmith.metrics.vertical import rasterize

    da = mesh.to_xarray(hf)
    np.testing.assert_array_equal(da.values, rasterize(mesh, hf))
    assert da.dims == ("y", "x") and da.rio.crs is not None
    back = as_data(da)  # and in again: the same grid
    assert back.transform == pytest.approx(hf.transform, abs=1e-9)
    np.testing.assert_array_equal(back.nodata_mask, np.isnan(da.values))
    # on a DataArray's grid too
    import rioxarray

    np.testing.assert_array_equal(mesh.to_xarray(rioxarray.open_rasterio(SAMPLE)).values, da.values)


def test_notebook_view(mesh):
    page = mesh._repr_html_()
    assert f"{mesh.n_vertices:,}" in page and f"{mesh.n_triangles:,}" in page
    assert "<img src='data:image/png;base64," in page and "greedy" in page


def test_geodataframe_land_use_and_footprints():
    import geopandas as gpd

    dtm = tinsmith.read_heightfield(shared("urban/delft_ahn3/delft_dtm_0.5m.tif"))
    water = shared("vector/delft_bgt/bgt_waterdeel.sqlite")
    frame = gpd.read_file(water)
    frame["role"] = "water"  # a role column: no key matching needed
    _same_mesh(tinsmith.wavelet(dtm, landuse=frame), tinsmith.wavelet(dtm, landuse=water))
    _same_mesh(tinsmith.simplify(dtm, method="wavelet", landuse=frame), tinsmith.wavelet(dtm, landuse=water))


def test_geodataframe_footprints_for_the_city():
    import geopandas as gpd

    from tests.test_city import synthetic_city

    dsm, dtm, truth = synthetic_city()
    footprints = [polygon for polygon, _ in truth]
    frame = gpd.GeoDataFrame(geometry=footprints, crs=None)
    a = tinsmith.city(dsm, ground=dtm, footprints=footprints).mesh
    b = tinsmith.city(dsm, ground=dtm, footprints=frame).mesh
    _same_mesh(a, b)
