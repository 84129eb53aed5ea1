"""Rebuild the portable kernel cache shipped in ``src/tinsmith/kernels/_portable``.

    python tools/build_kernel_cache.py                    # every warmup job (what is shipped)
    python tools/build_kernel_cache.py --jobs default     # the README's first command only

Compiles the kernels of the chosen warmup jobs (``tinsmith.warmup.JOBS``) for
the generic CPU of this architecture, in a fresh process with an empty numba
cache, runs the README's first command as well, and stores what numba cached
with its manifest (see ``tinsmith.kernels.portable``); then compiles the
same for this machine's CPU and checks that the README's mesh is identical
bit for bit.  Rerun it after any
change to a kernel: ``tests/test_warmup.py`` fails while the shipped cache is
stale.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import sys
from tinsmith.warmup import warmup
from tinsmith.cli.main import main
from tinsmith.kernels import portable
warmup(sys.argv[1].split(","))
main(["simplify", "--sample", "st-helens", "-o", sys.argv[2]])
if sys.argv[3] == "build":
    manifest = portable.build()
    print(f"{len(manifest['kernels'])} kernels from {len(manifest['sources'])} files, numba {manifest['numba']}")
"""


def _child(jobs: str, out: Path, build: bool, generic: bool) -> None:
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, TINSMITH_NO_PORTABLE_CACHE="1", PYTHONPATH=str(ROOT / "src"))
        if generic:
            env.update(NUMBA_CPU_NAME="generic", NUMBA_CPU_FEATURES="")
        subprocess.run([sys.executable, "-c", CHILD, jobs, str(out), "build" if build else "check"],
                       env=env, cwd=ROOT, check=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", default=None, help="warmup jobs to ship, comma-separated (default: all)")
    ap.add_argument("--no-check", action="store_true",
                    help="skip compiling for this CPU to check that the meshes are identical (about a minute)")
    args = ap.parse_args()
    if args.jobs is None:
        sys.path.insert(0, str(ROOT / "src"))
        from tinsmith.warmup import JOBS

        args.jobs = ",".join(JOBS)
    with tempfile.TemporaryDirectory() as tmp:
        generic, host = Path(tmp) / "generic.ply", Path(tmp) / "host.ply"
        _child(args.jobs, generic, build=True, generic=True)
        if not args.no_check:
            # the shipped code is the generic CPU's; the README's mesh must be what this CPU's own code gives
            _child("default", host, build=False, generic=False)
            import numpy as np

            import tinsmith

            a, b = tinsmith.read_mesh(generic), tinsmith.read_mesh(host)
            same = np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)
            print(f"README mesh from the generic code {'identical to' if same else 'DIFFERS from'} this CPU's own")
            if not same:
                return 1
    size = sum(p.stat().st_size for p in (ROOT / "src/tinsmith/kernels/_portable").iterdir())
    print(f"wrote src/tinsmith/kernels/_portable ({size / 1e6:.1f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
