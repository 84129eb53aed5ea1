"""The data model: Heightfield, PointCloud, StopCriteria, TerrainMesh."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from tinsmith import (
    Heightfield,
    InvalidInputError,
    InvalidMeshError,
    NoDataError,
    PointCloud,
    StopCriteria,
    TerrainMesh,
)


# -- Heightfield -------------------------------------------------------------------------
def test_plain_array_with_cell_size_is_north_up_with_south_west_origin():
    hf = Heightfield(np.arange(12.0).reshape(3, 4), cell_size=2.0)
    assert hf.shape == (3, 4)
    assert hf.cell_size == (2.0, 2.0)
    assert hf.is_north_up and hf.handedness == -1
    assert hf.bounds == (0.0, 0.0, 8.0, 6.0)
    x, y = hf.pixel_to_world(0, 0)
    assert (x, y) == (1.0, 5.0)  # centre of the north-west cell


def test_pixel_world_round_trip_with_rotated_transform():
    hf = Heightfield(np.zeros((5, 7)), transform=(0.8, 0.6, 100.0, 0.6, -0.8, 200.0))
    rows, cols = np.mgrid[0:5, 0:7]
    x, y = hf.pixel_to_world(rows, cols)
    r, c = hf.world_to_pixel(x, y)
    np.testing.assert_allclose(r, rows, atol=1e-12)
    np.testing.assert_allclose(c, cols, atol=1e-12)
    assert not hf.is_north_up
    assert hf.cell_size == pytest.approx((1.0, 1.0))


def test_nodata_value_nan_and_mask_are_combined():
    z = np.array([[1.0, -9999.0, 3.0], [np.nan, 5.0, 6.0]])
    mask = np.array([[False, False, False], [False, False, True]])
    hf = Heightfield(z, cell_size=1, nodata=-9999, nodata_mask=mask | np.isnan(z))
    assert hf.n_valid == 3
    assert np.isnan(hf.z[hf.nodata_mask]).all()
    hf2 = Heightfield(z, cell_size=1, nodata=float("nan"), nodata_mask=z == -9999)
    assert hf2.n_valid == 4


def test_input_array_is_copied_and_result_read_only():
    z = np.ones((3, 3))
    hf = Heightfield(z, cell_size=1)
    z[0, 0] = 99
    assert hf.z[0, 0] == 1
    with pytest.raises(ValueError):
        hf.z[0, 0] = 5


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(z=np.ones((1, 1)), cell_size=1), "at least 2 x 2"),
        (dict(z=np.ones((1, 5)), cell_size=1), "at least 2 x 2"),
        (dict(z=np.ones((2, 2, 2)), cell_size=1), "2-D"),
        (dict(z=np.array([["a", "b"], ["c", "d"]]), cell_size=1), "real numbers"),
        (dict(z=np.ones((2, 2))), "georeferencing"),
        (dict(z=np.ones((2, 2)), cell_size=-1), "cell_size must be a finite number > 0"),
        (dict(z=np.ones((2, 2)), cell_size=(1, 2, 3)), "pair"),
        (dict(z=np.ones((2, 2)), cell_size=1, transform=(1, 0, 0, 0, -1, 0)), "not both"),
        (dict(z=np.ones((2, 2)), transform=(1, 2, 0, 2, 4, 0)), "degenerate"),
        (dict(z=np.ones((2, 2)), transform=(1, 0, 0, 0, -1, math.inf)), "finite"),
        (dict(z=np.ones((2, 2)), cell_size=1, nodata_mask=np.zeros((3, 3), bool)), "shape"),
        (dict(z=np.ones((2, 2)), cell_size=1, nodata="x"), "nodata must be a number"),
    ],
)
def test_heightfield_rejects_bad_input(kwargs, message):
    z = kwargs.pop("z")
    with pytest.raises(InvalidInputError, match=message):
        Heightfield(z, **kwargs)


def test_undeclared_nan_and_inf_are_errors():
    z = np.ones((3, 3))
    z[1, 1] = np.nan
    z[0, 2] = np.inf
    with pytest.raises(InvalidInputError, match="1 NaN and 1 infinite"):
        Heightfield(z, cell_size=1)
    with pytest.raises(InvalidInputError, match="infinite"):
        Heightfield(z, cell_size=1, nodata=float("nan"))
    assert Heightfield(z, cell_size=1, nodata=float("nan"), nodata_mask=np.isinf(z)).n_valid == 7


def test_all_nodata_is_an_error():
    with pytest.raises(NoDataError, match="every cell"):
        Heightfield(np.full((4, 4), -1.0), cell_size=1, nodata=-1)


# -- PointCloud ---------------------------------------------------------------------------
def test_point_cloud_validates_and_filters_classes():
    pc = PointCloud([[0, 0, 1], [1, 0, 2], [0, 1, 3]], classification=[2, 6, 2])
    assert pc.class_counts() == {2: 2, 6: 1}
    ground = pc.filter_classes([2])
    assert len(ground) == 2 and set(ground.classification) == {2}
    with pytest.raises(NoDataError, match=r"no points of class \[9\].*2 \(2 points\), 6 \(1 points\)"):
        pc.filter_classes([9])
    with pytest.raises(InvalidInputError, match=r"\(N, 3\)"):
        PointCloud(np.zeros((4, 2)))
    with pytest.raises(InvalidInputError, match="NaN"):
        PointCloud([[0, 0, np.nan]])
    with pytest.raises(NoDataError):
        PointCloud(np.zeros((0, 3)))
    with pytest.raises(NoDataError, match="no classification"):
        PointCloud([[0, 0, 0]]).filter_classes([2])


@pytest.mark.parametrize("statistic, expected", [("max", 7.0), ("min", 1.0), ("mean", 4.0)])
def test_gridding_points_combines_heights_per_cell(statistic, expected):
    # nine cells of 1 m, one point per cell at the centre, plus two extra points in the centre cell
    xs, ys = np.meshgrid([0.5, 1.5, 2.5], [0.5, 1.5, 2.5])
    pts = np.column_stack([xs.ravel(), ys.ravel(), np.full(9, 4.0)])
    pts = np.vstack([pts, [[1.4, 1.6, 1.0], [1.6, 1.4, 7.0]]])
    hf = PointCloud(pts, crs="EPSG:28992").to_heightfield(cell_size=1.0, statistic=statistic)
    assert hf.shape == (3, 3) and hf.crs == "EPSG:28992"
    assert hf.bounds == (0.0, 0.0, 3.0, 3.0)
    assert hf.z[1, 1] == expected
    assert np.all(np.delete(hf.z.ravel(), 4) == 4.0)


def test_gridding_leaves_empty_cells_as_nodata_and_picks_a_sensible_cell_size():
    rng = np.random.default_rng(1)
    pts = rng.uniform(0, 100, (40_000, 3))
    pc = PointCloud(pts)
    assert pc.default_cell_size() == 1.0  # spacing 0.5 m, doubled
    hf = pc.to_heightfield()
    assert 0.0 < hf.nodata_fraction < 0.05
    with pytest.raises(InvalidInputError, match="statistic"):
        pc.to_heightfield(statistic="median")
    with pytest.raises(InvalidInputError, match="cell_size"):
        pc.to_heightfield(cell_size=0)


# -- StopCriteria ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(max_error=-1), "max_error must be a finite number >= 0, got -1.0"),
        (dict(max_error=float("nan")), "max_error"),
        (dict(max_error="1"), "max_error"),
        (dict(max_vertices=2), "max_vertices must be a whole number >= 3"),
        (dict(max_vertices=10.5), "max_vertices"),
        (dict(max_vertices=True), "max_vertices"),
        (dict(max_triangles=0), "max_triangles"),
    ],
)
def test_stop_criteria_validate(kwargs, message):
    with pytest.raises(InvalidInputError, match=message):
        StopCriteria(**kwargs)


def test_stop_criteria_first_rule_reached_wins():
    stop = StopCriteria(max_error=1.0, max_vertices=100)
    assert stop.is_set and not StopCriteria().is_set
    assert stop.reached(2.0, 50, 80) is None
    assert stop.reached(0.5, 200, 80) == "max_error"
    assert stop.reached(2.0, 100, 80) == "max_vertices"
    assert StopCriteria(max_triangles=10).reached(9.0, 4, 10) == "max_triangles"


def test_stop_criteria_counts_fit_bounds_the_counts_only():
    stop = StopCriteria(max_error=0.1, max_vertices=100, max_triangles=150)
    assert stop.counts_fit(100, 150) and not stop.counts_fit(101, 150) and not stop.counts_fit(100, 151)
    assert StopCriteria(max_error=0.1).counts_fit(10**9, 10**9)


# -- TerrainMesh -----------------------------------------------------------------------------
SQUARE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 1], [0, 1, 1]], dtype=float)


def test_valid_mesh_passes_and_derives_edges():
    mesh = TerrainMesh(SQUARE, [[0, 1, 2], [0, 2, 3]]).validate()
    edges, counts = mesh.edges()
    assert len(edges) == 5 and sorted(counts) == [1, 1, 1, 1, 2]
    assert len(mesh.boundary_edges()) == 4
    np.testing.assert_allclose(mesh.signed_areas_2d(), [0.5, 0.5])


@pytest.mark.parametrize(
    "triangles, message",
    [
        ([[0, 2, 1]], "clockwise"),
        ([[0, 1, 1]], "repeat a vertex"),
        ([[0, 1, 2], [1, 2, 0]], "duplicate"),
        ([[0, 1, 2], [0, 2, 3], [0, 4, 2], [0, 2, 5]], "more than two"),
        ([[0, 2, 4]], "zero area"),
    ],
)
def test_invalid_meshes_are_reported(triangles, message):
    v = np.vstack([SQUARE, [[2, 2, 0], [-1, 3, 0]]])
    mesh = TerrainMesh(v, triangles)
    with pytest.raises(InvalidMeshError, match=message):
        mesh.validate()


@pytest.mark.parametrize(
    "vertices, triangles, message",
    [
        (np.zeros((3, 2)), [[0, 1, 2]], r"vertices must have shape \(N, 3\)"),
        (SQUARE, [[0, 1, 7]], "index vertices 0..3"),
        (SQUARE, [[0, 1]], r"\(M, 3\)"),
        (SQUARE, [[0.0, 1.0, 2.0]], "integer"),
        (np.full((3, 3), np.nan), [[0, 1, 2]], "finite"),
    ],
)
def test_mesh_rejects_bad_arrays(vertices, triangles, message):
    with pytest.raises(InvalidInputError, match=message):
        TerrainMesh(vertices, triangles)


# -- what a TerrainMesh carries beside its arrays ----------------------------------------------


def _labelled_square() -> TerrainMesh:
    return TerrainMesh(
        SQUARE, [[0, 1, 2], [0, 2, 3]], info={"method": "test"},
        triangle_attributes={"region": np.array([1, 2]), "slope": np.array([[0.1, 0.2], [0.3, 0.4]])},
        vertex_attributes={"site": np.array(["free", "fixed", "free", "boundary"])},
        constrained_edges=[[0, 2], [2, 3]], node_strings={"dyke": [3, 2, 1], "tip": [1, 0]},
        labels={"region": {1: "channel", 2: "meadow"}}, tables={"region": {"roughness": [0.0, 0.03, 0.05]}},
    )


@pytest.mark.parametrize("where", ["constructor", "assignment"])
@pytest.mark.parametrize("element, rows, message", [
    ("triangle", 3, "triangle attribute 'region' has 3 rows; the mesh has 2 triangles"),
    ("vertex", 5, "vertex attribute 'region' has 5 rows; the mesh has 4 vertices"),
])
def test_attributes_have_one_row_per_element(where, element, rows, message):
    with pytest.raises(InvalidMeshError, match=message):
        if where == "constructor":
            TerrainMesh(SQUARE, [[0, 1, 2], [0, 2, 3]], **{f"{element}_attributes": {"region": np.zeros(rows)}})
        else:
            mesh = TerrainMesh(SQUARE, [[0, 1, 2], [0, 2, 3]])
            getattr(mesh, f"{element}_attributes")["region"] = np.zeros(rows)
    with pytest.raises(InvalidMeshError, match="a scalar"):
        TerrainMesh(SQUARE, [[0, 1, 2], [0, 2, 3]]).triangle_attributes["region"] = 3


def test_attributes_keep_their_dtype_and_any_further_dimension():
    mesh = _labelled_square()
    assert mesh.triangle_attributes["region"].dtype == np.int64
    assert mesh.triangle_attributes["slope"].shape == (2, 2)
    assert mesh.vertex_attributes["site"].dtype.kind == "U"
    assert sorted(mesh.triangle_attributes) == ["region", "slope"] and "region" in mesh.triangle_attributes
    del mesh.triangle_attributes["slope"]
    assert list(mesh.triangle_attributes) == ["region"]


@pytest.mark.parametrize("field, value, message", [
    ("constrained_edges", [[0, 4]], "constrained_edges index vertices 0..3, got indices 0..4"),
    ("constrained_edges", [[0, 1, 2]], r"shape \(E, 2\)"),
    ("constrained_edges", [[0.0, 1.0]], "integer"),
    ("node_strings", {"dyke": [0, -1]}, "node string 'dyke' index vertices 0..3"),
    ("node_strings", {"dyke": [[0, 1]]}, "1-D array"),
    ("labels", {"region": ["channel"]}, "code: name"),
    ("tables", {"building": {"height": [[1.0]]}}, "1-D"),
])
def test_edge_data_and_code_tables_are_checked(field, value, message):
    mesh = TerrainMesh(SQUARE, [[0, 1, 2], [0, 2, 3]])
    with pytest.raises(InvalidMeshError, match=message):
        setattr(mesh, field, value)
    with pytest.raises(InvalidMeshError, match=message):
        TerrainMesh(SQUARE, [[0, 1, 2], [0, 2, 3]], **{field: value})


def test_edge_data_defaults_and_types():
    mesh = TerrainMesh(SQUARE, [[0, 1, 2], [0, 2, 3]])
    assert mesh.constrained_edges.shape == (0, 2) and mesh.node_strings == {} and mesh.labels == {} == mesh.tables
    mesh.constrained_edges = np.array([[0, 2]], np.int32)
    assert mesh.constrained_edges.dtype == np.int64
    mesh.labels = {"region": {np.int64(1): "channel"}}
    assert mesh.labels == {"region": {1: "channel"}}


def test_check_reports_attributes_the_mesh_outgrew():
    mesh = _labelled_square()
    assert mesh.check() == []
    mesh.triangles = mesh.triangles[:1]
    assert mesh.check() == ["triangle attribute 'region' has 2 rows; the mesh has 1 triangles",
                            "triangle attribute 'slope' has 2 rows; the mesh has 1 triangles"]
    with pytest.raises(InvalidMeshError, match="'region' has 2 rows"):
        mesh.validate()


def test_copy_carries_everything_and_shares_nothing():
    mesh = _labelled_square()
    twin = mesh.copy()
    for name in ("region", "slope"):
        np.testing.assert_array_equal(twin.triangle_attributes[name], mesh.triangle_attributes[name])
    np.testing.assert_array_equal(twin.vertex_attributes["site"], mesh.vertex_attributes["site"])
    np.testing.assert_array_equal(twin.constrained_edges, mesh.constrained_edges)
    np.testing.assert_array_equal(twin.node_strings["dyke"], [3, 2, 1])
    assert twin.labels == mesh.labels and twin.info == {"method": "test"}
    np.testing.assert_array_equal(twin.tables["region"]["roughness"], [0.0, 0.03, 0.05])
    twin.triangle_attributes["region"][0] = 9
    twin.constrained_edges[0, 0] = 1
    twin.info["method"] = "other"
    assert mesh.triangle_attributes["region"][0] == 1 and mesh.constrained_edges[0, 0] == 0
    assert mesh.info["method"] == "test"
    moved = mesh.copy(vertices=SQUARE + 1.0)
    np.testing.assert_array_equal(moved.vertices, SQUARE + 1.0)
    np.testing.assert_array_equal(moved.triangle_attributes["region"], [1, 2])
    with pytest.raises(InvalidMeshError, match="takes 4 vertices, got 3"):
        mesh.copy(vertices=SQUARE[:3])


@pytest.mark.parametrize("keep", [[1], np.array([False, True])])
def test_submesh_keeps_the_rows_and_edges_of_what_it_keeps(keep):
    mesh = _labelled_square()
    half = mesh.submesh(keep)  # triangle 0-2-3: vertex 1 goes, 2 -> 1, 3 -> 2
    np.testing.assert_array_equal(half.vertices, SQUARE[[0, 2, 3]])
    np.testing.assert_array_equal(half.triangles, [[0, 1, 2]])
    np.testing.assert_array_equal(half.triangle_attributes["region"], [2])
    np.testing.assert_array_equal(half.triangle_attributes["slope"], [[0.3, 0.4]])
    np.testing.assert_array_equal(half.vertex_attributes["site"], ["free", "free", "boundary"])
    np.testing.assert_array_equal(half.constrained_edges, [[0, 1], [1, 2]])
    np.testing.assert_array_equal(half.node_strings["dyke"], [2, 1])
    assert "tip" not in half.node_strings  # one vertex left: no line
    assert half.labels == mesh.labels and half.info == mesh.info and half.crs == mesh.crs
    assert mesh.submesh([]).n_triangles == 0
    with pytest.raises(InvalidMeshError, match="a mask of 2 triangles"):
        mesh.submesh(np.array([True]))


def test_pickling_keeps_the_typed_data():
    mesh = _labelled_square()
    back = pickle.loads(pickle.dumps(mesh))
    np.testing.assert_array_equal(back.triangle_attributes["region"], [1, 2])
    np.testing.assert_array_equal(back.constrained_edges, mesh.constrained_edges)
    assert back.labels == mesh.labels and back.info == mesh.info
    with pytest.raises(InvalidMeshError):  # still checked against the unpickled mesh
        back.triangle_attributes["region"] = [1]


def test_info_keys_of_0_1_still_read_and_write_with_a_deprecation_warning():
    mesh = _labelled_square()
    mesh.tables["building"] = {"height": np.array([12.5])}
    expected = {
        "triangle_region": mesh.triangle_attributes["region"],
        "site_kind": mesh.vertex_attributes["site"],
        "constrained_edges": mesh.constrained_edges,
        "node_strings": mesh.node_strings,
        "region_names": ["channel", "meadow"],
        "building_height": mesh.tables["building"]["height"],
    }
    for key, value in expected.items():
        assert key in mesh.info
        with pytest.warns(DeprecationWarning, match=rf"mesh.info\['{key}'\] is deprecated"):
            got = mesh.info[key]
        assert got is value or got == value
    with pytest.warns(DeprecationWarning):
        assert mesh.info.get("triangle_kind") is None
    assert "triangle_kind" not in mesh.info and "patch_names" not in mesh.info
    assert dict(mesh.info) == {"method": "test"}  # the metadata only
    with pytest.warns(DeprecationWarning, match=r"use mesh.labels\['patch'\]"):
        mesh.info["patch_names"] = ["ground", "buildings"]
    assert mesh.labels["patch"] == {0: "ground", 1: "buildings"}
    with pytest.warns(DeprecationWarning):
        old = TerrainMesh(SQUARE, [[0, 1, 2], [0, 2, 3]], info={"triangle_kind": [0, 1], "method": "x"})
    np.testing.assert_array_equal(old.triangle_attributes["kind"], [0, 1])
    assert dict(old.info) == {"method": "x"}
    with pytest.warns(DeprecationWarning), pytest.raises(InvalidMeshError, match="'kind' has 3 rows"):
        old.info["triangle_kind"] = [0, 1, 2]
