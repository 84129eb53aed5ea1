"""Mean curvature (Meyer et al. 2003) on analytic surfaces, and the cCVT density built on it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import Heightfield, InvalidInputError
from tinsmith.algorithms.cvt.curvature import curvature_density, mean_curvature


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


def _integrals(poly, rho, main=None):
    from tinsmith.kernels.cvt import polygon_integrals

    rho = np.asarray(rho, float)
    if main is None:
        main = np.ones((rho.shape[0] - 1, rho.shape[1] - 1), bool)
    mass, mx, my, mxx, myy = polygon_integrals(np.asarray(poly, float), rho, main)
    return mass, mx, my, mxx + myy


def test_density_integrals_over_polygons_are_exact():
    r, c = np.mgrid[0:20, 0:30].astype(float)
    ones = np.ones((20, 30))
    square = [[2.5, 3.25], [9.75, 3.25], [9.75, 8.5], [2.5, 8.5]]
    mass, mx, my, m2 = _integrals(square, ones)
    assert mass == pytest.approx(7.25 * 5.25) and mx / mass == pytest.approx(6.125) and my / mass == pytest.approx(5.875)
    x0, x1, y0, y1 = 2.5, 9.75, 3.25, 8.5
    assert m2 == pytest.approx((x1**3 - x0**3) / 3 * (y1 - y0) + (y1**3 - y0**3) / 3 * (x1 - x0))
    # either orientation, either diagonals: the same integrals
    rev = _integrals(square[::-1], ones, np.zeros((19, 29), bool))
    np.testing.assert_allclose(rev, (mass, mx, my, m2), rtol=1e-12)
    # a linear density (x = col, y = row) is linear on every triangle: exact against the closed form
    rho = 1.0 + 0.1 * c + 0.2 * r
    tri = [[1.2, 1.5], [11.7, 2.25], [4.4, 13.9]]
    x0, x1, y0, y1 = 2.5, 9.75, 3.25, 8.5
    mass, mx, my, m2 = _integrals(square, rho, diagonal_rule_like(rho))
    area = (x1 - x0) * (y1 - y0)
    ix = (x1**2 - x0**2) / 2 * (y1 - y0)
    iy = (y1**2 - y0**2) / 2 * (x1 - x0)
    ixx = (x1**3 - x0**3) / 3 * (y1 - y0)
    iyy = (y1**3 - y0**3) / 3 * (x1 - x0)
    ixy = (x1**2 - x0**2) / 2 * (y1**2 - y0**2) / 2
    assert mass == pytest.approx(area + 0.1 * ix + 0.2 * iy)
    assert mx == pytest.approx(ix + 0.1 * ixx + 0.2 * ixy)
    assert my == pytest.approx(iy + 0.1 * ixy + 0.2 * iyy)
    ixxx = (x1**4 - x0**4) / 4 * (y1 - y0)
    iyyy = (y1**4 - y0**4) / 4 * (x1 - x0)
    ixxy = (x1**3 - x0**3) / 3 * (y1**2 - y0**2) / 2
    ixyy = (x1**2 - x0**2) / 2 * (y1**3 - y0**3) / 3
    assert m2 == pytest.approx(ixx + iyy + 0.1 * (ixxx + ixyy) + 0.2 * (ixxy + iyyy))
    # a triangle: mass of a linear density = area times its value at the centroid
    m, _, _, _ = _integrals(tri, rho)
    p = np.asarray(tri)
    tri_area = 0.5 * abs((p[1, 0] - p[0, 0]) * (p[2, 1] - p[0, 1]) - (p[2, 0] - p[0, 0]) * (p[1, 1] - p[0, 1]))
    cx, cy = p.mean(axis=0)
    assert m == pytest.approx(tri_area * (1.0 + 0.1 * cx + 0.2 * cy))


def diagonal_rule_like(rho):
    from tinsmith.triangulation.grid import diagonal_rule

    return diagonal_rule(rho)


def test_density_integrals_stop_at_the_data_and_at_nodata():
    ones = np.ones((10, 10))
    # a polygon reaching beyond the grid: only the part over the grid's triangles counts
    mass, _, _, _ = _integrals([[-5.0, -5.0], [4.0, -5.0], [4.0, 4.0], [-5.0, 4.0]], ones)
    assert mass == pytest.approx(16.0)
    holes = ones.copy()
    holes[5, 5] = np.nan  # the six triangles touching cell (5, 5) carry nothing
    full, _, _, _ = _integrals([[0.0, 0.0], [9.0, 0.0], [9.0, 9.0], [0.0, 9.0]], ones)
    cut, _, _, _ = _integrals([[0.0, 0.0], [9.0, 0.0], [9.0, 9.0], [0.0, 9.0]], holes)
    assert full == pytest.approx(81.0) and cut == pytest.approx(81.0 - 3.0)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.5, 18.5), min_size=6, max_size=6))
def test_density_integrals_match_a_quadrature_on_random_triangles(coords):
    # Dunavant's 7-point rule, exact to degree 5: rho (x^2 + y^2) with a linear rho is degree 3
    p = np.array(coords).reshape(3, 2)
    twice = (p[1, 0] - p[0, 0]) * (p[2, 1] - p[0, 1]) - (p[2, 0] - p[0, 0]) * (p[1, 1] - p[0, 1])
    if abs(twice) < 1e-3:
        return
    r, c = np.mgrid[0:20, 0:20].astype(float)
    rho = 2.0 + 0.3 * c - 0.05 * r  # linear: the grid's piecewise-linear density is this plane
    bary = [(1 / 3, 1 / 3, 1 / 3, 0.225)]
    for a, b, w in ((0.059715871789770, 0.470142064105115, 0.132394152788506),
                    (0.797426985353087, 0.101286507323456, 0.125939180544827)):
        bary += [(a, b, b, w), (b, a, b, w), (b, b, a, w)]
    area = abs(twice) / 2
    want = np.zeros(4)
    for l0, l1, l2, w in bary:
        x, y = l0 * p[0] + l1 * p[1] + l2 * p[2]
        f = 2.0 + 0.3 * x - 0.05 * y
        want += w * area * np.array([f, f * x, f * y, f * (x * x + y * y)])
    np.testing.assert_allclose(_integrals(p, rho), want, rtol=1e-9, atol=1e-9)


def test_dual_cells_partition_the_domain_and_lloyd_steps_lower_the_energy():
    from tinsmith.kernels.cvt import cell_integrals
    from tinsmith.triangulation.delaunay import delaunay
    from tinsmith.triangulation.grid import diagonal_rule

    r, c = np.mgrid[0:31, 0:41].astype(float)
    rho = 1.0 + 0.05 * c + 0.5 * np.exp(-((r - 15) ** 2 + (c - 20) ** 2) / 30.0)
    main = diagonal_rule(rho)
    whole = _integrals([[0, 0], [40, 0], [40, 30], [0, 30]], rho, main)
    rng = np.random.default_rng(1)
    border = [[0, 0], [40, 0], [40, 30], [0, 30], [20, 0], [40, 15], [20, 30], [0, 15]]
    pts = np.vstack([np.array(border, float), rng.uniform(1, 29, size=(40, 2)) * [40 / 30, 1]])
    energies = []
    for _ in range(8):
        cells = cell_integrals(pts[:, 0].copy(), pts[:, 1].copy(), delaunay(pts).triangles, rho, main)
        cells = np.column_stack([cells[:, :3], cells[:, 3] + cells[:, 4]])
        np.testing.assert_allclose(cells.sum(axis=0)[[0, 1, 2, 3]], whole, rtol=1e-10)  # the cells tile the rectangle
        energies.append(float((cells[:, 3] - 2 * (pts * cells[:, 1:3]).sum(axis=1) + (pts**2).sum(axis=1) * cells[:, 0]).sum()))
        pts[len(border):] = cells[len(border):, 1:3] / cells[len(border):, [0]]  # interior sites to their centroids
    # the dual cells only approximate the Voronoi cells: the energy falls fast, then settles (not strictly monotone)
    assert energies[0] > energies[1] > energies[2] > energies[3] and max(energies[3:]) < 0.7 * energies[0]
