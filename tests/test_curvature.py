"""Mean curvature (Meyer et al. 2003) on analytic surfaces, and the cCVT density built on it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import Heightfield, InvalidInputError
from tinsmith.algorithms.curvature import curvature_density, mean_curvature


def _grid(n=81, cell=1.0):
    r, c = np.mgrid[0:n, 0:n]
    return (c - n // 2) * cell, (r - n // 2) * cell


@pytest.mark.parametrize("radius", [60.0, 200.0])
def test_spheres_cylinders_planes_and_bowls_have_their_analytic_curvature(radius):
    x, y = _grid()
    sphere = mean_curvature(Heightfield(np.sqrt(radius**2 - x**2 - y**2), cell_size=1.0))
    np.testing.assert_allclose(sphere, 1.0 / radius, rtol=0.02)  # the border too: from its neighbours
    cylinder = mean_curvature(Heightfield(np.sqrt(radius**2 - x**2), cell_size=1.0))
    np.testing.assert_allclose(cylinder[2:-2, 2:-2], 1.0 / (2 * radius), rtol=0.02)
    bowl = mean_curvature(Heightfield(-np.sqrt(radius**2 - x**2 - y**2), cell_size=1.0))
    np.testing.assert_allclose(bowl, -1.0 / radius, rtol=0.02)  # pits are negative
    plane = mean_curvature(Heightfield(0.3 * x - 0.2 * y + 7.0, cell_size=1.0))
    assert np.abs(plane).max() < 1e-12


def test_a_saddle_has_zero_mean_curvature_at_its_centre_and_nodata_stays_nodata():
    x, y = _grid(41, 0.5)
    saddle = mean_curvature(Heightfield((x**2 - y**2) / 40.0, cell_size=0.5))
    assert abs(saddle[20, 20]) < 1e-9
    z = np.sqrt(100.0**2 - x**2 - y**2)
    z[10:15, 10:15] = np.nan
    h = mean_curvature(Heightfield(z, cell_size=0.5, nodata=float("nan")))
    assert np.isnan(h[10:15, 10:15]).all() and np.isfinite(h[~np.isnan(z)]).all()
    np.testing.assert_allclose(h[25:35, 25:35], 0.01, rtol=0.02)


def test_the_density_has_mean_one_a_floor_and_a_gamma():
    hf = tinsmith.sample()
    rho = curvature_density(hf)
    assert np.nanmean(rho) == pytest.approx(1.0) and np.isnan(rho[~hf.valid]).all()
    h = np.abs(mean_curvature(hf))
    floor = 0.1 * np.nanmean(h)
    expected = np.maximum(h, floor)
    np.testing.assert_allclose(rho, expected / np.nanmean(expected), rtol=1e-12)
    sharp = curvature_density(hf, gamma=2.0)
    assert np.nanmax(sharp) / np.nanmin(sharp) == pytest.approx((np.nanmax(rho) / np.nanmin(rho)) ** 2, rel=1e-9)
    assert np.nanstd(curvature_density(hf, gamma=0.0)) == 0.0  # gamma 0: uniform
    with pytest.raises(InvalidInputError, match="density_gamma"):
        curvature_density(hf, gamma=-1.0)
    with pytest.raises(InvalidInputError, match="floor"):
        curvature_density(hf, floor=0.0)


@settings(max_examples=40, deadline=None)
@given(st.floats(-1000, 1000), st.floats(0.5, 3.0))
def test_a_shift_in_height_changes_nothing_and_the_cell_size_scales_it(shift, cell):
    x, y = _grid(31, cell)
    base = np.sqrt(300.0**2 - x**2 - y**2)
    h0 = mean_curvature(Heightfield(base, cell_size=cell))
    h1 = mean_curvature(Heightfield(base + shift, cell_size=cell))
    np.testing.assert_allclose(h0, h1, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(h0, 1.0 / 300.0, rtol=0.02)  # whatever the sampling
