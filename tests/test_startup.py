"""A first run that does not compile, a message when something compiles, and a command line that starts at once.

No wall-clock limits here (the machines are shared); the times are in
benchmarks/RESULTS_startup.md.  What is tested is what makes them: the
shipped kernel cache is current and is used, and start-up imports neither
numba nor numpy.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tinsmith
from tinsmith.kernels import compiling, portable

ROOT = Path(__file__).resolve().parents[1]


def _run(code: str, env: dict | None = None, timeout: int = 600) -> subprocess.CompletedProcess:
    env = {**os.environ, "TINSMITH_COMPILE_NOTICE": "1", **(env or {})}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout,
                          env=env, cwd=ROOT)


def test_shipped_kernel_cache_is_current():
    """Every source file the shipped kernels were compiled from is unchanged (else: python tools/build_kernel_cache.py)."""
    manifest = json.loads((portable.SHIPPED / portable.MANIFEST).read_text())
    assert manifest["cpu"] == "generic"
    package = Path(tinsmith.__file__).parent
    stale = [rel for rel, digest in manifest["sources"].items()
             if hashlib.sha256((package / rel).read_bytes()).hexdigest() != digest]
    assert not stale, f"kernels changed since the shipped cache was built: {stale}; run python tools/build_kernel_cache.py"
    shipped = {e["function"] for e in manifest["kernels"]}
    assert {"refine", "flush", "insert_point", "rasterize_triangles"} <= shipped
    for entry in manifest["kernels"]:
        *_, overloads = portable._read_index(portable.SHIPPED / entry["index"])
        assert overloads and all((portable.SHIPPED / name).is_file() for name in overloads.values())


def test_first_run_loads_the_shipped_kernels_without_compiling(tmp_path):
    """The README's first command in a fresh numba cache: no compilation, the mesh of the docs."""
    if not portable.matches(json.loads((portable.SHIPPED / portable.MANIFEST).read_text())):
        pytest.skip("the shipped kernel cache was built with another numba, llvmlite, Python or platform")
    out = tmp_path / "st_helens.ply"
    done = _run(
        "import sys\nfrom tinsmith.cli.main import main\nfrom tinsmith.kernels import compiling\n"
        f"code = main(['simplify', '--sample', 'st-helens', '-o', {str(out)!r}])\n"
        "print('compiled', compiling.compiled()[0])\nsys.exit(code)",
        env={"NUMBA_CACHE_DIR": str(tmp_path / "numba")},
    )
    assert done.returncode == 0, done.stderr
    assert "compiled 0" in done.stdout
    assert compiling.MESSAGE not in done.stderr
    assert "61,653 vertices, 122,619 triangles" in done.stdout
    mesh = tinsmith.read_mesh(out)
    reference = tinsmith.simplify(tinsmith.sample("st-helens"))  # this process: whatever cache it has
    assert np.array_equal(mesh.vertices, reference.vertices)
    assert np.array_equal(mesh.triangles, reference.triangles)


def test_a_compilation_is_announced_once_on_standard_error():
    done = _run(
        "import numba\nfrom tinsmith.kernels import compiling\nfrom tinsmith.kernels import _jit\n"
        "import sys\ncompiling.announce_with(lambda m: print('said:', m, file=sys.stderr))\n"
        "def twice(x):\n    return 2 * x\n"
        "twice.__module__ = 'tinsmith.kernels.fake'\n"
        "def thrice(x):\n    return 3 * x\n"
        "thrice.__module__ = 'tinsmith.kernels.fake'\n"
        "a, b = numba.njit(twice), numba.njit(thrice)\n"
        "print(a(2), b(2), compiling.compiled()[0])",
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["4", "6", "2"]
    assert done.stderr.count("said: " + compiling.MESSAGE) == 1


def test_other_numba_code_is_not_announced():
    done = _run(
        "import numba, sys\nfrom tinsmith.kernels import compiling, _jit\n"
        "compiling.announce_with(lambda m: print('said', file=sys.stderr))\n"
        "print(numba.njit(lambda x: x + 1)(1))",
    )
    assert done.returncode == 0 and done.stdout.strip() == "2"
    assert "said" not in done.stderr


HEAVY = ("numba", "numpy", "scipy", "rasterio", "meshio")


# formats lists the format modules' registrations, which import numpy: it only keeps numba and scipy out
@pytest.mark.parametrize("args, unloaded", [(["--help"], HEAVY), (["methods"], HEAVY), (["samples"], HEAVY),
                                            (["formats"], ("numba", "scipy"))])
def test_the_command_line_starts_without_numba_or_numpy(args, unloaded):
    done = _run(
        "import sys, contextlib, io\nfrom tinsmith.cli.main import main\n"
        f"with contextlib.redirect_stdout(io.StringIO()):\n    code = main({args!r})\n"
        f"print(code, sorted(m for m in {unloaded!r} if m in sys.modules))"
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "0 []"


def test_import_tinsmith_loads_methods_on_first_use():
    done = _run(
        "import sys, tinsmith\nbefore = 'numba' in sys.modules\n"
        "names = [m.name for m in tinsmith.methods()]\nlisted = 'numba' in sys.modules\n"
        "mesh = tinsmith.greedy(tinsmith.sample(), max_error=50)\n"
        "print(before, listed, 'numba' in sys.modules, 'greedy' in names, mesh.n_vertices > 3)"
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "False", "True", "True", "True"]


def test_every_public_name_resolves():
    for name in tinsmith.__all__:
        assert getattr(tinsmith, name) is not None
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        tinsmith.nope  # noqa: B018


def test_warmup_runs_jobs_and_refuses_unknown_ones():
    from tinsmith.warmup import JOBS, warmup

    seen = []
    seconds = warmup(["default"], progress=seen.append)
    assert seen == ["default"] and set(seconds) == {"default"}
    assert list(JOBS) == ["default", "methods", "points", "city", "filters", "reconstruct", "tiles"]
    with pytest.raises(tinsmith.InvalidOptionError, match="warmup job 'nope' is unknown; the jobs are: default"):
        warmup(["nope"])


def test_the_notice_can_be_turned_off():
    done = _run(
        "import numba, sys\nfrom tinsmith.kernels import compiling, _jit\n"
        "compiling.announce_with(lambda m: print('said', file=sys.stderr))\n"
        "f = lambda x: x + 1\nf.__module__ = 'tinsmith.kernels.fake'\nprint(numba.njit(f)(1))",
        env={"TINSMITH_COMPILE_NOTICE": "0"},
    )
    assert done.returncode == 0 and done.stdout.strip() == "2"
    assert "said" not in done.stderr


def test_cli_warmup(capsys):
    from tinsmith.cli.main import main

    assert main(["warmup", "--jobs", "default"]) == 0
    assert "warmed up default in" in capsys.readouterr().out
    assert main(["warmup", "--jobs", "nope"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["tinsmith: error: warmup job 'nope' is unknown; "
                   "the jobs are: default, methods, points, city, filters, reconstruct, tiles"]


def test_a_stale_numba_index_is_replaced_by_the_shipped_cache(tmp_path):
    """An index numba would ignore (written for an older source file) gets the shipped entries, no compile."""
    if not portable.matches(json.loads((portable.SHIPPED / portable.MANIFEST).read_text())):
        pytest.skip("the shipped kernel cache was built with another numba, llvmlite, Python or platform")
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    run = (
        "import pickle, sys\nimport tinsmith\nfrom tinsmith.kernels import compiling, greedy\n"
        "tinsmith.greedy(tinsmith.sample(), max_error=20.0)\n"
        "cf = greedy.refine._cache._cache_file\n"
        "with open(cf._index_path, 'rb') as f:\n    version = pickle.load(f); stamp, overloads = pickle.loads(f.read())\n"
        "print('compiled', compiling.compiled()[0], 'current', stamp == cf._source_stamp)\n"
        "if sys.argv[-1] == 'stale':\n"
        "    with open(cf._index_path, 'wb') as f:\n"
        "        pickle.dump(version, f); f.write(pickle.dumps(((0.0, 0), overloads)))\n"
    )
    first = _run(run, env=env)
    assert first.returncode == 0, first.stderr
    done = subprocess.run([sys.executable, "-c", run, "stale"], capture_output=True, text=True, timeout=600,
                          env={**os.environ, **env}, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    again = _run(run, env=env)
    assert again.returncode == 0, again.stderr
    assert "compiled 0 current True" in first.stdout and "compiled 0 current True" in again.stdout
