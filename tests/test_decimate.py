"""Decimation: analytic surfaces, the stop rules, the outline, nodata, dense-mesh input, validity on random grids."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import tinsmith
from tinsmith import Decimation, Heightfield, InvalidInputError, NoDataError, TerrainMesh
from tinsmith.metrics import vertical_error
from tinsmith.triangulation.grid import grid_mesh

from .conftest import punch_holes


def _area(mesh: TerrainMesh) -> float:
    return float(mesh.signed_areas_2d().sum())


def _on_cells(mesh: TerrainMesh, hf: Heightfield) -> None:
    """Every vertex is a valid cell centre with that cell's height."""
    r, c = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    r, c = np.round(r).astype(int), np.round(c).astype(int)
    assert hf.valid[r, c].all()
    np.testing.assert_array_equal(mesh.vertices[:, 2], hf.z[r, c])


def test_a_plane_collapses_to_its_four_corners_with_zero_error(plane_hf):
    mesh = tinsmith.decimate(plane_hf, max_error=1e-9)
    assert (mesh.n_vertices, mesh.n_triangles) == (4, 2)
    assert vertical_error(mesh, plane_hf)["max"] < 1e-9
    assert _area(mesh) == pytest.approx(_area(grid_mesh(plane_hf)))


def test_a_roof_keeps_its_ridge_and_nothing_else():
    r, c = np.mgrid[0:21, 0:31]
    hf = Heightfield(10.0 - np.abs(r - 10.0), cell_size=1.0)  # ridge along row 10
    mesh = tinsmith.decimate(hf, max_error=1e-9)
    assert vertical_error(mesh, hf)["max"] < 1e-9
    # the four corners and the two ends of the ridge
    assert mesh.n_vertices == 6 and mesh.n_triangles == 4


def test_vertex_and_triangle_budgets_and_the_error_bound():
    r, c = np.mgrid[0:40, 0:55]
    hf = Heightfield(np.sin(r / 5.0) * 20 + np.cos(c / 7.0) * 15 + 0.01 * r * c, cell_size=5.0)
    full = grid_mesh(hf)
    for n in (6, 50, 400):
        mesh = tinsmith.decimate(hf, max_vertices=n)
        assert mesh.n_vertices == n and mesh.check() == []
        assert _area(mesh) == pytest.approx(_area(full), rel=1e-12)
        _on_cells(mesh, hf)
    assert tinsmith.decimate(hf, max_triangles=301).n_triangles <= 301
    for e in (0.5, 2.0, 8.0):
        mesh = tinsmith.decimate(hf, max_error=e)
        err = vertical_error(mesh, hf)
        assert err["max"] <= e and err["coverage"] == 1.0 and mesh.info["error"]["max"] == err["max"]
    # fewer vertices, larger error
    rmse = [vertical_error(tinsmith.decimate(hf, max_vertices=n), hf)["rmse"] for n in (800, 200, 50)]
    assert rmse[0] < rmse[1] < rmse[2]
    # the first rule reached wins
    assert tinsmith.decimate(hf, max_error=8.0, max_vertices=100).n_vertices <= 100
    with pytest.raises(InvalidInputError, match="leave no room"):
        tinsmith.decimate(hf, max_vertices=3)


def test_levels_share_one_sequence_and_runs_are_deterministic():
    r, c = np.mgrid[0:30, 0:30]
    hf = Heightfield(np.hypot(r - 12.0, c - 17.0) ** 1.5, cell_size=2.0)
    dec = Decimation(hf)
    for n in (30, 200):
        a = dec.mesh(dec.n_vertices - n)
        b = tinsmith.decimate(hf, max_vertices=n)
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.triangles, b.triangles)


def test_nodata_holes_stay_holes_and_their_outline_stays(cone_hf):
    full = grid_mesh(cone_hf)
    mesh = tinsmith.decimate(cone_hf, max_vertices=60)
    assert mesh.check() == [] and mesh.n_vertices == 60
    assert _area(mesh) == pytest.approx(_area(full))
    _on_cells(mesh, cone_hf)
    # the corners of the notch the nodata block (cells 0..4) cuts stay (the square at (4, 4) keeps one triangle)
    x, y = cone_hf.pixel_to_world(np.array([5, 5, 4, 0]), np.array([0, 4, 5, 5]))
    kept = {tuple(p) for p in np.round(mesh.vertices[:, :2], 9)}
    assert {tuple(p) for p in np.round(np.column_stack([x, y]), 9)} <= kept


def test_a_dense_mesh_decimates_with_the_error_at_its_vertices():
    r, c = np.mgrid[0:25, 0:25]
    hf = Heightfield(np.sin(r / 4.0) * 5 + c * 0.3, cell_size=3.0)
    dense = grid_mesh(hf)
    mesh = tinsmith.decimate(dense, max_error=0.5)
    assert mesh.check() == [] and mesh.n_vertices < dense.n_vertices / 3
    assert mesh.info["error"]["max"] <= 0.5
    assert vertical_error(mesh, hf)["max"] == pytest.approx(mesh.info["error"]["max"])
    assert tinsmith.decimate(dense, max_vertices=40).n_vertices == 40
    flipped = TerrainMesh(dense.vertices, dense.triangles[:, ::-1])
    with pytest.raises(InvalidInputError, match="valid 2.5-D mesh.*clockwise"):
        tinsmith.decimate(flipped, max_vertices=10)
    with pytest.raises(InvalidInputError, match="takes a Heightfield or TerrainMesh"):
        tinsmith.decimate(np.zeros((4, 4)), max_vertices=10)


def test_reachable_through_simplify_lod_and_compare(cone_hf):
    mesh = tinsmith.simplify(cone_hf, method="decimate", max_vertices=100)
    assert mesh.info["method"] == "decimate" and mesh.n_vertices == 100
    rows = tinsmith.compare_methods(cone_hf, ["decimate", "greedy"], max_vertices=100)
    assert [row["method"] for row in rows] == ["decimate", "greedy"]


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_every_output_is_a_valid_mesh_with_the_input_outline(data):
    h = data.draw(st.integers(2, 14))  # a heightfield of one row or column is refused: no triangle
    w = data.draw(st.integers(2, 14))
    z = data.draw(arrays(np.float64, (h, w), elements=st.floats(-50, 50, allow_nan=False)))
    z, mask = punch_holes(z, data) if data.draw(st.booleans()) else (z, np.zeros((h, w), bool))
    if mask.all():
        return
    hf = Heightfield(z, cell_size=(2.0, 3.0), nodata_mask=mask)
    try:
        full = grid_mesh(hf)
    except NoDataError:
        with pytest.raises(NoDataError):
            tinsmith.decimate(hf, max_vertices=4)
        return
    dec = Decimation(hf)
    k = data.draw(st.integers(0, dec.n_steps))
    mesh = dec.mesh(k)
    assert mesh.check() == []
    assert mesh.n_vertices == len(np.unique(full.triangles)) - k
    assert _area(mesh) == pytest.approx(_area(full), rel=1e-9)
    boundary = {tuple(sorted(map(tuple, np.round(full.vertices[e, :2], 6)))) for e in full.boundary_edges()}
    kept = {tuple(p) for p in np.round(mesh.vertices[:, :2], 6)}
    # every border vertex of the input that turns a corner is kept
    border_points = {p for e in boundary for p in e}
    for p in border_points:
        nbrs = [q for e in boundary if p in e for q in e if q != p]
        if len(nbrs) != 2 or abs(
            (nbrs[0][0] - p[0]) * (nbrs[1][1] - p[1]) - (nbrs[1][0] - p[0]) * (nbrs[0][1] - p[1])
        ) > 1e-6:
            assert p in kept
    _on_cells(mesh, hf)


def test_the_command_line_decimates_a_dense_mesh_file(tmp_path, capsys):
    from tinsmith.cli.main import main

    r, c = np.mgrid[0:30, 0:40]
    hf = Heightfield(np.sin(r / 4.0) * 8 + c * 0.2, cell_size=2.0, crs="EPSG:32610")
    dense = tmp_path / "dense.ply"
    tinsmith.write(grid_mesh(hf), dense)
    out = tmp_path / "out.obj"
    assert main(["simplify", str(dense), "-o", str(out), "--method", "decimate", "--max-error", "0.5", "--json"]) == 0
    import json

    report = json.loads(capsys.readouterr().out)
    assert report["input_vertices"] == 30 * 40 and report["vertical_error"]["max"] <= 0.5
    assert report["vertical_error"]["coverage"] == 1.0 and tinsmith.read_mesh(out).n_vertices == report["n_vertices"]
    levels = tmp_path / "levels"
    assert main(["lod", str(dense), "-o", str(levels), "--method", "decimate", "--vertices", "300,60", "--json"]) == 0
    index = json.loads(capsys.readouterr().out)
    assert [row["n_vertices"] for row in index["levels"]] == [300, 60]
    # a method that needs a grid says so, in one line
    assert main(["simplify", str(dense), "-o", str(tmp_path / "g.ply"), "--method", "greedy"]) == 1
    err = capsys.readouterr().err
    assert "is a mesh, but method 'greedy' takes a raster or a point cloud; methods that take meshes: decimate" in err
