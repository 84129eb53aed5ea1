"""The point-cloud TIN's kernels compiled ahead of time: built, current, used without numba, the same results.

What they are for (a fresh process's first TIN without numba's half-second
start) is measured in benchmarks/RESULTS_points.md, not here.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tinsmith.kernels import ahead, portable

ROOT = Path(__file__).resolve().parents[1]

#: a cloud with repeated points (merged) and a gap (cut by max_edge), large enough for strips on two workers, and
#: a small one triangulated in one piece (whose duplicates map is int64 where the strips' is int32)
CLOUD = """
import hashlib, sys
import numpy as np
import tinsmith
rng = np.random.default_rng(5)
xy = rng.uniform(0, 400, (60_000, 2))
xy = xy[(np.abs(xy[:, 0] - 200) > 30) | (xy[:, 1] < 300)]
xyz = np.column_stack([xy, np.sin(xy[:, 0] / 40) * 5 + rng.normal(0, 0.1, len(xy))])
xyz = np.concatenate([xyz, xyz[:500] + [0, 0, 1]])
small = np.concatenate([xyz[:3000], xyz[:40] + [0, 0, 2]])
for cloud in (tinsmith.PointCloud(xyz), tinsmith.PointCloud(small)):
    for workers in (1, 2):
        mesh = tinsmith.tin(cloud, workers=workers, duplicates="mean")
        print(workers, mesh.n_triangles, hashlib.sha1(mesh.triangles.tobytes() + mesh.vertices.tobytes()).hexdigest())
from tinsmith.kernels import ahead
print("numba" in sys.modules, ahead.available())
"""


def _run(code: str, **env) -> list[str]:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=ROOT,
                          env={**os.environ, **env})
    assert done.returncode == 0, done.stderr
    return done.stdout.split("\n")


def _needs_extension():
    """Skips where the package build compiled no kernels (kernels=none); else the extension must be there."""
    manifest = portable.read_manifest()
    if manifest is None or not portable.matches(manifest):
        pytest.skip("the package was built without compiled kernels (kernels=none) or for another environment")
    if os.environ.get(ahead.DISABLE):
        pytest.skip(f"{ahead.DISABLE} is set")
    assert ahead.available(), ("the kernels compiled ahead of time are missing or stale (their sources changed): "
                               "pip install -e . again, or python -m tinsmith.kernels.ahead_build")


def test_tin_in_a_fresh_process_loads_no_numba_and_makes_the_jit_mesh():
    _needs_extension()
    *compiled, flags, _ = _run(CLOUD)
    assert flags == "False True"  # numba not loaded, the extension used
    *jitted, flags, _ = _run(CLOUD, **{ahead.DISABLE: "1"})
    assert flags == "True False"
    assert compiled == jitted
    assert compiled[0].split()[1:] == compiled[1].split()[1:]  # one and two workers: the same mesh
    assert compiled[2].split()[1:] == compiled[3].split()[1:]


def test_arguments_of_other_types_go_to_the_jit_kernel():
    _needs_extension()
    strips = ahead.load("tinsmith.kernels.strips")
    same = np.array([0, 0, 2, 2, 2, 5], np.int32)
    assert strips.merged_count(same) == 3  # compiled: int32, contiguous
    assert strips.merged_count(same.astype(np.int64)) == 3  # int64: the jit kernel
    assert strips.merged_count(np.repeat(same, 2)[::2]) == 3  # strided: the jit kernel
    tin = ahead.load("tinsmith.kernels.tin")
    assert tin.PERTURBED == 2 and tin.SEGMENT_CROSSES_CONSTRAINT == 1  # constants from the manifest
    assert callable(tin.insert_segment)  # not compiled ahead: the jit module's


def test_argument_checks_follow_the_compiled_types():
    array = ahead._check(["array", "int32", 1, True, True])
    readable = ahead._check(["array", "float64", 1, False, False])
    a = np.zeros(4, np.int32)
    assert array(a) and not array(a.astype(np.int64)) and not array(np.zeros((2, 2), np.int32))
    assert not array(np.zeros(8, np.int32)[::2]) and not array([0, 1])
    a.flags.writeable = False
    assert not array(a)  # the kernel writes into it
    assert readable(a.astype(float)) and readable(np.zeros(8)[::2])  # read-only and any strides: taken
    integer, real = ahead._check(["int"]), ahead._check(["float"])
    assert integer(3) and integer(np.int32(3)) and not integer(True) and not integer(3.0)
    assert real(0.5) and real(np.float64(0.5)) and not real(1) and not real(np.float32(0.5))
    pair = ahead._check(["tuple", [["int"], ["float"]]])
    assert pair((1, 2.0)) and not pair((1, 2)) and not pair([1, 2.0])


def test_an_extension_of_other_sources_is_not_loaded(tmp_path):
    _needs_extension()
    manifest = json.loads((ahead.HERE / f"{ahead.NAME}.json").read_text())
    shutil.copy(ahead.HERE / manifest["file"], tmp_path / manifest["file"])
    (tmp_path / f"{ahead.NAME}.json").write_text(json.dumps(manifest))
    module, _ = ahead.load_extension(tmp_path)
    assert module is not None
    (tmp_path / f"{ahead.NAME}.json").write_text(json.dumps({**manifest, "sources": "0" * 64}))
    assert ahead.load_extension(tmp_path) == (None, None)
    (tmp_path / f"{ahead.NAME}.json").write_text(json.dumps({**manifest, "environment": {"numpy": "1.0"}}))
    assert ahead.load_extension(tmp_path) == (None, None)
    (tmp_path / f"{ahead.NAME}.json").write_text("{")
    assert ahead.load_extension(tmp_path) == (None, None)


def test_every_entry_is_a_kernel_of_its_module_with_a_signature():
    import importlib

    from numba.core.dispatcher import Dispatcher

    for entry in ahead.ENTRIES:
        module, function = entry.split(":")
        assert isinstance(getattr(importlib.import_module(module), function), Dispatcher), entry
        for i, signature in enumerate(ahead.signatures(entry)):
            assert signature.count("(") == signature.count(")") and "(" in signature, entry
            assert ahead.symbol(entry, i) == f"{module.rsplit('.', 1)[1]}__{function}_{i}"


def test_an_extension_that_does_not_load_is_not_used(tmp_path):
    _needs_extension()
    manifest = json.loads((ahead.HERE / f"{ahead.NAME}.json").read_text())
    (tmp_path / manifest["file"]).write_bytes(b"not a shared library")
    (tmp_path / f"{ahead.NAME}.json").write_text(json.dumps(manifest))
    assert ahead.load_extension(tmp_path) == (None, None)
