"""Remeshing closed and higher-genus surfaces chart by chart (Alliez et al. 2003, section 4.1): closed, same genus, exact N."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import TerrainMesh, shapes
from tinsmith.algorithms.remesh.charts import chart_cut, charts
from tinsmith.algorithms.remesh.skeleton import mesh_edges
from tinsmith.metrics import self_intersections
from tinsmith.metrics.surface import closest_points

from .conftest import euler, good_share


def ellipsoid(n=3000, axes=(10.0, 10.0, 10.0)) -> TerrainMesh:
    return shapes.ellipsoid(n, axes)


def torus(nu=90, nv=36) -> TerrainMesh:
    return shapes.torus(nu, nv)


def genus_two(step=0.03) -> TerrainMesh:
    """The level set (x (x-1)^2 (x-2) + y^2)^2 + z^2 = 0.02 (a two-holed surface) by VTK's contouring."""
    pv = pytest.importorskip("pyvista")
    lo, hi = np.array([-0.45, -0.85, -0.35]), np.array([2.45, 0.85, 0.35])
    grid = pv.ImageData(dimensions=np.ceil((hi - lo) / step).astype(int) + 1, spacing=(step,) * 3, origin=lo)
    x, y, z = grid.points.T
    grid["f"] = (x * (x - 1) ** 2 * (x - 2) + y ** 2) ** 2 + z ** 2 - 0.02
    surface = grid.contour([1e-9], scalars="f").triangulate().clean()
    return TerrainMesh(np.asarray(surface.points, float), surface.faces.reshape(-1, 4)[:, 1:])


def check_closed(source, mesh, n):
    assert mesh.n_vertices == n and len(np.unique(mesh.triangles)) == n
    assert len(mesh.boundary_edges()) == 0
    assert euler(mesh) == euler(source)
    mesh_edges(mesh.triangles)  # manifold and consistently oriented, or it raises
    # every vertex on the input surface
    gap = np.linalg.norm(closest_points(source.vertices, source.triangles, mesh.vertices) - mesh.vertices, axis=1)
    assert gap.max() < 1e-6 * np.ptp(source.vertices, axis=0).max()


@pytest.mark.parametrize("n", [400, 2500])
def test_sphere_closed_exact_and_well_shaped(n):
    source = ellipsoid()
    mesh = tinsmith.remesh(source, max_vertices=n)
    check_closed(source, mesh, n)
    assert mesh.info["remesh"]["parameterization"] == "charts"
    assert good_share(mesh) >= 0.98
    radius = np.linalg.norm(mesh.vertices, axis=1)
    assert radius.max() <= 10.0 + 1e-9 and radius.min() > 9.9


@pytest.mark.parametrize("n", [600, 3000])
def test_torus_keeps_its_genus(n):
    source = torus()
    mesh = tinsmith.remesh(source, max_vertices=n)
    check_closed(source, mesh, n)
    assert euler(mesh) == 0
    assert good_share(mesh) >= 0.98
    assert self_intersections(mesh) == 0


def test_genus_two_surface_from_marching_cubes():
    source = genus_two()
    assert euler(source) == -2
    mesh = tinsmith.remesh(source, max_vertices=2000)
    check_closed(source, mesh, 2000)
    assert good_share(mesh) >= 0.98


def test_reconstructed_torus_and_a_city_solid():
    """Two closed meshes as they come from other tools: a torus reconstructed from a jittered cloud (its
    slivers give noisy normals), and a watertight city block (sharp edges at every wall)."""
    cloud = shapes.torus_points(grid=(173, 58))
    scanned = tinsmith.reconstruct(tinsmith.PointCloud(cloud), mode="general")
    assert len(scanned.boundary_edges()) == 0
    mesh = tinsmith.remesh(scanned, max_vertices=3000)
    check_closed(scanned, mesh, 3000)
    assert good_share(mesh) >= 0.95

    from .test_city import synthetic_city

    dsm, dtm, _ = synthetic_city(tree=False)
    solid = tinsmith.city(dsm, ground=dtm, solid=True).mesh
    mesh = tinsmith.remesh(solid, max_vertices=1500)
    check_closed(solid, mesh, 1500)
    assert self_intersections(mesh) == 0
    # the solid's sharp edges are kept: its corners are vertices of the result
    corners = {tuple(np.round(p, 9)) for p in solid.vertices}
    assert len(corners & {tuple(np.round(p, 9)) for p in mesh.vertices}) >= 8


def test_charts_are_disks_that_do_not_cross_sharp_edges():
    source = torus()
    e = mesh_edges(source.triangles)
    label = charts(source, e)
    for c in range(label.max() + 1):
        part = TerrainMesh(source.vertices, source.triangles[label == c])
        verts, local = np.unique(part.triangles, return_inverse=True)
        piece = TerrainMesh(source.vertices[verts], local.reshape(-1, 3))
        assert euler(piece) == 1 and len(piece.boundary_edges()) > 0
    cut = chart_cut(e, label)
    assert len(cut) > 0
    # a closed loop of barrier edges (a meridian of the torus) always has two charts beside it
    nv = 36
    barrier = np.column_stack([np.arange(nv), (np.arange(nv) + 1) % nv])
    again = charts(source, e, barriers=barrier)
    faces = e.faces[np.isin(e.edges @ np.array([source.n_vertices, 1]),
                           np.sort(barrier, axis=1) @ np.array([source.n_vertices, 1]))]
    assert (again[faces[:, 0]] != again[faces[:, 1]]).all()


def test_closed_remesh_is_deterministic_and_refuses_breaklines():
    source = ellipsoid(1500)
    a = tinsmith.remesh(source, max_vertices=500, seed=3)
    b = tinsmith.remesh(source, max_vertices=500, seed=3)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)
    with pytest.raises(tinsmith.InvalidOptionError, match="breaklines"):
        tinsmith.remesh(source, max_vertices=500, breaklines=[np.array([[0.0, 0.0], [1.0, 1.0]])])


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.floats(0.5, 2.0), st.floats(0.5, 2.0), st.integers(150, 1200), st.integers(0, 3))
def test_any_ellipsoid_comes_out_closed_with_exact_count(ay, az, n, seed):
    source = ellipsoid(1200, (10.0, 10.0 * ay, 10.0 * az))
    mesh = tinsmith.remesh(source, max_vertices=n, seed=seed)
    assert mesh.n_vertices == n and len(np.unique(mesh.triangles)) == n
    assert len(mesh.boundary_edges()) == 0 and euler(mesh) == 2
    mesh_edges(mesh.triangles)


def test_cli_remeshes_a_closed_mesh_file(tmp_path, capsys):
    import json

    from tinsmith.cli.main import main

    source = tmp_path / "torus.ply"
    tinsmith.write(torus(), str(source))
    out = tmp_path / "out.ply"
    assert main(["remesh", str(source), "-o", str(out), "--vertices", "800", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["parameterization"] == "charts" and report["charts"] >= 2
    assert "vertical_error" not in report and report["surface_distance"]["max_relative"] < 0.02
    back = tinsmith.read_mesh(out)
    assert back.n_vertices == 800 and len(back.boundary_edges()) == 0 and euler(back) == 0
