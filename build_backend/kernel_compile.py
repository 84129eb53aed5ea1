"""Compile tinsmith's kernels into a package tree: what the build backend (tinsmith_build.py) runs.

No setuptools here, so that tools/build_kernel_cache.py runs it outside a
build environment too.  See tinsmith_build.py for what is compiled, where it
goes and how earlier builds are reused.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ENV_PROCESSES = "TINSMITH_BUILD_PROCESSES"
ENV_CACHE = "TINSMITH_BUILD_CACHE"
#: the warmup jobs the longest to compile first, so that the processes end together (unlisted ones last)
LONGEST_FIRST = ("methods", "default", "tiles", "reconstruct", "points", "filters", "city")
#: jobs that run in the process of another when both are asked for: their kernels are mostly that job's
#: (greedy insertion, the quadtree, the metrics), compiled once there rather than again in a process of their own
RIDES_WITH = {"default": "methods", "tiles": "methods"}

ENV_ROOT = "TINSMITH_BUILD_ROOT"
#: the start of every script the build runs: the package being built is imported from the folder it is built in
PRELUDE = f"import os, sys; sys.path.insert(0, os.environ[{ENV_ROOT!r}])"

CHILD = PRELUDE + """
import sys
from tinsmith.kernels import portable
from tinsmith.warmup import warmup
warmup(sys.argv[1].split(","))
portable.build(sys.argv[2])
"""

MERGE = PRELUDE + """
import sys
from pathlib import Path
from tinsmith.kernels import portable
parts, dest, jobs = [Path(p) for p in sys.argv[1].split(",")], Path(sys.argv[2]), sys.argv[3].split(",")
print(len(portable.merge(parts, dest, extra={"jobs": jobs, "source": sys.argv[4]})["kernels"]))
"""

SETUP = PRELUDE + """
import json
from tinsmith.kernels import portable
from tinsmith.warmup import JOBS
print(portable.environment_tag())
print(",".join(JOBS))
print(json.dumps(portable.environment(), separators=(",", ":")))
"""

AHEAD = PRELUDE + """
import sys
from pathlib import Path
from tinsmith.kernels import ahead_build
ahead_build.build(reuse=Path(sys.argv[1]) if sys.argv[1] else None)
"""


class KernelBuildError(Exception):
    """A warmup job failed while the build compiled the kernels (its own output says why)."""


def _env(package_root: Path, **extra) -> dict:
    """The environment of the build's own processes: they import the package being built, from ``package_root``.

    ``ENV_ROOT``, not PYTHONPATH: pip's build environment drops from ``sys.path`` every folder that the
    machine's site-packages puts there, which includes this very one when the package is already installed
    editable (a reinstall).  Each script starts with :data:`PRELUDE`, which puts it first.
    """
    return {**os.environ, ENV_ROOT: str(package_root), "PYTHONDONTWRITEBYTECODE": "1", "TINSMITH_COMPILE_NOTICE": "0",
            **extra}


def source_digest(package_root: Path) -> str:
    """SHA-256 of every Python file of the package: the same digest, the same jobs, the same kernels compiled."""
    h = hashlib.sha256()
    base = Path(package_root) / "tinsmith"
    for path in sorted(base.rglob("*.py")):
        h.update(path.relative_to(base).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def _done_before(folder: Path, source: str, jobs: list[str], env: dict) -> bool:
    """True when ``folder`` holds the kernels of ``jobs`` compiled from this very source in this environment."""
    try:
        manifest = json.loads((folder / "manifest.json").read_text())
    except (OSError, ValueError):
        return False
    return (manifest.get("source") == source and set(jobs) <= set(manifest.get("jobs", ()))
            and all(manifest.get(k) == v for k, v in env.items()))


def reuse_folder() -> Path | None:
    """Where builds keep their compiled kernels for the next build on this machine (None: nowhere)."""
    value = os.environ.get(ENV_CACHE, "").strip()
    if value.lower() in ("none", "0", "no", "off", "false"):
        return None
    if value:
        return Path(value)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "tinsmith" / "kernels"


def compile_kernels(package_root: Path, jobs: list[str] | None = None, incremental: bool = False,
                    processes: int | None = None, log=print) -> int:
    """Compile the kernels of the warmup ``jobs`` (None: all) for the generic CPU into ``tinsmith/kernels/_portable``.

    One process per job, ``processes`` at a time (default: the CPUs), each
    with its own numba cache; their caches are merged.  The kernels whose
    code is unchanged are not compiled again: they are seeded from the
    compiled kernels of the last build on this machine (:func:`reuse_folder`,
    one folder per numba, llvmlite, numpy, Python and platform), or with
    ``incremental`` from those already in ``package_root``; when that build
    was of the very same Python files (:func:`source_digest`) and jobs, its
    kernels are taken as they are, without running the jobs.  Returns the
    number of kernels stored.
    """
    package_root = Path(package_root)
    dest = package_root / "tinsmith" / "kernels" / "_portable"
    start = time.perf_counter()
    tag, all_jobs, env = _python(SETUP, env=_env(package_root)).split()
    jobs = all_jobs.split(",") if jobs is None else jobs
    if processes is None:
        processes = int(os.environ.get(ENV_PROCESSES) or os.cpu_count() or 1)
    processes = max(1, min(processes, len(jobs)))
    reuse = reuse_folder()
    reuse = reuse / tag if reuse is not None else None
    source = source_digest(package_root)
    for earlier in (reuse, dest if incremental else None):
        if earlier is not None and _done_before(earlier, source, jobs, json.loads(env)):
            if earlier != dest:
                if dest.exists():
                    shutil.rmtree(dest)
                shutil.copytree(earlier, dest)
            log(f"tinsmith: the kernels of this source were compiled by an earlier build: {earlier}")
            return len(json.loads((dest / "manifest.json").read_text())["kernels"])
    if reuse is not None and (reuse / "manifest.json").is_file():
        if dest.exists():
            shutil.rmtree(dest)
        shutil.copytree(reuse, dest)
        log(f"tinsmith: kernels compiled by an earlier build reused from {reuse} where their code is unchanged")
        incremental = True
    incremental = incremental and (dest / "manifest.json").is_file()
    order = sorted(jobs, key=lambda j: LONGEST_FIRST.index(j) if j in LONGEST_FIRST else len(LONGEST_FIRST))
    plural = "es" if processes > 1 else ""
    log(f"tinsmith: compiling the kernels of {', '.join(order)} for the generic CPU in {processes} process{plural}")
    with tempfile.TemporaryDirectory(prefix="tinsmith-kernels-") as tmp:
        tmp = Path(tmp)
        generic = {"NUMBA_CPU_NAME": "generic", "NUMBA_CPU_FEATURES": ""}
        if not incremental:
            generic["TINSMITH_NO_PORTABLE_CACHE"] = "1"
        parts = _run_jobs(package_root, _units(order), processes, tmp, generic, log)
        merged = tmp / "merged"
        done = _python(MERGE, ",".join(map(str, parts)), str(merged), ",".join(order), source, env=_env(package_root))
        if dest.exists():
            shutil.rmtree(dest)
        shutil.copytree(merged, dest)
        if reuse is not None:
            _replace(merged, reuse)
    count = int(done.strip())
    log(f"tinsmith: {count} compiled kernels in {dest} ({time.perf_counter() - start:.0f} s)")
    return count


def compile_ahead(package_root: Path, log=print) -> bool:
    """Compile the point-cloud TIN's kernels ahead of time into ``tinsmith/kernels`` (``tinsmith.kernels.ahead``).

    Reuses an earlier build's (:func:`reuse_folder`) when its kernel sources
    and environment are these.  Needs a C compiler to link the extension:
    when this fails the build goes on, with a message, and the jit kernels
    serve that path (numba's start then costs a first call about half a
    second).  Returns whether the extension was made.
    """
    reuse = reuse_folder()
    try:
        out = _python(AHEAD, str(reuse / "ahead") if reuse is not None else "", env=_env(package_root))
    except KernelBuildError as e:
        log(f"tinsmith: warning: the kernels were not compiled ahead of time; the jit kernels serve instead.\n{e}")
        return False
    log(out.strip())
    return True


def _python(script: str, *args: str, env: dict) -> str:
    """What ``script`` printed, run by this Python; a failure raises :class:`KernelBuildError` with its stderr."""
    done = subprocess.run([sys.executable, "-c", script, *args], env=env, capture_output=True, text=True)
    if done.returncode:
        step = script.strip().splitlines()[-1]
        raise KernelBuildError(f"the build step `{step}` failed (exit code {done.returncode}; package from "
                               f"{env[ENV_ROOT]}):\n{done.stderr.strip()}")
    return done.stdout


def _units(order: list[str]) -> list[str]:
    """The jobs of ``order`` as the processes run them: ``"methods,default,tiles"`` (:data:`RIDES_WITH`), ``"city"``."""
    riders = {job: host for job, host in RIDES_WITH.items() if job in order and host in order}
    return [",".join([job, *(r for r in order if riders.get(r) == job)]) for job in order if job not in riders]


def _run_jobs(package_root: Path, units: list[str], processes: int, tmp: Path, env: dict, log) -> list[Path]:
    """Run each unit of jobs in a process of its own, ``processes`` at a time; the folders their caches were built in."""
    pending, running, parts = list(units), [], []
    while pending or running:
        while pending and len(running) < processes:
            unit = pending.pop(0)
            part = tmp / f"part-{len(parts)}"
            child_env = _env(package_root, NUMBA_CACHE_DIR=str(tmp / f"numba-{len(parts)}"), **env)
            proc = subprocess.Popen([sys.executable, "-c", CHILD, unit, str(part)], env=child_env)
            running.append((unit, time.perf_counter(), proc))
            parts.append(part)
        time.sleep(0.2)
        for item in list(running):
            unit, began, proc = item
            cpu = _reap(proc)
            if cpu is None:
                continue
            running.remove(item)
            if proc.returncode:
                for _, _, other in running:
                    other.kill()
                message = f"compiling the kernels of warmup job {unit!r} failed (exit code {proc.returncode})"
                raise KernelBuildError(message)
            log(f"tinsmith: kernels of {unit.replace(',', ', ')} compiled in {time.perf_counter() - began:.0f} s "
                f"({cpu:.0f} s of CPU)")
    return parts


def _reap(proc: subprocess.Popen) -> float | None:
    """None while ``proc`` runs; then the CPU seconds it used (nan where the platform does not say)."""
    if not hasattr(os, "wait4"):
        return None if proc.poll() is None else float("nan")
    pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
    if pid == 0:
        return None
    proc.returncode = os.waitstatus_to_exitcode(status)
    return usage.ru_utime + usage.ru_stime


def _replace(src: Path, dest: Path) -> None:
    """Copy ``src`` to ``dest`` as one step (a copy beside it, renamed); a failure leaves ``dest`` as it was."""
    try:
        dest.parent.mkdir(parents=True, exist_ok=True)
        tmp = dest.with_name(f".{dest.name}.{os.getpid()}")
        shutil.copytree(src, tmp)
        old = dest.with_name(f".{dest.name}.{os.getpid()}.old")
        if dest.exists():
            dest.rename(old)
        tmp.rename(dest)
        shutil.rmtree(old, ignore_errors=True)
    except OSError:
        pass  # a cache: the build does not depend on it
