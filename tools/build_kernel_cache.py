"""Compile the kernels into the source tree's ``src/tinsmith/kernels/_portable``, as ``pip install -e .`` does.

    python tools/build_kernel_cache.py                    # every warmup job, only the kernels whose code changed
    python tools/build_kernel_cache.py --jobs default     # the README's first command only
    python tools/build_kernel_cache.py --fresh            # compile everything again

The package build does this itself (``build_backend/``); this
script is for a source tree whose kernels changed since, without reinstalling,
and it checks what the build does not: that the README's mesh from the
generic CPU's code is identical bit for bit to the mesh from this CPU's own
code (about a minute more; ``--no-check`` skips it).  Nothing it writes is
tracked by git.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "build_backend"), str(ROOT / "src")]

from kernel_compile import compile_kernels  # noqa: E402

README = """
import sys
from tinsmith.cli.main import main
sys.exit(main(["simplify", "--sample", "st-helens", "-o", sys.argv[1]]))
"""


def _readme_mesh(out: Path, **env) -> None:
    """The README's first command in an empty numba cache (``env``: numba's CPU, the compiled cache or not)."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(ROOT / "src"), TINSMITH_COMPILE_NOTICE="0", **env)
        subprocess.run([sys.executable, "-c", README, str(out)], env=env, cwd=ROOT, check=True, capture_output=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", default=None, help="warmup jobs to compile, comma-separated (default: all)")
    ap.add_argument("--processes", type=int, default=None, help="parallel processes (default: the CPUs)")
    ap.add_argument("--fresh", action="store_true", help="compile every kernel, not only those whose code changed")
    ap.add_argument("--no-check", action="store_true",
                    help="skip comparing the README's mesh from the generic code with this CPU's own (about a minute)")
    args = ap.parse_args()
    jobs = args.jobs.split(",") if args.jobs else None
    compile_kernels(ROOT / "src", jobs, incremental=not args.fresh, processes=args.processes)
    if not args.no_check:
        import numpy as np

        import tinsmith

        with tempfile.TemporaryDirectory() as tmp:
            generic, host = Path(tmp) / "generic.ply", Path(tmp) / "host.ply"
            _readme_mesh(generic)  # the compiled cache, seeded
            _readme_mesh(host, TINSMITH_NO_PORTABLE_CACHE="1")  # compiled for this CPU
            a, b = tinsmith.read_mesh(generic), tinsmith.read_mesh(host)
            same = np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)
        print(f"README mesh from the generic code {'identical to' if same else 'DIFFERS from'} this CPU's own")
        if not same:
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
