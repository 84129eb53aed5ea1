"""One contract for every method, and the public API as type checkers see it.

Every name of ``tinsmith.methods()`` is a function ``tinsmith.<name>(data, *, max_error=None,
max_vertices=None, max_triangles=None, <its options>, progress=None) -> TerrainMesh``, the one
the registry runs, reachable from ``tinsmith.simplify`` and ``tinsmith simplify --method``.
Each package that imports its names on first use lists them in an ``__init__.pyi`` stub, the
same names its ``__all__`` gives at run time.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import json
import pkgutil
from pathlib import Path

import numpy as np
import pytest

import tinsmith
from tinsmith import Heightfield, InvalidOptionError, PointCloud, TerrainMesh
from tinsmith.algorithms import registry
from tinsmith.algorithms.declaration import STOP_RULES
from tinsmith.cli.main import main

METHODS = [m.name for m in tinsmith.methods()]
PACKAGE = Path(tinsmith.__file__).parent


@pytest.fixture(scope="module")
def piece() -> Heightfield:
    """A 40 x 50 window of the embedded sample (30 m cells, UTM): every method runs on it in a second or two."""
    hf = tinsmith.sample("st-helens")
    a, b, c, d, e, f = hf.transform[:6]
    r0, c0 = 100, 200
    return Heightfield(np.array(hf.z[r0:r0 + 40, c0:c0 + 50]), transform=(a, b, c + a * c0 + b * r0, d, e, f + d * c0 + e * r0),
                       crs=hf.crs, nodata=hf.nodata)


def _cloud(hf: Heightfield) -> PointCloud:
    """The window's cell centres as a point cloud."""
    r, c = np.nonzero(hf.valid)
    x, y = hf.pixel_to_world(r, c)
    return PointCloud(np.column_stack([x, y, hf.z[r, c]]), crs=hf.crs)


def _input(record, hf):
    return _cloud(hf) if record.input == "points" else hf


def _budget(record) -> dict:
    """The stop rule a method needs to run (remesh places exactly max_vertices); else its defaults."""
    return {"max_vertices": 150} if record.exact_budget else {}


@pytest.mark.parametrize("name", METHODS)
def test_every_method_is_a_public_function_with_the_one_signature(name):
    record = tinsmith.get_method(name)
    function = getattr(tinsmith, name)
    assert function is record.function  # the registry entry is the public function
    assert name in tinsmith.__all__
    params = list(inspect.signature(function).parameters.values())
    assert params[0].name == "data"
    assert params[0].kind in (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    assert all(p.kind is inspect.Parameter.KEYWORD_ONLY for p in params[1:])
    assert [p.name for p in params[1:4]] == list(STOP_RULES) and params[-1].name == "progress"
    assert all(p.default is None for p in params[1:4] + params[-1:])
    assert [p.name for p in params[4:-1]] == [o.name for o in record.current_options()]
    assert inspect.signature(function).return_annotation is TerrainMesh
    assert "Parameters" in function.__doc__ and "progress" in function.__doc__


@pytest.mark.parametrize("name", METHODS)
def test_every_method_returns_a_terrain_mesh_and_refuses_the_stop_rules_it_cannot_honour(name, piece):
    record = tinsmith.get_method(name)
    data = _input(record, piece)
    seen = []
    mesh = getattr(tinsmith, name)(data, progress=seen.append, **_budget(record))
    assert isinstance(mesh, TerrainMesh) and mesh.n_triangles > 0
    assert mesh.info["method"] == name
    if record.exact_budget:  # max_vertices is the number of vertices placed (cvt, remesh)
        assert mesh.n_vertices == _budget(record)["max_vertices"]
    assert all(0.0 <= f <= 1.0 for f in seen)
    for rule in STOP_RULES:
        if rule not in record.stop_rules:
            with pytest.raises(InvalidOptionError, match=rule):
                getattr(tinsmith, name)(data, **{rule: 100})


def _write_inputs(tmp_path: Path, hf: Heightfield) -> tuple[Path, Path]:
    """The window as a GeoTIFF and as an x y z text cloud."""
    import rasterio
    from rasterio.transform import Affine

    tif = tmp_path / "piece.tif"
    with rasterio.open(tif, "w", driver="GTiff", width=hf.shape[1], height=hf.shape[0], count=1, dtype="float64",
                       crs=hf.crs, transform=Affine(*hf.transform[:6]), nodata=-9999.0) as ds:
        ds.write(np.where(hf.valid, hf.z, -9999.0), 1)
    xyz = tmp_path / "piece.xyz"
    np.savetxt(xyz, _cloud(hf).xyz, fmt="%.3f")
    return tif, xyz


@pytest.mark.parametrize("name", METHODS)
def test_simplify_reaches_every_method_from_the_api_and_the_command_line(name, piece, tmp_path, capsys, monkeypatch):
    record = tinsmith.get_method(name)
    calls = []
    function = record.function

    def counted(data, **kwargs):
        calls.append(name)
        return function(data, **kwargs)

    monkeypatch.setitem(registry._FUNCTIONS, name, counted)
    mesh = tinsmith.simplify(_input(record, piece), method=name, **_budget(record))
    assert calls == [name] and mesh.info["method"] == name
    tif, xyz = _write_inputs(tmp_path, piece)
    source = xyz if record.input == "points" else tif
    budget = ["--max-vertices", "150"] if record.exact_budget else []
    code = main(["simplify", str(source), "--method", name, *budget, "-o", str(tmp_path / "out.ply"), "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert json.loads(out)["method"] == name and calls == [name, name]


def test_former_names_still_work_with_a_warning_at_the_callers_line(piece):
    with pytest.warns(DeprecationWarning, match="n_vertices of remesh is deprecated .* use max_vertices") as caught:
        mesh = tinsmith.remesh(piece, n_vertices=120)
    assert caught[0].filename == __file__ and mesh.n_vertices == 120
    with pytest.warns(DeprecationWarning, match="tinsmith.urban is deprecated") as caught:
        model = tinsmith.urban(piece)
    assert caught[0].filename == __file__
    np.testing.assert_array_equal(model.mesh.triangles, tinsmith.blocks(piece).triangles)
    with pytest.warns(DeprecationWarning, match="method 'urban' is deprecated") as caught:
        mesh = tinsmith.simplify(piece, method="urban")
    assert caught[0].filename == __file__ and isinstance(mesh, TerrainMesh)


def test_what_is_not_a_method_says_so():
    """tin is a triangulation and city returns a richer model: neither is registered, both docstrings say so."""
    assert "tin" not in METHODS and "city" not in METHODS
    assert "not a registered method" in tinsmith.tin.__doc__
    assert "Not a registered method" in tinsmith.city.__doc__
    assert inspect.signature(tinsmith.city).return_annotation in ("CityModel", tinsmith.algorithms.CityModel)


# -- the stubs ---------------------------------------------------------------------------------
def _packages() -> list[str]:
    names = ["tinsmith"]
    for info in pkgutil.walk_packages([str(PACKAGE)], "tinsmith."):
        if info.ispkg:
            names.append(info.name)
    return names


def _stub(package: str) -> Path:
    return PACKAGE.joinpath(*package.split(".")[1:], "__init__.pyi")


def _stub_names(stub: Path) -> tuple[list[str], set[str]]:
    """(the stub's __all__, every name it imports or defines)."""
    tree = ast.parse(stub.read_text())
    listed, defined = None, set()
    for node in tree.body:
        if isinstance(node, ast.ImportFrom):
            assert node.level == 1, f"{stub}: lazy_loader takes only `from .module import name` lines"
            defined |= {a.asname or a.name for a in node.names}
        elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            defined.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            defined.add(node.target.id)
        elif isinstance(node, ast.Assign) and node.targets[0].id == "__all__":
            listed = [ast.literal_eval(e) for e in node.value.elts]
    assert listed is not None, f"{stub} has no __all__"
    return listed, defined


STUBBED = [p for p in _packages() if _stub(p).exists()]


def test_every_lazily_loaded_package_has_a_stub_and_no_hand_kept_table():
    assert {"tinsmith", "tinsmith.algorithms", "tinsmith.core", "tinsmith.io", "tinsmith.metrics",
            "tinsmith.tiles"} <= set(STUBBED)
    for package in _packages():
        init = PACKAGE.joinpath(*package.split(".")[1:], "__init__.py")
        tree = ast.parse(init.read_text())
        assigned = {t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets
                    if isinstance(t, ast.Name)}
        assert "_LAZY" not in assigned, f"{package}: list the names in __init__.pyi instead of a _LAZY table"
        lazy = "__getattr__" in init.read_text()
        assert not lazy or package in STUBBED, f"{package} loads names on first use but has no __init__.pyi"


@pytest.mark.parametrize("package", STUBBED)
def test_the_stub_and_the_runtime_agree(package):
    listed, defined = _stub_names(_stub(package))
    assert len(listed) == len(set(listed)), f"{package}: a name twice in __all__"
    assert set(listed) <= defined, f"{package}: __all__ names {sorted(set(listed) - defined)}, which the stub lacks"
    module = importlib.import_module(package)
    assert sorted(module.__all__) == sorted(listed)
    assert set(listed) <= set(dir(module))
    for name in defined:  # every name the stub promises exists (what a stub adds beyond __all__ as well)
        assert hasattr(module, name), f"{package}.{name}"
    assert not hasattr(module, "no_such_name")
