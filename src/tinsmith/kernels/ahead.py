"""Kernels compiled ahead of time: a point cloud's TIN without numba in the process.

numba's start costs a fresh process about half a second (its import, the
import of SciPy's linear algebra that its array functions make to find a
BLAS, and the loading of every cached kernel), which a TIN of 40,000 points
(20-30 ms) pays on its first call.  So the package build also compiles the
kernels of that path (:data:`ENTRIES`) into one extension module with numba's
ahead-of-time compiler (``numba.pycc``): the same code and the same flags as
the jit kernels (``nogil`` releases the GIL, so the workers' threads run at
once), for the generic CPU as the portable cache is (see
``build_backend/`` and :mod:`.ahead_build`).  It lies beside this module as
``_ahead`` (the extension, named for this Python) and ``_ahead.json`` (what
it was built from).  Nothing compiled is kept in the repository.

:func:`load` gives a kernel module's functions by name: the compiled one when
the extension holds it, was built from these very kernel sources for this
numpy, and the call's arguments are exactly of the types it was compiled for
(checked at every call: the compiled code checks nothing and would read an
array of another type as its own); else the jit kernel, which imports numba.
Its module's numeric constants come from the manifest; anything else loads
the module.  Same code and flags, so the same results bit for bit (tested
against the jit kernels).  ``TINSMITH_NO_AHEAD=1`` turns it off.

This module imports no numba.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.machinery
import importlib.util
import json
import os
import sys
import threading
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
NAME = "_ahead"
#: set to any non-empty value: use the jit kernels only
DISABLE = "TINSMITH_NO_AHEAD"

# Types of the signatures, in numba's notation (evaluated against ``numba.types`` by the build).  An array
# a kernel only reads is declared read-only, which takes a writable one too.
_F1, _I1, _I4, _U1, _B1 = "float64[::1]", "int64[::1]", "int32[::1]", "uint8[::1]", "boolean[::1]"
_READ_F1 = "Array(float64, 1, 'A', readonly=True)"  # a column of the points, e.g. xyz[:, 0]
_READ_F2 = "Array(float64, 2, 'C', readonly=True)"
_READ_I4 = "Array(int32, 1, 'C', readonly=True)"
#: the triangulation's buffers (:func:`tinsmith.triangulation.delaunay.buffers`)
_M = f"Tuple(({_F1}, {_F1}, {_I4}, {_I4}, {_U1}, {_I4}, {_U1}, {_I4}, {_U1}, {_I1}))"

#: ``module:function`` -> signature (or signatures) of each kernel compiled ahead of time: the path of
#: :func:`tinsmith.tin` (point cloud to TIN, in strips on threads or in one piece, whose duplicates map is
#: int64 where the strips' is int32).
ENTRIES = {
    "tinsmith.kernels.predicates:orient2d": "float64(float64, float64, float64, float64, float64, float64)",
    "tinsmith.kernels.tin:seeded_permutation": "int64[::1](int64)",
    "tinsmith.kernels.tin:brio_order": f"int64[::1]({_READ_F2}, {_I1}, {_I1}, int64)",
    "tinsmith.kernels.tin:first_in_front": f"none({_I1}, {_I1})",
    "tinsmith.kernels.tin:triangulate": f"int64({_M}, {_I1}, {_I4}, {_I1}, int64)",
    "tinsmith.kernels.tin:label_components": f"int32[::1]({_M})",
    "tinsmith.kernels.strips:ranked": f"float64[::1]({_READ_F1}, {_I1})",
    "tinsmith.kernels.strips:strip_starts": f"int64[::1]({_READ_F1}, Array(float64, 1, 'C', readonly=True))",
    "tinsmith.kernels.strips:strip_ids": f"int32[::1]({_READ_F1}, float64, float64, int64)",
    "tinsmith.kernels.strips:final_triangles": f"uint8[::1]({_M}, float64, float64, int64)",
    "tinsmith.kernels.strips:gather": f"Tuple((int64, int64[:, ::1]))({_M}, {_U1}, {_READ_I4}, {_I4}, {_I4}, int64, {_U1})",
    "tinsmith.kernels.strips:close_up": f"int64({_I4}, {_I4}, {_I1}, {_I1})",
    "tinsmith.kernels.strips:frontier_walls": f"int64({_M}, {_I1}, {_I1}, {_I1})",
    "tinsmith.kernels.strips:copy_kept": f"int64({_M}, {_U1}, {_I1}, {_I4}, {_I4}, int64)",
    "tinsmith.kernels.strips:merged_count": (f"int64({_READ_I4})", "int64(Array(int64, 1, 'C', readonly=True))"),
    "tinsmith.kernels.strips:hull_turns_left": f"boolean({_READ_I4}, {_READ_I4}, int64, {_READ_F1}, {_READ_F1})",
    "tinsmith.kernels.strips:lowest_duplicates": (f"int64({_I4}, int64, {_I4}, {_I4})", f"int64({_I4}, int64, {_I4}, {_I1})"),
    "tinsmith.kernels.pointtin:xy_covariance": f"UniTuple(float64, 3)({_READ_F2})",
    "tinsmith.kernels.pointtin:folded_heights": (f"Tuple(({_I1}, {_F1}))({_READ_I4}, {_READ_F1}, int64)",
                                                 f"Tuple(({_I1}, {_F1}))(Array(int64, 1, 'C', readonly=True), "
                                                 f"{_READ_F1}, int64)"),
    "tinsmith.kernels.pointtin:edge_counts":
        f"int64[::1]({_READ_F1}, {_READ_F1}, {_READ_I4}, int64, Array(int64, 2, 'C', readonly=True), float64, float64)",
    "tinsmith.kernels.pointtin:edge_middle":
        f"float64[::1]({_READ_F1}, {_READ_F1}, {_READ_I4}, int64, Array(int64, 2, 'C', readonly=True), float64, "
        "float64, int64, int64, int64)",
    "tinsmith.kernels.pointtin:short_triangles": f"boolean[::1]({_READ_F1}, {_READ_F1}, {_READ_I4}, int64, float64)",
    "tinsmith.kernels.pointtin:kept_mesh":
        f"Tuple(({_B1}, int64))({_READ_I4}, Array(boolean, 1, 'C', readonly=True), int64, int32[:, ::1])",
    "tinsmith.kernels.pointtin:used_points":
        f"float64[:, ::1]({_READ_F2}, Array(boolean, 1, 'C', readonly=True), Array(int64, 1, 'C', readonly=True), "
        "Array(float64, 1, 'C', readonly=True))",
}


def signatures(entry: str) -> tuple[str, ...]:
    """The signatures of ``entry`` in :data:`ENTRIES`, as a tuple."""
    value = ENTRIES[entry]
    return (value,) if isinstance(value, str) else tuple(value)


def symbol(entry: str, i: int = 0) -> str:
    """The extension's name for signature ``i`` of ``module:function`` (``tin__triangulate_0``)."""
    module, function = entry.split(":")
    return f"{module.rsplit('.', 1)[1]}__{function}_{i}"


def sources_digest(files) -> str:
    """SHA-256 of the kernel modules ``files`` (names in this folder): those whose code the extension holds."""
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0" + (HERE / name).read_bytes() + b"\0")
    return h.hexdigest()


def environment() -> dict:
    """What the extension depends on besides the sources: numpy's version (its C interface) and Python's."""
    return {"numpy": np.__version__, "python": f"{sys.version_info[0]}.{sys.version_info[1]}"}


# ----------------------------------------------------------------------------------------------------------
# The argument checks, from the specs the build writes (a list a signature): ["array", dtype, ndim, c_contiguous, writable],
# ["tuple", [spec, ...]], ["int"], ["float"], ["bool"].


def _check(spec):
    kind = spec[0]
    if kind == "array":
        dtype, ndim, contiguous, writable = np.dtype(spec[1]), spec[2], spec[3], spec[4]

        def array(a):
            if type(a) is not np.ndarray or a.dtype != dtype or a.ndim != ndim:
                return False
            flags = a.flags
            return flags.aligned and (flags.c_contiguous or not contiguous) and (flags.writeable or not writable)

        return array
    if kind == "tuple":
        items = [_check(s) for s in spec[1]]
        return lambda t: type(t) is tuple and len(t) == len(items) and all(c(v) for c, v in zip(items, t, strict=True))
    if kind == "int":
        return lambda v: isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
    if kind == "float":
        return lambda v: type(v) is float or type(v) is np.float64
    if kind == "bool":
        return lambda v: type(v) is bool or type(v) is np.bool_
    raise ValueError(f"unknown argument spec {spec!r}")


def _guarded(compiled: list, specs: list, module: str, name: str):
    """The first of ``compiled`` (one a signature) whose argument types ``specs`` the call's are, else the jit
    kernel ``module.name``."""
    overloads = [(len(s), [_check(a) for a in s], f) for f, s in zip(compiled, specs, strict=True)]

    def kernel(*args):
        for n, checks, f in overloads:
            if len(args) == n and all(c(a) for c, a in zip(checks, args, strict=True)):
                return f(*args)
        return getattr(importlib.import_module(module), name)(*args)

    kernel.__name__ = kernel.__qualname__ = name
    kernel.__doc__ = f"``{module}.{name}``, compiled ahead of time (:mod:`tinsmith.kernels.ahead`)."
    kernel.compiled = compiled
    return kernel


_state: dict = {}
_lock = threading.Lock()


def _extension():
    """``(module, manifest)`` of the compiled extension when it is there and current, else ``(None, None)``."""
    if "ext" not in _state:
        with _lock:  # kernels are first looked up on the workers' threads too
            if "ext" not in _state:
                _state["ext"] = (None, None) if os.environ.get(DISABLE) else load_extension(HERE)
    return _state["ext"]


def current_manifest(folder: Path) -> dict | None:
    """The manifest of the extension in ``folder`` when the extension is there and was built from these kernel
    sources for this environment, else None."""
    try:
        manifest = json.loads((Path(folder) / f"{NAME}.json").read_text())
        path = Path(folder) / manifest["file"]
        current = (manifest["environment"] == environment() and manifest["sources"] == sources_digest(manifest["files"])
                   and path.name.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES)) and path.is_file())
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return manifest if current else None


def load_extension(folder: Path):
    """``(module, manifest)`` of the extension in ``folder`` when it is current (:func:`current_manifest`) and
    loads, else ``(None, None)``."""
    manifest = current_manifest(folder)
    if manifest is None:
        return None, None
    path = Path(folder) / manifest["file"]
    try:
        spec = importlib.util.spec_from_file_location(f"{__package__}.{NAME}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except (ImportError, OSError):  # e.g. built against another C library: the jit kernels serve
        return None, None
    return module, manifest


def available() -> bool:
    """Whether the compiled extension is there, current and in use."""
    return _extension()[0] is not None


class Kernels:
    """A kernel module's functions, compiled ahead of time where they can be (see the module's docstring)."""

    def __init__(self, module: str):
        self._module = module

    def __getattr__(self, name: str):
        if name.startswith("__"):
            raise AttributeError(name)
        ext, manifest = _extension()
        entry = f"{self._module}:{name}"
        if ext is not None and entry in manifest["entries"]:
            specs = manifest["entries"][entry]
            compiled = [getattr(ext, symbol(entry, i)) for i in range(len(specs))]
            value = _guarded(compiled, specs, self._module, name)
        elif ext is not None and name in manifest["constants"].get(self._module, {}):
            value = manifest["constants"][self._module][name]
        else:
            value = getattr(importlib.import_module(self._module), name)
        setattr(self, name, value)
        return value

    def __repr__(self):
        return f"<kernels of {self._module}{' (ahead of time)' if available() else ''}>"


_loaded: dict = {}


def load(module: str) -> Kernels:
    """The functions and constants of the kernel module ``module`` (e.g. ``"tinsmith.kernels.tin"``); one
    :class:`Kernels` a module, whichever caller asks, so each kernel's argument checks are made once."""
    return _loaded.setdefault(module, Kernels(module))
