"""tinsmith's build backend: setuptools', plus the numba kernels compiled into what it builds.

A package with compiled code compiles it when it is built; tinsmith's
compiled code is numba's cache of its kernels.  This backend (PEP 517, in
the source tree: ``backend-path`` in pyproject.toml) is setuptools' own with
two additions:

- ``get_requires_for_build_wheel`` and ``..._editable`` add the project's
  runtime dependencies (read from pyproject.toml) to setuptools', so that
  the isolated build environment compiles with the numba, llvmlite and numpy
  that pip then installs beside the package (when they differ, the compiled
  kernels are not used and kernels compile on first use, as without them).
- setuptools' ``build_py`` (named as its ``cmdclass`` in pyproject.toml) runs
  the warmup jobs (``tinsmith.warmup.JOBS``) for the generic CPU of the
  architecture, one process per job, and stores numba's cache with its
  manifest (``tinsmith.kernels.portable``) as the package's
  ``kernels/_portable``: in the wheel, or in the source tree for an
  editable install (gitignored).  Kernels whose code is unchanged since the
  last build on this machine are taken from it rather than compiled again
  (``~/.cache/tinsmith/kernels``, one folder per numba, llvmlite, numpy,
  Python and platform; ``TINSMITH_BUILD_CACHE`` names another folder, or
  ``none``).  A wheel that holds them is tagged for its Python and
  platform (``bdist_wheel``), as any wheel with compiled code.

What is compiled: the setting ``kernels`` (``pip install --config-settings
kernels=...``) or else the environment variable ``TINSMITH_BUILD_KERNELS``:
``all`` (the default: every warmup job, what the test suite uses), ``none``
(compile nothing, and install no runtime dependency in the build
environment: for packagers; kernels then compile on first use, or with
``tinsmith warmup``), or a comma-separated list of jobs (``default``: the
README's first command).  ``TINSMITH_BUILD_PROCESSES`` sets the number of
processes (default: the CPUs).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

from setuptools import build_meta as _setuptools
from setuptools.build_meta import *  # noqa: F403  (build_sdist, prepare_metadata_for_build_*, ...)
from setuptools.command.bdist_wheel import bdist_wheel as _bdist_wheel
from setuptools.command.build_py import build_py as _build_py

ROOT = Path(__file__).resolve().parents[1]
SETTING = "kernels"
ENV_SETTING = "TINSMITH_BUILD_KERNELS"
ENV_PROCESSES = "TINSMITH_BUILD_PROCESSES"
ENV_CACHE = "TINSMITH_BUILD_CACHE"
#: the warmup jobs the longest to compile first, so that the processes end together (unlisted ones last)
LONGEST_FIRST = ("methods", "default", "tiles", "reconstruct", "points", "filters", "city")

_config_settings: dict = {}


def requested_jobs(config_settings: dict | None = None) -> list[str] | None:
    """The warmup jobs whose kernels the build compiles: None for all, [] for none (the setting, else the variable)."""
    value = ((config_settings or {}).get(SETTING) or os.environ.get(ENV_SETTING) or "all").strip().lower()
    if value == "all":
        return None
    if value in ("none", "0", "no", "off", "false"):
        return []
    return [j.strip() for j in value.split(",") if j.strip()]


def _runtime_requirements() -> list[str]:
    with open(ROOT / "pyproject.toml", "rb") as f:
        return list(tomllib.load(f)["project"]["dependencies"])


def get_requires_for_build_wheel(config_settings=None):
    extra = [] if requested_jobs(config_settings) == [] else _runtime_requirements()
    return _setuptools.get_requires_for_build_wheel(config_settings) + extra


def get_requires_for_build_editable(config_settings=None):
    extra = [] if requested_jobs(config_settings) == [] else _runtime_requirements()
    return _setuptools.get_requires_for_build_editable(config_settings) + extra


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    _config_settings.clear()
    _config_settings.update(config_settings or {})
    return _setuptools.build_wheel(wheel_directory, config_settings, metadata_directory)


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    _config_settings.clear()
    _config_settings.update(config_settings or {})
    return _setuptools.build_editable(wheel_directory, config_settings, metadata_directory)


class BuildPy(_build_py):
    """setuptools' ``build_py``, then the kernels compiled into the built package (or the source tree, editable)."""

    def run(self):
        super().run()
        jobs = requested_jobs(_config_settings)
        if jobs == []:
            print("tinsmith: kernels not compiled at build time (kernels=none); they compile on first use")
            return
        if self.editable_mode:
            package_root = Path(self.get_package_dir("tinsmith")).resolve().parent
        else:
            package_root = Path(self.build_lib).resolve()
        compile_kernels(package_root, jobs, incremental=self.editable_mode)


class BdistWheel(_bdist_wheel):
    """setuptools' ``bdist_wheel``, tagged for this Python and platform when the wheel holds compiled kernels."""

    def finalize_options(self):
        super().finalize_options()
        if requested_jobs(_config_settings) != []:
            self.root_is_pure = False  # e.g. cp311-cp311-linux_x86_64, as for any wheel with compiled code


CHILD = """
import sys
from tinsmith.kernels import portable
from tinsmith.warmup import warmup
warmup(sys.argv[1].split(","))
portable.build(sys.argv[2])
"""

MERGE = """
import sys
from pathlib import Path
from tinsmith.kernels import portable
parts, dest, jobs = [Path(p) for p in sys.argv[1].split(",")], Path(sys.argv[2]), sys.argv[3].split(",")
print(len(portable.merge(parts, dest, extra={"jobs": jobs})["kernels"]))
"""

SETUP = """
from tinsmith.kernels import portable
from tinsmith.warmup import JOBS
print(portable.environment_tag())
print(",".join(JOBS))
"""


def _env(package_root: Path, **extra) -> dict:
    path = os.pathsep.join(p for p in (str(package_root), os.environ.get("PYTHONPATH")) if p)
    return {**os.environ, "PYTHONPATH": path, "PYTHONDONTWRITEBYTECODE": "1", "TINSMITH_COMPILE_NOTICE": "0", **extra}


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
    ``incremental`` from those already in ``package_root``.  Returns the
    number of kernels stored.
    """
    package_root = Path(package_root)
    dest = package_root / "tinsmith" / "kernels" / "_portable"
    start = time.perf_counter()
    tag, all_jobs = subprocess.run([sys.executable, "-c", SETUP], env=_env(package_root), capture_output=True, text=True,
                                   check=True).stdout.split()
    jobs = all_jobs.split(",") if jobs is None else jobs
    if processes is None:
        processes = int(os.environ.get(ENV_PROCESSES) or os.cpu_count() or 1)
    processes = max(1, min(processes, len(jobs)))
    reuse = reuse_folder()
    reuse = reuse / tag if reuse is not None else None
    if reuse is not None and (reuse / "manifest.json").is_file():
        if dest.exists():
            shutil.rmtree(dest)
        shutil.copytree(reuse, dest)
        log(f"tinsmith: kernels compiled by an earlier build reused from {reuse} where their code is unchanged")
        incremental = True
    incremental = incremental and (dest / "manifest.json").is_file()
    order = sorted(jobs, key=lambda j: LONGEST_FIRST.index(j) if j in LONGEST_FIRST else len(LONGEST_FIRST))
    log(f"tinsmith: compiling the kernels of {', '.join(order)} for the generic CPU in {processes} processes")
    with tempfile.TemporaryDirectory(prefix="tinsmith-kernels-") as tmp:
        tmp = Path(tmp)
        generic = {"NUMBA_CPU_NAME": "generic", "NUMBA_CPU_FEATURES": ""}
        if not incremental:
            generic["TINSMITH_NO_PORTABLE_CACHE"] = "1"
        parts = _run_jobs(package_root, order, processes, tmp, generic, log)
        merged = tmp / "merged"
        done = subprocess.run([sys.executable, "-c", MERGE, ",".join(map(str, parts)), str(merged), ",".join(order)],
                              env=_env(package_root), capture_output=True, text=True, check=True)
        if dest.exists():
            shutil.rmtree(dest)
        shutil.copytree(merged, dest)
        if reuse is not None:
            _replace(merged, reuse)
    count = int(done.stdout.strip())
    log(f"tinsmith: {count} compiled kernels in {dest} ({time.perf_counter() - start:.0f} s)")
    return count


def _run_jobs(package_root: Path, order: list[str], processes: int, tmp: Path, env: dict, log) -> list[Path]:
    """Run each job in a process of its own, ``processes`` at a time; the folders their caches were built in."""
    pending, running, parts = list(order), [], []
    while pending or running:
        while pending and len(running) < processes:
            job = pending.pop(0)
            part = tmp / f"part-{job}"
            child_env = _env(package_root, NUMBA_CACHE_DIR=str(tmp / f"numba-{job}"), **env)
            proc = subprocess.Popen([sys.executable, "-c", CHILD, job, str(part)], env=child_env)
            running.append((job, time.perf_counter(), proc))
            parts.append(part)
        time.sleep(0.2)
        for item in list(running):
            job, began, proc = item
            cpu = _reap(proc)
            if cpu is None:
                continue
            running.remove(item)
            if proc.returncode:
                for _, _, other in running:
                    other.kill()
                raise RuntimeError(f"compiling the kernels of warmup job {job!r} failed (exit code {proc.returncode})")
            log(f"tinsmith: kernels of {job} compiled in {time.perf_counter() - began:.0f} s ({cpu:.0f} s of CPU)")
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
