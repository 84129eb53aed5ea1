"""The method registry and the simplify dispatcher."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

import tinsmith
from tinsmith import InvalidInputError, InvalidOptionError, TerrainMesh, UnknownMethodError
from tinsmith.algorithms import registry
from tinsmith.algorithms.registry import Option, register
from tinsmith.triangulation.grid import grid_mesh


@pytest.fixture
def toy_method():
    """A throwaway method with one option of each kind, removed after the test."""
    calls = []

    @register(
        "toy",
        description="test method",
        options=[
            Option("strength", float, 1.0, "how strong (z units)", minimum=0.0, exclusive_min=True),
            Option("rounds", int, 2, "how many rounds", minimum=1, maximum=5),
            Option("mode", str, "fast", "how", choices=("fast", "slow")),
            Option("flag", bool, False, "a switch"),
        ],
    )
    def toy(hf, *, strength, rounds, mode, flag, stop, progress):
        """A toy that returns the grid mesh."""
        calls.append(dict(strength=strength, rounds=rounds, mode=mode, flag=flag, stop=stop))
        if progress:
            progress(1.0)
        return grid_mesh(hf)

    yield toy, calls
    registry._REGISTRY.pop("toy")
    registry._FUNCTIONS.pop("toy")


def test_simplify_defaults_to_greedy(plane_hf):
    mesh = tinsmith.simplify(plane_hf)
    assert mesh.info["method"] == tinsmith.DEFAULT_METHOD == "greedy"


def test_unknown_method_lists_the_valid_ones(plane_hf):
    with pytest.raises(UnknownMethodError, match="unknown method 'nope'; choose one of: blocks, cvt, decimate, "
                                                 "features, flood, greedy, grid, quadtree, quality, reconstruct, remesh, "
                                                 "subsample, wavelet"):
        tinsmith.simplify(plane_hf, method="nope")


def test_unknown_option_lists_the_valid_ones(plane_hf, toy_method):
    with pytest.raises(InvalidOptionError, match="'grid' has no option 'bogus'; its options are: none"):
        tinsmith.simplify(plane_hf, method="grid", bogus=1)
    with pytest.raises(InvalidOptionError, match="its options are: strength, rounds, mode, flag, max_error"):
        tinsmith.simplify(plane_hf, method="toy", bogus=1)


def test_stop_rules_are_validated_even_for_methods_without_them(plane_hf):
    with pytest.raises(InvalidInputError, match="max_error must be a finite number >= 0, got -1.0"):
        tinsmith.simplify(plane_hf, method="grid", max_error=-1)
    with pytest.raises(InvalidOptionError, match="'grid' takes no stop rules"):
        tinsmith.simplify(plane_hf, method="grid", max_vertices=10)
    assert tinsmith.simplify(plane_hf, method="grid", max_error=None).n_triangles > 0


def test_options_are_validated_defaulted_and_recorded(plane_hf, toy_method):
    toy, calls = toy_method
    seen = []
    mesh = tinsmith.simplify(plane_hf, method="toy", rounds=3, max_error=0.5, progress=seen.append)
    assert calls[-1]["strength"] == 1.0 and calls[-1]["rounds"] == 3 and calls[-1]["mode"] == "fast"
    assert calls[-1]["stop"].max_error == 0.5
    assert seen == [1.0]
    assert mesh.info["method"] == "toy"
    assert mesh.info["options"] == {
        "strength": 1.0, "rounds": 3, "mode": "fast", "flag": False,
        "max_error": 0.5, "max_vertices": None, "max_triangles": None,
    }
    # the direct call validates the same way
    for bad, message in [
        (dict(strength=0), "strength must be a finite number > 0"),
        (dict(rounds=9), "rounds must be a whole number >= 1 and <= 5"),
        (dict(mode="medium"), "mode must be one of 'fast', 'slow'"),
        (dict(flag="yes"), "flag must be True or False"),
        (dict(max_vertices=1), "max_vertices must be a whole number >= 3"),
    ]:
        with pytest.raises(InvalidInputError, match=message):
            toy(plane_hf, **bad)


def test_public_function_signature_and_docs_come_from_the_record(toy_method):
    toy, _ = toy_method
    params = inspect.signature(toy).parameters
    assert list(params) == ["data", "max_error", "max_vertices", "max_triangles", "strength", "rounds", "mode",
                            "flag", "progress"]
    assert params["rounds"].default == 2
    assert "how many rounds; default 2" in toy.__doc__
    assert "A toy that returns the grid mesh." in toy.__doc__
    assert [m.name for m in tinsmith.methods()][-1] == "toy"


def test_wrong_input_type_is_reported():
    with pytest.raises(InvalidInputError, match="'grid' takes a Heightfield, got ndarray"):
        tinsmith.grid(np.zeros((3, 3)))


def test_registering_twice_or_with_a_conflicting_option_type_fails(toy_method):
    with pytest.raises(ValueError, match="registered twice"):
        register("toy", description="again")(lambda hf, **kw: None)
    with pytest.raises(ValueError, match="already uses it as float"):
        register("toy2", description="x", options=[Option("strength", int, 1, "x")])(lambda hf, **kw: None)
    assert "toy2" not in registry._REGISTRY


def test_methods_return_terrain_meshes(plane_hf):
    cloud = tinsmith.PointCloud(np.column_stack([np.random.default_rng(0).random((400, 2)) * 30,
                                                 np.zeros(400)]))
    for m in tinsmith.methods():
        required = {"max_vertices": 60} if m.exact_budget else {}  # the budget of a method that places it
        data = cloud if m.input == "points" else plane_hf
        assert isinstance(m.function(data, **required), TerrainMesh)


def test_a_stop_rule_the_method_cannot_honour_is_refused_by_name(plane_hf):
    params = inspect.signature(tinsmith.cvt).parameters
    assert {"max_error", "max_vertices", "max_triangles"} <= set(params)  # every method's signature has all three
    with pytest.raises(InvalidOptionError, match="'cvt' takes max_vertices .*, not max_error"):
        tinsmith.cvt(plane_hf, max_error=1.0)
    with pytest.raises(InvalidOptionError, match="'reconstruct' takes no stop rules, got max_triangles"):
        tinsmith.reconstruct(np.random.default_rng(0).uniform(size=(20, 3)), max_triangles=10)
    assert "Not honoured by this method" in tinsmith.cvt.__doc__


@pytest.fixture
def renamed_method():
    """A method with a deprecated option name, a legacy keyword and a deprecated twin, removed after the test."""
    record = registry.declare(registry.Declaration(
        "renamed", module=__name__, description="test method", stop_rules=("max_vertices",),
        options=[Option("count", int, None, "how many", minimum=3, replaced_by="max_vertices")],
        legacy={"extra": "ask for the extra elsewhere"}))

    @register("renamed")
    def renamed(hf, *, stop, progress, extra=False):
        mesh = grid_mesh(hf)
        return (mesh, "extra") if extra else mesh

    yield renamed, record
    registry._REGISTRY.pop("renamed")
    registry._FUNCTIONS.pop("renamed")


def test_a_deprecated_option_name_warns_at_the_caller_and_passes_its_value_on(plane_hf, renamed_method):
    renamed, record = renamed_method
    assert "count" not in inspect.signature(renamed).parameters  # the signature has the current names only
    assert record.accepted() == ["max_vertices"]
    with pytest.warns(DeprecationWarning, match="count of renamed is deprecated and will be removed: use max_vertices") as w:
        mesh = renamed(plane_hf, count=10)
    assert w[0].filename == __file__
    assert mesh.info["options"]["max_vertices"] == 10
    with pytest.warns(DeprecationWarning) as w:
        tinsmith.simplify(plane_hf, method="renamed", count=10)
    assert w[0].filename == __file__
    with pytest.warns(DeprecationWarning), pytest.raises(InvalidInputError, match="count must be a whole number >= 3"):
        renamed(plane_hf, count=1)  # checked under the name the caller used
    with pytest.warns(DeprecationWarning), pytest.raises(InvalidOptionError, match="give max_vertices alone"):
        renamed(plane_hf, count=10, max_vertices=12)
    with pytest.warns(DeprecationWarning, match="extra of renamed is deprecated and will be removed: ask for the extra"):
        mesh, extra = renamed(plane_hf, extra=True)
    assert extra == "extra" and mesh.info["method"] == "renamed"


def test_a_deprecated_method_runs_by_name_but_is_not_listed(plane_hf):
    assert "urban" not in [m.name for m in tinsmith.methods()]
    assert "urban" in [m.name for m in tinsmith.methods(deprecated=True)]
    with pytest.warns(DeprecationWarning, match="method 'urban' is deprecated .* tinsmith.city") as w:
        record = tinsmith.get_method("urban")
    assert w[0].filename == __file__ and record.name == "urban"


def test_an_option_of_one_input_kind_is_refused_with_the_other(plane_hf):
    greedy = tinsmith.get_method("greedy")
    assert greedy.option("workers").input is None and greedy.option("max_edge").input == "points"
    assert greedy.option("holes").describe().startswith("point clouds: ")
    cloud = tinsmith.PointCloud(np.random.default_rng(0).uniform(0, 10, size=(50, 3)))
    assert tinsmith.greedy(cloud, workers=2, max_error=0.5).n_triangles  # workers: both kinds
    with pytest.raises(InvalidOptionError, match="option 'duplicates' of method 'greedy' applies to a PointCloud only"):
        tinsmith.simplify(plane_hf, duplicates="mean")
    assert tinsmith.greedy(plane_hf, duplicates="lowest", max_edge="auto").n_triangles  # the defaults pass


def test_point_methods_take_xyz_arrays(plane_hf):
    xyz = np.random.default_rng(0).uniform(0, 10, size=(60, 3))
    assert tinsmith.reconstruct(xyz).n_triangles > 0
    with pytest.raises(InvalidInputError, match=r"xyz must have shape \(N, 3\)"):
        tinsmith.reconstruct(np.zeros((5, 2)))
