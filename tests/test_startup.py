"""A first run that does not compile, a message when something compiles, and a command line that starts at once.

No wall-clock limits here (the machines are shared); the times are in
benchmarks/RESULTS_startup.md.  What is tested is what makes them: the
kernels the package build compiled are current and are used, a kernel's
staleness follows its own code (on a synthetic kernel, whatever the build
compiled), and start-up imports neither numba nor numpy.
"""

from __future__ import annotations

import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

import tinsmith
from tinsmith.kernels import compiling, portable

ROOT = Path(__file__).resolve().parents[1]


def _run(code: str, env: dict | None = None, timeout: int = 600, args=()) -> subprocess.CompletedProcess:
    env = {**os.environ, "TINSMITH_COMPILE_NOTICE": "1", **(env or {})}
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=timeout,
                          env=env, cwd=ROOT)


def _built() -> dict:
    """The manifest of the kernels the package build compiled; skips when there are none for this environment."""
    manifest = portable.read_manifest()
    if manifest is None:
        pytest.skip("no compiled kernels: the package was built with kernels=none (they compile on first use)")
    if not portable.matches(manifest):
        pytest.skip("the compiled kernels were built with another numba, llvmlite, numpy, Python or platform")
    return manifest


def test_built_kernel_cache_is_current():
    """Every kernel the build compiled still has the code it was compiled from (else its cache is not used)."""
    manifest = _built()
    assert manifest["cpu"] == "generic"
    stale = portable.stale(manifest)
    assert not stale, (f"kernels changed since the package build compiled them: {stale}; "
                       "pip install -e . again (it compiles only those) or python tools/build_kernel_cache.py")
    if "default" in manifest.get("jobs", ()):
        assert {"refine", "flush", "insert_point", "rasterize_triangles"} <= {e["function"] for e in manifest["kernels"]}
    for entry in manifest["kernels"]:
        *_, overloads = portable._read_index(portable.SHIPPED / entry["index"])
        assert overloads and all((portable.SHIPPED / name).is_file() for name in overloads.values())


def test_first_run_loads_the_built_kernels_without_compiling(tmp_path):
    """The README's first command in a fresh numba cache: no compilation, the mesh of the docs."""
    if "default" not in _built().get("jobs", ()):
        pytest.skip("the package build did not compile the README's kernels (kernels=...)")
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


# A kernel module of its own: the digest and the seeding, checked without the package's compiled cache.
SYNTHETIC = """
import numpy as np
from numba import njit

SCALE = 2.0


@njit(cache=True)
def helper(x):
    return x * SCALE


@njit(cache=True)
def kernel(a):
    \"\"\"Sum of the scaled values.\"\"\"
    s = 0.0
    for v in a:
        s += helper(v)  # scaled
    return s


@njit(cache=True)
def other(a):
    return a[0] + 1.0
"""


def _synthetic_digest(source: str, name: str = "kernel") -> str:
    module = types.ModuleType("tinsmith.kernels._synthetic")
    source = source.replace("@njit(cache=True)", "@njit").replace("cache=True, ", "")  # nowhere to cache: no file
    exec(compile(source, "synthetic.py", "exec"), module.__dict__)
    return portable._Digester().value(getattr(module, name), ())


@pytest.mark.parametrize("edit", [
    ("import numpy as np\n", "# a comment\n\n\nimport numpy as np\n"),  # every line moves
    ("# scaled", "# scaled by SCALE"),
    ("Sum of the scaled values.", "The sum, scaled."),  # the kernel's own docstring
    ("def helper(x):\n", 'def helper(x):\n    """Scaled."""\n'),  # a docstring where there was none
    ("a[0] + 1.0", "a[0] + 2.0"),  # another kernel of the file
])
def test_a_kernel_digest_ignores_comments_docstrings_and_other_kernels(edit):
    assert _synthetic_digest(SYNTHETIC.replace(*edit)) == _synthetic_digest(SYNTHETIC)


@pytest.mark.parametrize("edit", [
    ("s = 0.0", "s = 1.0"),  # a constant only: numba's own cache key (the bytecode) misses it
    ("return x * SCALE", "return x * SCALE + 1.0"),  # a callee
    ("SCALE = 2.0", "SCALE = 3.0"),  # a module-level constant the callee reads
    ("@njit(cache=True)\ndef helper", "@njit(cache=True, inline='always')\ndef helper"),  # a callee's options
    ("for v in a:", "for v in a[::-1]:"),
])
def test_a_kernel_digest_follows_its_code_constants_and_callees(edit):
    assert SYNTHETIC.count(edit[0]) == 1
    assert _synthetic_digest(SYNTHETIC.replace(*edit)) != _synthetic_digest(SYNTHETIC)


SEEDING = """
import sys
from pathlib import Path
import numpy as np
import tinsmith.kernels
from tinsmith.kernels import compiling, portable
folder, mode, dtypes = Path(sys.argv[1]), sys.argv[2], sys.argv[3].split(",")
tinsmith.kernels.__path__.append(str(folder / "src"))
portable.SHIPPED = folder / "portable"
from tinsmith.kernels import synthetic
print("value", *[synthetic.kernel(np.arange(3, dtype=t)) for t in dtypes], "compiled", compiling.compiled()[0])
if mode != "run":
    print("built", len(portable.build(folder / mode)["kernels"]))
"""


def _synthetic_runner(tmp_path):
    """A synthetic kernel module beside the package's, and a function that runs it in a fresh process."""
    (tmp_path / "src").mkdir()
    source = tmp_path / "src" / "synthetic.py"
    source.write_text(SYNTHETIC.replace("from numba import njit", "from tinsmith.kernels._jit import jit as njit")
                      .replace("@njit(cache=True)", "@njit"))

    def run(mode="run", dtypes="float64", cache="numba", seeded=False):
        env = {"NUMBA_CACHE_DIR": str(tmp_path / cache)}
        if mode != "run":
            env.update({"NUMBA_CPU_NAME": "generic", "NUMBA_CPU_FEATURES": ""})
            if not seeded:
                env[portable.DISABLE] = "1"
        done = _run(SEEDING, args=[str(tmp_path), mode, dtypes], env=env)
        assert done.returncode == 0, done.stderr
        return done.stdout.split()

    return source, run


def test_a_built_kernel_is_seeded_until_its_own_code_changes(tmp_path):
    """Build a tiny kernel's cache, then run it in a fresh cache: seeded after a comment edit, compiled after a callee's."""
    source, run = _synthetic_runner(tmp_path)
    assert run("portable", cache="numba-build") == ["value", "6.0", "compiled", "1", "built", "2"]  # kernel, helper
    assert run() == ["value", "6.0", "compiled", "0"]  # seeded into an empty cache
    source.write_text("# a comment: every line moves, numba's own index of the file is stale\n" + source.read_text()
                      .replace("a[0] + 1.0", "a[0] + 2.0"))
    assert run() == ["value", "6.0", "compiled", "0"]  # seeded again
    source.write_text(source.read_text().replace("return x * SCALE", "return x * SCALE + 1.0"))
    assert run() == ["value", "9.0", "compiled", "1"]  # a callee changed: compiled, not the old code


def test_a_build_seeded_from_an_earlier_one_keeps_the_kernels_only_others_call(tmp_path):
    """The helper is linked into the seeded kernel's entry and never loaded; the new build still has it."""
    _, run = _synthetic_runner(tmp_path)
    assert run("portable", cache="numba-build")[-2:] == ["built", "2"]
    assert run("again", cache="numba-again", seeded=True) == ["value", "6.0", "compiled", "0", "built", "2"]


def test_the_caches_of_several_build_processes_merge(tmp_path):
    """Two processes compile the kernel for different arrays; the merged cache has both."""
    _, run = _synthetic_runner(tmp_path)
    assert run("part1", "float64", cache="numba-1")[-2:] == ["built", "2"]
    assert run("part2", "int64,float64", cache="numba-2")[-2:] == ["built", "2"]
    manifest = portable.merge([tmp_path / "part1", tmp_path / "part2"], tmp_path / "portable", extra={"jobs": ["x"]})
    assert manifest["jobs"] == ["x"] and len(manifest["kernels"]) == 2
    kernel = next(e for e in manifest["kernels"] if e["function"] == "kernel")
    *_, overloads = portable._read_index(tmp_path / "portable" / kernel["index"])
    assert len(overloads) == 2 and all((tmp_path / "portable" / name).is_file() for name in overloads.values())
    assert run(dtypes="int64,float64") == ["value", "6.0", "6.0", "compiled", "0"]


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
    assert list(JOBS) == ["default", "methods", "points", "city", "filters", "hydrology", "reconstruct", "tiles"]
    with pytest.raises(tinsmith.InvalidOptionError, match="warmup job 'nope' is unknown; the jobs are: default"):
        warmup(["nope"])


def test_warmup_stops_each_method_by_a_rule_it_takes():
    """The build runs the methods job: a rule a method refuses (wavelet's max_vertices) fails every install."""
    from tinsmith.algorithms import methods
    from tinsmith.warmup import _pieces, _stop

    _, pieces = _pieces()
    for method in methods():
        stop = _stop(method, pieces[0])
        assert set(stop) <= set(method.stop_rules), (method.name, stop)
        assert bool(stop) == bool(method.stop_rules), method.name


def test_a_failing_warmup_job_stops_the_build_naming_the_job(monkeypatch):
    """The package build compiles by running the warmup jobs; one that fails is named, and nothing is installed."""
    root = Path(__file__).resolve().parents[1]
    monkeypatch.syspath_prepend(str(root / "build_backend"))
    from kernel_compile import KernelBuildError, compile_kernels

    monkeypatch.setenv("TINSMITH_BUILD_CACHE", "none")
    before = sorted((root / "src" / "tinsmith" / "kernels").glob("_portable/*"))
    with pytest.raises(KernelBuildError, match="warmup job 'nope' failed"):
        compile_kernels(root / "src", ["nope"], processes=1, log=lambda message: None)
    assert sorted((root / "src" / "tinsmith" / "kernels").glob("_portable/*")) == before


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
                   "the jobs are: default, methods, points, city, filters, hydrology, reconstruct, tiles"]


def test_a_stale_numba_index_is_replaced_by_the_built_cache(tmp_path):
    """An index numba would ignore (written for an older source file) gets the built entries, no compile."""
    if "default" not in _built().get("jobs", ()):
        pytest.skip("the package build did not compile the README's kernels (kernels=...)")
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
