"""One stop rule, several methods, one table: the API and the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

import tinsmith
from tinsmith import Heightfield, InvalidOptionError, UnknownMethodError
from tinsmith.cli.main import main


def _hf():
    r, c = np.mgrid[0:70, 0:90]
    return Heightfield(np.sin(r / 7.0) * 25 + np.cos(c / 11.0) * 15 + r * 0.3, cell_size=2.0)


def test_every_method_gets_the_same_budget_and_the_same_metrics():
    hf = _hf()
    rows = tinsmith.compare_methods(hf, ["greedy", "subsample", "features", "grid"], max_vertices=400)
    assert [r["method"] for r in rows] == ["greedy", "subsample", "features", "grid"]
    for r in rows[:3]:
        assert r["n_vertices"] <= 400
    assert rows[3]["n_vertices"] == hf.n_valid and rows[3]["max_error"] == 0.0  # the reference, unbudgeted
    for r in rows:
        mesh = tinsmith.simplify(hf, method=r["method"], **({} if r["method"] == "grid" else {"max_vertices": 400}))
        assert r["max_error"] == tinsmith.vertical_error(mesh, hf)["max"]  # the same meshes, measured alike
        assert 0 < r["min_angle"] <= 60 and r["max_aspect_ratio"] >= 1 and r["time"] >= 0
    greedy = rows[0]
    assert greedy["max_error"] <= min(r["max_error"] for r in rows[1:3])  # refinement beats the baselines here


def test_the_error_rule_is_met_by_each_method():
    rows = tinsmith.compare_methods(_hf(), ["greedy", "subsample", "features"], max_error=2.0)
    assert all(r["max_error"] <= 2.0 for r in rows)


def test_bad_calls_fail_before_any_work():
    hf = _hf()
    with pytest.raises(InvalidOptionError, match="exactly one stop rule"):
        tinsmith.compare_methods(hf, ["greedy"], max_error=1.0, max_vertices=10)
    with pytest.raises(InvalidOptionError, match="exactly one stop rule"):
        tinsmith.compare_methods(hf, ["greedy"])
    with pytest.raises(UnknownMethodError, match="unknown method 'nope'"):
        tinsmith.compare_methods(hf, ["greedy", "nope"], max_vertices=100)


def test_cli_table_markdown_and_json(capsys):
    assert main(["compare", "--sample", "st-helens", "--methods", "greedy,subsample", "--max-vertices", "2000"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("sample st-helens: 148,885 valid cells, max vertices 2,000")
    assert out[1].split()[:3] == ["method", "vertices", "triangles"] and out[2].startswith("greedy")
    assert main(["compare", "--sample", "st-helens", "--methods", "subsample", "--max-error", "50", "--markdown"]) == 0
    md = capsys.readouterr().out.splitlines()
    assert md[0].startswith("| method | vertices |") and md[1].startswith("|---|") and md[2].startswith("| subsample |")
    assert main(["compare", "--sample", "st-helens", "--methods", "greedy", "--max-triangles", "1000", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["rule"] == {"max_triangles": 1000} and report["rows"][0]["n_triangles"] <= 1000


@pytest.mark.parametrize(
    "args, message",
    [
        (["--methods", "greedy,nope", "--max-error", "1"], "unknown method 'nope'"),
        (["--max-error", "1", "--max-vertices", "5"], "exactly one of --max-error"),
        (["--methods", "greedy"], "exactly one of --max-error"),
        (["--methods", "greedy", "--max-error", "-1"], "max_error must be a finite number >= 0"),
    ],
)
def test_cli_errors_are_one_line(capsys, args, message):
    assert main(["compare", "--sample", "st-helens", *args]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_a_method_that_cannot_meet_the_rule_gets_a_row_with_the_reason(capsys):
    hf = tinsmith.sample("st-helens")  # padded to 513, the quadtree keeps a full-resolution edge strip
    rows = tinsmith.compare_methods(hf, ["greedy", "quadtree"], max_vertices=1000)
    assert rows[0]["n_vertices"] <= 1000 and "error" not in rows[0]
    assert rows[1]["n_vertices"] is None and "coarsest quadtree mesh" in rows[1]["error"]
    assert main(["compare", "--sample", "st-helens", "--methods", "greedy,quadtree", "--max-vertices", "1000"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-1].startswith("quadtree: the coarsest quadtree mesh has")
