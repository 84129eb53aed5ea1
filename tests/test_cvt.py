"""Curvature CVT (Duan et al. 2016): sites, iteration, invariants and errors."""

from itertools import pairwise

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import Heightfield, metrics
from tinsmith.algorithms.cvt.curvature import curvature_density
from tinsmith.algorithms.cvt.cvt import FIXED, FREE, SLIDE, CVTState
from tinsmith.errors import InvalidInputError, InvalidOptionError, TinsmithWarning


def _hills(h=48, w=64, cell=10.0, seed=0, hole=None):
    """Smooth hills (the paper's test surface, scaled) with an optional nodata hole (r0, r1, c0, c1)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w].astype(float)
    u, v = (x - w / 2) / (w / 6), (y - h / 2) / (h / 6)
    z = 300.0 * (4 * u**2 + v**2) * np.exp(-(u**2) - v**2) + rng.normal(0, 0.01, (h, w))
    if hole is not None:
        r0, r1, c0, c1 = hole
        z[r0:r1, c0:c1] = np.nan
    return Heightfield(z, cell_size=cell, origin=(1000.0, 5000.0), nodata=np.nan)


def _state(hf, n, **kw):
    opts = dict(density_gamma=1.0, density_floor=0.1, anchor_fraction=0.0, control_points=None, breaklines=None, seed=0)
    opts.update(kw)
    return CVTState(hf, n_sites=n, **opts)


def _check_triangulation(state, x, y, tri):
    """Counter-clockwise triangles; every edge used twice in opposite directions, except the outline chords once."""
    a, b, c = (np.column_stack([x[tri[:, k]], y[tri[:, k]]]) for k in range(3))
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    assert (area > 0).all()
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    assert len(np.unique(directed, axis=0)) == len(directed)  # no edge walked twice the same way
    keys = {tuple(e) for e in directed.tolist()}
    single = {tuple(sorted(e)) for e in directed.tolist() if (e[1], e[0]) not in keys}
    chords = {tuple(sorted(e)) for e in state.chords.tolist()}
    assert single <= chords | _split_chords(state, x, y)


def _split_chords(state, x, y):
    """Chord pieces where a site lies on a chord (the constraint is split there)."""
    out = set()
    for i, j in state.chords.tolist():
        for k in range(len(x)):
            if k in (i, j):
                continue
            cross = (x[j] - x[i]) * (y[k] - y[i]) - (y[j] - y[i]) * (x[k] - x[i])
            if abs(cross) < 1e-9 and min(x[i], x[j]) <= x[k] <= max(x[i], x[j]) and min(y[i], y[j]) <= y[k] <= max(y[i], y[j]):
                out |= {tuple(sorted((i, k))), tuple(sorted((k, j)))}
    return out


def _on_run(state, x, y, i):
    """Distance (world units) of site i to the polyline of its run."""
    rx, ry, cum = state.runs[state.site_run[i]][:3]
    px, py = x[i] * state.sx, y[i] * state.sy
    best = np.inf
    for k in range(len(rx) - 1):
        d = np.array([rx[k + 1] - rx[k], ry[k + 1] - ry[k]])
        t = np.clip(((px - rx[k]) * d[0] + (py - ry[k]) * d[1]) / (d @ d), 0, 1)
        best = min(best, np.hypot(px - rx[k] - t * d[0], py - ry[k] - t * d[1]))
    return best


@settings(max_examples=12, deadline=None)
@given(
    st.integers(0, 10_000),
    st.sampled_from(["lbfgs", "anderson", "lloyd"]),
    st.booleans(),
    st.integers(40, 160),
)
def test_every_iteration_is_a_valid_mesh_and_fixed_and_boundary_sites_keep_their_place(seed, acceleration, hole, n):
    hf = _hills(seed=seed % 7, hole=(14, 26, 20, 34) if hole else None)
    x0, y0 = hf.pixel_to_world(np.array([10.0, 40.0]), np.array([12.0, 50.0]))
    state = _state(hf, n, control_points=np.column_stack([x0, y0]), anchor_fraction=0.1, seed=seed)
    fixed = np.flatnonzero(state.kind == FIXED)
    start = (state.x[fixed].copy(), state.y[fixed].copy())
    seen = []

    def check(it, x, y, tri, energy):
        _check_triangulation(state, x, y, tri)
        np.testing.assert_array_equal(x[fixed], start[0])
        np.testing.assert_array_equal(y[fixed], start[1])
        for i in np.flatnonzero(state.kind == SLIDE):
            assert _on_run(state, x, y, i) < 1e-6
        # free sites stay on the data
        free = state.kind == FREE
        assert tinsmith.kernels.cvt.covered_points(x[free], y[free], hf.valid).all()
        seen.append(energy)

    state.run(tol=0.0, max_iter=6, acceleration=acceleration, on_iteration=check)
    assert len(seen) == 7 and seen[-1] < seen[0]
    mesh = state.to_mesh(state.triangles)
    problems = metrics.surface_problems(mesh)
    assert problems["border"] > 0 and {k: v for k, v in problems.items() if k != "border"} == dict.fromkeys(
        ["degenerate", "duplicate", "overused", "misoriented"], 0)
    # the control points are vertices, at their cells
    r, c = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    kept = {(round(a, 6), round(b, 6)) for a, b in zip(r, c, strict=True)}
    assert {(10.0, 12.0), (40.0, 50.0)} <= kept


def test_same_seed_same_mesh_and_another_seed_another_start():
    hf = _hills()
    a = tinsmith.cvt(hf, max_vertices=120, seed=3)
    b = tinsmith.cvt(hf, max_vertices=120, seed=3)
    c = tinsmith.cvt(hf, max_vertices=120, seed=4)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    assert a.vertices.shape != c.vertices.shape or not np.array_equal(a.vertices, c.vertices)


def test_a_plane_gives_nearly_equilateral_triangles_and_the_exact_vertex_count():
    y, x = np.mgrid[0:60, 0:80].astype(float)
    hf = Heightfield(100 + 0.2 * x + 0.1 * y, cell_size=5.0)
    mesh = tinsmith.cvt(hf, max_vertices=300, max_iter=100)
    assert mesh.n_vertices == 300
    angles = metrics.triangle_angles(mesh).min(axis=1)
    assert (angles >= 30).mean() >= 0.95 and metrics.aspect_ratios(mesh).max() < 3
    # a plane is reproduced exactly: every site's height is the plane's
    assert metrics.vertical_error(mesh, hf)["max"] < 1e-9
    assert mesh.info["cvt"]["energy"][-1] < mesh.info["cvt"]["energy"][0]


def test_sites_gather_where_the_surface_bends():
    hf = _hills(64, 64)
    mesh = tinsmith.cvt(hf, max_vertices=400, density_gamma=2.0)
    r, c = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    rho = curvature_density(hf, gamma=2.0)
    at_sites = rho[np.rint(r).astype(int), np.rint(c).astype(int)]
    assert np.median(at_sites) > 1.5 * np.median(rho)


def test_anchors_are_greedy_insertions_first_points_and_never_move():
    hf = _hills()
    n = 150
    mesh = tinsmith.cvt(hf, max_vertices=n, anchor_fraction=0.4, max_iter=10)
    assert mesh.info["cvt"]["sites"]["anchors"] > 0.3 * n
    greedy = tinsmith.greedy(hf, max_vertices=4 + mesh.info["cvt"]["sites"]["anchors"] + 10)
    g = {tuple(np.round(v[:2], 6)) for v in greedy.vertices}
    fixed = mesh.vertices[mesh.vertex_attributes["site"] == "fixed"]
    on_greedy = np.mean([tuple(np.round(v[:2], 6)) in g for v in fixed])
    assert on_greedy > 0.95  # the four grid corners are greedy's too


def test_breaklines_become_edges_and_nodata_is_cut_out():
    hf = _hills(hole=(14, 26, 20, 34))
    line_r, line_c = np.array([5.0, 40.0]), np.array([5.0, 15.0])
    x, y = hf.pixel_to_world(line_r, line_c)
    mesh = tinsmith.cvt(hf, max_vertices=200, breaklines=[np.column_stack([x, y])])
    # every triangle's centroid lies on data: the hole is not covered
    g = mesh.vertices[mesh.triangles].mean(axis=1)
    gr, gc = hf.world_to_pixel(g[:, 0], g[:, 1])
    assert tinsmith.kernels.cvt.covered_points(gc, gr, hf.valid).all()
    # the breakline is a chain of mesh edges from one end to the other
    r, c = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    on = np.flatnonzero(np.abs((c - 5.0) * (40.0 - 5.0) - (r - 5.0) * (15.0 - 5.0)) < 1e-6)
    on = on[(r[on] >= 5 - 1e-9) & (r[on] <= 40 + 1e-9)]
    order = on[np.argsort(r[on])]
    edges = {tuple(sorted(e)) for t in mesh.triangles.tolist() for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    assert len(order) >= 3 and all(tuple(sorted(p)) in edges for p in pairwise(order))


def test_lbfgs_and_anderson_reach_a_lower_energy_than_plain_lloyd_in_as_many_iterations():
    hf = _hills(64, 80)
    energy = {}
    for acc in ("lloyd", "lbfgs"):
        mesh = tinsmith.cvt(hf, max_vertices=300, acceleration=acc, tol=0.0, max_iter=25)
        energy[acc] = mesh.info["cvt"]["energy"][-1]
    assert energy["lbfgs"] <= energy["lloyd"]


def test_bad_requests_get_clear_errors():
    hf = _hills()
    with pytest.raises(InvalidOptionError, match="takes max_vertices .*not max_error"):
        tinsmith.cvt(hf, max_error=2.0)
    with pytest.raises(InvalidOptionError, match="max_vertices of at least 4"):
        tinsmith.cvt(hf, max_vertices=3)
    with pytest.raises(InvalidInputError, match="acceleration must be one of"):
        tinsmith.cvt(hf, acceleration="newton")
    with pytest.raises(InvalidInputError, match="anchor_fraction"):
        tinsmith.cvt(hf, anchor_fraction=1.0)
    pts = np.column_stack(hf.pixel_to_world(np.arange(0, 40, 2.0), np.full(20, 3.0)))
    with pytest.raises(InvalidOptionError, match="below the .* sites that must be kept"):
        tinsmith.cvt(hf, max_vertices=10, control_points=pts)
    holed = _hills(hole=(14, 26, 20, 34))
    with pytest.warns(TinsmithWarning, match="1 entirely outside"):  # in the hole: dropped, said (io.geometry)
        tinsmith.cvt(holed, control_points=[holed.pixel_to_world(20.0, 25.0)])


def test_small_islands_of_data_are_left_out_and_no_triangle_spans_nodata():
    hf = _hills()
    z = hf.z.copy()
    z[:, 44:] = np.nan
    z[20:23, 55:58] = hf.z[20:23, 55:58]  # an island of 3 x 3 cells, far smaller than a site's cell
    hf = Heightfield(z, cell_size=10.0, origin=(1000.0, 5000.0), nodata=np.nan)
    mesh = tinsmith.cvt(hf, max_vertices=60)
    r, c = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    assert c.max() <= 43 + 1e-9 and mesh.n_vertices == 60
    err = metrics.vertical_error(mesh, hf)
    assert err["n_valid"] - err["n_covered"] == 9  # the island, counted as uncovered


def test_table1_measures_are_exact_on_a_plane_and_zero_for_the_full_mesh():
    y, x = np.mgrid[0:40, 0:50].astype(float)
    hf = Heightfield(3.0 * x + 2.0 * y, cell_size=1.0)
    full = tinsmith.grid(hf)
    assert metrics.contour_distance(full, hf, 10.0)["mean"] == 0.0
    coarse = tinsmith.cvt(hf, max_vertices=40)
    e = metrics.vertical_error_at_centroids(coarse, hf)
    assert e["max"] < 1e-9 and e["n_covered"] == coarse.n_triangles
    wx, wy = hf.pixel_to_world(np.array([3.25, 10.5]), np.array([7.5, 0.0]))
    np.testing.assert_allclose(metrics.dem_heights(hf, wx, wy), [3 * 7.5 + 2 * 3.25, 2 * 10.5])
    assert np.isnan(metrics.dem_heights(hf, *hf.pixel_to_world(np.array([-3.0]), np.array([0.0]))))[0]
    # a mesh raised by 5 on a plane rising 3 per cell in x: every contour moves by 5 / 3 cells... within the grid
    lifted = tinsmith.TerrainMesh(full.vertices + [0, 0, 5.0], full.triangles)
    d = metrics.contour_distance(lifted, hf, 10.0)
    slope = np.hypot(3.0, 2.0)
    assert d["mean"] == pytest.approx(5.0 / slope, rel=0.02) and d["hausdorff"] < 5.0 / 2.0 + 0.5


def test_the_command_line_runs_cvt_and_refuses_an_error_bound(tmp_path, capsys):
    from tinsmith.cli.main import main
    from tinsmith.samples import sample_path

    out = tmp_path / "m.ply"
    code = main(["simplify", str(sample_path("st-helens")), "-o", str(out), "--method", "cvt", "--ratio", "0.002",
                 "--fit-heights"])
    text = capsys.readouterr().out
    assert code == 0 and out.exists() and "method cvt: 298 vertices" in text
    code = main(["simplify", str(sample_path("st-helens")), "-o", str(tmp_path / "n.ply"), "--method", "cvt",
                 "--max-error", "5"])
    assert code == 1 and "takes max_vertices" in capsys.readouterr().err and not (tmp_path / "n.ply").exists()
