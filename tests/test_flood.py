"""The flood method (tinsmith.algorithms.flood): a quality mesh under a time-step floor, the streams as breaklines,
the outline cut for a solver, and a report of where the error bound gave way, checked against the DEM."""

import json
import warnings

import numpy as np
import pytest

import tinsmith
from tinsmith.algorithms.flood import flood as F
from tinsmith.cli.main import main
from tinsmith.core import Heightfield
from tinsmith.errors import InvalidInputError, InvalidOptionError, TinsmithWarning
from tinsmith.hydrology import GRAVITY, WIDTH_COEFF, normal_depth
from tinsmith.io.boundaries import named_boundaries
from tinsmith.io.flood import in_line_border_triangles
from tinsmith.triangulation.shape import triangle_angles

BOUND = 10.0


@pytest.fixture(scope="module")
def helens():
    return tinsmith.read_heightfield(tinsmith.sample_path("st-helens"))


@pytest.fixture(scope="module")
def mesh(helens):
    return tinsmith.flood(helens, max_error=BOUND)


def _speed(hf):
    return F.wave_speed(hf, None, 100.0, 0.03)


# -- the report of the relaxed bound, against an independent check of the mesh against the DEM -----------------

def test_the_relaxed_bound_report_matches_the_mesh_against_the_dem(mesh, helens):
    import shapely

    report = mesh.info["flood"]["relaxed"]
    assert report["bound"] == BOUND and report["triangles"] > 0  # the default time step does relax it here
    error = np.abs(tinsmith.rasterize(mesh, helens) - helens.z)
    error[~helens.valid] = np.nan
    assert report["max_error"] == pytest.approx(np.nanmax(error), rel=1e-9)
    w = report["worst_cell"]
    assert error[w["row"], w["col"]] == pytest.approx(report["max_error"], rel=1e-9)
    x, y = helens.pixel_to_world(np.array([float(w["row"])]), np.array([float(w["col"])]))
    assert (w["x"], w["y"]) == (pytest.approx(x[0]), pytest.approx(y[0]))
    # every cell over the bound lies in a triangle the report counts, and every such triangle holds one
    rows, cols = np.nonzero(error > BOUND * (1 + 1e-9))
    cx, cy = helens.pixel_to_world(rows.astype(float), cols.astype(float))
    polygons = shapely.polygons(mesh.vertices[mesh.triangles][:, :, :2])
    tree = shapely.STRtree(polygons)
    cells, hit = tree.query(shapely.points(cx, cy), predicate="dwithin", distance=1e-6)
    assert set(cells.tolist()) == set(range(len(rows)))  # every over-bound cell is in some triangle
    # a cell on an edge belongs to both triangles; count those whose own plane is over the bound there
    over = set()
    for c, t in zip(cells.tolist(), hit.tolist(), strict=True):
        a, b, d = mesh.vertices[mesh.triangles[t]]
        m = np.array([[b[0] - a[0], d[0] - a[0]], [b[1] - a[1], d[1] - a[1]]])
        u, v = np.linalg.solve(m, [cx[c] - a[0], cy[c] - a[1]])
        z = a[2] + u * (b[2] - a[2]) + v * (d[2] - a[2])
        if abs(z - helens.z[rows[c], cols[c]]) > BOUND * (1 + 1e-6):
            over.add(t)
    assert len(over) == report["triangles"]
    area = shapely.area(polygons[sorted(over)]).sum()
    assert report["area"] == pytest.approx(area, rel=1e-9)
    assert report["area_share"] == pytest.approx(area / shapely.area(polygons).sum(), rel=1e-9)


def test_no_floor_means_the_bound_holds_everywhere(helens):
    window = Heightfield(helens.z[100:260, 60:220], transform=helens.transform, crs=helens.crs)
    dry = Heightfield(np.zeros(window.shape), transform=window.transform, crs=window.crs)
    mesh = tinsmith.flood(window, max_error=BOUND, depth=dry)  # no water expected: no floor
    assert mesh.info["flood"]["relaxed"]["triangles"] == 0
    assert tinsmith.vertical_error(mesh, window)["max"] <= BOUND
    assert mesh.info["flood"]["below_step"] == 0


def test_a_longer_time_step_relaxes_more(helens):
    window = Heightfield(helens.z[100:260, 60:220], transform=helens.transform, crs=helens.crs)
    relaxed = [tinsmith.flood(window, max_error=BOUND, time_step=s).info["flood"]["relaxed"] for s in (0.5, 5.0, 20.0)]
    counts = [r["area"] for r in relaxed]
    assert counts[0] < counts[1] < counts[2]


# -- what the floor buys: a longer time step than quality's at the same bound -----------------------------------

def test_the_smallest_step_is_longer_than_qualitys(mesh, helens):
    speed = _speed(helens)
    step = mesh.info["flood"]["time_step"]
    quality = tinsmith.quality(helens, max_error=BOUND)
    flood_min = F.step_report(mesh, helens, speed, step)["min_step"]
    assert flood_min == pytest.approx(mesh.info["flood"]["min_step"])
    theirs = F.step_report(quality, helens, speed, step)
    assert flood_min > 1.5 * theirs["min_step"]  # 1.71 x measured
    below = mesh.info["flood"]["below_step"] / mesh.n_triangles
    assert below < 0.8 * theirs["below_step"] / quality.n_triangles  # 7.7% against 11.5% measured


def test_the_step_report_counts_the_triangles_below_the_target(mesh, helens):
    speed = _speed(helens)
    step = mesh.info["flood"]["time_step"]
    tri = mesh.vertices[mesh.triangles][:, :, :2]
    sides = np.linalg.norm(tri - np.roll(tri, -1, axis=1), axis=2).sum(axis=1)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    inradius = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) / sides
    corners = np.concatenate([tri, tri.mean(axis=1, keepdims=True)], axis=1).reshape(-1, 2)
    rows, cols = helens.world_to_pixel(corners[:, 0], corners[:, 1])
    c = speed[np.rint(rows).astype(int).clip(0, helens.shape[0] - 1),
              np.rint(cols).astype(int).clip(0, helens.shape[1] - 1)].reshape(-1, 4).max(axis=1)
    steps = inradius / c
    assert mesh.info["flood"]["min_step"] == pytest.approx(steps.min())
    assert mesh.info["flood"]["below_step"] == int((steps < step * (1 - 1e-9)).sum())


# -- shape, boundaries, ANUGA -----------------------------------------------------------------------------------

def test_every_plan_view_angle_is_at_least_30_degrees(mesh):
    angles = triangle_angles(mesh, dims=2).min(axis=1)
    assert angles.min() >= 30.0 - 1e-6
    assert mesh.info["quality"]["below_min_angle"] == 0


def test_the_outline_is_cut_into_outflows_and_walls(mesh):
    kinds = {name.rsplit("_", 1)[0] for name in mesh.node_strings}
    assert {"outflow", "wall"} <= kinds <= {"outflow", "inflow", "wall"}
    border = {tuple(sorted(e)) for lp in named_boundaries(mesh)["outline"] for e in zip(lp[:-1], lp[1:], strict=True)}
    covered = [tuple(sorted(e)) for ids in mesh.node_strings.values() for e in zip(ids[:-1], ids[1:], strict=True)]
    assert sorted(covered) == sorted(border)  # every border edge in exactly one segment


def test_a_given_stream_is_a_breakline_and_opens_the_outline(helens):
    window = Heightfield(helens.z[100:260, 60:220], transform=helens.transform, crs=helens.crs)
    x, y = window.pixel_to_world(np.array([-5.0, 165.0]), np.array([80.0, 80.0]))  # north to south, across
    line = np.column_stack([x, y])
    with pytest.warns(TinsmithWarning, match="clipped to the data's outline"):  # it runs on past the DEM
        mesh = tinsmith.flood(window, max_error=BOUND, streams=[line])
    assert mesh.info["flood"]["streams"] == 1 and not mesh.info["flood"]["streams_derived"]
    assert mesh.info["flood"]["stream_breaklines"] == 1
    on_line = np.abs(mesh.vertices[:, 0] - x[0]) < 1e-6
    assert on_line.sum() >= 3  # the breakline's vertices, at the column's cell centres
    assert {n.rsplit("_", 1)[0] for n in mesh.node_strings} == {"inflow", "outflow", "wall"}


@pytest.mark.filterwarnings("ignore:.*negative cells set to zero depth:UserWarning")  # ANUGA's drying film
def test_a_short_event_runs_in_anuga(mesh):
    import contextlib
    import io

    with contextlib.redirect_stdout(io.StringIO()):
        anuga = pytest.importorskip("anuga")
    with warnings.catch_warnings():
        warnings.simplefilter("error", TinsmithWarning)
        domain = mesh.to_anuga(friction=0.03)
    assert len(in_line_border_triangles(domain)) == 0  # none ANUGA cannot reconstruct
    assert set(domain.boundary.values()) == set(mesh.node_strings)
    domain.set_store(False)
    bc = anuga.Transmissive_stage_zero_momentum_boundary(domain)
    domain.set_boundary({tag: bc for tag in set(domain.boundary.values())})
    anuga.Rate_operator(domain, rate=0.001)
    with contextlib.redirect_stdout(io.StringIO()):
        for _ in domain.evolve(yieldstep=30.0, finaltime=60.0):
            pass
    q = domain.quantities
    assert np.isfinite(q["stage"].centroid_values).all() and np.isfinite(q["xmomentum"].centroid_values).all()
    assert domain.get_water_volume() > 0


def test_same_input_same_mesh(helens):
    window = Heightfield(helens.z[100:260, 60:220], transform=helens.transform, crs=helens.crs)
    a, b = (tinsmith.flood(window, max_error=BOUND) for _ in range(2))
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    assert a.node_strings.keys() == b.node_strings.keys()


# -- the expected flow ----------------------------------------------------------------------------------------

def test_normal_depth_of_a_wide_river_follows_manning_over_its_width():
    # a long plane falling 1 m per 10 m cell to the east: the last column carries the most
    z = np.add.outer(np.zeros(3), np.arange(400.0, 0.0, -1.0))
    hf = Heightfield(z, cell_size=10.0)
    rain, n = 0.01, 0.03
    depth, speed = normal_depth(hf, rain=rain, manning=n)
    area = 100.0 * 400  # the last cell's contributing area: its row, 400 cells
    discharge = rain * area
    width = max(10.0, WIDTH_COEFF * np.sqrt(discharge))
    assert width > 10.0  # the width grows with the discharge here
    q = discharge / width
    assert depth[1, -1] == pytest.approx((n * q / np.sqrt(0.1)) ** 0.6, rel=1e-9)
    assert speed[1, -1] == pytest.approx(q / depth[1, -1], rel=1e-9)


def test_the_wave_speed_has_a_sheet_of_water_at_least():
    z = np.add.outer(np.zeros(5), np.arange(5.0, 0.0, -1.0))
    hf = Heightfield(z, cell_size=10.0)
    c = F.wave_speed(hf, None, 1.0, 0.03)  # 1 mm/h: a normal depth far below the sheet
    assert (c >= np.sqrt(GRAVITY * F.SHEET_DEPTH)).all()
    given = Heightfield(np.full(hf.shape, 0.4), cell_size=10.0)
    np.testing.assert_allclose(F.wave_speed(hf, given, 100.0, 0.03), np.sqrt(GRAVITY * 0.4))  # still water


# -- bad input ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize(("options", "error", "match"), [
    ({"time_step": "soon"}, InvalidInputError, "time_step must be a finite number > 0"),
    ({"time_step": -1.0}, InvalidInputError, "time_step must be a finite number > 0"),
    ({"rain": 0.0}, InvalidOptionError, "rain"),
    ({"manning": -0.03}, InvalidOptionError, "manning"),
    ({"depth": np.zeros((4, 4))}, InvalidInputError, "depth must be a raster on the DEM's grid"),
])
def test_bad_options_give_one_clear_line(options, error, match):
    hf = Heightfield(np.add.outer(np.arange(20.0), np.arange(20.0)), cell_size=10.0)
    with pytest.raises(error, match=match):
        tinsmith.flood(hf, max_error=1.0, **options)


def test_a_depth_raster_on_another_grid_is_refused():
    hf = Heightfield(np.add.outer(np.arange(20.0), np.arange(20.0)), cell_size=10.0)
    other = Heightfield(np.zeros((20, 20)), cell_size=5.0)
    with pytest.raises(InvalidInputError, match="depth must be a raster on the DEM's grid"):
        tinsmith.flood(hf, max_error=1.0, depth=other)


def test_a_dem_in_degrees_is_refused_naming_the_utm_zone():
    hf = Heightfield(np.add.outer(np.arange(20.0), np.arange(20.0)),
                     transform=(0.001, 0, -122.2, 0, -0.001, 46.2), crs="EPSG:4326")
    with pytest.raises(InvalidInputError, match="flood measures in metres, but the CRS .* is geographic.*UTM"):
        tinsmith.flood(hf, max_error=1.0)


def test_cells_that_are_not_square_are_refused():
    hf = Heightfield(np.add.outer(np.arange(20.0), np.arange(20.0)), transform=(10.0, 0, 0, 0, -12.0, 0))
    with pytest.raises(InvalidInputError, match="flood needs square cells"):
        tinsmith.flood(hf, max_error=1.0)


# -- the command line -----------------------------------------------------------------------------------------

def test_cli_writes_the_segments_and_reports_the_time_step(tmp_path, capsys):
    out = tmp_path / "m.2dm"
    code = main(["simplify", "--sample", "st-helens", "--method", "flood", "--max-error", "20", "-o", str(out),
                 "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["method"] == "flood" and summary["flood"]["time_step_auto"]
    assert any(s.startswith("outflow_") for s in summary["segments"])
    text = out.read_text()
    assert text.count("\nNS ") >= len(summary["segments"])
