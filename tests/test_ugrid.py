"""UGRID NetCDF (tinsmith.io.ugrid): written by tinsmith, read back by tinsmith, xugrid, uxarray and QGIS."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import tinsmith
from tests.qgis_session import mesh_layer, qgis_app
from tinsmith.io import reader_for

pytest.importorskip("netCDF4")
pytest.importorskip("xarray")


@pytest.fixture(scope="module")
def meshed(tmp_path_factory):
    """A quality mesh of St. Helens with a named region, a breakline and a named boundary segment, written to .nc."""
    import shapely

    hf = tinsmith.sample("st-helens")
    x0, y0, x1, y1 = hf.bounds
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    mesh = tinsmith.simplify(hf, method="quality", max_error=15.0,
                             breaklines=[shapely.LineString([(x0 + 500, y0 + 500), (x1 - 500, y1 - 500)])],
                             regions=[(shapely.box(cx - 1000, cy - 1000, cx + 1000, cy + 1000), None, "crater rim")])
    mesh = tinsmith.segment_outline(mesh, lines={"north wall": shapely.LineString([(x0, y1), (x1, y1)])})
    mesh.vertex_attributes = {"depth": np.linspace(0.0, 1.0, mesh.n_vertices)}
    path = tinsmith.write(mesh, tmp_path_factory.mktemp("ugrid") / "st-helens.nc")
    return mesh, path


def test_round_trip_through_tinsmith(meshed):
    mesh, path = meshed
    assert reader_for(path).description.startswith("UGRID")
    back = tinsmith.read(path)
    assert np.array_equal(back.vertices, mesh.vertices) and np.array_equal(back.triangles, mesh.triangles)
    assert tinsmith.io.crs.to_epsg(back.crs) == tinsmith.io.crs.to_epsg(mesh.crs) == 26710
    assert np.array_equal(back.triangle_attributes["region"], mesh.triangle_attributes["region"])
    assert back.labels["region"] == {1: "crater rim"}  # names with blanks kept (flag_names)
    assert np.array_equal(back.vertex_attributes["depth"], mesh.vertex_attributes["depth"])
    assert set(back.node_strings) == set(mesh.node_strings) and mesh.node_strings
    for name, ids in mesh.node_strings.items():
        assert np.array_equal(back.node_strings[name], ids)
    edges = {tuple(e) for e in np.sort(mesh.constrained_edges, axis=1)}
    assert {tuple(e) for e in np.sort(back.constrained_edges, axis=1)} == edges and edges


def test_the_file_follows_ugrid_and_cf(meshed):
    import xarray as xr

    mesh, path = meshed
    with xr.open_dataset(path) as ds:
        topo = ds["mesh2d"].attrs
        assert topo["cf_role"] == "mesh_topology" and topo["topology_dimension"] == 2
        faces = ds[topo["face_node_connectivity"]]
        assert faces.attrs["start_index"] == 0 and faces.shape == (mesh.n_triangles, 3)
        assert ds["mesh2d_node_z"].attrs["standard_name"] == "altitude"
        assert ds["mesh2d_node_x"].attrs["grid_mapping"] == "crs"
        crs = ds["crs"].attrs
        assert crs["grid_mapping_name"] == "transverse_mercator" and crs["epsg"] == 26710 and crs["crs_wkt"] == crs["wkt"]
        boundary = ds[topo["boundary_node_connectivity"]]
        assert boundary.attrs["cf_role"] == "boundary_node_connectivity"
        names = ds["mesh2d_boundary_name"]
        assert names.attrs["location"] == "boundary"
        assert names.attrs["flag_meanings"].split() == ["wall_1", "north_wall"]  # segment_outline named every edge
        # every border edge once
        written = [tuple(e) for e in np.sort(boundary.values, axis=1)]
        assert len(written) == len(set(written)) == len(mesh.boundary_edges())
        assert set(written) == {tuple(e) for e in np.sort(mesh.boundary_edges(), axis=1)}
        assert ds["mesh2d_region"].attrs["flag_meanings"] == "terrain crater_rim"


def test_xugrid_reads_it(meshed):
    xu = pytest.importorskip("xugrid")
    mesh, path = meshed
    uds = xu.open_dataset(path)
    grid = uds.ugrid.grid
    assert grid.n_face == mesh.n_triangles and grid.n_node == mesh.n_vertices
    assert np.array_equal(grid.face_node_connectivity, mesh.triangles)
    assert np.allclose(grid.node_x, mesh.vertices[:, 0]) and np.allclose(grid.node_y, mesh.vertices[:, 1])
    assert grid.crs.to_epsg() == 26710
    assert np.array_equal(uds["mesh2d_node_z"].values, mesh.vertices[:, 2])
    assert np.array_equal(uds["mesh2d_region"].values, mesh.triangle_attributes["region"])
    # to_xugrid: the same topology, in memory
    again = mesh.to_xugrid()
    assert again.ugrid.grid.n_face == mesh.n_triangles and again.ugrid.grid.crs.to_epsg() == 26710


def test_uxarray_reads_it(meshed):
    ux = pytest.importorskip("uxarray")
    mesh, path = meshed
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # uxarray: projected coordinates, its spherical geometry does not apply
        uxds = ux.open_dataset(path, path)
    grid = uxds.uxgrid
    assert grid.n_face == mesh.n_triangles and grid.n_node == mesh.n_vertices
    assert np.array_equal(np.asarray(grid.face_node_connectivity.values), mesh.triangles)
    assert np.allclose(grid.node_lon.values, mesh.vertices[:, 0]) and np.allclose(grid.node_lat.values, mesh.vertices[:, 1])
    assert np.array_equal(uxds["mesh2d_node_z"].values, mesh.vertices[:, 2])
    region = uxds["mesh2d_region"]
    assert np.array_equal(region.values, mesh.triangle_attributes["region"])
    assert "crater_rim" in region.attrs["flag_meanings"]
    assert "EPSG\",26710" in uxds["crs"].attrs["crs_wkt"]
    names = uxds["mesh2d_boundary_name"]
    assert len(names) == len(mesh.boundary_edges()) and "north_wall" in names.attrs["flag_meanings"]


def test_qgis_reads_it_as_a_mesh_layer_with_its_crs(meshed):
    qgis_app()
    mesh, path = meshed
    layer = mesh_layer(path)
    assert layer.isValid()
    assert layer.crs().authid() == "EPSG:26710"
    provider = layer.dataProvider()
    assert provider.faceCount() == mesh.n_triangles and provider.vertexCount() == mesh.n_vertices
    groups = [provider.datasetGroupMetadata(i).name() for i in range(provider.datasetGroupCount())]
    assert "Bed Elevation" in groups and "mesh2d_region" in groups


def test_quadrilaterals_and_fill_values_from_other_tools(tmp_path):
    """A UGRID file as D-Flow FM writes one: 1-based, mixed triangles and quads with fill values, no CRS."""
    import xarray as xr

    x = np.array([0.0, 1.0, 2.0, 0.0, 1.0, 2.0])
    y = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    faces = np.array([[1, 2, 5, 4], [2, 3, 5, -999]])
    ds = xr.Dataset({
        "Mesh2": ((), 0, {"cf_role": "mesh_topology", "topology_dimension": 2, "node_coordinates": "Mesh2_node_x Mesh2_node_y",
                          "face_node_connectivity": "Mesh2_face_nodes", "face_dimension": "nFaces"}),
        "Mesh2_node_x": ("nNodes", x), "Mesh2_node_y": ("nNodes", y),
        "Mesh2_node_z": ("nNodes", np.arange(6.0), {"mesh": "Mesh2", "location": "node"}),
        "Mesh2_face_nodes": (("nFaces", "nMax"), faces, {"cf_role": "face_node_connectivity", "start_index": 1,
                                                         "_FillValue": -999}),
        "Mesh2_face_level": ("nFaces", np.array([7.0, 8.0]), {"mesh": "Mesh2", "location": "face"}),
    })
    path = tmp_path / "dflow.nc"
    ds.to_netcdf(path, engine="netcdf4")
    mesh = tinsmith.read(path)
    assert mesh.n_triangles == 3 and mesh.crs is None
    assert mesh.vertices[:, 2].tolist() == list(np.arange(6.0))
    assert sorted(map(sorted, mesh.triangles.tolist())) == [[0, 1, 4], [0, 3, 4], [1, 2, 4]]
    assert sorted(mesh.triangle_attributes["face_level"].tolist()) == [7.0, 7.0, 8.0]


def test_a_netcdf_raster_is_still_a_raster(tmp_path):
    """``.nc`` with no mesh topology goes to GDAL, as before."""
    import xarray as xr

    z = np.arange(20.0).reshape(4, 5)
    xr.Dataset({"z": (("y", "x"), z)}, coords={"x": np.arange(5.0) * 10, "y": 100.0 - np.arange(4.0) * 10}).to_netcdf(
        tmp_path / "dem.nc", engine="netcdf4")
    assert reader_for(tmp_path / "dem.nc").kind == "raster"
    assert tinsmith.read(tmp_path / "dem.nc", cell_size=10.0).shape == (4, 5)


def test_geographic_coordinates_are_longitudes_and_latitudes(tmp_path):
    import xarray as xr

    mesh = tinsmith.TerrainMesh(np.array([[10.0, 50.0, 1.0], [10.1, 50.0, 2.0], [10.0, 50.1, 3.0]]),
                                np.array([[0, 1, 2]]), crs="EPSG:4326")
    path = tinsmith.write(mesh, tmp_path / "geo.nc")
    with xr.open_dataset(path) as ds:
        assert ds["mesh2d_node_x"].attrs["standard_name"] == "longitude"
        assert ds["mesh2d_node_x"].attrs["units"] == "degrees_east"
        assert ds["crs"].attrs["grid_mapping_name"] == "latitude_longitude"
    assert tinsmith.io.crs.to_epsg(tinsmith.read(path).crs) == 4326


def test_a_damaged_file_is_one_clear_error(tmp_path):
    path = tmp_path / "bad.nc"
    import xarray as xr

    xr.Dataset({"Mesh2": ((), 0, {"cf_role": "mesh_topology", "topology_dimension": 1})}).to_netcdf(path, engine="netcdf4")
    with pytest.raises(tinsmith.InvalidInputError, match="holds no 2-D UGRID mesh"):
        tinsmith.read(path)


def test_units_are_udunits_and_a_mesh_without_crs_says_none(tmp_path):
    import xarray as xr

    tri = np.array([[0, 1, 2]])
    xyz = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 2.0], [0.0, 1.0, 3.0]])
    for crs, unit in (("EPSG:32611", "m"), ("EPSG:2263", "US_survey_foot"), (None, None)):
        path = tinsmith.write(tinsmith.TerrainMesh(xyz, tri, crs=crs), tmp_path / f"{unit}.nc")
        with xr.open_dataset(path) as ds:
            assert ds["mesh2d_node_x"].attrs.get("units") == unit and ds["mesh2d_node_z"].attrs.get("units") == unit
            assert ("crs" in ds.variables) == (crs is not None)
        back = tinsmith.read(path).crs
        assert (back is None) if crs is None else tinsmith.io.crs.to_epsg(back) == int(crs.split(":")[1])
