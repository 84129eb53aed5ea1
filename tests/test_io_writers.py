"""Every writer, checked with a reader that is not tinsmith's, then round-tripped through tinsmith.

Reference readers: meshio (PLY, OBJ, STL, OFF, VTK, VTU, MSH), trimesh (glTF),
pyogrio (GeoJSON, GeoPackage), rasterio (GeoTIFF); 2DM and LandXML have no
reference library, so the tests parse them with plain Python / ElementTree.
"""

from __future__ import annotations

import dataclasses
import json
import os
import struct
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest
import rasterio
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from rasterio.crs import CRS

import tinsmith
import tinsmith.io as tio
from tinsmith.core import Heightfield, TerrainMesh
from tinsmith.errors import FileError, FormatError, InvalidInputError, UnsupportedFormatError
from tinsmith.io.crs import to_epsg
from tinsmith.triangulation.grid import grid_mesh

pytest.importorskip("pyogrio")
import pyogrio.raw  # noqa: E402

LANDXML = "{http://www.landxml.org/schema/LandXML-1.2}"
MESHIO_SUFFIXES = [".ply", ".obj", ".stl", ".off", ".vtk", ".vtu", ".msh"]
GLTF_SUFFIXES = [".gltf", ".glb"]
TEXT_SUFFIXES = [".2dm", ".landxml", ".xml"]
UGRID_SUFFIXES = [".nc"]  # also in test_ugrid (xugrid, uxarray and QGIS read it back)
VECTOR_SUFFIXES = [".geojson", ".gpkg"]
RASTER_SUFFIXES = [".tif", ".tiff"]
MESH_SUFFIXES = MESHIO_SUFFIXES + GLTF_SUFFIXES + TEXT_SUFFIXES + UGRID_SUFFIXES
CITYJSON_SUFFIXES = [".json"]  # tested in test_urban (terrain and buildings)
ADCIRC_SUFFIXES = [".14", ".grd"]  # tested in test_solver_formats (with its own reader of fort.14)
SELAFIN_SUFFIXES = [".slf", ".srf", ".selafin"]  # tested in test_selafin (with its own readers of SELAFIN and .cli)
ALL_SUFFIXES = MESH_SUFFIXES + VECTOR_SUFFIXES + RASTER_SUFFIXES + CITYJSON_SUFFIXES + ADCIRC_SUFFIXES + SELAFIN_SUFFIXES
#: Formats that cannot hold a CRS: the dispatcher writes a .prj beside them.
SIDECAR_SUFFIXES = set(MESHIO_SUFFIXES) | {".2dm"}
ST_HELENS = Path(tinsmith.__file__).parent / "data" / "samples" / "st_helens_30m.tif"


def test_every_suffix_is_tested():
    assert set(tio.WRITERS) == set(ALL_SUFFIXES)


# -- inputs ---------------------------------------------------------------------------------


@pytest.fixture(params=["plane", "cone"])
def case(request, plane_hf, cone_hf):
    """(heightfield, grid mesh): the plane has EPSG:32610, the cone no CRS and a nodata block."""
    hf = plane_hf if request.param == "plane" else cone_hf
    return hf, grid_mesh(hf)


@pytest.fixture(scope="module")
def st_helens():
    """(heightfield, grid mesh) of the St. Helens sample, read with rasterio directly."""
    with rasterio.open(ST_HELENS) as ds:
        hf = Heightfield(
            ds.read(1),
            transform=tuple(ds.transform)[:6],
            crs=ds.crs.to_wkt(),
            nodata=ds.nodata,
            source_dtype=ds.dtypes[0],
        )
    return hf, grid_mesh(hf)


def _epsg(mesh: TerrainMesh):
    return to_epsg(mesh.crs)


def _write(mesh, folder: Path, suffix: str, grid=None) -> Path:
    """Write through the dispatcher; check it left exactly the file (and its .prj) in ``folder``."""
    path = folder / f"out{suffix}"
    assert tio.write(mesh, path, grid=grid) == path
    expected = {path.name}
    if suffix in SIDECAR_SUFFIXES and mesh.crs:
        expected.add("out.prj")
    assert set(os.listdir(folder)) == expected
    return path


def _check_sidecar(path: Path, mesh: TerrainMesh):
    prj = path.with_suffix(".prj")
    if mesh.crs is None:
        assert not prj.exists()
    else:
        assert CRS.from_wkt(prj.read_text()).to_epsg() == _epsg(mesh)


def _float32_tolerance(mesh: TerrainMesh, relative_to=None) -> float:
    """A few float32 ulps of the largest coordinate magnitude (relative to an origin)."""
    v = mesh.vertices if relative_to is None else mesh.vertices - relative_to
    return 4 * float(np.abs(v).max()) * np.finfo(np.float32).eps


# -- meshio formats -----------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", MESHIO_SUFFIXES)
def test_meshio_formats_match_the_reference_reader(case, tmp_path, suffix):
    hf, mesh = case
    path = _write(mesh, tmp_path, suffix)
    ref = meshio.read(path)
    tri = np.concatenate([c.data for c in ref.cells if c.type == "triangle"])
    assert len(tri) == mesh.n_triangles
    if suffix == ".stl":  # unindexed float32 corners; meshio merges identical vertices
        assert len(ref.points) == mesh.n_vertices
        np.testing.assert_array_equal(ref.points[tri], mesh.vertices[mesh.triangles].astype(np.float32))
    else:
        assert ref.points.dtype.itemsize == 8  # float64 kept
        np.testing.assert_array_equal(ref.points, mesh.vertices)
        np.testing.assert_array_equal(tri, mesh.triangles)
    _check_sidecar(path, mesh)


def test_ply_is_binary_little_endian_float64(plane_hf, tmp_path):
    path = _write(grid_mesh(plane_hf), tmp_path, ".ply")
    header = path.read_bytes().split(b"end_header", 1)[0].decode("ascii")
    assert "format binary_little_endian 1.0" in header
    assert "property double x" in header


def test_vtk_is_legacy_version_4_2(plane_hf, tmp_path):
    path = _write(grid_mesh(plane_hf), tmp_path, ".vtk")
    assert path.read_bytes().startswith(b"# vtk DataFile Version 4.2")


def test_gmsh_is_msh22_ascii_with_named_groups(cone_hf, tmp_path):
    mesh = grid_mesh(cone_hf)
    path = _write(mesh, tmp_path, ".msh")
    lines = path.read_text().splitlines()
    assert lines[:3] == ["$MeshFormat", "2.2 0 8", "$EndMeshFormat"]
    ref = meshio.read(path)
    assert {k: list(v) for k, v in ref.field_data.items()} == {"outline": [1, 1], "terrain": [1, 2]}
    blocks = {c.type: k for k, c in enumerate(ref.cells)}
    for key in ("gmsh:physical", "gmsh:geometrical"):  # triangles: the terrain, surface 1
        tags = ref.cell_data[key][blocks["triangle"]]
        assert len(tags) == mesh.n_triangles and (tags == 1).all()
    border = np.sort(ref.cells[blocks["line"]].data, axis=1)  # lines: the border, one loop
    assert (ref.cell_data["gmsh:physical"][blocks["line"]] == 1).all()
    expected = mesh.boundary_edges()
    assert len(border) == len(expected)
    np.testing.assert_array_equal(np.unique(border, axis=0), expected)


def test_meshio_chatter_is_silenced(plane_hf, tmp_path, capsys):
    mesh = grid_mesh(plane_hf)
    for suffix in MESHIO_SUFFIXES:
        tio.read(tio.write(mesh, tmp_path / f"m{suffix}"))
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""


def test_obj_and_off_round_trip_awkward_floats(tmp_path):
    v = np.array([[0.1, 1e-300, -2.5e17], [1 / 3, 123456789.123456789, np.pi], [np.nextafter(1.0, 2.0), -0.0, 7.0]])
    mesh = TerrainMesh(v, [[0, 1, 2]])
    for suffix in (".obj", ".off", ".2dm", ".landxml"):
        path = tio.write(mesh, tmp_path / f"f{suffix}")
        np.testing.assert_array_equal(tio.read_mesh(path).vertices, v)


# -- glTF -------------------------------------------------------------------------------------------


def _gltf_json(path: Path) -> dict:
    data = path.read_bytes()
    if path.suffix == ".glb":
        magic, version, _ = struct.unpack_from("<4sII", data, 0)
        assert magic == b"glTF" and version == 2
        length, kind = struct.unpack_from("<I4s", data, 12)
        assert kind == b"JSON"
        return json.loads(data[20 : 20 + length])
    return json.loads(data)


def _trimesh_world(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World vertices (glTF frame), faces and face normals through trimesh, node transforms applied."""
    scene = trimesh.load_scene(path, process=False)
    (node,) = scene.graph.nodes_geometry
    transform, name = scene.graph[node]
    geom = scene.geometry[name]
    return trimesh.transform_points(geom.vertices, transform), np.asarray(geom.faces), geom.face_normals


def _check_gltf(path: Path, mesh: TerrainMesh):
    tree = _gltf_json(path)
    extras = tree["scenes"][0]["extras"]
    origin = np.array(extras["origin"])
    np.testing.assert_array_equal(origin, np.round(origin))  # whole units
    (node,) = [n for n in tree["nodes"] if "mesh" in n]
    assert node["translation"] == [origin[0], origin[2], -origin[1]]
    position = tree["accessors"][tree["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    assert position["componentType"] == 5126  # float32
    if mesh.crs:
        assert CRS.from_wkt(extras["crs"]).to_epsg() == _epsg(mesh) == extras["epsg"]
    else:
        assert "crs" not in extras
    if path.suffix == ".gltf":
        assert tree["buffers"][0]["uri"].startswith("data:application/octet-stream;base64,")

    world_y_up, faces, normals = _trimesh_world(path)
    np.testing.assert_array_equal(faces, mesh.triangles)
    expected_y_up = mesh.vertices[:, [0, 2, 1]] * [1, 1, -1]
    np.testing.assert_allclose(world_y_up, expected_y_up, rtol=0, atol=_float32_tolerance(mesh, origin))
    # counter-clockwise from above stays front-facing: every face normal points up (+Y)
    assert (normals[:, 1] > 0).all()


@pytest.mark.parametrize("suffix", GLTF_SUFFIXES)
def test_gltf_matches_trimesh(case, tmp_path, suffix):
    _, mesh = case
    _check_gltf(_write(mesh, tmp_path, suffix), mesh)


# -- 2DM and LandXML, parsed independently --------------------------------------------------------


def _parse_2dm(path: Path):
    lines = path.read_text().splitlines()
    assert lines[0] == "MESH2D"
    assert lines[1].startswith('MESHNAME "') and lines[1].endswith('"')
    assert "NUM_MATERIALS_PER_ELEM 1" in lines
    elements = [line.split() for line in lines if line.startswith("E3T ")]
    nodes = [line.split() for line in lines if line.startswith("ND ")]
    strings = [line.split() for line in lines if line.startswith("NS ")]
    assert len(elements) + len(nodes) + len(strings) + 3 == len(lines)
    assert strings[-1][-1] == "outline_1" and int(strings[-1][-2]) < 0  # one loop round a grid mesh
    ids = [int(e[1]) for e in elements]
    tri = np.array([[int(n) for n in e[2:5]] for e in elements])
    materials = {e[5] for e in elements}
    nid = [int(n[1]) for n in nodes]
    xyz = np.array([[float(c) for c in n[2:5]] for n in nodes])
    return ids, tri, materials, nid, xyz


def test_2dm_parsed_independently(case, tmp_path):
    _, mesh = case
    path = _write(mesh, tmp_path, ".2dm")
    ids, tri, materials, nid, xyz = _parse_2dm(path)
    assert ids == list(range(1, mesh.n_triangles + 1))
    assert nid == list(range(1, mesh.n_vertices + 1))
    assert materials == {"1"}
    np.testing.assert_array_equal(tri - 1, mesh.triangles)
    np.testing.assert_array_equal(xyz, mesh.vertices)
    _check_sidecar(path, mesh)


def _parse_landxml(path: Path):
    root = ET.parse(path).getroot()
    assert root.tag == f"{LANDXML}LandXML"
    surfaces = root.findall(f"{LANDXML}Surfaces/{LANDXML}Surface")
    assert len(surfaces) == 1
    definition = surfaces[0].find(f"{LANDXML}Definition")
    assert definition.get("surfType") == "TIN"
    points = definition.findall(f"{LANDXML}Pnts/{LANDXML}P")
    faces = definition.findall(f"{LANDXML}Faces/{LANDXML}F")
    ids = [int(p.get("id")) for p in points]
    ney = np.array([[float(c) for c in p.text.split()] for p in points])
    tri = np.array([[int(i) for i in f.text.split()] for f in faces])
    return root, ids, ney, tri


@pytest.mark.parametrize("suffix", [".landxml", ".xml"])
def test_landxml_parsed_independently(case, tmp_path, suffix):
    _, mesh = case
    path = _write(mesh, tmp_path, suffix)
    root, ids, ney, tri = _parse_landxml(path)
    assert root.get("version") == "1.2"
    assert len(root.get("date")) == 10 and len(root.get("time")) == 8
    assert root.find(f"{LANDXML}Application").get("name") == "tinsmith"
    metric = root.find(f"{LANDXML}Units/{LANDXML}Metric")
    assert metric is not None and metric.get("linearUnit") == "meter"
    assert ids == list(range(1, mesh.n_vertices + 1))
    np.testing.assert_array_equal(ney[:, 0], mesh.vertices[:, 1])  # northing first
    np.testing.assert_array_equal(ney[:, 1], mesh.vertices[:, 0])
    np.testing.assert_array_equal(ney[:, 2], mesh.vertices[:, 2])
    np.testing.assert_array_equal(tri - 1, mesh.triangles)
    cs = root.find(f"{LANDXML}CoordinateSystem")
    if mesh.crs:
        assert int(cs.get("epsgCode")) == _epsg(mesh)
        assert CRS.from_wkt(cs.get("ogcWktCode")).to_epsg() == _epsg(mesh)
    else:
        assert cs is None
    assert not path.with_suffix(".prj").exists()


@pytest.mark.parametrize(
    ("crs", "system", "linear"),
    [("EPSG:2227", "Imperial", "USSurveyFoot"), ("EPSG:2992", "Imperial", "foot"), ("EPSG:26710", "Metric", "meter")],
)
def test_landxml_units_follow_the_crs(tmp_path, crs, system, linear):
    mesh = TerrainMesh([[0, 0, 1], [1, 0, 2], [0, 1, 3]], [[0, 1, 2]], crs=crs)
    root = ET.parse(tio.write(mesh, tmp_path / "u.xml")).getroot()
    units = root.find(f"{LANDXML}Units")[0]
    assert units.tag == f"{LANDXML}{system}"
    assert units.get("linearUnit") == linear
    assert units.get("areaUnit") == ("squareFoot" if system == "Imperial" else "squareMeter")
    assert units.get("volumeUnit") == ("cubicFeet" if system == "Imperial" else "cubicMeter")


def test_landxml_date_honours_source_date_epoch(tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")  # 2023-11-14 22:13:20 UTC
    mesh = TerrainMesh([[0, 0, 1], [1, 0, 2], [0, 1, 3]], [[0, 1, 2]])
    root = ET.parse(tio.write(mesh, tmp_path / "d.landxml")).getroot()
    assert (root.get("date"), root.get("time")) == ("2023-11-14", "22:13:20")


def test_2dm_reader_takes_quads_and_sparse_ids(tmp_path):
    path = tmp_path / "hand.2dm"
    path.write_text(
        "MESH2D\nMESHNAME \"hand\"\n"
        "E4Q 7 10 20 30 40 1\n"
        "E3T 9 20 50 30 2\n"
        "NS 10 20 -30\n"
        "ND 10 0 0 1\nND 20 1 0 2\nND 30 1 1 3\nND 40 0 1 4\nND 50 2 0.5 5\n"
    )
    mesh = tio.read_mesh(path)
    np.testing.assert_array_equal(mesh.vertices[:, 2], [1, 2, 3, 4, 5])
    assert mesh.n_triangles == 3
    assert mesh.check() == []  # counter-clockwise kept
    assert mesh.info["name"] == "hand"


def test_2dm_reader_rejects_unknown_node(tmp_path):
    path = tmp_path / "bad.2dm"
    path.write_text("MESH2D\nE3T 1 1 2 9 1\nND 1 0 0 0\nND 2 1 0 0\nND 3 0 1 0\n")
    with pytest.raises(FormatError, match="bad.2dm.*node id 9"):
        tio.read_mesh(path)


def test_landxml_reader_ids_invisible_faces_and_other_versions(tmp_path):
    path = tmp_path / "other.xml"
    path.write_text(
        '<?xml version="1.0"?>\n'
        '<LandXML xmlns="http://www.landxml.org/schema/LandXML-1.0" version="1.0">'
        '<CoordinateSystem epsgCode="26710"/>'
        '<Surfaces><Surface name="ground"><Definition surfType="TIN"><Pnts>'
        '<P id="5">10 100 1</P><P id="2">10 101 2</P><P id="9">11 100 3</P><P id="4">11 101 4</P>'
        "</Pnts><Faces><F>5 2 9</F><F i=\"1\">2 4 9</F></Faces></Definition></Surface>"
        '<Surface name="second"><Definition surfType="TIN"><Pnts><P id="1">0 0 0</P></Pnts></Definition></Surface>'
        "</Surfaces></LandXML>"
    )
    mesh = tio.read_mesh(path)
    np.testing.assert_array_equal(mesh.vertices[0], [100, 10, 1])  # easting, northing, elevation
    np.testing.assert_array_equal(mesh.triangles, [[0, 1, 2]])
    assert to_epsg(mesh.crs) == 26710
    assert mesh.info["name"] == "ground"


# -- GeoJSON and GeoPackage ---------------------------------------------------------------------------


def _polygon_rings(wkb_list) -> np.ndarray:
    """(M, 4, 3) rings of single-ring 3-D polygons, ISO (1003) or extended (0x80000003) WKB."""
    rings = []
    for wkb in wkb_list:
        wkb = bytes(wkb)
        order, kind, n_rings, n_points = struct.unpack_from("<BIII", wkb, 0)
        assert order == 1 and kind in (1003, 0x80000003) and n_rings == 1 and n_points == 4
        assert len(wkb) == 109
        rings.append(np.frombuffer(wkb, "<f8", offset=13).reshape(4, 3))
    return np.array(rings)


@pytest.mark.parametrize("suffix", VECTOR_SUFFIXES)
def test_vector_formats_match_pyogrio(case, tmp_path, suffix):
    _, mesh = case
    path = _write(mesh, tmp_path, suffix)
    info = pyogrio.read_info(path)
    assert info["features"] == mesh.n_triangles
    assert info["geometry_type"] == "Polygon Z"
    assert list(info["fields"]) == ["id", "zmean"]
    assert pyogrio.list_layers(path)[0][0] == "tin"
    if mesh.crs:
        assert CRS.from_user_input(info["crs"]).to_epsg() == _epsg(mesh)
    elif suffix == ".geojson":  # GeoJSON without a "crs" member means WGS 84 to every reader
        assert "crs" not in json.loads(path.read_text())
    else:
        assert info["crs"] is None
    _, _, geometry, (ids, zmean) = pyogrio.raw.read(path)
    rings = _polygon_rings(geometry)
    np.testing.assert_array_equal(rings, mesh.vertices[mesh.triangles[:, [0, 1, 2, 0]]])
    np.testing.assert_array_equal(ids, np.arange(mesh.n_triangles))
    np.testing.assert_allclose(zmean, mesh.vertices[mesh.triangles, 2].mean(axis=1), rtol=1e-15)


def test_geojson_keeps_a_projected_crs_in_a_crs_member(plane_hf, tmp_path):
    path = _write(grid_mesh(plane_hf), tmp_path, ".geojson")
    doc = json.loads(path.read_text())
    assert doc["crs"]["properties"]["name"] == "urn:ogc:def:crs:EPSG::32610"


# -- GeoTIFF ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", RASTER_SUFFIXES)
def test_geotiff_matches_rasterio(case, tmp_path, suffix):
    hf, mesh = case
    path = _write(mesh, tmp_path, suffix, grid=hf)
    with rasterio.open(path) as ds:
        assert ds.shape == hf.shape
        assert tuple(ds.transform)[:6] == hf.transform
        assert np.isnan(ds.nodata)
        assert ds.dtypes[0] == ("float64" if hf.source_dtype == "float64" else "float32")
        assert ds.profile["tiled"] and ds.compression.name.lower() == "deflate"
        if hf.crs:
            assert ds.crs.to_epsg() == CRS.from_user_input(hf.crs).to_epsg()
        else:
            assert ds.crs is None
        z = ds.read(1).astype(np.float64)
    np.testing.assert_array_equal(z, hf.z)  # NaN exactly in the nodata cells


def test_geotiff_keeps_float32_and_int16_heights(tmp_path):
    z = np.arange(20, dtype=np.int16).reshape(4, 5) * 1000 + 7
    hf = Heightfield(z, cell_size=1.0, crs="EPSG:32610")
    path = tio.write(grid_mesh(hf), tmp_path / "i.tif", grid=hf)
    with rasterio.open(path) as ds:
        assert ds.dtypes[0] == "float32"
        np.testing.assert_array_equal(ds.read(1), z)


# -- round trip through tinsmith's readers ------------------------------------------------------------


@pytest.mark.parametrize("suffix", MESH_SUFFIXES)
def test_round_trip_through_tinsmith(case, tmp_path, suffix):
    _, mesh = case
    back = tio.read_mesh(_write(mesh, tmp_path, suffix))
    assert back.n_triangles == mesh.n_triangles
    assert _epsg(back) == _epsg(mesh)
    assert back.info["source"].endswith(f"out{suffix}")
    if suffix == ".stl":
        np.testing.assert_array_equal(
            back.vertices[back.triangles], mesh.vertices[mesh.triangles].astype(np.float32).astype(np.float64)
        )
    elif suffix in GLTF_SUFFIXES:
        np.testing.assert_array_equal(back.triangles, mesh.triangles)
        atol = _float32_tolerance(mesh, np.round(mesh.vertices.mean(0))) * 2
        np.testing.assert_allclose(back.vertices, mesh.vertices, rtol=0, atol=atol)
    else:
        np.testing.assert_array_equal(back.triangles, mesh.triangles)
        np.testing.assert_array_equal(back.vertices, mesh.vertices)
    assert back.check() == []


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64), min_size=9, max_size=9))
def test_text_formats_round_trip_any_float64(values):
    mesh = TerrainMesh(np.array(values).reshape(3, 3), [[0, 1, 2]])
    with tempfile.TemporaryDirectory() as folder:
        for suffix in (".2dm", ".landxml", ".obj", ".off", ".ply", ".msh", ".vtu"):
            back = tio.read_mesh(tio.write(mesh, Path(folder) / f"h{suffix}"))
            np.testing.assert_array_equal(back.vertices, mesh.vertices)


def test_meshio_reader_splits_quads_and_rejects_triangle_free_files(tmp_path):
    points = np.array([[0, 0, 1], [1, 0, 2], [1, 1, 3], [0, 1, 4]], dtype=float)
    meshio.write(tmp_path / "q.vtu", meshio.Mesh(points, [("quad", np.array([[0, 1, 2, 3]]))]))
    mesh = tio.read_mesh(tmp_path / "q.vtu")
    assert mesh.n_triangles == 2 and mesh.check() == []
    meshio.write(tmp_path / "lines.vtu", meshio.Mesh(points, [("line", np.array([[0, 1], [1, 2]]))]))
    with pytest.raises(InvalidInputError, match="lines.vtu.*no triangles"):
        tio.read_mesh(tmp_path / "lines.vtu")


def test_reader_takes_the_crs_of_a_prj_sidecar(tmp_path):
    mesh = TerrainMesh([[0, 0, 1], [1, 0, 2], [0, 1, 3]], [[0, 1, 2]])
    path = tio.write(mesh, tmp_path / "s.ply")
    assert tio.read_mesh(path).crs is None
    path.with_suffix(".prj").write_text(CRS.from_epsg(26710).to_wkt(version="WKT1_ESRI"))
    assert to_epsg(tio.read_mesh(path).crs) == 26710


# -- St. Helens: real coordinates, 150k vertices ------------------------------------------------------


@pytest.mark.slow
def test_st_helens_geotiff_reproduces_the_dem(st_helens, tmp_path):
    hf, mesh = st_helens
    path = _write(mesh, tmp_path, ".tif", grid=hf)
    with rasterio.open(ST_HELENS) as src, rasterio.open(path) as out:
        dem = src.read(1, masked=True)
        back = out.read(1)
        assert out.crs == src.crs and out.transform == src.transform
        assert out.dtypes[0] == "float32"
    assert np.array_equal(np.isnan(back), np.ma.getmaskarray(dem))
    valid = ~np.ma.getmaskarray(dem)
    assert np.array_equal(back[valid], dem.data[valid].astype(np.float32))


@pytest.mark.slow
@pytest.mark.parametrize("suffix", [".glb", ".2dm", ".landxml", ".vtu", ".gpkg"])
def test_st_helens_formats(st_helens, tmp_path, suffix):
    _, mesh = st_helens
    path = _write(mesh, tmp_path, suffix)
    if suffix == ".glb":
        _check_gltf(path, mesh)
        # relative float32 positions keep millimetres at UTM coordinates
        back = tio.read_mesh(path)
        assert np.abs(back.vertices - mesh.vertices).max() < 1e-3
    elif suffix == ".gpkg":
        assert pyogrio.read_info(path)["features"] == mesh.n_triangles
        assert CRS.from_user_input(pyogrio.read_info(path)["crs"]).to_epsg() == 26710
    else:
        back = tio.read_mesh(path)
        np.testing.assert_array_equal(back.vertices, mesh.vertices)
        np.testing.assert_array_equal(back.triangles, mesh.triangles)
        assert _epsg(back) == 26710


# -- atomic output and errors ---------------------------------------------------------------------------


def _half_then_fail(mesh, path, *, grid=None):
    Path(path).write_bytes(b"ply\nformat binary_little_endian 1.0\n")
    raise RuntimeError("disk on fire")


@pytest.fixture
def failing_ply(monkeypatch):
    record = tio.WRITERS[".ply"]
    monkeypatch.setitem(tio.WRITERS, ".ply", dataclasses.replace(record, function=_half_then_fail))


def test_failed_write_leaves_nothing(plane_hf, tmp_path, failing_ply):
    with pytest.raises(FormatError, match="out.ply.*disk on fire"):
        tio.write(grid_mesh(plane_hf), tmp_path / "out.ply")
    assert os.listdir(tmp_path) == []


def test_failed_rewrite_keeps_the_old_file(plane_hf, tmp_path, monkeypatch):
    mesh = grid_mesh(plane_hf)
    path = _write(mesh, tmp_path, ".ply")
    before = {name: (tmp_path / name).read_bytes() for name in os.listdir(tmp_path)}
    record = tio.WRITERS[".ply"]
    monkeypatch.setitem(tio.WRITERS, ".ply", dataclasses.replace(record, function=_half_then_fail))
    with pytest.raises(FormatError):
        tio.write(mesh, path)
    assert {name: (tmp_path / name).read_bytes() for name in os.listdir(tmp_path)} == before


def test_unsupported_suffix_lists_the_known_ones(plane_hf, tmp_path):
    with pytest.raises(UnsupportedFormatError) as err:
        tio.write(grid_mesh(plane_hf), tmp_path / "out.dwg")
    for suffix in (".ply", ".2dm", ".landxml", ".gpkg", ".tif"):
        assert suffix in str(err.value)
    assert os.listdir(tmp_path) == []


def test_missing_output_folder(plane_hf, tmp_path):
    with pytest.raises(FileError, match="does not exist"):
        tio.write(grid_mesh(plane_hf), tmp_path / "nowhere" / "out.obj")


def test_geotiff_needs_the_grid(plane_hf, tmp_path):
    with pytest.raises(InvalidInputError, match="grid"):
        tio.write(grid_mesh(plane_hf), tmp_path / "out.tif")
    assert os.listdir(tmp_path) == []


# -- attributes: the formats that hold them -----------------------------------------------------


def _with_attributes(mesh: TerrainMesh) -> TerrainMesh:
    """``mesh`` carrying one attribute of every kind a writer meets (numbers, booleans, strings, two columns)."""
    m, n = mesh.n_triangles, mesh.n_vertices
    return TerrainMesh(
        mesh.vertices, mesh.triangles, crs=mesh.crs,
        triangle_attributes={"region": np.arange(m, dtype=np.int64) % 3, "share": np.linspace(0, 1, m),
                             "flag": np.arange(m) % 2 == 0, "pair": np.zeros((m, 2))},
        vertex_attributes={"w": np.linspace(-1, 1, n), "id": np.arange(n, dtype=np.int64),
                           "site": np.array(["free"] * n)},
    )


@pytest.mark.parametrize("suffix", [".vtk", ".vtu"])
def test_vtk_carries_one_column_attributes_as_cell_and_point_data(case, tmp_path, suffix):
    mesh = _with_attributes(case[1])
    path = _write(mesh, tmp_path, suffix)
    ref = meshio.read(path)
    assert set(ref.cell_data) == {"region", "share", "flag"} and set(ref.point_data) == {"w", "id"}
    np.testing.assert_array_equal(ref.cell_data["region"][0], mesh.triangle_attributes["region"])
    np.testing.assert_array_equal(ref.point_data["w"], mesh.vertex_attributes["w"])
    back = tio.read_mesh(path)
    assert set(back.triangle_attributes) == {"region", "share", "flag"} and set(back.vertex_attributes) == {"w", "id"}
    for name in ("region", "share", "flag"):
        np.testing.assert_array_equal(back.triangle_attributes[name], mesh.triangle_attributes[name])
        assert back.triangle_attributes[name].dtype.isnative
    for name in ("w", "id"):
        np.testing.assert_array_equal(back.vertex_attributes[name], mesh.vertex_attributes[name])
    assert back.triangle_attributes["flag"].dtype == np.uint8  # booleans as 0/1


def test_ply_carries_one_column_vertex_attributes(plane_hf, tmp_path):
    mesh = _with_attributes(grid_mesh(plane_hf))
    mesh.vertex_attributes["big"] = np.full(mesh.n_vertices, 2**40, np.int64)  # no int32: left out
    path = _write(mesh, tmp_path, ".ply")
    header = path.read_bytes().split(b"end_header", 1)[0].decode("ascii")
    assert "property int32 id" in header and "property double w" in header
    assert "big" not in header and "region" not in header  # no face properties (meshio writes none)
    back = tio.read_mesh(path)
    assert set(back.vertex_attributes) == {"w", "id"} and back.triangle_attributes == {}
    np.testing.assert_array_equal(back.vertex_attributes["id"], mesh.vertex_attributes["id"])
    np.testing.assert_array_equal(back.vertex_attributes["w"], mesh.vertex_attributes["w"])


def test_meshio_reader_gives_each_half_of_a_quad_its_cell_data(tmp_path):
    points = np.array([[0, 0, 1], [1, 0, 2], [1, 1, 3], [0, 1, 4], [2, 0, 0]], dtype=float)
    cells = [("triangle", np.array([[1, 4, 2]])), ("quad", np.array([[0, 1, 2, 3]]))]
    meshio.write(tmp_path / "mixed.vtu", meshio.Mesh(points, cells, cell_data={"region": [np.array([7]), np.array([5])]}))
    back = tio.read_mesh(tmp_path / "mixed.vtu")
    np.testing.assert_array_equal(back.triangle_attributes["region"], [7, 5, 5])


def test_2dm_materials_and_node_strings_round_trip(cone_hf, tmp_path):
    mesh = grid_mesh(cone_hf)
    region = (mesh.vertices[mesh.triangles, 0].mean(axis=1) > 20).astype(np.int64)  # the east half: region 1
    mesh = TerrainMesh(mesh.vertices, mesh.triangles, triangle_attributes={"region": region},
                       labels={"region": {1: "east"}}, constrained_edges=mesh.boundary_edges()[:0])
    path = _write(mesh, tmp_path, ".2dm")
    _, _, materials, _, _ = _parse_2dm(path)
    assert materials == {"1", "2"}
    back = tio.read_mesh(path)
    np.testing.assert_array_equal(back.triangle_attributes["region"], region)
    assert list(back.node_strings) == ["outline_1"]  # the outline loop, closed
    loop = back.node_strings["outline_1"]
    assert loop[0] == loop[-1] and len(np.unique(loop)) == len(mesh.boundary_edges())
    # a file whose elements all have material 1 (or none) gives no region
    (tmp_path / "plain").mkdir()
    assert tio.read_mesh(_write(grid_mesh(cone_hf), tmp_path / "plain", ".2dm")).triangle_attributes == {}


def test_2dm_reader_takes_materials_of_quads_and_files_without_them(tmp_path):
    path = tmp_path / "m.2dm"
    path.write_text("MESH2D\nE4Q 1 1 2 3 4 3\nE3T 2 2 5 3 2\nND 1 0 0 0\nND 2 1 0 0\nND 3 1 1 0\nND 4 0 1 0\nND 5 2 0 0\n")
    np.testing.assert_array_equal(tio.read_mesh(path).triangle_attributes["region"], [1, 2, 2])  # E3T, then the quad's halves
    path.write_text("MESH2D\nE3T 1 1 2 3\nE3T 2 1 3 4 2\nND 1 0 0 0\nND 2 1 0 0\nND 3 1 1 0\nND 4 0 1 0\n")
    assert tio.read_mesh(path).triangle_attributes == {}  # not every element has one


def test_obj_groups_and_stl_solids_follow_the_labelled_patches(plane_hf, tmp_path):
    for folder in "osp":
        (tmp_path / folder).mkdir()
    mesh = grid_mesh(plane_hf)
    patch = np.where(np.arange(mesh.n_triangles) < 10, 2, 0)
    mesh.triangle_attributes["patch"] = patch
    mesh.labels["patch"] = {2: "walls", 0: "ground"}
    obj = _write(mesh, tmp_path / "o", ".obj")
    lines = obj.read_text().splitlines()
    assert [line for line in lines if line.startswith("g ")] == ["g ground", "g walls"]  # by code
    back = meshio.read(obj)
    assert sum(len(c.data) for c in back.cells) == mesh.n_triangles
    stl = _write(mesh, tmp_path / "s", ".stl").read_text()
    assert [line for line in stl.splitlines() if line.startswith("solid ")] == ["solid ground", "solid walls"]
    assert stl.count("facet normal") == mesh.n_triangles
    del mesh.labels["patch"]  # unnamed patches: one plain mesh
    assert "g " not in _write(mesh, tmp_path / "p", ".obj").read_text()
