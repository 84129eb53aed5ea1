"""A portable cache of compiled kernels, shipped in the package, so that a first run does not compile.

numba compiles a kernel on its first call and caches the machine code on
disk; on this project's reference machine the kernels of the default job
(greedy insertion, its nodata outline, the metrics) take one to two minutes
to compile.  This module ships that cache:

- :func:`build` (run by ``tools/build_kernel_cache.py``) takes the cache of a
  run made with ``NUMBA_CPU_NAME=generic`` and ``NUMBA_CPU_FEATURES=""`` (code
  for the baseline of the architecture, which every CPU of that architecture
  runs) and stores it in ``_portable/`` with a manifest: numba, llvmlite and
  Python versions, platform, and the SHA-256 of every kernel module and of
  every other source file that holds a shipped kernel (numba's own cache
  checks only the function's own code; a changed helper it inlines would
  go unnoticed).
- :func:`seed` copies it into numba's own cache (wherever numba keeps the
  cache of each kernel: beside the source, or in the user's cache folder)
  when the manifest matches this installation exactly and numba has no
  cache of that kernel yet.  The entries are re-keyed to this machine's code
  generator (numba keys an entry by the CPU it was compiled for); the code
  is the generic one.  Nothing else changes: numba loads and checks the
  entries as it does its own.  Without IEEE-changing flags (no fastmath),
  generic and host code compute the same results bit for bit (tested).

When the manifest does not match (another numba, another Python, an edited
kernel), nothing is seeded and kernels compile as usual, with a message
(:mod:`tinsmith.kernels.compiling`).
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import platform
import shutil
import sys
from pathlib import Path

SHIPPED = Path(__file__).with_name("_portable")
MANIFEST = "manifest.json"
_PACKAGE_ROOT = Path(__file__).resolve().parents[1]


def _environment() -> dict:
    import llvmlite
    import numba

    return {
        "numba": numba.__version__,
        "llvmlite": llvmlite.__version__,
        "python": f"{sys.version_info[0]}.{sys.version_info[1]}",
        "machine": platform.machine(),
        "system": platform.system(),
    }


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def dispatchers():
    """Every numba dispatcher defined at module level in an imported ``tinsmith`` module."""
    from numba.core.dispatcher import Dispatcher

    found = {}
    for name, module in list(sys.modules.items()):
        if module is None or not (name == "tinsmith" or name.startswith("tinsmith.")):
            continue
        for value in list(vars(module).values()):
            if isinstance(value, Dispatcher) and value.py_func.__module__ == name and value._cache is not None:
                found[(name, value.py_func.__qualname__)] = value
    return [found[k] for k in sorted(found)]


def _cache_file(dispatcher):
    """numba's index/data file object of a dispatcher (None when the dispatcher does not cache)."""
    cache = getattr(dispatcher, "_cache", None)
    return getattr(cache, "_cache_file", None)


def _read_index(path: Path):
    with open(path, "rb") as f:
        version = pickle.load(f)
        stamp, overloads = pickle.loads(f.read())
    return version, stamp, overloads


def build(dest: Path = SHIPPED) -> dict:
    """Store the cache entries of every compiled dispatcher in ``dest``; return the manifest.

    Call it in a process whose kernels were compiled (not loaded from a
    cache) with ``NUMBA_CPU_NAME=generic`` and ``NUMBA_CPU_FEATURES`` empty,
    after running the jobs whose kernels are to be shipped.
    """
    from numba.core import config

    if config.CPU_NAME != "generic" or config.CPU_FEATURES != "":
        raise RuntimeError("build() needs NUMBA_CPU_NAME=generic and NUMBA_CPU_FEATURES='' (portable code)")
    dest = Path(dest)
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    files, sources = [], {}
    for d in dispatchers():
        cf = _cache_file(d)
        index = Path(cf._index_path)
        if not d.overloads or not index.exists():
            continue
        _, _, overloads = _read_index(index)
        shutil.copyfile(index, dest / index.name)
        for data_name in overloads.values():
            shutil.copyfile(Path(cf._cache_path) / data_name, dest / data_name)
        source = Path(sys.modules[d.py_func.__module__].__file__).resolve()
        sources[source.relative_to(_PACKAGE_ROOT).as_posix()] = _digest(source)
        files.append({"module": d.py_func.__module__, "function": d.py_func.__qualname__, "index": index.name})
    # every kernel module too: inlined helpers (the heap, the scans) and intrinsics have no cache entry of their own
    for source in Path(__file__).parent.glob("*.py"):
        if source.name not in ("portable.py", "compiling.py", "__init__.py"):
            sources[source.relative_to(_PACKAGE_ROOT).as_posix()] = _digest(source)
    manifest = {**_environment(), "cpu": "generic", "sources": dict(sorted(sources.items())), "kernels": files}
    (dest / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n")
    return manifest


def matches(manifest: dict) -> bool:
    """True when the shipped cache was built by this numba, llvmlite, Python and platform from these sources."""
    env = _environment()
    if any(manifest.get(k) != v for k, v in env.items()):
        return False
    for rel, digest in manifest.get("sources", {}).items():
        path = _PACKAGE_ROOT / rel
        if not path.is_file() or _digest(path) != digest:
            return False
    return True


_shipped: dict | None = None
_local_codegen = None


def _shipped_kernels() -> dict:
    """{(module, qualname): index file} of the shipped cache, or {} when it does not match this installation."""
    global _shipped
    if os.environ.get("TINSMITH_NO_PORTABLE_CACHE"):
        return {}
    if _shipped is None:
        try:
            manifest = json.loads((SHIPPED / MANIFEST).read_text())
            kernels = {(e["module"], e["function"]): SHIPPED / e["index"] for e in manifest["kernels"]}
            _shipped = kernels if matches(manifest) else {}
        except (OSError, ValueError, KeyError, TypeError):
            _shipped = {}
    return _shipped


def _current(cf) -> bool:
    """True when numba has an index for this kernel that it would use (this numba, this source file)."""
    try:
        version, stamp, _ = _read_index(Path(cf._index_path))
    except (OSError, EOFError, pickle.UnpicklingError, ValueError, TypeError):
        return False
    return version == cf._version and stamp == cf._source_stamp


def seed(dispatcher) -> bool:
    """Copy a kernel's shipped cache into numba's cache when numba has none it would use; True when it did.

    Called by the decorators of :mod:`._jit` for every kernel as its module
    is imported; does nothing when there is no shipped cache for the kernel,
    when the shipped cache does not match this installation, when numba
    already has a current cache of the kernel (a stale one, from an older
    source file, is replaced), or when that cache can't be written.
    """
    global _local_codegen
    f = dispatcher.py_func
    index = _shipped_kernels().get((f.__module__, f.__qualname__))
    cf = _cache_file(dispatcher)
    if index is None or cf is None or _current(cf):
        return False
    try:
        if _local_codegen is None:
            from numba.core.registry import cpu_target

            _local_codegen = cpu_target.target_context.codegen().magic_tuple()
        _, _, overloads = _read_index(index)
        dispatcher._cache._impl.locator.ensure_cache_path()
        for data_name in overloads.values():
            _atomic_copy(index.parent / data_name, Path(cf._cache_path) / data_name)
        # re-keyed to this machine's code generator: (signature, codegen, bytecode hashes)
        cf._save_index({(sig, _local_codegen, hashes): name for (sig, _, hashes), name in overloads.items()})
    except (OSError, pickle.UnpicklingError, ValueError, AttributeError, TypeError):
        return False
    return True


def _atomic_copy(src: Path, dst: Path) -> None:
    tmp = dst.with_name(f".{dst.name}.{os.getpid()}.tmp")
    shutil.copyfile(src, tmp)
    os.replace(tmp, dst)
