"""Feature points: importance measures on analytic surfaces, budgets, nodata, error rule."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import tinsmith
from tinsmith import Heightfield, InvalidInputError
from tinsmith.algorithms import importance
from tinsmith.metrics import non_delaunay_edges, vertical_error

from .conftest import punch_holes


def test_sobel_is_the_slope_and_curvature_the_hessian_on_analytic_surfaces():
    r, c = np.mgrid[0:20, 0:30]
    dx, dy = 2.0, 3.0
    x, y = c * dx, -r * dy  # north-up: rows go south
    plane = Heightfield(0.5 * x - 0.25 * y, cell_size=(dx, dy))
    sob = importance(plane, "sobel")
    np.testing.assert_allclose(sob[1:-1, 1:-1], np.hypot(0.5, 0.25), rtol=1e-12)
    np.testing.assert_allclose(importance(plane, "curvature")[1:-1, 1:-1], 0.0, atol=1e-12)
    bowl = Heightfield(x**2 + 3 * y**2, cell_size=(dx, dy))
    np.testing.assert_allclose(importance(bowl, "curvature")[1:-1, 1:-1], 6.0, rtol=1e-9)


def test_budget_is_an_upper_bound_and_the_corners_are_kept():
    r, c = np.mgrid[0:60, 0:80]
    hf = Heightfield(np.sin(r / 6.0) * 20 + np.cos(c / 9.0) * 15, cell_size=10.0)
    for n in (10, 100, 700):
        mesh = tinsmith.features(hf, max_vertices=n)
        assert mesh.n_vertices <= n and mesh.check() == []
        assert len(non_delaunay_edges(mesh)) == 0
        corners = {(0.0 + 5, 600.0 - 5), (795.0, 600.0 - 5), (5.0, 5.0), (795.0, 5.0)}
        assert corners <= {(round(x, 6), round(y, 6)) for x, y in mesh.vertices[:, :2]}
        err = vertical_error(mesh, hf)
        assert err["coverage"] == 1.0 and err["max"] == mesh.info["error"]["max"]
    # more points, smaller error: curvature picks the ridges of this surface
    coarse, fine = (vertical_error(tinsmith.features(hf, max_vertices=n, measure="curvature"), hf)["rmse"] for n in (100, 1000))
    assert fine < coarse


def test_error_and_triangle_rules():
    r, c = np.mgrid[0:50, 0:50]
    hf = Heightfield(np.hypot(r - 25.0, c - 25.0) * 2 + np.sin(c / 3.0) * 4, cell_size=1.0)
    mesh = tinsmith.features(hf, max_error=3.0)
    assert vertical_error(mesh, hf)["max"] <= 3.0
    assert tinsmith.features(hf, max_triangles=200).n_triangles <= 200
    with pytest.raises(InvalidInputError, match="leave no room"):
        tinsmith.features(hf, max_vertices=3)
    with pytest.raises(InvalidInputError, match="measure must be one of"):
        tinsmith.features(hf, measure="laplace")


def test_nodata_holes_are_cut_and_never_a_vertex(cone_hf):
    mesh = tinsmith.features(cone_hf, max_vertices=300)
    assert mesh.check() == [] and mesh.n_vertices <= 300
    rows, cols = cone_hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    assert cone_hf.valid[np.rint(rows).astype(int), np.rint(cols).astype(int)].all()
    covered = ~np.isnan(tinsmith.rasterize(mesh, cone_hf))
    assert not (covered & cone_hf.nodata_mask).any()
    assert vertical_error(mesh, cone_hf)["coverage"] == 1.0


@settings(max_examples=40, deadline=None)
@given(
    z=arrays(np.float64, st.tuples(st.integers(3, 20), st.integers(3, 20)), elements=st.floats(-50, 50)),
    holes=st.data(),
    budget=st.integers(4, 80),
    measure=st.sampled_from(["sobel", "curvature"]),
)
def test_property_valid_constrained_delaunay_within_budget(z, holes, budget, measure):
    z, mask = punch_holes(z, holes)
    try:
        hf = Heightfield(z, cell_size=1.0, nodata=float("nan"))
        tinsmith.grid(hf)
        mesh = tinsmith.features(hf, max_vertices=budget, measure=measure)
    except tinsmith.NoDataError:
        return
    except InvalidInputError as exc:  # the outline of the holes alone is over the budget
        assert "leave no room" in str(exc)
        return
    assert mesh.check() == [] and mesh.n_vertices <= budget
    assert len(non_delaunay_edges(mesh, constrained=mesh.constrained_edges)) == 0
    # the engine's error and the metric's agree to the last bits (hypothesis found a 1-ulp difference once)
    assert vertical_error(mesh, hf)["max"] == pytest.approx(mesh.info["error"]["max"], rel=1e-12, abs=1e-12)
