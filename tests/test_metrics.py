"""Metrics against hand-computed cases, and the exactness of the rasteriser on real data."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tinsmith
from tinsmith import Heightfield, TerrainMesh
from tinsmith.metrics import aspect_ratios, mesh_metrics, rasterize, triangle_angles, triangle_quality, vertical_error


def _corner_mesh(hf, z_of):
    """Two triangles over the corner cell centres of hf, heights from z_of(x, y)."""
    h, w = hf.shape
    r = np.array([0, 0, h - 1, h - 1])
    c = np.array([0, w - 1, w - 1, 0])
    x, y = hf.pixel_to_world(r, c)
    v = np.column_stack([x, y, z_of(x, y)])
    return TerrainMesh(v, [[0, 2, 1], [0, 3, 2]])


def test_offset_plane_gives_constant_error():
    hf = Heightfield(np.zeros((5, 5)), cell_size=1.0)
    mesh = _corner_mesh(hf, lambda x, y: np.full_like(x, 2.0))
    assert mesh.check() == []
    e = vertical_error(mesh, hf)
    assert e == {
        "n_valid": 25, "n_covered": 25, "coverage": 1.0,
        "max": 2.0, "rmse": 2.0, "mean_abs": 2.0, "bias": 2.0, "p99": 2.0,
    }


def test_bump_in_the_middle_hand_computed():
    z = np.zeros((3, 3))
    z[1, 1] = 3.0  # the mesh over the corners is flat at 0, so e = -3 at the centre, 0 elsewhere
    hf = Heightfield(z, cell_size=1.0)
    e = vertical_error(_corner_mesh(hf, lambda x, y: np.zeros_like(x)), hf)
    assert e["max"] == 3.0
    assert e["bias"] == pytest.approx(-3.0 / 9)
    assert e["mean_abs"] == pytest.approx(3.0 / 9)
    assert e["rmse"] == pytest.approx(math.sqrt(9.0 / 9))
    assert e["p99"] == pytest.approx(np.percentile([0] * 8 + [3], 99))


def test_partial_coverage_and_nodata_cells():
    z = np.arange(16.0).reshape(4, 4)
    hf = Heightfield(z, cell_size=1.0, nodata=15.0)  # one nodata cell (row 3, col 3)
    h, w = hf.shape
    # one triangle: north-west corner, north-east corner, south-west corner -> covers r + c <= 3
    x, y = hf.pixel_to_world(np.array([0, 0, 3]), np.array([0, 3, 0]))
    zz = hf.z[[0, 0, 3], [0, 3, 0]]
    mesh = TerrainMesh(np.column_stack([x, y, zz]), [[0, 2, 1]])
    e = vertical_error(mesh, hf)
    assert e["n_valid"] == 15
    assert e["n_covered"] == 10  # cells with r + c <= 3
    assert e["coverage"] == pytest.approx(10 / 15)
    assert e["max"] == pytest.approx(0.0, abs=1e-12)  # z is linear in r and c


def test_rasterize_marks_uncovered_cells_nan():
    hf = Heightfield(np.zeros((4, 4)), cell_size=1.0)
    x, y = hf.pixel_to_world(np.array([0, 0, 3]), np.array([0, 3, 0]))
    mesh = TerrainMesh(np.column_stack([x, y, [1.0, 1.0, 1.0]]), [[0, 2, 1]])
    out = rasterize(mesh, hf)
    r, c = np.mgrid[0:4, 0:4]
    assert np.array_equal(np.isnan(out), r + c > 3)
    assert np.all(out[r + c <= 3] == 1.0)


def test_no_coverage_gives_nan_statistics():
    hf = Heightfield(np.zeros((3, 3)), cell_size=1.0)
    mesh = TerrainMesh([[100, 100, 0], [101, 100, 0], [100, 101, 0]], [[0, 1, 2]])
    e = vertical_error(mesh, hf)
    assert e["coverage"] == 0 and math.isnan(e["max"])


# -- triangle quality -----------------------------------------------------------------------
EQUILATERAL = TerrainMesh([[0, 0, 0], [2, 0, 0], [1, math.sqrt(3), 0]], [[0, 1, 2]])
RIGHT = TerrainMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])


def test_equilateral_and_right_isosceles_by_hand():
    np.testing.assert_allclose(triangle_angles(EQUILATERAL), [[60, 60, 60]])
    assert aspect_ratios(EQUILATERAL)[0] == pytest.approx(1.0)
    np.testing.assert_allclose(triangle_angles(RIGHT), [[90, 45, 45]])
    # longest sqrt(2), perimeter 2 + sqrt(2), area 1/2
    expected = math.sqrt(2) * (2 + math.sqrt(2)) / (4 * math.sqrt(3) * 0.5)
    assert aspect_ratios(RIGHT)[0] == pytest.approx(expected)
    q = triangle_quality(RIGHT)
    assert q["min_angle"]["min"] == pytest.approx(45)
    assert q["max_angle"]["max"] == pytest.approx(90)
    assert q["share_min_angle_below_20"] == 0.0


def test_3d_and_2d_quality_differ_on_a_steep_triangle():
    steep = TerrainMesh([[0, 0, 0], [1, 0, 0], [0, 1, 10]], [[0, 1, 2]])
    assert triangle_quality(steep, 2)["min_angle"]["min"] == pytest.approx(45)
    q3 = triangle_quality(steep, 3)
    # in 3-D the corner at (1, 0, 0) between edges (-1, 0, 0) and (-1, 1, 10)
    expected = math.degrees(math.acos(1 / math.sqrt(102)))
    assert q3["max_angle"]["max"] == pytest.approx(max(90.0, expected))
    assert q3["share_min_angle_below_20"] == 1.0


def test_degenerate_triangle_has_infinite_aspect_ratio():
    flat = TerrainMesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]])
    assert math.isinf(aspect_ratios(flat, 2)[0])
    np.testing.assert_allclose(sorted(triangle_angles(flat, 2)[0]), [0, 0, 180])


def test_quality_is_unaffected_by_large_world_offsets():
    shifted = TerrainMesh(EQUILATERAL.vertices + [5e6, 4e6, 1e3], EQUILATERAL.triangles)
    assert aspect_ratios(shifted)[0] == pytest.approx(1.0, abs=1e-9)


def test_mesh_metrics_collects_everything(plane_hf):
    mesh = tinsmith.grid(plane_hf)
    m = mesh_metrics(mesh, plane_hf)
    assert m["n_vertices"] == mesh.n_vertices and m["n_triangles"] == mesh.n_triangles
    assert set(m) == {"n_vertices", "n_triangles", "quality_3d", "quality_2d", "vertical_error"}
    assert m["quality_2d"]["min_angle"]["median"] == pytest.approx(45)


def test_full_resolution_mesh_of_the_sample_has_zero_error_and_full_coverage():
    hf = tinsmith.sample("st-helens")
    mesh = tinsmith.grid(hf)
    e = vertical_error(mesh, hf)
    assert e["max"] == 0.0
    assert e["coverage"] == 1.0 and e["n_valid"] == 148_885


def test_points_on_the_top_and_right_sides_of_the_mesh_are_covered():
    """Points on the far sides of the mesh's box are inside it, whatever the rounding of their bucket.

    Here (y - y_lo) / ((y_hi - y_lo) / 28) lands a rounding past 28 for the top row, at y of a survey's
    northing: those points were once reported outside the mesh.
    """
    y_lo, y_hi = 3798000.001, 3798577.555
    xs = np.linspace(0.0, 50.0, 15)
    ys = np.linspace(y_lo, y_hi, 29)
    ys[-1] = y_hi
    xx, yy = np.meshgrid(xs, ys)
    vertices = np.column_stack([xx.ravel(), yy.ravel(), 0.01 * xx.ravel()])
    w = len(xs)
    quads = [(r * w + c, r * w + c + 1, (r + 1) * w + c + 1, (r + 1) * w + c) for r in range(len(ys) - 1) for c in range(w - 1)]
    triangles = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    mesh = TerrainMesh(vertices, triangles)
    assert int(np.sqrt(mesh.n_triangles)) == 28  # the bucket grid's side
    error = tinsmith.vertical_error_at_points(mesh, vertices)
    assert error["n_covered"] == len(vertices) and error["max"] < 1e-9
