"""A portable cache of compiled kernels, built with the package, so that a first run does not compile.

numba compiles a kernel on its first call and caches the machine code on
disk; the kernels of the README's first command take a minute or more to
compile.  Building the package compiles them instead (``pip install``, see
``build_backend/`` at the root of the source tree) and stores numba's cache
in ``_portable/`` beside this module: in the wheel, or in the source tree for
an editable install.  Nothing compiled is kept in the repository.

- :func:`build` takes the cache of a run made with ``NUMBA_CPU_NAME=generic``
  and ``NUMBA_CPU_FEATURES=""`` (code for the baseline of the architecture,
  which every CPU of that architecture runs) and stores it with a manifest:
  numba, llvmlite, numpy and Python versions, platform, and for every kernel
  the :func:`digest` of its own code.  :func:`merge` joins the caches that
  several build processes made.
- :func:`seed` copies a kernel's entries into numba's own cache (wherever
  numba keeps it: beside the source, or in the user's cache folder) when the
  manifest's environment is this one, the kernel's digest is unchanged and
  numba has no current cache of that kernel.  It runs once per kernel, just
  before numba first looks for the kernel in its cache.  The entries are
  re-keyed to this machine's code generator (numba keys an entry by the CPU
  it was compiled for); the code is the generic one.  Nothing else changes:
  numba loads and checks the entries as it does its own.  Without
  IEEE-changing flags (no fastmath), generic and host code compute the same
  results bit for bit (tested).

Staleness is per kernel: numba's own cache key hashes a function's bytecode
but not its constants, and not the kernels it calls (their code is linked
into the caller's cache entry).  :func:`digest` covers those too, so a
kernel whose callee changed is compiled again, while an edit to a comment,
a docstring or another kernel of the same file leaves it seeded.  When the
environment or a digest does not match, that kernel compiles as usual, with
a message (:mod:`tinsmith.kernels.compiling`).
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import platform
import shutil
import sys
import types
from pathlib import Path

import numpy as np
from numba.core.dispatcher import Dispatcher
from numba.core.extending import _Intrinsic
from numba.core.types import Type as NumbaType

SHIPPED = Path(__file__).with_name("_portable")
MANIFEST = "manifest.json"
#: set to any non-empty value: seed nothing (every kernel compiles on first use, or loads numba's own cache)
DISABLE = "TINSMITH_NO_PORTABLE_CACHE"


def environment() -> dict:
    """What a compiled kernel depends on besides its own code: the compiler, numpy, Python and the platform."""
    import llvmlite
    import numba
    import numpy

    return {
        "numba": numba.__version__,
        "llvmlite": llvmlite.__version__,
        "numpy": numpy.__version__,
        "python": f"{sys.version_info[0]}.{sys.version_info[1]}",
        "machine": platform.machine(),
        "system": platform.system(),
    }


def environment_tag() -> str:
    """:func:`environment` as a folder name: ``numba-0.68.1_llvmlite-0.50.0_numpy-2.4.6_python-3.11_x86_64-Linux``."""
    env = environment()
    return "_".join([*(f"{k}-{env[k]}" for k in ("numba", "llvmlite", "numpy", "python")),
                     f"{env['machine']}-{env['system']}"])


class _Digester:
    """SHA-256 of what a kernel's machine code is made from, memoised per function object.

    A function's part: its bytecode, constants (code objects of nested
    functions recursively; its own docstring left out), names, argument
    layout, defaults and closure.  Then every global it names: a jitted
    function by its digest and jit options, an intrinsic by the digest of its
    definition, a ``tinsmith`` module by the digests of the attributes the
    code names, a constant by its value, anything from another package by its
    qualified name (the environment covers those packages' versions).  Not
    part of it: file name, line numbers, comments, other functions' code.
    """

    def __init__(self):
        self._memo: dict[int, tuple[object, str]] = {}
        self._active: set[int] = set()

    def function(self, func) -> str:
        key = id(func)
        if key in self._memo:
            return self._memo[key][1]
        if key in self._active:  # recursion: the cycle is covered by the outer call
            return f"recursive {func.__module__}.{func.__qualname__}"
        self._active.add(key)
        try:
            code = func.__code__
            names = sorted(_names(code))
            parts = [
                self._code(code, func.__doc__),
                self.value(func.__defaults__, names),
                self.value(func.__kwdefaults__ and sorted(func.__kwdefaults__.items()), names),
                self.value(tuple(c.cell_contents for c in func.__closure__ or ()), names),
            ]
            glob = func.__globals__
            parts += [f"{n}={self.value(glob[n], names)}" for n in names if n in glob]
            result = hashlib.sha256("\n".join(parts).encode()).hexdigest()
        finally:
            self._active.discard(key)
        self._memo[key] = (func, result)
        return result

    def _code(self, code: types.CodeType, doc) -> str:
        consts = code.co_consts
        # a function's first constant is its docstring, or None where it has none (up to Python 3.11)
        if consts and (consts[0] is None or (doc is not None and consts[0] == doc)):
            consts = consts[1:]
        return repr((
            code.co_argcount, code.co_posonlyargcount, code.co_kwonlyargcount, code.co_flags, code.co_code.hex(),
            code.co_names, code.co_varnames, code.co_freevars, code.co_cellvars,
            tuple(self._code(c, None) if isinstance(c, types.CodeType) else self.value(c, ()) for c in consts),
        ))

    def value(self, v, names) -> str:
        if isinstance(v, Dispatcher):
            return f"jit {self.function(v.py_func)} {sorted(v.targetoptions.items())!r}"
        if isinstance(v, _Intrinsic):
            return f"intrinsic {self.function(v._defn)}"
        if isinstance(v, types.FunctionType) and _ours(v.__module__):
            return f"function {self.function(v)}"
        if isinstance(v, types.ModuleType):
            if not _ours(v.__name__):
                return f"module {v.__name__}"
            return f"module {v.__name__} " + " ".join(
                f"{n}={self.value(getattr(v, n), names)}" for n in names if hasattr(v, n)
            )
        if v is None or isinstance(v, (bool, int, float, complex, str, bytes)):
            return f"{type(v).__name__} {v!r}"
        if isinstance(v, (tuple, list)):
            return "(" + ", ".join(self.value(x, names) for x in v) + ")"
        if isinstance(v, np.ndarray):
            return f"array {v.dtype.str} {v.shape} {hashlib.sha256(np.ascontiguousarray(v).tobytes()).hexdigest()}"
        if isinstance(v, np.generic):
            return f"{v.dtype.str} {v!r}"
        if isinstance(v, (np.dtype, NumbaType)):
            return f"{type(v).__name__} {v!r}"
        if isinstance(v, type):
            return f"class {v.__module__}.{v.__qualname__} {getattr(v, '_fields', '')}"
        # anything else by its type only: a repr may hold a memory address
        return f"object {type(v).__module__}.{type(v).__qualname__}"


def _names(code: types.CodeType) -> set[str]:
    """Every name a code object and the code objects nested in it load (globals and attributes alike)."""
    found = set(code.co_names)
    for c in code.co_consts:
        if isinstance(c, types.CodeType):
            found |= _names(c)
    return found


def _ours(module: str) -> bool:
    return module == "tinsmith" or module.startswith("tinsmith.")


_digester = _Digester()


def digest(dispatcher) -> str:
    """SHA-256 of a jitted function's code, its jit options and everything it calls or reads (:class:`_Digester`)."""
    return hashlib.sha256(_digester.value(dispatcher, ()).encode()).hexdigest()


def dispatchers():
    """Every numba dispatcher defined at module level in an imported ``tinsmith`` module."""
    found = {}
    for name, module in list(sys.modules.items()):
        if module is None or not _ours(name):
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


def _write_index(path: Path, version, stamp, overloads) -> None:
    with open(path, "wb") as f:
        pickle.dump(version, f, protocol=-1)
        f.write(pickle.dumps((stamp, overloads), protocol=-1))


def build(dest: Path) -> dict:
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
    kernels = []
    for d in dispatchers():
        cf = _cache_file(d)
        index = Path(cf._index_path)
        if not d.overloads or not index.exists():
            continue
        _, _, overloads = _read_index(index)
        shutil.copyfile(index, dest / index.name)
        for data_name in overloads.values():
            shutil.copyfile(Path(cf._cache_path) / data_name, dest / data_name)
        kernels.append({"module": d.py_func.__module__, "function": d.py_func.__qualname__, "index": index.name,
                        "digest": digest(d)})
    kernels += _carried_over(dest, {(e["module"], e["function"]) for e in kernels})
    manifest = {**environment(), "cpu": "generic", "kernels": kernels}
    (dest / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n")
    return manifest


def _carried_over(dest: Path, stored: set) -> list[dict]:
    """Copy into ``dest`` the package's compiled kernels that this process did not load but that are still current.

    A kernel that only other kernels call is linked into their cache
    entries; when those load from the cache it is never loaded itself, yet
    it is needed whenever a caller compiles again.
    """
    carried = []
    for (module, function), entry in _shipped_kernels().items():
        d = getattr(sys.modules.get(module), function, None)
        if (module, function) in stored or not isinstance(d, Dispatcher) or digest(d) != entry["digest"]:
            continue
        try:
            _, _, overloads = _read_index(SHIPPED / entry["index"])
            for name in overloads.values():
                shutil.copyfile(SHIPPED / name, dest / name)
            shutil.copyfile(SHIPPED / entry["index"], dest / entry["index"])
        except OSError:
            continue
        carried.append(entry)
    return carried


def merge(parts: list[Path], dest: Path, extra: dict | None = None) -> dict:
    """Join the caches :func:`build` wrote in ``parts`` (from several processes) into ``dest``; return its manifest.

    A kernel compiled in several parts keeps every signature compiled in any
    of them (the first part's entry of a signature they share).  ``extra``:
    more fields for the manifest (the build records its jobs).
    """
    manifests = [json.loads((Path(p) / MANIFEST).read_text()) for p in parts]
    env = {k: v for k, v in manifests[0].items() if k != "kernels"}
    if any({k: v for k, v in m.items() if k != "kernels"} != env for m in manifests):
        raise ValueError("the parts were built in different environments")
    dest = Path(dest)
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    merged: dict[tuple[str, str], dict] = {}
    entries: dict[tuple[str, str], dict] = {}
    for part, manifest in zip(parts, manifests, strict=True):
        for entry in manifest["kernels"]:
            key = (entry["module"], entry["function"])
            first = merged.setdefault(key, entry)
            if first["digest"] != entry["digest"]:
                raise ValueError(f"{key[0]}.{key[1]} was built from two versions of its code")
            version, stamp, overloads = _read_index(Path(part) / entry["index"])
            have = entries.setdefault(key, {"version": version, "stamp": stamp, "overloads": {}})["overloads"]
            stem = first["index"][: -len(".nbi")]
            for sig_key, data_name in overloads.items():
                if sig_key not in have:
                    name = f"{stem}.{len(have) + 1}.nbc"
                    shutil.copyfile(Path(part) / data_name, dest / name)
                    have[sig_key] = name
    for key, entry in merged.items():
        e = entries[key]
        _write_index(dest / entry["index"], e["version"], e["stamp"], e["overloads"])
    manifest = {**env, **(extra or {}), "kernels": [merged[k] for k in sorted(merged)]}
    (dest / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n")
    return manifest


def read_manifest(folder: Path | None = None) -> dict | None:
    """The manifest of a built cache (default: the package's), or None when there is none (the build skipped it)."""
    try:
        return json.loads((Path(SHIPPED if folder is None else folder) / MANIFEST).read_text())
    except (OSError, ValueError):
        return None


def matches(manifest: dict) -> bool:
    """True when the cache was built by this numba, llvmlite, numpy, Python and platform."""
    return all(manifest.get(k) == v for k, v in environment().items())


def stale(manifest: dict) -> list[str]:
    """The kernels of ``manifest`` whose code (or a callee's) changed since it was built, as ``module.function``.

    Imports the modules of the manifest's kernels.
    """
    import importlib

    out = []
    for e in manifest["kernels"]:
        obj = importlib.import_module(e["module"])
        for part in e["function"].split("."):
            obj = getattr(obj, part, None)
        if obj is None or not hasattr(obj, "py_func") or digest(obj) != e["digest"]:
            out.append(f"{e['module']}.{e['function']}")
    return out


_shipped: dict | None = None
_local_codegen = None


def _shipped_kernels() -> dict:
    """{(module, qualname): manifest entry} of the shipped cache, or {} when there is none for this environment."""
    global _shipped
    if os.environ.get(DISABLE):
        return {}
    if _shipped is None:
        manifest = read_manifest()
        try:
            ok = manifest is not None and matches(manifest)
            _shipped = {(e["module"], e["function"]): e for e in manifest["kernels"]} if ok else {}
        except (KeyError, TypeError):
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

    Does nothing when there is no shipped cache of the kernel for this
    environment, when the kernel's digest differs from the one it was built
    from, when numba already has a current cache of it (a stale one, from an
    older source file, is replaced), or when that cache can't be written.
    """
    global _local_codegen
    f = dispatcher.py_func
    entry = _shipped_kernels().get((f.__module__, f.__qualname__))
    cf = _cache_file(dispatcher)
    if entry is None or cf is None or _current(cf) or digest(dispatcher) != entry["digest"]:
        return False
    index = SHIPPED / entry["index"]
    try:
        if _local_codegen is None:
            from numba.core.registry import cpu_target

            _local_codegen = cpu_target.target_context.codegen().magic_tuple()
        _, _, overloads = _read_index(index)
        dispatcher._cache._impl.locator.ensure_cache_path()
        rekeyed = {}
        for i, ((sig, _, hashes), data_name) in enumerate(overloads.items(), 1):
            name = cf._data_name(i)
            _atomic_copy(index.parent / data_name, Path(cf._cache_path) / name)
            # re-keyed to this machine's code generator: (signature, codegen, bytecode hashes)
            rekeyed[(sig, _local_codegen, hashes)] = name
        cf._save_index(rekeyed)
    except (OSError, pickle.UnpicklingError, ValueError, AttributeError, TypeError):
        return False
    return True


def seed_on_first_load(dispatcher) -> None:
    """Make numba call :func:`seed` for this kernel just before it first looks for it in its cache.

    Deferred from the decorator to the first call so that the digest sees
    the whole module (callees defined further down, modules imported later).
    """
    cache = getattr(dispatcher, "_cache", None)
    if cache is None or not hasattr(cache, "load_overload"):
        return
    load = cache.load_overload

    def load_overload(sig, target_context):
        cache.load_overload = load
        seed(dispatcher)
        return load(sig, target_context)

    cache.load_overload = load_overload


def _atomic_copy(src: Path, dst: Path) -> None:
    tmp = dst.with_name(f".{dst.name}.{os.getpid()}.tmp")
    shutil.copyfile(src, tmp)
    os.replace(tmp, dst)
