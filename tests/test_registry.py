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


def test_simplify_defaults_to_greedy(plane_hf):
    mesh = tinsmith.simplify(plane_hf)
    assert mesh.info["method"] == tinsmith.DEFAULT_METHOD == "greedy"


def test_unknown_method_lists_the_valid_ones(plane_hf):
    with pytest.raises(UnknownMethodError, match="unknown method 'nope'; choose one of: cvt, decimate, features, greedy, grid, quadtree, quality, reconstruct, remesh, subsample, urban, wavelet"):
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
    assert list(params) == ["data", "strength", "rounds", "mode", "flag", "max_error", "max_vertices",
                            "max_triangles", "progress"]
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
