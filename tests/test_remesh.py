"""Isotropic remeshing with an exact vertex budget (Alliez et al. 2003): counts, features, quality, the conformal path."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import TerrainMesh
from tinsmith.algorithms.remesh.remesh import lscm
from tinsmith.cli.main import main
from tinsmith.metrics import surface_problems
from tinsmith.metrics.surface import polyline_distances

from .conftest import good_share, grid_mesh, punch_holes


def boundary_length(mesh) -> float:
    b = mesh.boundary_edges()
    return float(np.linalg.norm(mesh.vertices[b[:, 0]] - mesh.vertices[b[:, 1]], axis=1).sum())


def hemisphere(n=6000, seed=0, radius=10.0):
    from scipy.spatial import ConvexHull

    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    p[:, 2] = np.abs(p[:, 2])
    theta = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    pts = np.concatenate([p[p[:, 2] > 0.03], np.column_stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)])])
    hull = ConvexHull(np.concatenate([pts, [[0, 0, -1.0]]]))
    tri = hull.simplices[(hull.simplices < len(pts)).all(axis=1)]
    normal = np.cross(pts[tri[:, 1]] - pts[tri[:, 0]], pts[tri[:, 2]] - pts[tri[:, 0]])
    flip = (normal * pts[tri].mean(axis=1)).sum(axis=1) < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    return TerrainMesh(pts * radius, tri)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.integers(6, 30), st.integers(6, 30), st.data(), st.floats(0.05, 1.5),
       st.sampled_from(["uniform", "curvature"]))
def test_exactly_n_vertices_always_in_a_valid_mesh(seed, h, w, holes, fraction, density):
    z = np.random.default_rng(seed).normal(0, 0.5, (h, w)).cumsum(axis=1)
    z, _ = punch_holes(z, holes)
    try:
        source = grid_mesh(z)
    except tinsmith.NoDataError:
        return
    n = max(20, int(fraction * source.n_vertices))
    try:
        mesh = tinsmith.remesh(source, max_vertices=n, density=density, seed=seed, iterations=10, parameterization="xy")
    except tinsmith.InvalidOptionError as exc:  # more corners than the budget: said clearly
        assert "corners" in str(exc)
        return
    assert mesh.n_vertices == n
    assert mesh.check() == []
    assert len(np.unique(mesh.triangles)) == n  # every vertex in a triangle


def test_st_helens_2k_is_well_shaped_keeps_its_boundary_and_is_deterministic():
    source = tinsmith.simplify(tinsmith.sample("st-helens"), method="grid")
    mesh = tinsmith.remesh(source, max_vertices=2000)
    assert mesh.n_vertices == 2000 and mesh.check() == []
    assert good_share(mesh) >= 0.98
    assert boundary_length(mesh) == pytest.approx(boundary_length(source), rel=0.02)
    # every boundary vertex of the result lies on the boundary of the input
    b = source.boundary_edges()
    a, c = source.vertices[b[:, 0], :2], source.vertices[b[:, 1], :2]
    for p in mesh.vertices[np.unique(mesh.boundary_edges()), :2][::7]:
        d = c - a
        t = np.clip(((p - a) * d).sum(axis=1) / (d * d).sum(axis=1), 0, 1)
        assert np.linalg.norm(p - (a + t[:, None] * d), axis=1).min() < 1e-6
    assert mesh.info["remesh"]["parameterization"] == "xy"
    np.testing.assert_array_equal(tinsmith.remesh(source, max_vertices=2000).vertices, mesh.vertices)


def test_a_rectangle_keeps_its_corners_and_its_boundary_length():
    z = np.add.outer(np.linspace(0, 5, 31), np.sin(np.linspace(0, 6, 41)))
    source = grid_mesh(z, cell=2.0)
    mesh = tinsmith.remesh(source, max_vertices=300)
    corners = source.vertices[[0, 40, 31 * 41 - 41, 31 * 41 - 1]]
    for c in corners:
        assert np.linalg.norm(mesh.vertices - c, axis=1).min() == 0
    assert boundary_length(mesh) == pytest.approx(boundary_length(source), rel=1e-3)


def test_a_sharp_ridge_is_kept_as_a_line_of_vertices():
    c = np.arange(41)
    source = grid_mesh(np.tile(-np.abs(c - 20).astype(float), (41, 1)))  # a 90-degree ridge along one column
    ridge = source.vertices[np.argmax(source.vertices[:, 2]), 0]
    mesh = tinsmith.remesh(source, max_vertices=400)
    on_ridge = mesh.vertices[:, 0] == ridge
    assert on_ridge.sum() >= 8 and np.allclose(mesh.vertices[on_ridge, 2], 0.0)
    e, _ = mesh.edges()
    side = np.sign(mesh.vertices[:, 0] - ridge)
    assert not ((side[e[:, 0]] * side[e[:, 1]]) < 0).any()  # no edge crosses the ridge
    assert good_share(mesh) > 0.95


def test_a_hemisphere_goes_through_the_conformal_path():
    source = hemisphere()
    mesh = tinsmith.remesh(source, max_vertices=800)
    assert mesh.info["remesh"]["parameterization"] == "conformal"
    problems = surface_problems(mesh)  # manifold and oriented (a hemisphere is no terrain: its rim faces out)
    assert mesh.n_vertices == 800 and problems.pop("border") > 0 and not any(problems.values())
    r = np.linalg.norm(mesh.vertices, axis=1)
    assert r.max() <= 10 + 1e-9 and r.min() > 9.95  # on the input's chords of the sphere
    assert good_share(mesh) > 0.97
    # uniform density in 3-D: as many vertices above 45 degrees of latitude as the cap's share of the area
    high = (mesh.vertices[:, 2] > 10 * np.sin(np.pi / 4)).mean()
    assert high == pytest.approx(1 - np.sin(np.pi / 4), abs=0.05)


def test_lscm_preserves_angles_of_a_flat_patch_and_refuses_closed_meshes_the_remesher_cuts():
    z = np.zeros((9, 13))
    flat = grid_mesh(z)
    uv = lscm(flat)
    # a flat mesh maps to itself up to a similarity: all edge length ratios kept
    e, _ = flat.edges()
    ratio = np.linalg.norm(uv[e[:, 0]] - uv[e[:, 1]], axis=1) / np.linalg.norm(
        flat.vertices[e[:, 0], :2] - flat.vertices[e[:, 1], :2], axis=1)
    assert np.ptp(ratio) < 1e-6
    from scipy.spatial import ConvexHull

    p = np.random.default_rng(1).normal(size=(200, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    tri = ConvexHull(p).simplices
    normal = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])
    flip = (normal * p[tri].mean(axis=1)).sum(axis=1) < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    sphere = TerrainMesh(p, tri)
    with pytest.raises(tinsmith.InvalidInputError, match=r"0 boundary loops and Euler characteristic 2 \(closed\)"):
        lscm(sphere)
    out = tinsmith.remesh(sphere, max_vertices=50)  # the remesher cuts it into charts instead
    assert out.info["remesh"]["parameterization"] == "charts"
    assert out.n_vertices == 50 and len(out.boundary_edges()) == 0


def test_cli_remesh(tmp_path, capsys):
    out = tmp_path / "remeshed.ply"
    code = main(["remesh", "--sample", "st-helens", "--vertices", "1500", "--density", "curvature", "--gamma", "2",
                 "-o", str(out), "--json"])
    stdout, err = capsys.readouterr()
    assert code == 0, err
    report = json.loads(stdout)
    assert report["n_vertices"] == 1500 == tinsmith.read_mesh(out).n_vertices
    assert main(["remesh", "--sample", "st-helens", "--vertices", "2", "-o", str(out)]) == 1
    assert "'--vertices': 2 is not in the range x>=3" in capsys.readouterr().err


def _segment_hits(p, q, a, b) -> bool:
    """Whether segments p-q and a-b cross at a point inside both (touching ends do not count)."""
    def orient(u, v, w):
        return (v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0])
    d1, d2, d3, d4 = orient(a, b, p), orient(a, b, q), orient(p, q, a), orient(p, q, b)
    return d1 * d2 < -1e-9 and d3 * d4 < -1e-9


def test_breaklines_stay_edges_meet_at_a_corner_and_keep_their_length():
    z = np.add.outer(np.linspace(0, 3, 41), np.sin(np.linspace(0, 4, 51)))
    source = grid_mesh(z)
    o = source.vertices[:, :2].min(axis=0)  # the lower left cell centre; the data spans 50 x 40
    bent = o + np.array([[5.0, 35.0], [25.0, 15.0], [45.0, 35.0]])  # a 90-degree turn at the bottom
    theta = np.linspace(0.2, 2.9, 60)
    arc = o + np.column_stack([25 + 15 * np.cos(theta), 20 + 15 * np.sin(theta)])  # crosses both arms
    low = o + np.array([[10.0, 8.0], [40.0, 8.0]])
    mesh = tinsmith.remesh(source, max_vertices=400, breaklines=[bent, arc, low])
    assert mesh.n_vertices == 400 and mesh.check() == []
    xy = mesh.vertices[:, :2]
    for corner in [*bent, low[0], low[1], arc[0], arc[-1]]:
        assert np.linalg.norm(xy - corner, axis=1).min() < 1e-9  # ends and the sharp bend are vertices
    assert (np.abs(np.linalg.norm(xy - (o + [25, 20]), axis=1) - 15) < 0.01).sum() >= 8  # along the arc
    e, _ = mesh.edges()
    for line in (bent, arc, low):
        for a, b in zip(line[:-1], line[1:], strict=False):
            assert not any(_segment_hits(xy[i], xy[j], a, b) for i, j in e)  # no edge crosses the line
        # the output's edges along the line: their length against the line's (in x-y)
        def off(p, line=line):
            return polyline_distances(p, line)[0]

        on = off(xy) < 1e-9
        size = np.linalg.norm(xy[e[:, 0]] - xy[e[:, 1]], axis=1)
        along = on[e[:, 0]] & on[e[:, 1]] & (off((xy[e[:, 0]] + xy[e[:, 1]]) / 2) < 0.05 * size)  # no shortcut
        kept = np.linalg.norm(xy[e[along, 0]] - xy[e[along, 1]], axis=1).sum()
        length = np.linalg.norm(np.diff(line, axis=0), axis=1).sum()
        assert kept == pytest.approx(length, rel=0.01)


def test_breaklines_need_the_xy_space_and_the_data():
    with pytest.raises(tinsmith.InvalidOptionError, match="x-y parameter space"):
        tinsmith.remesh(hemisphere(), max_vertices=300, breaklines=[np.array([[0.0, 0.0], [1.0, 1.0]])])
    source = grid_mesh(np.zeros((10, 10)))
    with pytest.raises(tinsmith.InvalidInputError, match="breaklines do not overlap the data"):
        tinsmith.remesh(source, max_vertices=50, breaklines=[np.array([[100.0, 100.0], [120.0, 100.0]])])
    with pytest.raises(tinsmith.InvalidInputError, match=r"breaklines\[0\] must be"):
        tinsmith.remesh(source, max_vertices=50, breaklines=[np.array([1.0, 2.0])])


def test_cli_remesh_with_a_breakline_file(tmp_path, capsys):
    lines = tmp_path / "lines.geojson"
    lines.write_text(json.dumps({"type": "FeatureCollection",
                                 "crs": {"type": "name", "properties": {"name": "EPSG:26710"}}, "features": [{
        "type": "Feature", "properties": {},
        "geometry": {"type": "LineString", "coordinates": [[561000, 5110000], [565000, 5118000]]}}]}))
    out = tmp_path / "r.ply"
    code = main(["remesh", "--sample", "st-helens", "--vertices", "1200", "--breaklines", str(lines), "-o", str(out)])
    _, err = capsys.readouterr()
    assert code == 0, err
    mesh = tinsmith.read_mesh(out)
    a, b = np.array([561000.0, 5110000.0]), np.array([565000.0, 5118000.0])
    t = np.clip(((mesh.vertices[:, :2] - a) @ (b - a)) / ((b - a) @ (b - a)), 0, 1)
    assert (np.linalg.norm(mesh.vertices[:, :2] - (a + t[:, None] * (b - a)), axis=1) < 1e-6).sum() >= 10
