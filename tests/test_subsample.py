"""Regular subsampling: lattice, extent, stop rules, nodata, pyramid."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import tinsmith
from tinsmith import Heightfield, InvalidInputError, InvalidOptionError
from tinsmith.metrics import vertical_error

from .conftest import punch_holes


def _pixels(mesh, hf):
    rows, cols = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    return np.rint(rows).astype(int), np.rint(cols).astype(int)


def test_keeps_every_step_th_row_and_column_and_the_last(plane_hf):
    h, w = plane_hf.shape
    mesh = tinsmith.subsample(plane_hf, step=3)
    rows, cols = _pixels(mesh, plane_hf)
    expect_r = sorted(set(range(0, h, 3)) | {h - 1})
    expect_c = sorted(set(range(0, w, 3)) | {w - 1})
    assert sorted(set(rows)) == expect_r and sorted(set(cols)) == expect_c
    assert mesh.n_vertices == len(expect_r) * len(expect_c)
    assert mesh.n_triangles == 2 * (len(expect_r) - 1) * (len(expect_c) - 1)
    assert mesh.check() == [] and mesh.info["step"] == 3 and mesh.info["method"] == "subsample"
    # a plane is reproduced exactly, over the whole extent
    err = vertical_error(mesh, plane_hf)
    assert err["max"] < 1e-9 and err["coverage"] == 1.0


def test_step_one_is_the_full_resolution_grid(cone_hf):
    full, sub = tinsmith.grid(cone_hf), tinsmith.subsample(cone_hf, step=1)
    np.testing.assert_array_equal(full.vertices, sub.vertices)
    np.testing.assert_array_equal(full.triangles, sub.triangles)


def test_count_rules_take_the_finest_step_that_fits():
    r, c = np.mgrid[0:101, 0:77]
    hf = Heightfield(np.sin(r / 9.0) * 30 + c, cell_size=5.0)
    for kwargs, field in ((dict(max_vertices=500), "n_vertices"), (dict(max_triangles=400), "n_triangles")):
        mesh = tinsmith.subsample(hf, **kwargs)
        step, limit = mesh.info["step"], next(iter(kwargs.values()))
        assert getattr(mesh, field) <= limit
        assert getattr(tinsmith.subsample(hf, step=step - 1), field) > limit  # one finer would not fit


def test_error_rule_takes_the_coarsest_power_of_two_that_meets_it():
    r, c = np.mgrid[0:129, 0:129]
    hf = Heightfield(np.hypot(r - 64.0, c - 64.0) ** 1.5 / 10 + np.sin(c / 3.0), cell_size=1.0)
    for bound in (5.0, 1.0, 0.1):
        mesh = tinsmith.subsample(hf, max_error=bound)
        step = mesh.info["step"]
        assert vertical_error(mesh, hf)["max"] <= bound  # measured, not estimated
        assert mesh.info["error"]["max"] == vertical_error(mesh, hf)["max"]
        assert step & (step - 1) == 0  # a power of two
        if step < 128:
            assert vertical_error(tinsmith.subsample(hf, step=2 * step), hf)["max"] > bound


def test_step_and_stop_rules_are_alternatives_and_limits_are_checked(plane_hf):
    with pytest.raises(InvalidOptionError, match="either step or a stop rule"):
        tinsmith.subsample(plane_hf, step=2, max_vertices=100)
    with pytest.raises(InvalidInputError, match="step must be a whole number >= 1"):
        tinsmith.subsample(plane_hf, step=0)
    with pytest.raises(InvalidInputError, match="coarsest subsampling has 4 vertices"):
        tinsmith.subsample(plane_hf, max_vertices=3)


def test_pyramid_levels_get_coarser(cone_hf):
    levels = tinsmith.subsample_pyramid(cone_hf, levels=4)
    assert [m.info["step"] for m in levels] == [1, 2, 4, 8]
    counts = [m.n_vertices for m in levels]
    assert counts == sorted(counts, reverse=True) and len(set(counts)) == 4
    with pytest.raises(InvalidInputError, match="levels must be a whole number >= 1"):
        tinsmith.subsample_pyramid(cone_hf, levels=0)


def test_through_simplify_and_the_cli_option_names():
    record = tinsmith.get_method("subsample")
    assert [o.name for o in record.options] == ["step"] and record.stop_rules
    hf = tinsmith.sample("st-helens")
    mesh = tinsmith.simplify(hf, method="subsample", step=8)
    assert mesh.info["step"] == 8 and mesh.check() == []


@settings(max_examples=60, deadline=None)
@given(
    z=arrays(np.float64, st.tuples(st.integers(2, 30), st.integers(2, 30)), elements=st.floats(-100, 100)),
    holes=st.data(),
    step=st.integers(1, 12),
)
def test_property_valid_mesh_of_lattice_nodes_with_nodata(z, holes, step):
    z, mask = punch_holes(z, holes)
    try:
        hf = Heightfield(z, cell_size=2.0, nodata=float("nan"))
        mesh = tinsmith.subsample(hf, step=step)
    except tinsmith.NoDataError:
        return  # every cell nodata, or no coarse square with three valid corners
    assert mesh.check() == []
    rows, cols = _pixels(mesh, hf)
    h, w = z.shape
    assert np.all((rows % step == 0) | (rows == h - 1)) and np.all((cols % step == 0) | (cols == w - 1))
    assert not mask[rows, cols].any()  # no vertex on nodata
    np.testing.assert_array_equal(mesh.vertices[:, 2], hf.z[rows, cols])
