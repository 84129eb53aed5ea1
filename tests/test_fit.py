"""Fitted heights: least squares over the covered cells, for any mesh."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import Heightfield, InvalidInputError
from tinsmith.algorithms.cvt.fit import fit_heights


def test_a_plane_is_fitted_exactly_and_the_triangles_stay(plane_hf):
    mesh = tinsmith.greedy(plane_hf, max_vertices=6)
    noisy = tinsmith.TerrainMesh(mesh.vertices + [0.0, 0.0, 3.0], mesh.triangles)  # every height 3 too high
    fitted = fit_heights(noisy, plane_hf)
    np.testing.assert_allclose(fitted.vertices[:, 2], mesh.vertices[:, 2], atol=1e-6)
    np.testing.assert_array_equal(fitted.vertices[:, :2], mesh.vertices[:, :2])
    np.testing.assert_array_equal(fitted.triangles, mesh.triangles)
    assert fitted.info["fit"]["residual"] < 1e-9


def test_fitting_lowers_the_rms_error_of_greedy_meshes_on_real_data():
    hf = tinsmith.sample()
    for n in (1500, 6000):
        mesh = tinsmith.greedy(hf, max_vertices=n)
        before, after = tinsmith.vertical_error(mesh, hf), tinsmith.vertical_error(fit_heights(mesh, hf), hf)
        assert after["rmse"] < 0.85 * before["rmse"] and after["coverage"] == before["coverage"]


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.integers(6, 60))
def test_the_rms_error_never_rises(seed, n):
    rng = np.random.default_rng(seed)
    z = rng.normal(size=(20, 25)).cumsum(axis=0).cumsum(axis=1)
    hf = Heightfield(z, cell_size=2.0)
    mesh = tinsmith.features(hf, max_vertices=n)
    before, after = tinsmith.vertical_error(mesh, hf)["rmse"], tinsmith.vertical_error(fit_heights(mesh, hf), hf)["rmse"]
    assert after <= before * (1 + 1e-9) + 1e-9


def test_bad_inputs_are_refused(plane_hf):
    far = tinsmith.TerrainMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(InvalidInputError, match="covers no valid cell"):
        fit_heights(far, plane_hf)
    with pytest.raises(InvalidInputError, match="needs a TerrainMesh and a Heightfield"):
        fit_heights(plane_hf, plane_hf)


def test_the_simplify_command_fits_heights_on_request(tmp_path, capsys):
    import json

    from tinsmith.cli.main import main

    runs = {}
    for flag in ([], ["--fit-heights"]):
        args = ["simplify", "--sample", "st-helens", "-o", str(tmp_path / "m.ply"), "--max-vertices", "3000", "--json", *flag]
        assert main(args) == 0
        runs[bool(flag)] = json.loads(capsys.readouterr().out)["vertical_error"]
    assert runs[True]["rmse"] < runs[False]["rmse"] and abs(runs[True]["bias"]) < 1e-6


def test_the_fitted_copy_keeps_what_the_mesh_carries(plane_hf):
    mesh = tinsmith.cvt(plane_hf, max_vertices=12)
    mesh.triangle_attributes["region"] = np.arange(mesh.n_triangles)
    fitted = fit_heights(mesh, plane_hf)
    np.testing.assert_array_equal(fitted.vertex_attributes["site"], mesh.vertex_attributes["site"])
    np.testing.assert_array_equal(fitted.triangle_attributes["region"], np.arange(mesh.n_triangles))
    assert fitted.info["method"] == "cvt" and "fit" in fitted.info
