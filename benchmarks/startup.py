"""Install and start-up: the build's compile, the command line's own cost, the README's first command.

    pip install -e ".[all]"
    python benchmarks/startup.py            # this installation; writes benchmarks/RESULTS_startup.md
    python benchmarks/startup.py --install  # first installs fresh clones of this repository, timed

Every figure is the wall time of a whole process (as a user sees it), run as
the installed ``tinsmith`` script beside the Python that runs the rows:

- ``--install``: ``git clone`` of this repository's committed HEAD, a new
  venv (``--system-site-packages``: the dependencies already installed are
  reused, so what is timed is the build itself, its isolated environment
  and the compile), ``pip install -e ".[all]"``, four ways in four clones:
  compiling every kernel with no earlier build to reuse (an empty
  ``TINSMITH_BUILD_CACHE``); again in a new clone, reusing that build's
  kernels (their code unchanged); the default build (the README's kernels
  only), with the README's first command run after it; and
  ``TINSMITH_BUILD_KERNELS=none`` (nothing compiled at install, the first
  run compiles).  The CPU time is
  that of every process of the install.  The rows below then run in the
  first venv.
- ``tinsmith --help`` and ``tinsmith methods``: median of 10 runs.
- The README's first command (``tinsmith simplify --sample st-helens -o
  st_helens.ply``) in an empty numba cache, as after ``pip install``: the
  first run (the compiled kernels are seeded into numba's cache), the second
  run, and the first run without them (``TINSMITH_NO_PORTABLE_CACHE=1``:
  every kernel compiles, which is what a first run costs where the build did
  not compile them or another numba is installed since).
- The command line's overhead: the README's first command against the same
  work as a library call in ``python -c``, both with a warm cache, 10 pairs
  taking turns; the overhead is the median of the pairs' differences.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import HERE, ROOT, machine

LIBRARY = (
    "import tinsmith\nfrom tinsmith.metrics import vertical_error\n"
    "hf = tinsmith.sample('st-helens')\nmesh = tinsmith.simplify(hf)\n"
    "mesh.info['error'] = vertical_error(mesh, hf)\ntinsmith.write(mesh, {out!r})\n"
)


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def wall(cmd, env=None, cwd=None) -> tuple[float, float, str]:
    """(wall seconds, CPU seconds of the process and its children, standard output and error)."""
    start, cpu = time.perf_counter(), _cpu()
    done = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **(env or {})}, cwd=cwd)
    elapsed = time.perf_counter() - start
    if done.returncode:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    return elapsed, _cpu() - cpu, done.stdout + done.stderr


def install(tmp: Path, name: str, env: dict) -> tuple[Path, float, float, list[str]]:
    """A clone of this repository and a venv with it installed (``pip install -e ".[all]"``, timed)."""
    clone, venv = tmp / f"clone-{name}", tmp / f"venv-{name}"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    seconds, cpu, out = wall([venv / "bin/python", "-m", "pip", "install", "-v", "-e", ".[all]"], env, cwd=clone)
    log = [line.strip() for line in out.splitlines() if re.match(r"\s*tinsmith: ", line)]
    print(f"install {name}: {seconds:.0f} s, {cpu:.0f} s of CPU", *log, sep="\n  ", flush=True)
    return venv, seconds, cpu, log


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "RESULTS_startup.md"))
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--install", action="store_true", help="time pip install -e in fresh clones first (many minutes)")
    ap.add_argument("--no-compile", action="store_true", help="skip the first run without the compiled kernels")
    args = ap.parse_args()
    rows, installs, notes = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        python = Path(sys.executable)
        if args.install:
            reuse = {"TINSMITH_BUILD_CACHE": str(tmp / "build-cache"), "TINSMITH_BUILD_KERNELS": "all"}
            venv, s, c, log = install(tmp, "cold", reuse)
            installs.append(("every kernel compiled (no earlier build)", s, c))
            notes += log
            _, s, c, log = install(tmp, "warm", reuse)
            installs.append(("the same, reusing the kernels of that earlier build", s, c))
            notes += log
            out = f"{tmp}/st_helens.ply"
            default, s, c, _ = install(tmp, "default", {"TINSMITH_BUILD_CACHE": str(tmp / "build-cache-default"),
                                                        "TINSMITH_BUILD_KERNELS": "default"})
            installs.append(("the default build: the README's kernels (no earlier build)", s, c))
            readme = [default / "bin/tinsmith", "simplify", "--sample", "st-helens", "-o", out]
            first = wall(readme, {"NUMBA_CACHE_DIR": f"{tmp}/numba-default"})
            rows.append(("README first command after the default install: first run", "1 run", first[0], first[0],
                         first[0]))
            other, s, c, _ = install(tmp, "none", {"TINSMITH_BUILD_KERNELS": "none"})
            installs.append(("TINSMITH_BUILD_KERNELS=none (nothing compiled)", s, c))
            readme = [other / "bin/tinsmith", "simplify", "--sample", "st-helens", "-o", out]
            first = wall(readme, {"NUMBA_CACHE_DIR": f"{tmp}/numba-none"})
            rows.append(("README first command after the install that compiled nothing: first run", "1 run",
                         first[0], first[0], first[0]))
            python = venv / "bin/python"
        tinsmith = python.with_name("tinsmith")
        for sub in (["--help"], ["methods"]):
            times = [wall([tinsmith, *sub])[0] for _ in range(args.runs)]
            rows.append((f"tinsmith {' '.join(sub)}", f"median of {args.runs}", statistics.median(times), min(times),
                         max(times)))
            print(rows[-1], flush=True)
        out = f"{tmp}/st_helens.ply"
        readme = [tinsmith, "simplify", "--sample", "st-helens", "-o", out]
        fresh = {"NUMBA_CACHE_DIR": f"{tmp}/numba"}
        first, second = wall(readme, fresh)[0], wall(readme, fresh)[0]
        rows.append(("README first command, empty numba cache: first run", "1 run", first, first, first))
        rows.append(("README first command: second run", "1 run", second, second, second))
        if not args.no_compile:
            compiled = wall(readme, {"NUMBA_CACHE_DIR": f"{tmp}/numba-none", "TINSMITH_NO_PORTABLE_CACHE": "1"})[0]
            rows.append(("README first command, first run without the compiled kernels (every kernel compiles)",
                         "1 run", compiled, compiled, compiled))
        cli, lib = [], []
        for _ in range(10):
            cli.append(wall(readme, fresh)[0])
            lib.append(wall([python, "-c", LIBRARY.format(out=out)], fresh)[0])
        rows.append(("README first command, warm cache", "median of 10", statistics.median(cli), min(cli), max(cli)))
        rows.append(("the same work as a library call (python -c)", "median of 10", statistics.median(lib), min(lib),
                     max(lib)))
        pairs = [c - b for c, b in zip(cli, lib, strict=True)]
    for r in rows:
        print(r, flush=True)
    load = os.getloadavg()[0]
    lines = [
        "# Install, start-up and first run",
        "",
        f"Command: `python benchmarks/startup.py{' --install' if args.install else ''}`  ",
        f"{machine()}; wall time of whole processes (s), the installed `tinsmith` script; "
        f"load average {load:.1f} at the end.",
        "",
    ]
    if installs:
        lines += [
            '`pip install -e ".[all]"` in a fresh clone and a new venv (`--system-site-packages`: the '
            "dependencies already installed are reused; the build's isolated environment installs its own):",
            "",
            "| install | wall (s) | CPU (s) |",
            "|---|---|---|",
            *[f"| {what} | {s:.0f} | {c:.0f} |" for what, s, c in installs],
            "",
            "What the builds said (wall and CPU seconds of each warmup job's process):",
            "",
            *[f"    {line}" for line in notes],
            "",
        ]
    lines += [
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
