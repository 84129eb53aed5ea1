"""Quadtree (RTIN): Martini's meshes exactly, the strict bound, crack-free on any grid, nodata."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import tinsmith
from tinsmith import Heightfield, InvalidInputError, QuadtreeHierarchy
from tinsmith.metrics import vertical_error

from .conftest import punch_holes


def _pixel_triangles(mesh, hf):
    """The triangles as sets of (col, row) corners."""
    r, c = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    px = np.rint(np.column_stack([c, r])).astype(int)
    return {tuple(sorted(map(tuple, px[t].tolist()))) for t in mesh.triangles}


def _t_junctions(mesh) -> int:
    """Vertices lying strictly inside an edge of the mesh (there are none in a conforming mesh)."""
    v = mesh.vertices[:, :2]
    tri = mesh.triangles
    edges = np.unique(np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1), axis=0)
    count = 0
    for a, b in edges:
        pa, pb = v[a], v[b]
        d = pb - pa
        rel = v - pa
        cross = rel[:, 0] * d[1] - rel[:, 1] * d[0]
        t = (rel @ d) / (d @ d)
        count += int(np.sum((np.abs(cross) < 1e-9 * (d @ d)) & (t > 1e-12) & (t < 1 - 1e-12)))
    return count


def test_non_strict_mode_gives_martinis_meshes_exactly():
    pymartini = pytest.importorskip("pymartini")
    z = tinsmith.sample("st-helens").z
    z = np.where(np.isnan(z), np.nanmin(z), z)
    z = np.pad(z, ((0, 513 - z.shape[0]), (0, 513 - z.shape[1])), mode="edge").astype(np.float32)
    hf = Heightfield(z, cell_size=1.0)
    tree = QuadtreeHierarchy(hf, strict=False)
    tile = pymartini.Martini(513).create_tile(z)
    for max_error in (1.0, 5.0, 20.0):
        v, tr = tile.get_mesh(max_error)
        v = v.reshape(-1, 2).astype(int)
        theirs = {tuple(sorted(map(tuple, v[t].tolist()))) for t in tr.reshape(-1, 3)}
        mesh = tree.mesh(max_error)
        assert _pixel_triangles(mesh, hf) == theirs
        # and Martini's estimate exceeds the bound, which the strict mode never does
        assert vertical_error(mesh, hf)["max"] > max_error
        strict = tinsmith.quadtree(hf, max_error=max_error)
        assert vertical_error(strict, hf)["max"] <= max_error


def test_grids_of_any_size_are_cut_back_to_the_data_not_refined_along_its_edge():
    r, c = np.mgrid[0:40, 0:70]
    hf = Heightfield(0.3 * c - 0.2 * r + 5.0, cell_size=1.0)  # a plane on a 40 x 70 grid, padded to 129 x 129
    mesh = tinsmith.quadtree(hf, max_error=1e-6)
    assert mesh.check() == [] and _t_junctions(mesh) == 0
    err = vertical_error(mesh, hf)
    assert err["coverage"] == 1.0 and err["max"] < 1e-6
    assert mesh.n_vertices < 20  # a few fans, not a full-resolution strip along the cut


def test_real_dem_with_nodata_and_any_size():
    hf = tinsmith.sample("st-helens")  # 468 x 327, nodata corners
    tree = QuadtreeHierarchy(hf)
    previous = None
    for max_error in (20.0, 5.0, 1.0):
        mesh = tree.mesh(max_error)
        assert mesh.check() == []
        err = vertical_error(mesh, hf)
        assert err["max"] <= max_error and err["coverage"] > 0.99
        covered = ~np.isnan(tinsmith.rasterize(mesh, hf))
        assert not (covered & hf.nodata_mask).any()
        if previous is not None:  # nested levels from one hierarchy
            assert _pixel_triangles(previous, hf) != _pixel_triangles(mesh, hf)
            assert mesh.n_triangles > previous.n_triangles
        previous = mesh


def test_count_rules_and_the_default_bound(cone_hf):
    # the padding of a 41 x 41 grid to 65 x 65 is cut back at full resolution: 220 vertices at least
    mesh = tinsmith.quadtree(cone_hf, max_vertices=400)
    assert mesh.n_vertices <= 400 and mesh.check() == []
    finer = tinsmith.quadtree(cone_hf, max_error=mesh.info["max_error_used"] * 0.999)
    assert finer.n_vertices > 400  # the smallest bound that fits
    assert tinsmith.quadtree(cone_hf, max_triangles=500).n_triangles <= 500
    lo, hi = cone_hf.z_range
    default = tinsmith.quadtree(cone_hf)
    assert vertical_error(default, cone_hf)["max"] <= (hi - lo) / 1000
    with pytest.raises(InvalidInputError, match="coarsest quadtree mesh"):
        tinsmith.quadtree(cone_hf, max_vertices=3)
    # a south-up grid mirrors the world: the triangles still turn counter-clockwise from +z
    south_up = Heightfield(cone_hf.z, transform=(2.0, 0.0, 0.0, 0.0, 2.0, 0.0), nodata_mask=cone_hf.nodata_mask)
    mesh = tinsmith.quadtree(south_up, max_error=0.5)
    assert mesh.check() == [] and (mesh.signed_areas_2d() > 0).all()
    assert vertical_error(mesh, south_up)["max"] <= 0.5


def test_diagonal_rule_squares_fans_and_the_finest_level_is_the_grid_mesh():
    rng = np.random.default_rng(3)
    hf = Heightfield(rng.normal(size=(17, 17)) * 10, cell_size=1.0)
    fine = tinsmith.quadtree(hf, max_error=0.0, diagonal="rule")
    grid = tinsmith.grid(hf)
    key = lambda m: sorted(tuple(sorted(map(tuple, np.round(m.vertices[t, :2], 9)))) for t in m.triangles)  # noqa: E731
    assert key(fine) == key(grid)  # every square split to single cells, cut as the grid mesh (formula 1)
    # a cone: coarse squares far out, fine ones at the tip, fans between them, never a T-junction
    r, c = np.mgrid[0:33, 0:33]
    cone = Heightfield(np.maximum(0.0, 20.0 - 2.0 * np.hypot(r - 8.0, c - 8.0)), cell_size=1.0)
    tree = QuadtreeHierarchy(cone, diagonal="rule")
    for e in (0.5, 2.0, 8.0):
        mesh = tree.mesh(e)
        assert mesh.check() == [] and _t_junctions(mesh) == 0
        assert vertical_error(mesh, cone)["max"] <= e
        assert len(mesh.boundary_edges()) < 4 * 32  # whole squares along the border where the cone is flat
    fan = tree.mesh(2.0)
    degrees = np.bincount(fan.triangles.ravel())
    assert degrees.max() >= 8  # a fan centre with edge middles
    with pytest.raises(tinsmith.InvalidOptionError, match="diagonal='rule' is always strict"):
        tinsmith.quadtree(cone, max_error=1.0, strict=False, diagonal="rule")
    with pytest.raises(tinsmith.InvalidInputError, match="diagonal must be one of"):
        tinsmith.quadtree(cone, max_error=1.0, diagonal="main")


@settings(max_examples=90, deadline=None)
@given(
    z=arrays(np.float64, st.tuples(st.integers(2, 23), st.integers(2, 23)), elements=st.floats(-60, 60)),
    holes=st.data(),
    max_error=st.sampled_from([0.0, 0.5, 5.0, 50.0]),
    mode=st.sampled_from([(True, "alternate"), (False, "alternate"), (True, "rule")]),
)
def test_property_crack_free_valid_and_within_the_bound(z, holes, max_error, mode):
    strict, diagonal = mode
    z, mask = punch_holes(z, holes)
    before = z.copy()
    try:
        hf = Heightfield(z, cell_size=2.0, nodata=float("nan"))
        mesh = tinsmith.quadtree(hf, max_error=max_error, strict=strict, diagonal=diagonal)
    except tinsmith.NoDataError:
        return
    np.testing.assert_array_equal(z, before)
    assert mesh.check() == []
    assert _t_junctions(mesh) == 0
    covered = ~np.isnan(tinsmith.rasterize(mesh, hf))
    assert not (covered & hf.nodata_mask).any()  # no triangle over a cell without data
    if strict:
        assert vertical_error(mesh, hf)["max"] <= max_error
    if not hf.nodata_mask.any():  # cut back to the data, not short of it: every cell covered
        assert covered.all()
