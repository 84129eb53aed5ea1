"""The quality method: an exact vertical error bound and a minimum plan-view angle at once (METHODS.md section 12)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith.errors import InvalidInputError
from tinsmith.metrics import vertical_error
from tinsmith.metrics.quality import triangle_angles
from tinsmith.metrics.topology import surface_problems

from .conftest import shared

SAMPLE = tinsmith.sample_path("st-helens")
TUJUNGA = "terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"


def _plan_min_angles(mesh):
    return triangle_angles(mesh, dims=2).min(axis=1)


def _check(mesh, hf, max_error, min_angle):
    err = vertical_error(mesh, hf)
    assert err["coverage"] == 1.0
    assert err["max"] <= max_error * (1 + 1e-9) + 1e-12
    assert _plan_min_angles(mesh).min() >= min_angle - 1e-6
    assert mesh.info["quality"]["below_min_angle"] == 0
    problems = surface_problems(mesh)
    assert problems["degenerate"] == problems["duplicate"] == problems["overused"] == problems["misoriented"] == 0


def _dem(seed, h, w, hole):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w]
    z = 20 * np.sin(xx / (3 + 5 * rng.random())) * np.cos(yy / (4 + 5 * rng.random())) + rng.normal(0, 0.5, (h, w))
    z = z.astype(np.float32)
    if hole:
        r0, c0 = rng.integers(2, h // 2), rng.integers(2, w // 2)
        z[r0 : r0 + rng.integers(2, h // 3), c0 : c0 + rng.integers(2, w // 3)] = np.nan
    return tinsmith.Heightfield(z, cell_size=1.0 + rng.random(), nodata_mask=np.isnan(z))


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), hole=st.booleans(), angle=st.sampled_from([20.0, 28.0, 30.0]),
       error=st.sampled_from([0.5, 2.0, 8.0]), breakline=st.booleans(), control=st.booleans())
def test_error_and_angle_bounds_hold_and_the_run_ends(seed, hole, angle, error, breakline, control):
    """Random DEMs, random cell sizes, nodata holes (staircase outlines: input angles of 45 and 90 degrees), a
    breakline along a row and control points, refined then improved (the default): every plan-view angle >= the
    bound, the error bound at every valid cell, no defect, every control point still a vertex."""
    hf = _dem(seed, 40, 50, hole)
    points = None
    if control:
        rows, cols = np.nonzero(hf.valid)
        pick = np.random.default_rng(seed).choice(len(rows), 3, replace=False)
        x, y = hf.pixel_to_world(rows[pick], cols[pick])
        points = np.column_stack([x, y])
    lines = None
    if breakline:
        valid_rows = np.flatnonzero(hf.valid.all(axis=1))
        if len(valid_rows):
            r = int(valid_rows[len(valid_rows) // 2])
            x, y = hf.pixel_to_world(np.array([r, r]), np.array([5, 44]))
            lines = [np.column_stack([x, y])]
    mesh = tinsmith.simplify(hf, method="quality", max_error=error, min_angle=angle, breaklines=lines,
                             control_points=points)
    _check(mesh, hf, error, angle)
    if lines is not None:
        assert len(mesh.constrained_edges) > 0
    if points is not None:
        assert (np.abs(mesh.vertices[None, :, :2] - points[:, None, :]).max(axis=2).min(axis=1) < 1e-9).all()


def test_sample_dem_at_30_degrees():
    hf = tinsmith.read_heightfield(SAMPLE)
    mesh = tinsmith.simplify(hf, method="quality", max_error=5.0)
    _check(mesh, hf, 5.0, 30.0)
    greedy = tinsmith.greedy(hf, max_error=5.0)
    # every triangle at 30 degrees, at the price of more vertices than greedy insertion (its slivers: 63-73%)
    assert (_plan_min_angles(greedy) >= 30).mean() < 0.8
    # refinement alone: Steiner points for the error too keep it near 2x (2.09 measured; the worst cell gave 2.9x)
    refined = tinsmith.simplify(hf, method="quality", max_error=5.0, improve=0)
    _check(refined, hf, 5.0, 30.0)
    assert greedy.n_vertices < refined.n_vertices < 2.4 * greedy.n_vertices
    # the improvement passes take most of the surplus back (0.67x the refinement's, 1.18x greedy's measured),
    # both bounds still holding
    assert mesh.n_vertices < 0.75 * refined.n_vertices
    assert mesh.n_vertices < 1.3 * greedy.n_vertices
    assert mesh.info["quality"]["improvement"]["removed"] == refined.n_vertices - mesh.n_vertices
    assert mesh.info["quality"]["off_grid_vertices"] > 0


def test_improvement_keeps_control_points_segments_and_grading():
    hf = _dem(11, 40, 50, True)
    x, y = hf.pixel_to_world(np.array([7, 30, 33]), np.array([9, 40, 12]))
    points = np.column_stack([x, y])
    r = int(np.flatnonzero(hf.valid.all(axis=1))[0])
    lx, ly = hf.pixel_to_world(np.array([r, r]), np.array([3, 46]))
    line = np.column_stack([lx, ly])
    for grading in (None, 1.4):
        refined = tinsmith.simplify(hf, method="quality", max_error=2.0, control_points=points, breaklines=[line],
                                    grading=grading, improve=0)
        mesh = tinsmith.simplify(hf, method="quality", max_error=2.0, control_points=points, breaklines=[line],
                                 grading=grading)
        _check(mesh, hf, 2.0, 30.0)
        assert mesh.n_vertices < refined.n_vertices
        for p in points:  # every control point is still a vertex
            assert np.abs(mesh.vertices[:, :2] - p).max(axis=1).min() < 1e-9
        # the breakline and the outline are kept: every constrained vertex of the refined mesh is still there
        kept = refined.vertices[np.unique(refined.constrained_edges)][:, :2]
        d = np.abs(mesh.vertices[None, :, :2] - kept[:, None, :]).max(axis=2).min(axis=1)
        assert d.max() < 1e-9
        if grading is not None:
            # the improvement checks every triangle it makes against its neighbours, so it adds no pair over the
            # grading; refinement checks a triangle when it is made only (docs/methods/quality.md)
            assert _over_grading(mesh, grading) <= _over_grading(refined, grading)


def _over_grading(mesh, grading):
    """Pairs of neighbouring triangles whose areas differ by more than grading**2."""
    areas = _areas(mesh)
    t = mesh.triangles
    edges = np.sort(np.stack([t, np.roll(t, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    owner = np.repeat(np.arange(len(t)), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    e, o = edges[order], owner[order]
    pair = (e[1:] == e[:-1]).all(axis=1)
    a, b = areas[o[:-1][pair]], areas[o[1:][pair]]
    return int((np.maximum(a, b) > grading**2 * np.minimum(a, b) * (1 + 1e-9)).sum())


def test_deterministic():
    hf = _dem(3, 30, 30, True)
    a = tinsmith.simplify(hf, method="quality", max_error=1.0)
    b = tinsmith.simplify(hf, method="quality", max_error=1.0)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)


def test_steiner_points_take_the_bilinear_height():
    # a plane: bilinear heights are exact, so the mesh is the plane everywhere
    yy, xx = np.mgrid[0:30, 0:40]
    hf = tinsmith.Heightfield((0.3 * xx - 0.2 * yy).astype(np.float64), cell_size=1.0)
    mesh = tinsmith.simplify(hf, method="quality", max_error=1e-9, max_area=20.0)
    row, col = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    assert np.allclose(mesh.vertices[:, 2], 0.3 * col - 0.2 * row, atol=1e-9)
    assert mesh.info["quality"]["off_grid_vertices"] > 0


def test_size_controls():
    hf = _dem(5, 40, 40, False)
    coarse = tinsmith.simplify(hf, method="quality", max_error=8.0)
    fine = tinsmith.simplify(hf, method="quality", max_error=8.0, max_area=10.0)
    x, y = fine.vertices[:, 0], fine.vertices[:, 1]
    t = fine.triangles
    area = 0.5 * np.abs((x[t[:, 1]] - x[t[:, 0]]) * (y[t[:, 2]] - y[t[:, 0]])
                        - (x[t[:, 2]] - x[t[:, 0]]) * (y[t[:, 1]] - y[t[:, 0]]))
    assert area.max() <= 10.0 * (1 + 1e-9)
    assert fine.n_vertices > coarse.n_vertices
    graded = tinsmith.simplify(hf, method="quality", max_error=8.0, grading=1.5)
    _check(graded, hf, 8.0, 30.0)


@pytest.mark.parametrize("options, word", [
    ({"min_angle": 0}, "min_angle"), ({"min_angle": 35}, "min_angle"), ({"max_area": 0}, "max_area"),
    ({"grading": 0.5}, "grading"), ({"improve": -1}, "improve"),
])
def test_bad_options_give_one_clear_line(options, word):
    hf = _dem(1, 20, 20, False)
    with pytest.raises(InvalidInputError, match=word) as info:
        tinsmith.simplify(hf, method="quality", **options)
    assert "\n" not in str(info.value)


def test_rectangular_cells_are_refused_with_one_line():
    hf = tinsmith.Heightfield(np.zeros((10, 10)), cell_size=(1.0, 2.0))
    with pytest.raises(tinsmith.errors.InvalidInputError, match="square cells"):
        tinsmith.simplify(hf, method="quality")


def test_real_dem_not_tuned_on():
    hf = tinsmith.read_heightfield(shared(TUJUNGA))
    mesh = tinsmith.simplify(hf, method="quality", max_error=40.0)
    _check(mesh, hf, 40.0, 30.0)


# -- regions and solver files -----------------------------------------------------------------------------------


def _areas(mesh):
    x, y, t = mesh.vertices[:, 0], mesh.vertices[:, 1], mesh.triangles
    return 0.5 * np.abs((x[t[:, 1]] - x[t[:, 0]]) * (y[t[:, 2]] - y[t[:, 0]])
                        - (x[t[:, 2]] - x[t[:, 0]]) * (y[t[:, 1]] - y[t[:, 0]]))


def test_regions_bound_their_triangles_and_follow_their_polygons():
    import shapely

    hf = _dem(7, 60, 60, False)
    x, y = hf.pixel_to_world(np.array([10, 10, 40, 40]), np.array([5, 30, 30, 5]))
    box = shapely.Polygon(np.column_stack([x, y]))  # corners on cell centres: snapping keeps it
    cx, cy = hf.pixel_to_world(np.array([25]), np.array([45]))
    disk = shapely.Point(cx[0], cy[0]).buffer(12 * hf.cell_size[0])
    limit = 2.0 * hf.cell_size[0] ** 2
    mesh = tinsmith.simplify(hf, method="quality", max_error=8.0,
                             regions=[(box, limit, "channel"), (disk, None, "meadow")])
    _check(mesh, hf, 8.0, 30.0)
    region, area = mesh.triangle_attributes["region"], _areas(mesh)
    assert mesh.labels["region"] == {1: "channel", 2: "meadow"}
    assert area[region == 1].max() <= limit * (1 + 1e-9)
    assert np.isclose(area[region == 1].sum(), box.area)  # the boundary is made of mesh edges
    assert (region == 2).sum() > 0 and area[region == 0].max() > limit
    # later regions win where they overlap
    both = tinsmith.simplify(hf, method="quality", max_error=8.0, regions=[(box, limit), (box, None, "over")])
    assert set(np.unique(both.triangle_attributes["region"])) <= {0, 2}


def test_regions_are_clipped_to_the_data():
    import shapely

    hf = _dem(11, 50, 60, True)
    x0, y0, x1, y1 = hf.bounds
    band = shapely.LineString([(x0 - 10, y0 - 10), (x1 + 10, y1 + 10)]).buffer(6 * hf.cell_size[0])
    mesh = tinsmith.simplify(hf, method="quality", max_error=4.0, regions=[(band, 4 * hf.cell_size[0] ** 2)])
    err = vertical_error(mesh, hf)
    assert err["coverage"] == 1.0 and err["max"] <= 4.0 * (1 + 1e-9)
    region = mesh.triangle_attributes["region"]
    assert (region == 1).sum() > 0 and _areas(mesh)[region == 1].max() <= 4 * hf.cell_size[0] ** 2 * (1 + 1e-9)
    # small angles only where the band's edge meets the outline (input angles), and reported
    assert mesh.info["quality"]["below_min_angle"] == (_plan_min_angles(mesh) < 30 - 1e-6).sum()


@pytest.mark.parametrize("regions, word", [
    ([("not a polygon", 1.0)], r"regions\[0\] must be a polygon"),
    ([(np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]]), -1.0)], r"regions\[0\]: max_area must be a number > 0"),
    ([(np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]]),)], r"regions\[0\] must be a \(polygon, max_area\)"),
    # no CRS to move them by, and nowhere near the data (tinsmith.io.geometry)
    ([(np.array([[1e6, 1e6], [1e6 + 5, 1e6], [1e6, 1e6 + 5]]), 1.0)], r"regions do not overlap the data"),
])
def test_bad_regions_give_one_clear_line(regions, word):
    hf = _dem(1, 20, 20, False)
    with pytest.raises(InvalidInputError, match=word) as info:
        tinsmith.simplify(hf, method="quality", regions=regions)
    assert "\n" not in str(info.value)


def _hole_breakline_regions_mesh():
    import shapely

    hf = _dem(3, 40, 50, True)
    x, y = hf.pixel_to_world(np.array([20, 20]), np.array([5, 44]))
    rx, ry = hf.pixel_to_world(np.array([25, 25, 35, 35]), np.array([10, 40, 40, 10]))
    return tinsmith.simplify(hf, method="quality", max_error=1.0, breaklines=[np.column_stack([x, y])],
                             regions=[(shapely.Polygon(np.column_stack([rx, ry])), 5.0, "channel")])


def test_2dm_carries_node_strings_and_materials(tmp_path):
    import py2dm

    from tinsmith.io.boundaries import named_boundaries

    mesh = _hole_breakline_regions_mesh()
    lines = named_boundaries(mesh)
    assert len(lines["outline"]) == 2 and len(lines["breaklines"]) >= 1
    # the outline loops are the border, each edge once
    loops = np.sort(np.concatenate([np.column_stack([lp[:-1], lp[1:]]) for lp in lines["outline"]]), axis=1)
    np.testing.assert_array_equal(np.unique(loops, axis=0), mesh.boundary_edges())
    assert len(loops) == len(mesh.boundary_edges())
    path = tinsmith.write(mesh, tmp_path / "m.2dm")
    with py2dm.Reader(str(path)) as reader:  # an independent reader
        strings = {ns.name: np.asarray(ns.nodes) - 1 for ns in reader.iter_node_strings()}
        materials = np.array([e.materials[0] for e in reader.iter_elements()])
    expected = {f"outline_{k + 1}": lp for k, lp in enumerate(lines["outline"])}
    expected.update({f"breakline_{k + 1}": bl for k, bl in enumerate(lines["breaklines"])})
    assert strings.keys() == expected.keys()
    for name, ids in expected.items():
        np.testing.assert_array_equal(strings[name], ids)
    np.testing.assert_array_equal(materials, mesh.triangle_attributes["region"] + 1)
    back = tinsmith.read_mesh(path)  # and our own reader
    assert back.node_strings.keys() == expected.keys()


def test_gmsh_file_carries_physical_groups(tmp_path):
    import meshio

    mesh = _hole_breakline_regions_mesh()
    path = tinsmith.write(mesh, tmp_path / "m.msh")
    ref = meshio.read(path)
    groups = {name: tuple(v) for name, v in ref.field_data.items()}
    assert groups == {"outline": (1, 1), "breaklines": (2, 1), "terrain": (1, 2), "channel": (2, 2)}
    tags = dict(zip([c.type for c in ref.cells], ref.cell_data["gmsh:physical"], strict=True))
    np.testing.assert_array_equal(tags["triangle"], mesh.triangle_attributes["region"] + 1)
    lines = np.sort(ref.cells[[c.type for c in ref.cells].index("line")].data, axis=1)
    border = {tuple(e) for e in mesh.boundary_edges().tolist()}
    on_border = np.array([tuple(e) in border for e in lines.tolist()])
    np.testing.assert_array_equal(on_border, tags["line"] == 1)  # outline: the border; breaklines: inside
    assert on_border.sum() == len(border)
    back = tinsmith.read_mesh(path)
    assert back.n_triangles == mesh.n_triangles


def test_a_slanted_region_boundary_is_not_split_into_slivers_of_cells():
    """Cell centres a hair's breadth from a slanted boundary would make refinement split it into tiny pieces;
    greedy's seeds near a breakline are left out, so the channel's triangles stay near its max_area."""
    import shapely

    hf = tinsmith.read_heightfield(shared(TUJUNGA))
    x0, y0, x1, y1 = hf.bounds
    channel = shapely.LineString([(x0, y0 + 0.3 * (y1 - y0)), (x1, y0 + 0.7 * (y1 - y0))]).buffer(300.0)
    mesh = tinsmith.simplify(hf, method="quality", max_error=20.0, regions=[(channel, 20_000.0, "channel")])
    area = _areas(mesh)[mesh.triangle_attributes["region"] == 1]
    cell = hf.cell_size[0] ** 2
    assert area.max() <= 20_000.0 * (1 + 1e-9)
    assert np.percentile(area, 5) > 0.5 * cell  # 0.006 cells when seeds hugged the boundary


# -- the angle limit, the guards against a refinement that does not converge, cells square within 1% ---------------
def _bowl(n=300):
    """A smooth paraboloid, the DEM on which 34 degrees cascaded (issue 42): 300 x 300 cells, 1 m."""
    r, c = np.mgrid[0:n, 0:n].astype(np.float64)
    return tinsmith.Heightfield((((r - n / 2) ** 2 + (c - n / 2) ** 2) / 100.0).astype(np.float32), cell_size=1.0)


def _unchecked_quality(hf, min_angle, **stop):
    """The method without the option checks, to run an angle above the accepted limit."""
    from tinsmith.algorithms.quality import quality as q

    return q.quality.__wrapped__(hf, min_angle=min_angle, max_area=None, grading=None, improve=0, regions=None,
                                 breaklines=None, control_points=None, stop=tinsmith.StopCriteria(**stop))


def test_min_angle_limit_is_33_degrees():
    hf = _dem(3, 30, 30, False)
    mesh = tinsmith.simplify(hf, method="quality", max_error=1.0, min_angle=33)
    _check(mesh, hf, 1.0, 33.0)
    with pytest.raises(InvalidInputError, match="min_angle.*<= 33") as info:
        tinsmith.simplify(hf, method="quality", min_angle=33.01)
    assert "\n" not in str(info.value)


def test_the_stall_guard_stops_a_cascade_with_one_line(monkeypatch):
    """At 36 degrees (above the limit) refinement cascades: each generation of Steiner points makes shorter edges.
    With the vertex budget out of the way, the stall guard ends it with an error naming min_angle and the guard;
    at the limit the 300 x 300 bowl of issue 42 (which cascaded at 34) converges."""
    from tinsmith.algorithms.quality import quality as q
    from tinsmith.errors import InvalidOptionError

    monkeypatch.setattr(q, "VERTEX_BUDGET", 1000.0)
    with pytest.raises(InvalidOptionError, match="min_angle: .*may not converge.*stall guard") as info:
        _unchecked_quality(_bowl(100), 36.0)
    assert "\n" not in str(info.value)
    monkeypatch.undo()
    mesh = tinsmith.simplify(_bowl(), method="quality", min_angle=33)
    assert mesh.info["stop_reason"] == "quality"
    assert mesh.info["quality"]["below_min_angle"] == 0


def test_the_vertex_budget_stops_with_one_line(monkeypatch, tmp_path, capsys):
    from tinsmith.algorithms.quality import quality as q
    from tinsmith.cli.main import main
    from tinsmith.errors import InvalidOptionError

    monkeypatch.setattr(q, "VERTEX_BUDGET", 0.05)  # a tiny budget: 0.05 vertices per valid cell
    hf = _dem(5, 40, 50, False)
    with pytest.raises(InvalidOptionError, match="min_angle: .*vertex budget stopped it at") as info:
        tinsmith.simplify(hf, method="quality", max_error=0.5, min_angle=30)
    assert "\n" not in str(info.value)
    # the command line: exit code 1, exactly one line naming the guard, no output
    out = tmp_path / "m.ply"
    assert main(["simplify", "--sample", "st-helens", "-o", str(out), "--method", "quality", "--max-error", "1"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("tinsmith: error: ") and "vertex budget" in err[0]
    assert not out.exists()


@pytest.mark.parametrize("cell", [(4.0037, 4.0139), (1.0, 1.0099), (1.0099, 1.0)])
@pytest.mark.parametrize("angle, error", [(30.0, 0.5), (33.0, 0.5)])
def test_cells_square_within_one_percent_are_meshed_with_world_bounds(cell, angle, error):
    """Refinement in cell units, angles and areas measured in world units: both bounds hold in world coordinates
    (the mesh's vertices) on cells up to 1% from square, with and without a nodata hole."""
    for seed, hole in ((0, False), (1, True)):
        base = _dem(seed, 60, 70, hole)
        hf = tinsmith.Heightfield(base.z, cell_size=cell, nodata_mask=~base.valid)
        mesh = tinsmith.simplify(hf, method="quality", max_error=error, min_angle=angle)
        _check(mesh, hf, error, angle)


@pytest.mark.parametrize("transform, sizes", [
    ((4.0, 0.0, 0.0, 0.0, -4.05, 0.0), "4 x 4.05"),  # 1.25% from square
    ((1.0, 0.0, 0.0, 0.0, -1.0101, 0.0), "1 x 1.0101"),
])
def test_cells_beyond_one_percent_are_refused_naming_the_sizes(transform, sizes):
    hf = tinsmith.Heightfield(np.zeros((10, 10)), transform=transform)
    with pytest.raises(InvalidInputError, match="square cells") as info:
        tinsmith.simplify(hf, method="quality")
    assert sizes in str(info.value) and "\n" not in str(info.value)
