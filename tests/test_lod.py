"""Levels of detail in one call: shared work, the same meshes as single runs, the lod command."""

from __future__ import annotations

import json

import numpy as np
import pytest

import tinsmith
from tinsmith import Heightfield, InvalidOptionError
from tinsmith.algorithms.lod import levels_of_detail
from tinsmith.cli.main import main


def _hf():
    r, c = np.mgrid[0:65, 0:65]
    return Heightfield(np.sin(r / 6.0) * 20 + np.cos(c / 8.0) * 12 + 0.2 * r, cell_size=3.0)


@pytest.mark.parametrize("method", ["greedy", "quadtree", "subsample", "features", "decimate"])
def test_levels_equal_single_runs(method):
    hf = _hf()
    levels = levels_of_detail(hf, method, max_errors=[1.0, 8.0, 3.0])
    for mesh, bound in zip(levels, [1.0, 8.0, 3.0], strict=True):
        single = tinsmith.simplify(hf, method=method, max_error=bound)
        np.testing.assert_array_equal(mesh.vertices, single.vertices)
        np.testing.assert_array_equal(mesh.triangles, single.triangles)
        assert mesh.info["rule"] == {"max_error": bound}
    budgets = levels_of_detail(hf, method, max_vertices=[300, 100])
    assert [m.info["level"] for m in budgets] == [0, 1]
    assert budgets[0].n_vertices <= 300 and budgets[1].n_vertices <= 100
    single = tinsmith.simplify(hf, method=method, max_vertices=100)
    np.testing.assert_array_equal(budgets[1].triangles, single.triangles)


def test_bad_levels_fail_before_any_work():
    hf = _hf()
    with pytest.raises(InvalidOptionError, match="not both or neither"):
        levels_of_detail(hf, "greedy", max_errors=[1.0], max_vertices=[10])
    with pytest.raises(InvalidOptionError, match="no stop rules"):
        levels_of_detail(hf, "grid", max_errors=[1.0])
    with pytest.raises(tinsmith.InvalidInputError, match="max_error must be"):
        levels_of_detail(hf, "greedy", max_errors=[1.0, -2.0])
    with pytest.raises(InvalidOptionError, match="has no option 'step'"):
        levels_of_detail(hf, "greedy", max_errors=[1.0], step=2)


def test_lod_command_writes_levels_and_index(tmp_path, capsys):
    out = tmp_path / "levels"
    assert main(["lod", "--sample", "st-helens", "-o", out, "--levels", "20,5", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    index = json.loads((out / "index.json").read_text())
    assert index["levels"] == report["levels"]
    assert [row["max_error"] for row in index["levels"]] == [20.0, 5.0]
    for row in index["levels"]:
        mesh = tinsmith.read_mesh(out / row["file"])
        assert mesh.n_triangles == row["n_triangles"]
        assert row["vertical_error"]["max"] <= row["max_error"]
    assert index["levels"][0]["n_vertices"] < index["levels"][1]["n_vertices"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--levels", "2,x"], "--levels takes numbers"),
        (["--levels", "2", "--vertices", "9"], "--levels (error bounds) or --vertices"),
        (["--levels", "2", "--format", "nope"], "unsupported output suffix"),
        (["--levels", "2", "--method", "grid"], "takes no stop rules"),
    ],
)
def test_lod_errors_are_one_line_and_write_nothing(tmp_path, capsys, args, message):
    out = tmp_path / "levels"
    assert main(["lod", "--sample", "st-helens", "-o", out, *args]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not out.exists()


def test_quadtree_rule_levels_come_from_one_hierarchy():
    hf = _hf()
    levels = levels_of_detail(hf, "quadtree", max_errors=[4.0, 1.0], diagonal="rule")
    for mesh, bound in zip(levels, [4.0, 1.0], strict=True):
        single = tinsmith.quadtree(hf, max_error=bound, diagonal="rule")
        np.testing.assert_array_equal(mesh.triangles, single.triangles)
        assert tinsmith.vertical_error(mesh, hf)["max"] <= bound
