"""Start-up: the command line's own cost, and the README's first command in a fresh numba cache.

    pip install -e ".[all]"
    python benchmarks/startup.py            # writes benchmarks/RESULTS_startup.md

Every figure is the wall time of a whole process (as a user sees it), run as
the installed ``tinsmith`` script beside this Python:

- ``tinsmith --help`` and ``tinsmith methods``: median of 10 runs.
- The README's first command (``tinsmith simplify --sample st-helens -o
  st_helens.ply``) in an empty numba cache, as after ``pip install``: the
  first run (the shipped kernels are copied into the cache), the second run,
  and the first run without the shipped cache (``TINSMITH_NO_PORTABLE_CACHE=1``:
  every kernel compiles, which is what a first run costs where the shipped
  cache does not match: another numba, Python or platform).
- The command line's overhead: the README's first command against the same
  work as a library call in ``python -c`` (read the sample, mesh it, measure
  it, write the PLY), both with a warm cache, 10 pairs taking turns; the
  overhead is the median of the pairs' differences (a pair shares the
  machine's mood; the difference of two medians on this shared machine
  swings by a few tenths).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import HERE, machine

TINSMITH = Path(sys.executable).with_name("tinsmith")
LIBRARY = (
    "import tinsmith\nfrom tinsmith.metrics import vertical_error\n"
    "hf = tinsmith.sample('st-helens')\nmesh = tinsmith.simplify(hf)\n"
    "mesh.info['error'] = vertical_error(mesh, hf)\ntinsmith.write(mesh, {out!r})\n"
)


def wall(cmd, env=None) -> float:
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **(env or {})})
    elapsed = time.perf_counter() - start
    if done.returncode:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed:\n{done.stderr}")
    return elapsed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "RESULTS_startup.md"))
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--no-compile", action="store_true", help="skip the first run without the shipped cache (~1-2 min)")
    args = ap.parse_args()
    rows = []
    for sub in (["--help"], ["methods"]):
        times = [wall([TINSMITH, *sub]) for _ in range(args.runs)]
        rows.append((f"tinsmith {' '.join(sub)}", f"median of {args.runs}", statistics.median(times), min(times), max(times)))
        print(rows[-1], flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        out = f"{tmp}/st_helens.ply"
        readme = [TINSMITH, "simplify", "--sample", "st-helens", "-o", out]
        fresh = {"NUMBA_CACHE_DIR": f"{tmp}/numba"}
        first = wall(readme, fresh)
        second = wall(readme, fresh)
        rows.append(("README first command, empty numba cache: first run", "1 run", first, first, first))
        rows.append(("README first command: second run", "1 run", second, second, second))
        if not args.no_compile:
            compiled = wall(readme, {"NUMBA_CACHE_DIR": f"{tmp}/numba-none", "TINSMITH_NO_PORTABLE_CACHE": "1"})
            rows.append(("README first command, first run without the shipped cache (every kernel compiles)",
                         "1 run", compiled, compiled, compiled))
        cli, lib = [], []
        for _ in range(10):
            cli.append(wall(readme, fresh))
            lib.append(wall([sys.executable, "-c", LIBRARY.format(out=out)], fresh))
        rows.append(("README first command, warm cache", "median of 10", statistics.median(cli), min(cli), max(cli)))
        rows.append(("the same work as a library call (python -c)", "median of 10", statistics.median(lib), min(lib),
                     max(lib)))
        pairs = [c - b for c, b in zip(cli, lib)]
    for r in rows[2:]:
        print(r, flush=True)
    lines = [
        "# Start-up and first run",
        "",
        "Command: `python benchmarks/startup.py`  ",
        f"{machine()}; wall time of whole processes (s), the installed `tinsmith` script.",
        "",
        "| what | runs | median | min | max |",
        "|---|---|---|---|---|",
        *[f"| {what} | {runs} | {med:.2f} | {lo:.2f} | {hi:.2f} |" for what, runs, med, lo, hi in rows],
        "",
        f"Overhead of the command line over the library call: {statistics.median(pairs):+.2f} s, the median of "
        f"10 paired differences (from {min(pairs):+.2f} to {max(pairs):+.2f} s).",
        "",
    ]
    Path(args.out).write_text("\n".join(lines))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
