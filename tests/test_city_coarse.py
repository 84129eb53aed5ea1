"""Buildings on coarse cells (2 m): small houses among trees, where the 3 x 3 plane test has no window inside a roof."""

from __future__ import annotations

import numpy as np
import pytest

import tinsmith
from tinsmith import Heightfield
from tinsmith.algorithms.urban.buildings import coarse, ridge_roof, twist_fits

shapely = pytest.importorskip("shapely")
pytest.importorskip("shapely.affinity")


def small_suburb(cell: float, seed: int = 0):
    """A 100 m square at ``cell`` on rolling ground: four detached gabled houses (two of 40 m2 with their eaves
    2.5 m above the highest ground under them, two of 150 m2), turned 0, 35, 20 and 60 degrees; three bumpy tree
    crowns standing alone and one leaning on a 150 m2 house.  Returns (dsm, houses, crown discs)."""
    import shapely.affinity

    rng = np.random.default_rng(seed)
    size = 100.0
    n = int(size / cell)
    rows, cols = np.mgrid[0:n, 0:n]
    x, y = (cols + 0.5) * cell, size - (rows + 0.5) * cell
    ground = 20.0 + 0.04 * x + 1.5 * np.sin(x / 25.0) + np.cos(y / 30.0)
    z = ground.copy()
    pts = shapely.points(x.ravel(), y.ravel())
    houses = []
    for (cx, cy), area, angle, eave in (((22, 75), 40, 0.0, 2.5), ((75, 78), 40, 35.0, 2.5),
                                        ((25, 25), 150, 20.0, 3.5), ((72, 28), 150, 60.0, 4.0)):
        length = np.sqrt(area * 1.5)
        width = area / length
        box = shapely.box(-length / 2, -width / 2, length / 2, width / 2)
        poly = shapely.affinity.translate(shapely.affinity.rotate(box, angle, origin=(0, 0)), cx, cy)
        inside = shapely.contains(poly, pts).reshape(n, n)
        across = -(x - cx) * np.sin(np.radians(angle)) + (y - cy) * np.cos(np.radians(angle))
        z[inside] = (ground[inside].max() + eave + 0.6 * (width / 2 - np.abs(across)))[inside]
        houses.append(poly)
    crowns = []
    for cx, cy, r, tall in ((50, 50, 7.0, 12.0), (48, 85, 5.0, 9.0), (88, 52, 6.0, 14.0), (38, 17, 6.0, 11.0)):
        d = np.hypot(x - cx, y - cy)
        crown = ground + tall * np.sqrt(np.clip(1 - (d / r) ** 2, 0, None)) + rng.normal(0, 0.5, d.shape)
        z = np.where(d < r, np.maximum(z, crown), z)
        crowns.append(shapely.Point(cx, cy).buffer(r))
    z += rng.normal(0, 0.03, z.shape)
    return Heightfield(z, cell_size=cell, origin=(0.0, size), crs="EPSG:32610"), houses, crowns


def test_coarse_cells_are_those_three_of_which_are_wider_than_the_narrowest_house():
    z = np.zeros((8, 8))
    assert not coarse(Heightfield(z, cell_size=0.5, crs="EPSG:32610"))
    assert not coarse(Heightfield(z, cell_size=1.0, crs="EPSG:32610"))
    assert coarse(Heightfield(z, cell_size=2.0, crs="EPSG:32610"))
    assert not coarse(Heightfield(z, cell_size=3.0, crs="EPSG:2992"))  # 3 ft in an Oregon CRS in feet


def test_twist_fits_is_zero_on_a_plane_and_measures_noise_like_the_three_by_three_window():
    r, c = np.mgrid[0:60, 0:60]
    plane = Heightfield(5.0 + 0.3 * c - 0.7 * r, cell_size=2.0, crs="EPSG:32610")
    inner = twist_fits(plane)[1:-1, 1:-1]
    assert np.allclose(inner, 0.0, atol=1e-9) and np.isinf(twist_fits(plane)[0]).all()
    noise = Heightfield(np.random.default_rng(1).normal(0, 0.3, (200, 200)), cell_size=2.0, crs="EPSG:32610")
    rms2 = np.sqrt(np.mean(twist_fits(noise)[1:-1, 1:-1] ** 2))
    assert rms2 == pytest.approx(0.3 * np.sqrt(6 / 9), rel=0.05)  # what a 3 x 3 window gives for the same noise


def test_ridge_roof_fits_a_turned_gable_and_not_a_bumpy_crown():
    rng = np.random.default_rng(2)
    r, c = np.mgrid[0:5, 0:8]
    r, c = r.ravel(), c.ravel()
    v = -c * np.sin(0.4) + r * np.cos(0.4)
    gable = 30.0 + 1.2 * (2.0 - np.abs(v - v.mean())) + rng.normal(0, 0.03, len(v))
    inliers, model = ridge_roof(r, c, gable, 0.2)
    assert inliers.mean() >= 0.9 and model is not None
    d = np.hypot(r - 2.0, (c - 3.5) * 0.8)
    dome = 30.0 + 8.0 * np.sqrt(np.clip(1 - (d / 4.0) ** 2, 0, None)) + rng.normal(0, 0.5, len(d))
    assert ridge_roof(r, c, dome, 0.2)[0].mean() < 0.75
    assert ridge_roof(r[:7], c[:7], gable[:7], 0.2)[1] is None  # fewer cells than twice its parameters


@pytest.mark.parametrize("cell", [2.0, 0.5])
def test_small_houses_among_trees_are_found_at_coarse_cells_and_the_trees_are_not(cell):
    dsm, houses, crowns = small_suburb(cell)
    found = [b.outline for b in tinsmith.city(dsm).buildings]
    for house in houses:  # the 40 m2 and the 150 m2 houses, each one building
        best = max(found, key=lambda f: f.intersection(house).area)
        assert best.intersection(house).area / best.union(house).area >= 0.5, (house.area, cell)
    assert len(found) == len(houses)
    trees = shapely.union_all(crowns).difference(shapely.union_all(houses))
    assert sum(f.intersection(trees).area for f in found) <= 0.1 * sum(h.area for h in houses)
