"""The full-resolution grid method: analytic surfaces, nodata, diagonal rule, properties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import tinsmith
from tinsmith import Heightfield, NoDataError
from tinsmith.metrics import vertical_error


def test_plane_gives_two_triangles_per_cell_and_zero_error(plane_hf):
    mesh = tinsmith.grid(plane_hf)
    rows, cols = plane_hf.shape
    assert mesh.n_vertices == rows * cols
    assert mesh.n_triangles == 2 * (rows - 1) * (cols - 1)
    assert mesh.check() == []
    assert mesh.crs == "EPSG:32610"
    err = vertical_error(mesh, plane_hf)
    assert err["max"] == 0.0 and err["coverage"] == 1.0
    assert mesh.info["method"] == "grid" and "method" in mesh.info["timings"]


def test_nodata_cells_are_holes(cone_hf):
    mesh = tinsmith.grid(cone_hf)
    assert mesh.check() == []
    assert mesh.n_vertices == cone_hf.n_valid
    # no vertex lies in the nodata block (rows 0-4, cols 0-4 -> x < 5, y > 36)
    x, y = mesh.vertices[:, 0], mesh.vertices[:, 1]
    assert not np.any((x < 5) & (y > 36))
    err = vertical_error(mesh, cone_hf)
    assert err["max"] == 0.0 and err["coverage"] == 1.0


def test_diagonal_follows_seed_004_rule():
    # mean 2.5: the corners (r, c) and (r+1, c+1) deviate by 2.5 and 7.5, the others by 2.5
    # -> 7.5 < 2.5 is false, so the square is cut along (r, c+1)-(r+1, c)
    hf = Heightfield([[0.0, 0.0], [0.0, 10.0]], cell_size=1)
    diag = _shared_edge(tinsmith.grid(hf))
    assert diag == {1, 2}
    hf = Heightfield([[10.0, 0.0], [0.0, 0.0]], cell_size=1)  # same, mirrored
    assert _shared_edge(tinsmith.grid(hf)) == {1, 2}
    hf = Heightfield([[0.0, 10.0], [0.0, 0.0]], cell_size=1)  # now the other pair deviates more
    assert _shared_edge(tinsmith.grid(hf)) == {0, 3}


def _shared_edge(mesh):
    edges, counts = mesh.edges()
    (a, b), = edges[counts == 2]
    return {int(a), int(b)}


def test_square_with_one_nodata_corner_keeps_one_triangle():
    hf = Heightfield([[1.0, 2.0], [3.0, -1.0]], cell_size=1, nodata=-1)
    mesh = tinsmith.grid(hf)
    assert mesh.n_triangles == 1 and mesh.n_vertices == 3
    assert mesh.check() == []


def test_no_triangle_possible_is_an_error():
    z = np.array([[1.0, -1, 1], [-1, 1, -1], [1, -1, 1]])  # checkerboard: two valid corners per square
    with pytest.raises(NoDataError, match="three valid corners"):
        tinsmith.grid(Heightfield(z, cell_size=1, nodata=-1))


@pytest.mark.parametrize(
    "transform",
    [(2.0, 0, 0, 0, -2.0, 10), (2.0, 0, 0, 0, 2.0, 0), (-2.0, 0, 10, 0, -2.0, 10), (0.6, 0.8, 0, 0.8, -0.6, 0)],
)
def test_triangles_are_counter_clockwise_for_any_transform(transform):
    hf = Heightfield(np.random.default_rng(0).normal(size=(6, 5)), transform=transform)
    mesh = tinsmith.grid(hf)
    assert mesh.check() == []
    assert vertical_error(mesh, hf)["max"] < 1e-12


@settings(max_examples=60, deadline=None)
@given(
    z=arrays(np.float64, st.tuples(st.integers(2, 9), st.integers(2, 9)), elements=st.floats(-1e4, 1e4)),
    holes=st.data(),
)
def test_property_any_grid_with_holes_gives_a_valid_exact_mesh(z, holes):
    mask = holes.draw(arrays(bool, z.shape))
    if mask.all():
        mask[0, 0] = False
    z_in = z.copy()
    z_in[mask] = np.nan
    before = z_in.copy()
    try:
        hf = Heightfield(z_in, cell_size=1.5, nodata=float("nan"))
        mesh = tinsmith.grid(hf)
    except NoDataError:
        return  # no square has three valid corners
    np.testing.assert_array_equal(z_in, before)  # input not modified
    assert mesh.check() == []
    err = vertical_error(mesh, hf)
    assert err["max"] <= 1e-9 * max(1.0, np.nanmax(np.abs(z_in)))
    # every vertex is a valid cell, every valid cell that is a triangle corner is covered
    r, c = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    assert hf.valid[np.rint(r).astype(int), np.rint(c).astype(int)].all()
