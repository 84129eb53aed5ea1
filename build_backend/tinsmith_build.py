"""tinsmith's build backend: setuptools', plus the numba kernels compiled into what it builds.

A package with compiled code compiles it when it is built; tinsmith's
compiled code is numba's cache of its kernels.  This backend (PEP 517, in
the source tree: ``backend-path`` in pyproject.toml) is setuptools' own with
two additions:

- ``get_requires_for_build_wheel`` and ``..._editable`` add the project's
  runtime dependencies (read from pyproject.toml) to setuptools', so that
  the isolated build environment compiles with the numba, llvmlite and numpy
  that pip then installs beside the package (when they differ, the compiled
  kernels are not used and kernels compile on first use, as without them),
  and shapely, which the city job imports.
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
- It then compiles the kernels of the point-cloud TIN ahead of time
  (``tinsmith.kernels.ahead``) into an extension module beside them, so that
  ``tinsmith.tin`` in a fresh process loads no numba; this needs a C
  compiler, and without one the build says so and goes on (the jit kernels
  then serve that path).  Reused from the last build's when the kernels'
  sources are unchanged.

What is compiled: the setting ``kernels`` (``pip install --config-settings
kernels=...``) or else the environment variable ``TINSMITH_BUILD_KERNELS``:
``default`` (the default: the README's first command, about a minute on
a 2-core machine), ``all`` (every warmup job, what the test suite uses:
CI asks for it; 3,116 CPU seconds on a loaded 2-core machine), ``none``
(compile nothing, and install no runtime dependency in the build
environment: for packagers; kernels then compile on first use, or with
``tinsmith warmup``), or a comma-separated list of jobs.  ``TINSMITH_BUILD_PROCESSES`` sets the number of
processes (default: the CPUs).
"""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path

from kernel_compile import KernelBuildError, compile_ahead, compile_kernels
from setuptools import build_meta as _setuptools
from setuptools.build_meta import *  # noqa: F403  (build_sdist, prepare_metadata_for_build_*, ...)
from setuptools.command.bdist_wheel import bdist_wheel as _bdist_wheel
from setuptools.command.build_py import build_py as _build_py

ROOT = Path(__file__).resolve().parents[1]
SETTING = "kernels"
ENV_SETTING = "TINSMITH_BUILD_KERNELS"

_config_settings: dict = {}


def requested_jobs(config_settings: dict | None = None) -> list[str] | None:
    """The warmup jobs whose kernels the build compiles: None for all, [] for none (the setting, else the variable)."""
    value = ((config_settings or {}).get(SETTING) or os.environ.get(ENV_SETTING) or "default").strip().lower()
    if value == "all":
        return None
    if value in ("none", "0", "no", "off", "false"):
        return []
    return [j.strip() for j in value.split(",") if j.strip()]


#: optional packages the warmup jobs import (city models: shapely), taken with their versions from these extras
JOB_EXTRAS = {"vector": ("shapely",)}


def _runtime_requirements() -> list[str]:
    """The project's dependencies and the optional ones the warmup jobs import, as pyproject.toml writes them."""
    with open(ROOT / "pyproject.toml", "rb") as f:
        project = tomllib.load(f)["project"]
    extras = [req for extra, names in JOB_EXTRAS.items() for req in project["optional-dependencies"][extra]
              if re.match(r"[A-Za-z0-9._-]+", req).group(0).lower() in names]
    return [*project["dependencies"], *extras]


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
        try:
            compile_kernels(package_root, jobs, incremental=self.editable_mode)
            compile_ahead(package_root)
        except Exception as e:  # noqa: BLE001  (every failure ends the build, below)
            # SystemExit, not an Exception: setuptools' editable build turns an Exception into a warning and
            # installs without the kernels, or fails formatting that warning and hides the cause
            what = str(e) if isinstance(e, KernelBuildError) else f"{type(e).__name__}: {e}"
            raise SystemExit(f"error: tinsmith: {what}\nTINSMITH_BUILD_KERNELS=none installs without compiling "
                             "the kernels (they then compile on first use)") from None


class BdistWheel(_bdist_wheel):
    """setuptools' ``bdist_wheel``, tagged for this Python and platform when the wheel holds compiled kernels."""

    def finalize_options(self):
        super().finalize_options()
        if requested_jobs(_config_settings) != []:
            self.root_is_pure = False  # e.g. cp311-cp311-linux_x86_64, as for any wheel with compiled code
