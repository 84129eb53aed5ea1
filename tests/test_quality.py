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

SAMPLE = "src/tinsmith/data/samples/st_helens_30m.tif"
TUJUNGA = "../shared/data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"


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
       error=st.sampled_from([0.5, 2.0, 8.0]), breakline=st.booleans())
def test_error_and_angle_bounds_hold_and_the_run_ends(seed, hole, angle, error, breakline):
    """Random DEMs, random cell sizes, nodata holes (staircase outlines: input angles of 45 and 90 degrees) and a
    breakline along a row: every plan-view angle >= the bound, the error bound at every valid cell, no defect."""
    hf = _dem(seed, 40, 50, hole)
    lines = None
    if breakline:
        valid_rows = np.flatnonzero(hf.valid.all(axis=1))
        if len(valid_rows):
            r = int(valid_rows[len(valid_rows) // 2])
            x, y = hf.pixel_to_world(np.array([r, r]), np.array([5, 44]))
            lines = [np.column_stack([x, y])]
    mesh = tinsmith.simplify(hf, method="quality", max_error=error, min_angle=angle, breaklines=lines)
    _check(mesh, hf, error, angle)
    if lines is not None:
        assert len(mesh.info["constrained_edges"]) > 0


def test_sample_dem_at_30_degrees():
    hf = tinsmith.read_heightfield(SAMPLE)
    mesh = tinsmith.simplify(hf, method="quality", max_error=5.0)
    _check(mesh, hf, 5.0, 30.0)
    greedy = tinsmith.greedy(hf, max_error=5.0)
    # every triangle at 30 degrees, at the price of more vertices than greedy insertion (its slivers: 63-73%)
    assert (_plan_min_angles(greedy) >= 30).mean() < 0.8
    assert greedy.n_vertices < mesh.n_vertices < 4 * greedy.n_vertices
    assert mesh.info["quality"]["off_grid_vertices"] > 0


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
    area = 0.5 * np.abs((x[t[:, 1]] - x[t[:, 0]]) * (y[t[:, 2]] - y[t[:, 0]]) - (x[t[:, 2]] - x[t[:, 0]]) * (y[t[:, 1]] - y[t[:, 0]]))
    assert area.max() <= 10.0 * (1 + 1e-9)
    assert fine.n_vertices > coarse.n_vertices
    graded = tinsmith.simplify(hf, method="quality", max_error=8.0, grading=1.5)
    _check(graded, hf, 8.0, 30.0)


@pytest.mark.parametrize("options, word", [
    ({"min_angle": 0}, "min_angle"), ({"min_angle": 35}, "min_angle"), ({"max_area": 0}, "max_area"),
    ({"grading": 0.5}, "grading"),
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
    hf = tinsmith.read_heightfield(TUJUNGA)
    mesh = tinsmith.simplify(hf, method="quality", max_error=40.0)
    _check(mesh, hf, 40.0, 30.0)
