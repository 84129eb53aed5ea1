"""Hostile option values, fuzzed: every command either works or says one clear line.

Hypothesis drives ``simplify``, ``tile``, ``remesh``, ``simplify --method cvt``,
``lod`` and ``reconstruct`` through the real entry point (``main``) with option
values drawn from wide ranges (0, negative, NaN, inf, huge, tiny) on a small DEM
and a small cloud, and checks the contract of every command: exit code 0 with
the outputs written, or exit code 1 with exactly one line on standard error
naming the problem (never an internal error or a traceback), no output or
temporary file left behind on failure, the input untouched, and no hang (a
fault-handler guard aborts the run with every thread's stack if a case takes
longer than minutes; it is no performance limit).
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import rasterio
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rasterio.transform import Affine

from tinsmith.cli.main import main

from .conftest import hang_guard

#: Seconds after which a single case is taken to hang (the whole run is aborted with stacks).
HANG_GUARD = 300

FLOATS = st.one_of(
    st.sampled_from([0.0, -0.0, -1.0, math.nan, math.inf, -math.inf, 1e308, 5e-324, 1e-9, 1e9]),
    st.floats(min_value=-1e6, max_value=1e6, allow_nan=False),
    st.floats(min_value=1e-3, max_value=50.0),
)
INTS = st.one_of(
    st.sampled_from([0, -1, 1, 2, 3, 4, 2**31, 2**63 - 1, 10**12]),
    st.integers(min_value=-10, max_value=5000),
)


def _number(value) -> str:
    return repr(float(value)) if isinstance(value, float) else str(value)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """A 48 x 40 DEM with a nodata hole (GeoTIFF) and a 3,000-point cloud (XYZ), hashed."""
    root = tmp_path_factory.mktemp("fuzz")
    r, c = np.mgrid[0:48, 0:40]
    z = (50 + 10 * np.sin(r / 6.0) * np.cos(c / 5.0) + 0.3 * r).astype(np.float32)
    z[20:26, 10:15] = -9999.0
    dem = root / "dem.tif"
    with rasterio.open(dem, "w", driver="GTiff", width=40, height=48, count=1, dtype="float32",
                       transform=Affine(5, 0, 500000, 0, -5, 4100000), crs="EPSG:32610", nodata=-9999.0) as ds:
        ds.write(z, 1)
    rng = np.random.default_rng(7)
    xy = rng.uniform(0, 100, (3000, 2))
    cloud = root / "cloud.xyz"
    np.savetxt(cloud, np.column_stack([xy, 20 + np.sin(xy[:, 0] / 9) * 3 + xy[:, 1] * 0.05]), fmt="%.4f")
    return root, {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in (dem, cloud)}


def _check_contract(workspace, args: list, outputs: list[Path], capsys) -> None:
    root, hashes = workspace
    out_dir = root / "out"
    shutil.rmtree(out_dir, ignore_errors=True)
    out_dir.mkdir()
    with hang_guard(HANG_GUARD):
        code = main([str(a) for a in args])
    _, err = capsys.readouterr()
    if os.environ.get("TINSMITH_FUZZ_LOG"):
        with open(os.environ["TINSMITH_FUZZ_LOG"], "a") as log:
            log.write(f"{code}\t{' '.join(str(a) for a in args[3:] if not str(a).startswith(str(root)))}\t{err.strip()}\n")
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err and "internal error" not in err, (args, err)
    assert code in (0, 1), (args, code, err)
    if code == 1:
        assert len(lines) == 1 and lines[0].startswith("tinsmith") and "error:" in lines[0], (args, err)
        assert not list(out_dir.iterdir()), (args, "left behind", list(out_dir.iterdir()))
    else:
        assert all(line.startswith("tinsmith: warning:") for line in lines), (args, err)
        for out in outputs:
            assert out.exists(), (args, out)
        assert not [p for p in out_dir.rglob(".*")], (args, "temporary files left")
    for path, digest in hashes.items():
        assert hashlib.sha256(path.read_bytes()).hexdigest() == digest, (args, path)


#: Examples per command (TINSMITH_FUZZ_EXAMPLES=500 for a longer hunt; CI runs the default).
EXAMPLES = int(os.environ.get("TINSMITH_FUZZ_EXAMPLES", "20"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=EXAMPLES <= 20,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@FUZZ
@given(method=st.sampled_from(["greedy", "quadtree", "subsample", "features", "decimate", "grid"]),
       rule=st.sampled_from(["--max-error", "--max-vertices", "--max-triangles"]), value=st.one_of(FLOATS, INTS))
def test_simplify_with_hostile_stop_rules(workspace, capsys, method, rule, value):
    root, _ = workspace
    out = root / "out" / "m.ply"
    _check_contract(workspace, ["simplify", root / "dem.tif", "-o", out, "--method", method, rule, _number(value)],
                    [out], capsys)


@FUZZ
@given(rule=st.sampled_from(["--max-vertices", "--ratio"]), value=st.one_of(FLOATS, INTS),
       iterations=st.one_of(st.none(), INTS))
def test_cvt_with_hostile_options(workspace, capsys, rule, value, iterations):
    root, _ = workspace
    out = root / "out" / "m.ply"
    args = ["simplify", root / "dem.tif", "-o", out, "--method", "cvt", rule, _number(value)]
    if iterations is not None:
        args += ["--max-iter", iterations]
    _check_contract(workspace, args, [out], capsys)


@FUZZ
@given(max_error=FLOATS, tile_size=INTS, halo=st.one_of(st.none(), INTS))
def test_tile_with_hostile_options(workspace, capsys, max_error, tile_size, halo):
    root, _ = workspace
    out = root / "out" / "t.ply"
    args = ["tile", root / "dem.tif", "-o", out, "--max-error", _number(max_error), "--tile-size", tile_size,
            "--workers", "1"]
    if halo is not None:
        args += ["--halo", halo]
    _check_contract(workspace, args, [out], capsys)


@FUZZ
@given(vertices=INTS, gamma=st.one_of(st.none(), FLOATS), smooth=st.one_of(st.none(), FLOATS),
       density=st.sampled_from([None, "uniform", "curvature"]))
def test_remesh_with_hostile_options(workspace, capsys, vertices, gamma, smooth, density):
    root, _ = workspace
    out = root / "out" / "r.ply"
    args = ["remesh", root / "dem.tif", "-o", out, "--vertices", vertices]
    for flag, value in (("--gamma", gamma), ("--smooth", smooth), ("--density", density)):
        if value is not None:
            args += [flag, value if isinstance(value, str) else _number(value)]
    _check_contract(workspace, args, [out], capsys)


@FUZZ
@given(kind=st.sampled_from(["--levels", "--vertices"]),
       values=st.lists(st.one_of(FLOATS, INTS), min_size=0, max_size=4),
       method=st.sampled_from(["greedy", "quadtree", "decimate"]))
def test_lod_with_hostile_levels(workspace, capsys, kind, values, method):
    root, _ = workspace
    out = root / "out" / "levels"
    args = ["lod", root / "dem.tif", "-o", out, "--method", method, kind, ",".join(_number(v) for v in values)]
    _check_contract(workspace, args, [out / "index.json"], capsys)


@FUZZ
@given(mode=st.sampled_from(["auto", "heightfield", "general"]), mu=st.one_of(st.none(), FLOATS),
       max_angle=st.one_of(st.none(), FLOATS), min_angle=st.one_of(st.none(), FLOATS),
       dexel=st.one_of(st.none(), FLOATS))
def test_reconstruct_with_hostile_options(workspace, capsys, mode, mu, max_angle, min_angle, dexel):
    root, _ = workspace
    out = root / "out" / "c.ply"
    args = ["reconstruct", root / "cloud.xyz", "-o", out, "--mode", mode]
    for flag, value in (("--mu", mu), ("--max-angle", max_angle), ("--min-angle", min_angle), ("--dexel-size", dexel)):
        if value is not None:
            args += [flag, _number(value)]
    _check_contract(workspace, args, [out], capsys)
