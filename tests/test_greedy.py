"""Greedy insertion: analytic surfaces, exact error bound, Delaunay property, stop rules."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import tinsmith
from tinsmith import Heightfield
from tinsmith.algorithms.greedy.engine import GreedyEngine
from tinsmith.errors import TinsmithWarning
from tinsmith.metrics import non_delaunay_edges, vertical_error

from .conftest import punch_holes, shared


def test_plane_needs_only_the_four_corners(plane_hf):
    mesh = tinsmith.greedy(plane_hf, max_error=1e-9)
    assert mesh.n_vertices == 4 and mesh.n_triangles == 2
    assert mesh.check() == []
    assert vertical_error(mesh, plane_hf)["max"] < 1e-9


@pytest.mark.parametrize("max_error", [5.0, 1.0, 0.25])
def test_cone_meets_the_bound_exactly_and_is_delaunay(max_error):
    r, c = np.mgrid[0:81, 0:81]
    hf = Heightfield(40.0 - np.hypot(r - 40.0, c - 40.0), cell_size=2.5, origin=(1000.0, 5000.0))
    mesh = tinsmith.greedy(hf, max_error=max_error)
    assert mesh.check() == []
    assert len(non_delaunay_edges(mesh)) == 0
    err = vertical_error(mesh, hf)
    assert err["max"] <= max_error and err["coverage"] == 1.0
    assert mesh.info["method"] == "greedy"
    assert mesh.info["error"]["max"] == pytest.approx(err["max"], abs=0)  # kernel and metrics agree
    assert mesh.n_vertices < hf.n_cells / 4


def test_count_limits_are_upper_bounds(cone_like=None):
    r, c = np.mgrid[0:60, 0:70]
    hf = Heightfield(np.sin(r / 5.0) * np.cos(c / 7.0) * 30.0, cell_size=1.0)
    for kwargs, field, limit in [
        (dict(max_vertices=100), "n_vertices", 100),
        (dict(max_triangles=150), "n_triangles", 150),
    ]:
        mesh = tinsmith.greedy(hf, **kwargs)
        assert getattr(mesh, field) <= limit
        assert mesh.info["stop_reason"] == next(iter(kwargs))
        assert mesh.check() == []
    both = tinsmith.greedy(hf, max_error=0.01, max_vertices=50)
    assert both.n_vertices <= 50 and both.info["stop_reason"] == "max_vertices"


def test_engine_levels_continue_where_they_stopped():
    r, c = np.mgrid[0:90, 0:75]
    hf = Heightfield(np.hypot(r - 30.0, c - 20.0) ** 1.3 + 5 * np.sin(c / 4.0), cell_size=10.0)
    engine = GreedyEngine(hf)
    levels = {}
    for e in (20.0, 5.0, 1.0):
        assert engine.refine(max_error=e) == "max_error"
        levels[e] = engine.to_mesh()
        assert engine.max_error <= e
    direct = GreedyEngine(hf)
    direct.refine(max_error=1.0)
    np.testing.assert_array_equal(direct.to_mesh().triangles, levels[1.0].triangles)
    assert levels[20.0].n_vertices < levels[5.0].n_vertices < levels[1.0].n_vertices


def test_without_stop_rules_the_default_bound_is_a_thousandth_of_the_relief():
    r, c = np.mgrid[0:50, 0:50]
    hf = Heightfield(np.sin(r / 6.0) * 100.0 + c, cell_size=1.0)
    mesh = tinsmith.greedy(hf)
    lo, hi = hf.z_range
    assert mesh.info["max_error_used"] == pytest.approx((hi - lo) / 1000)
    assert vertical_error(mesh, hf)["max"] <= (hi - lo) / 1000


def test_exact_run_reproduces_every_cell():
    z = np.random.default_rng(3).normal(size=(12, 9))
    hf = Heightfield(z, cell_size=1.0)
    engine = GreedyEngine(hf)
    assert engine.refine() == "exact"
    mesh = engine.to_mesh()
    assert mesh.n_vertices == z.size
    assert vertical_error(mesh, hf)["max"] == 0.0


def test_real_dem_error_bound_holds_exactly():
    hf = tinsmith.read_heightfield(shared("terrain_rgb/terrarium_grand_canyon_z11_385_803_elev.tif"))
    for max_error in (20.0, 5.0, 1.0):
        mesh = tinsmith.greedy(hf, max_error=max_error)
        err = vertical_error(mesh, hf)
        assert err["max"] <= max_error and err["coverage"] == 1.0
        assert mesh.check() == []
        # float32 heights: the kernel's error is the metrics' error, bit for bit
        assert hf.z.dtype == np.float32 and err["max"] == mesh.info["error"]["max"]


def test_nodata_holes_are_cut_out(cone_hf):
    mesh = tinsmith.greedy(cone_hf, max_error=0.5)
    assert mesh.check() == []
    err = vertical_error(mesh, cone_hf)
    assert err["max"] <= 0.5 and err["coverage"] == 1.0
    # no vertex on a nodata cell, no nodata cell centre covered
    covered = ~np.isnan(tinsmith.rasterize(mesh, cone_hf))
    assert not (covered & cone_hf.nodata_mask).any()


@settings(max_examples=40, deadline=None)
@given(
    z=arrays(np.float64, st.tuples(st.integers(2, 14), st.integers(2, 14)), elements=st.floats(-100, 100)),
    max_error=st.sampled_from([0.0, 0.5, 5.0]),
    north_up=st.booleans(),
)
def test_property_valid_delaunay_within_bound_and_input_untouched(z, max_error, north_up):
    before = z.copy()
    transform = (2.0, 0.0, 10.0, 0.0, -2.0, 50.0) if north_up else (2.0, 0.0, 10.0, 0.0, 2.0, 50.0)
    hf = Heightfield(z, transform=transform)
    mesh = tinsmith.greedy(hf, max_error=max_error)
    np.testing.assert_array_equal(z, before)
    assert mesh.check() == []
    assert len(non_delaunay_edges(mesh)) == 0
    err = vertical_error(mesh, hf)
    assert err["max"] <= max_error and err["coverage"] == 1.0
    # the metrics see no error the kernel did not see (same expression, same bits)
    assert err["max"] <= mesh.info["error"]["max"]


@settings(max_examples=60, deadline=None)
@given(
    z=arrays(np.float64, st.tuples(st.integers(3, 16), st.integers(3, 16)), elements=st.floats(-50, 50)),
    holes=st.data(),
    max_error=st.sampled_from([0.0, 1.0, 10.0]),
)
def test_property_nan_holes_are_cut_and_everything_else_holds(z, holes, max_error):
    z, mask = punch_holes(z, holes)
    before = z.copy()
    try:
        hf = Heightfield(z, cell_size=3.0, nodata=float("nan"))
        reference = tinsmith.grid(hf)  # the covered region
    except tinsmith.NoDataError:
        return
    mesh = tinsmith.greedy(hf, max_error=max_error)
    np.testing.assert_array_equal(z, before)
    assert mesh.check() == []
    # interior edges are Delaunay; the constrained outline is the mesh boundary
    assert len(non_delaunay_edges(mesh)) == 0
    err = vertical_error(mesh, hf)
    assert err["max"] <= max_error
    assert err["max"] <= mesh.info["error"]["max"]
    # same covered cells as the full-resolution mesh, and never a nodata cell
    covered = ~np.isnan(tinsmith.rasterize(mesh, hf))
    assert not (covered & hf.nodata_mask).any()
    np.testing.assert_array_equal(covered, ~np.isnan(tinsmith.rasterize(reference, hf)))


@settings(max_examples=40, deadline=None)
@given(
    z=arrays(np.float64, st.tuples(st.integers(3, 14), st.integers(3, 14)), elements=st.floats(-50, 50)),
    holes=st.data(),
    transform=st.sampled_from([(2.0, 0.0, 100.0, 0.0, -3.0, 500.0), (2.0, 0.0, 100.0, 0.0, 3.0, 500.0),
                               (1.5, 0.5, -20.0, -0.25, -2.0, 40.0)]),
)
def test_property_output_is_the_cells_of_the_kept_triangles_in_world_coordinates(z, holes, transform):
    z, _ = punch_holes(z, holes)
    try:
        engine = GreedyEngine(Heightfield(z, transform=transform, nodata=float("nan")))
    except tinsmith.NoDataError:
        return
    engine.refine(max_error=1.0)
    hf, mesh = engine.hf, engine.to_mesh()
    rows, cols, triangles, constrained = engine.output_cells()
    x, y = hf.pixel_to_world(rows, cols)
    np.testing.assert_array_equal(mesh.vertices, np.column_stack([x, y, hf.z[rows, cols]]))
    np.testing.assert_array_equal(mesh.triangles, triangles)
    np.testing.assert_array_equal(mesh.constrained_edges, constrained)
    assert triangles.dtype == rows.dtype == cols.dtype == np.int64
    assert hf.valid[rows, cols].all()  # no grid corner on nodata is kept
    np.testing.assert_array_equal(np.unique(triangles), np.arange(len(rows)))  # every kept vertex is used
    assert (mesh.signed_areas_2d() > 0).all()  # counter-clockwise in the world, whichever way the grid turns
    # constrained edges: each once, low id first, every one an edge of the mesh
    assert (constrained[:, 0] < constrained[:, 1]).all()
    assert len(np.unique(constrained, axis=0)) == len(constrained)
    sides = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    assert {tuple(e) for e in constrained.tolist()} <= {tuple(e) for e in sides.tolist()}


def _surface():
    r, c = np.mgrid[0:60, 0:80]
    return Heightfield(np.hypot(r - 30.0, c - 40.0) * 0.5 + 3 * np.sin(c / 5.0), cell_size=2.0, origin=(1000.0, 2000.0))


def test_breaklines_and_control_points_are_kept():
    hf = _surface()
    # two crossing lines: the cell nearest to the crossing joins both
    lines = [np.array([[1010.0, 1990.0], [1150.0, 1890.0]]), np.array([[1010.0, 1890.0], [1150.0, 1990.0], [1156.0, 1996.0]])]
    control = np.array([[1080.2, 1940.9], [1001.0, 1999.0]])
    mesh = tinsmith.greedy(hf, max_error=0.5, breaklines=lines, control_points=control)
    assert mesh.check() == []
    constrained = mesh.constrained_edges
    assert len(non_delaunay_edges(mesh, constrained=constrained)) == 0
    assert vertical_error(mesh, hf)["max"] <= 0.5
    # control points: the centres of their nearest cells are vertices
    rows, cols = hf.world_to_pixel(control[:, 0], control[:, 1])
    cx, cy = hf.pixel_to_world(np.rint(rows), np.rint(cols))
    verts = {(round(x, 6), round(y, 6)) for x, y in mesh.vertices[:, :2]}
    assert all((round(x, 6), round(y, 6)) in verts for x, y in zip(cx, cy, strict=True))
    # every breakline vertex (snapped) is a vertex, and the constrained edges run along the lines
    for line in lines:
        r, c = hf.world_to_pixel(line[:, 0], line[:, 1])
        x, y = hf.pixel_to_world(np.rint(r), np.rint(c))
        assert all((round(a, 6), round(b, 6)) in verts for a, b in zip(x, y, strict=True))
    assert len(constrained) >= 4


def test_breaklines_beyond_the_data_are_clipped_and_bad_shapes_refused(cone_hf):
    hf = _surface()
    with pytest.warns(TinsmithWarning, match="1 of 1 features clipped"):
        mesh = tinsmith.greedy(hf, breaklines=[np.array([[1010.0, 1990.0], [5000.0, 1990.0]])])
    assert mesh.n_triangles > 0
    with pytest.warns(TinsmithWarning, match="1 entirely outside"):
        # cone_hf: nodata block in rows 0-4, cols 0-4 (north-west corner, y > 36): the point is dropped
        tinsmith.greedy(cone_hf, control_points=np.array([[1.5, 39.5]]))
    with pytest.raises(tinsmith.InvalidInputError, match=r"\(N, 2\) or \(N, 3\)"):
        tinsmith.greedy(hf, control_points=np.ones((2, 4)))


def test_progress_is_reported_and_ends_at_one():
    r, c = np.mgrid[0:300, 0:300]
    hf = Heightfield(np.sin(r / 7.0) * np.cos(c / 9.0) * 50 + np.random.default_rng(0).normal(size=(300, 300)), cell_size=1.0)
    seen = []
    mesh = tinsmith.greedy(hf, max_error=0.5, progress=seen.append)
    assert mesh.n_vertices > 20_000  # more than one chunk
    assert len(seen) >= 2 and seen[-1] == 1.0
    assert all(0.0 <= f <= 1.0 for f in seen) and seen == sorted(seen)
    again = tinsmith.greedy(hf, max_error=0.5)
    np.testing.assert_array_equal(again.triangles, mesh.triangles)  # chunks do not change the result


def test_step_and_levels():
    r, c = np.mgrid[0:40, 0:50]
    hf = Heightfield(np.sin(r / 4.0) * np.cos(c / 6.0) * 20.0, cell_size=1.0)
    engine = GreedyEngine(hf)
    errors = [engine.max_error]
    for _ in range(5):
        assert engine.step() == 1
        errors.append(engine.max_error)
    assert engine.n_vertices == 9
    assert engine.step(100) == 100 and engine.n_vertices == 109
    # the same as refining straight to that many vertices
    direct = GreedyEngine(hf)
    direct.refine(max_vertices=109)
    np.testing.assert_array_equal(direct.to_mesh().triangles, engine.to_mesh().triangles)
    meshes = GreedyEngine(hf).levels([1.0, 5.0, 0.2])
    assert [vertical_error(m, hf)["max"] <= b for m, b in zip(meshes, [1.0, 5.0, 0.2], strict=True)] == [True] * 3
    assert meshes[1].n_vertices < meshes[0].n_vertices < meshes[2].n_vertices
    tiny = GreedyEngine(Heightfield(np.zeros((3, 3)), cell_size=1.0))
    assert tiny.step(10) == 0  # a plane needs nothing more


def _worst_cell_by_brute_force(z, valid, corners):
    """(error, flat index) of the worst valid cell of a triangle, the first in row order on ties: the oracle."""
    (x0, y0), (x1, y1), (x2, y2) = corners
    h, w = z.shape
    rows, cols = np.mgrid[0:h, 0:w]
    di = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    w1 = (cols - x0) * (y2 - y0) - (x2 - x0) * (rows - y0)
    w2 = (x1 - x0) * (rows - y0) - (cols - x0) * (y1 - y0)
    inside = (w1 >= 0) & (w2 >= 0) & (di - w1 - w2 >= 0) & valid
    z0, z1, z2 = (float(z[y, x]) for x, y in corners)
    d = float(di)
    height = z0 + (w1.astype(float) * ((z1 - z0) / d) + w2.astype(float) * ((z2 - z0) / d))
    height = np.where(w1 == di, z1, np.where(w2 == di, z2, height))  # the corners, exactly
    err = np.where(inside, np.abs(height - z), 0.0).ravel()
    best = err.max()
    return (best, int(np.argmax(err))) if best > 0 else (0.0, -1)


@settings(max_examples=80, deadline=None)
@given(data=st.data(), holes=st.booleans())
def test_property_triangle_scan_finds_the_worst_cell(data, holes):
    """The kernel's scan (cell by cell for small triangles, tile by tile with bounds for large ones) is exact."""

    h = data.draw(st.integers(3, 90), label="rows")
    w = data.draw(st.integers(3, 90), label="cols")
    seed = data.draw(st.integers(0, 2**32 - 1), label="seed")
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:h, 0:w]
    # smooth terrain (tight tile bounds) with rough patches and quantised heights (ties)
    z = 40 * np.sin(r / 9.0) + 25 * np.cos(c / 13.0) + rng.normal(0, 0.3, (h, w)) * (rng.random((h, w)) < 0.2)
    z = np.round(z, 1).astype(np.float32)
    valid = rng.random((h, w)) > 0.15 if holes else np.ones((h, w), bool)
    corners = [(int(rng.integers(0, w)), int(rng.integers(0, h))) for _ in range(3)]
    _assert_the_scan_is_exact(z, valid, holes, corners)


def _assert_the_scan_is_exact(z, valid, holes, corners):
    """The kernel's scan of the triangle (put counter-clockwise in (col, row); none when degenerate) finds the
    brute force's worst cell."""
    (x0, y0), (x1, y1), (x2, y2) = corners
    di = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    if di == 0:
        return
    if di < 0:
        corners = [corners[0], corners[2], corners[1]]
    assert _kernel_scan(z, valid, holes, corners) == _worst_cell_by_brute_force(z.astype(np.float64), valid, corners)


def _kernel_scan(z, valid, holes, corners):
    """(error, flat index) of the kernel's scan of one counter-clockwise triangle."""
    from tinsmith.kernels import greedy as kg

    h, w = z.shape
    grid = kg.make_grid(z.ravel(), valid.view(np.uint8).ravel(), not holes, h, w)
    px = np.array([p[0] for p in corners], np.float64)
    py = np.array([p[1] for p in corners], np.float64)
    cand = np.full(1, -1, np.int64)
    best = kg.scan_triangle(0, px, py, np.arange(3, dtype=np.int32), np.zeros(1, np.uint8), grid, cand)
    return best, int(cand[0])


#: The sides (u, v) from the first corner of every counter-clockwise triangle of area 1 with sides up to 5 cells.
_AREA_ONE_SIDES = [
    ((a, b), (c, d)) for a in range(-5, 6) for b in range(-5, 6) for c in range(-5, 6) for d in range(-5, 6)
    if a * d - b * c == 2
]


@settings(max_examples=150, deadline=None)
@given(data=st.data(), holes=st.booleans())
def test_property_area_one_triangle_scan_finds_the_worst_cell(data, holes):
    """Triangles of area 1 (twice the area 2) take a shortcut: their one cell besides the corners (Pick's theorem)."""
    seed = data.draw(st.integers(0, 2**32 - 1), label="seed")
    rng = np.random.default_rng(seed)
    h, w = 12, 12
    # quantised heights (ties, exact zeros) and flat patches
    z = np.round(rng.normal(0, 2, (h, w)), 0).astype(np.float32)
    z[rng.random((h, w)) < 0.2] = 1.0
    valid = rng.random((h, w)) > 0.3 if holes else np.ones((h, w), bool)
    u, v = data.draw(st.sampled_from(_AREA_ONE_SIDES), label="sides")
    x0 = data.draw(st.integers(max(0, -u[0], -v[0]), min(w - 1, w - 1 - u[0], w - 1 - v[0])), label="x0")
    y0 = data.draw(st.integers(max(0, -u[1], -v[1]), min(h - 1, h - 1 - u[1], h - 1 - v[1])), label="y0")
    start = data.draw(st.integers(0, 2), label="first corner")  # the shortcut's three cases
    corners = [(x0, y0), (x0 + u[0], y0 + u[1]), (x0 + v[0], y0 + v[1])]
    corners = corners[start:] + corners[:start]
    assert _kernel_scan(z, valid, holes, corners) == _worst_cell_by_brute_force(z.astype(np.float64), valid, corners)


def test_outline_that_joins_two_grid_corners_is_inserted():
    """The outline's first segment may join two grid corners across the square's diagonal.

    The corners' outgoing halfedges were once mislabelled, and this grid sent
    the constraint insertion round for ever.
    """
    valid = np.array([[1, 1, 1, 1], [1, 1, 1, 0], [1, 1, 0, 1], [1, 0, 0, 1]], bool)
    hf = Heightfield(np.where(valid, np.arange(16.0).reshape(4, 4), np.nan), cell_size=1, nodata=float("nan"))
    mesh = GreedyEngine(hf).to_mesh()
    assert mesh.check() == []
    assert mesh.n_triangles >= 1 and np.isfinite(mesh.vertices).all()


def test_data_without_area_is_a_clear_error():
    valid = np.zeros((5, 5), bool)
    valid[0, ::2] = valid[4, 1::2] = True  # single cells and no 2 x 2 square with three of them
    hf = Heightfield(np.where(valid, 1.0, np.nan), cell_size=1, nodata=float("nan"))
    with pytest.raises(tinsmith.NoDataError, match="covers no area"):
        tinsmith.greedy(hf, max_error=0.1)


# -- workers: tiles on threads ------------------------------------------------------------------------
def _sample_with_holes():
    return tinsmith.sample("st-helens")


def test_workers_mesh_tiles_that_join_within_the_bound_and_repeat():
    from tinsmith.metrics import seam_defects, surface_problems, vertical_error

    hf = _sample_with_holes()
    mesh = tinsmith.greedy(hf, max_error=2.0, workers=2)
    assert mesh.info["workers"] == 2 and mesh.info["tiles"] >= 4
    assert vertical_error(mesh, hf)["max"] <= 2.0 + 1e-9
    assert vertical_error(mesh, hf)["coverage"] == 1.0
    d = seam_defects(mesh, hf)
    assert d["t_junctions"] == 0 and d["cracks"] == 0 and d["overused_edges"] == 0
    problems = surface_problems(mesh)
    assert problems["degenerate"] == problems["duplicate"] == problems["misoriented"] == 0
    again = tinsmith.greedy(hf, max_error=2.0, workers=2)
    assert np.array_equal(mesh.vertices, again.vertices) and np.array_equal(mesh.triangles, again.triangles)
    # not the one-piece mesh, but about as large
    one = tinsmith.greedy(hf, max_error=2.0, workers=1)
    assert abs(mesh.n_vertices - one.n_vertices) <= 0.05 * one.n_vertices


def test_one_worker_is_the_one_piece_run_and_small_grids_default_to_it():
    hf = _sample_with_holes()
    from tinsmith.algorithms.greedy.greedy import PARALLEL_CELLS

    assert hf.n_cells < PARALLEL_CELLS
    a = tinsmith.greedy(hf, max_error=3.0)
    b = tinsmith.greedy(hf, max_error=3.0, workers=1)
    assert "workers" not in a.info
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)


def test_workers_refuse_what_tiles_cannot_keep():
    hf = _sample_with_holes()
    with pytest.raises(tinsmith.InvalidOptionError, match="workers=2 meshes tiles to an error bound: give max_error alone"):
        tinsmith.greedy(hf, max_vertices=1000, workers=2)
    with pytest.raises(tinsmith.InvalidOptionError, match="workers=2 does not take breaklines or control points"):
        tinsmith.greedy(hf, max_error=5.0, workers=2, control_points=[hf.pixel_to_world(100, 100)])
    with pytest.raises(tinsmith.TinsmithError, match="workers must be a whole number >= 1, got 0"):
        tinsmith.greedy(hf, max_error=5.0, workers=0)


def test_cli_simplify_takes_workers(tmp_path, capsys):
    from tinsmith.cli.main import main

    out = tmp_path / "m.ply"
    assert main(["simplify", "--sample", "st-helens", "--max-error", "5", "--workers", "2", "-o", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["options"]["workers"] == 2 and report["vertical_error"]["max"] <= 5.0


@settings(max_examples=120, deadline=None)
@given(data=st.data(), holes=st.booleans(), tall=st.booleans())
def test_property_sliver_scan_finds_the_worst_cell(data, holes, tall):
    """Slivers (a long triangle holding a few cells of its box) have their tiles found line by line: still exact."""
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1), label="seed"))
    short = data.draw(st.integers(2, 24), label="short side")
    long_ = data.draw(st.integers(200, 1500), label="long side")
    h, w = short, long_
    r, c = np.mgrid[0:h, 0:w]
    z = 30 * np.sin(c / 37.0) + 5 * r + rng.normal(0, 0.5, (h, w)) * (rng.random((h, w)) < 0.3)
    z = np.round(z, 1).astype(np.float32)
    valid = rng.random((h, w)) > 0.15 if holes else np.ones((h, w), bool)
    # two far ends and a third corner near the line between them (or at the same end: a fan's apex)
    xa, xb = sorted(int(v) for v in rng.choice(w, 2, replace=False))
    ya, yb = (int(v) for v in rng.integers(0, h, 2))
    xc = int(np.clip(rng.integers(xa, xb + 1) + rng.integers(-3, 4), 0, w - 1))
    yc = int(np.clip(round(ya + (yb - ya) * (xc - xa) / (xb - xa)) + rng.integers(-2, 3), 0, h - 1))
    corners = [(xa, ya), (xb, yb), (xc, yc)]
    if tall:  # the same on the transposed grid: lines are columns
        z, valid = z.T.copy(), valid.T.copy()
        corners = [(y, x) for x, y in corners]
    _assert_the_scan_is_exact(z, valid, holes, corners)


def _strip_heights(rng, h, w, kind):
    c = np.arange(w)[None, :] + np.zeros((h, 1))
    if kind == "noise":
        z = rng.normal(0, 1, (h, w))
    elif kind == "walk":
        z = np.cumsum(rng.normal(0, 1, (1, w)), axis=1) + 0.3 * rng.normal(0, 1, (h, w))
    else:  # smooth with quantised heights: ties and flat runs
        z = np.round(20 * np.sin(c / 50.0) + rng.normal(0, 0.2, (h, w)), 1)
    return z.astype(np.float32)


@settings(max_examples=40, deadline=None)
@given(
    short=st.integers(2, 3),
    long_=st.integers(2, 3000),
    kind=st.sampled_from(["noise", "walk", "smooth"]),
    tall=st.booleans(),
    share=st.sampled_from([0.0, 1e-3, 1e-2, 0.1]),
    seed=st.integers(0, 2**32 - 1),
)
def test_property_thin_strips_are_valid_delaunay_within_the_bound(short, long_, kind, tall, share, seed):
    """2 x N, 3 x N and N x 2, N x 3 grids: a valid Delaunay triangulation of the strip within the bound."""
    rng = np.random.default_rng(seed)
    z = _strip_heights(rng, short, long_, kind)
    if tall:
        z = z.T.copy()
    hf = Heightfield(z, cell_size=1.0)
    max_error = share * float(np.ptp(z))
    mesh = tinsmith.greedy(hf, max_error=max_error, workers=1)
    assert mesh.check() == []
    assert len(non_delaunay_edges(mesh)) == 0
    err = vertical_error(mesh, hf)
    assert err["max"] <= max_error and err["coverage"] == 1.0
    assert err["max"] <= mesh.info["error"]["max"]
    # the triangles cover the strip exactly: their plan-view areas sum to the grid's
    u, v = (mesh.vertices[mesh.triangles[:, k], :2] - mesh.vertices[mesh.triangles[:, 0], :2] for k in (1, 2))
    area = 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]).sum()
    assert area == pytest.approx((z.shape[0] - 1) * (z.shape[1] - 1), rel=1e-12)


def test_long_strip_with_a_corridor_of_data_holds_the_bound():
    """A 2-cell-wide diagonal corridor with nodata outside (a path cut from a raster): cut out, bound exact."""
    rng = np.random.default_rng(7)
    h, w = 60, 1500
    r, c = np.mgrid[0:h, 0:w]
    z = (np.cumsum(rng.normal(0, 1, w))[None, :] + 0.2 * rng.normal(0, 1, (h, w))).astype(np.float32)
    centre = (h - 1) / 2 + (h / 3) * np.sin(c / 200.0)
    z[np.abs(r - centre) > 1.0] = np.nan
    hf = Heightfield(z, cell_size=1.0, nodata=float("nan"))
    mesh = tinsmith.greedy(hf, max_error=0.5, workers=1)
    assert mesh.check() == []
    err = vertical_error(mesh, hf)
    assert err["max"] <= 0.5 and err["coverage"] == 1.0


@settings(max_examples=40, deadline=None)
@given(data=st.data(), holes=st.booleans())
def test_property_large_triangle_scan_block_by_block_finds_the_worst_cell(data, holes):
    """Triangles whose box spans 16 blocks of 64 x 64 cells are bounded block by block first: still exact."""
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1), label="seed"))
    h = data.draw(st.integers(200, 330), label="rows")
    w = data.draw(st.integers(200, 330), label="cols")
    r, c = np.mgrid[0:h, 0:w]
    rough = data.draw(st.sampled_from([0.0, 0.3, 5.0]), label="roughness")
    z = 40 * np.sin(r / 29.0) + 25 * np.cos(c / 41.0) + rng.normal(0, 1, (h, w)) * rough * (rng.random((h, w)) < 0.2)
    z = np.round(z, 1).astype(np.float32)
    valid = rng.random((h, w)) > 0.15 if holes else np.ones((h, w), bool)
    if holes:
        valid[rng.integers(0, h // 2):, : rng.integers(0, w)] = False  # a wide hole: blocks without data
    # corners near three sides: the box spans the grid (at least 4 x 4 blocks)
    xs = [int(rng.integers(0, w // 5)), int(rng.integers(4 * w // 5, w)), int(rng.integers(0, w))]
    ys = [int(rng.integers(0, h)), int(rng.integers(0, h // 5)), int(rng.integers(4 * h // 5, h))]
    corners = list(zip(xs, ys, strict=True))
    _assert_the_scan_is_exact(z, valid, holes, corners)
