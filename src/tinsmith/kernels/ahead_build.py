"""Compile the kernels of :data:`.ahead.ENTRIES` ahead of time into an extension module (run by the package build).

numba's ahead-of-time compiler (``numba.pycc``) compiles each entry for its
signature, with the flags of its jit decorator (``nogil``: the GIL released
around the call; the error model; numba's reference counting or not), for the
generic CPU of the architecture, and links them, with numba's small runtime,
into one extension module that needs numpy but not numba.  A C compiler is
needed for that link; without one the build says so and the jit kernels are
used.  Writes ``_ahead.<suffix>`` and ``_ahead.json`` (:mod:`.ahead`) into
``dest`` (default: beside :mod:`.ahead`).
"""

from __future__ import annotations

import contextlib
import importlib
import json
import os
import sys
import tempfile
import warnings
from pathlib import Path

from . import ahead


def _spec(ty) -> list:
    """The argument check of a numba type (:func:`.ahead._check`)."""
    from numba.core import types

    if isinstance(ty, types.Array):
        return ["array", str(ty.dtype), ty.ndim, ty.layout == "C", ty.mutable]
    if isinstance(ty, types.BaseTuple):
        return ["tuple", [_spec(t) for t in ty]]
    if isinstance(ty, types.Boolean):
        return ["bool"]
    if isinstance(ty, types.Integer):
        return ["int"]
    if isinstance(ty, types.Float):
        return ["float"]
    raise TypeError(f"no argument check for the numba type {ty}")


def _constants(module) -> dict:
    """The module's upper-case numbers (what callers read from a kernel module besides its kernels)."""
    return {k: v for k, v in vars(module).items()
            if k.isupper() and isinstance(v, (int, float)) and not isinstance(v, bool)}


def _current(folder: Path) -> bool:
    """Whether ``folder`` holds an extension built from these kernel sources, for this environment and numba."""
    import numba

    manifest = ahead.current_manifest(folder)
    return manifest is not None and manifest.get("numba") == numba.__version__


def _copy_built(src: Path, dest: Path) -> Path:
    """Copy the extension and its manifest from ``src`` to ``dest``, each file atomically, the manifest last."""
    manifest = json.loads((src / f"{ahead.NAME}.json").read_text())
    dest.mkdir(parents=True, exist_ok=True)
    for name in (manifest["file"], f"{ahead.NAME}.json"):
        tmp = dest / f".{name}.{os.getpid()}.tmp"
        tmp.write_bytes((src / name).read_bytes())
        os.replace(tmp, dest / name)
    return dest / manifest["file"]


def build(dest: Path | None = None, reuse: Path | None = None, log=print) -> Path:
    """Compile the entries into ``dest`` (a folder; default beside :mod:`.ahead`); returns the extension's path.

    ``reuse``: a folder where an earlier build left its extension; taken as
    it is when it is current (same kernel sources, numpy, Python, numba),
    else replaced by this build's.
    """
    dest = Path(dest) if dest is not None else ahead.HERE
    if reuse is not None and _current(Path(reuse)):
        target = _copy_built(Path(reuse), dest)
        log(f"tinsmith: the kernels compiled ahead of time by an earlier build reused from {reuse}")
        return target
    target = _compile(dest, log)
    if reuse is not None:
        with contextlib.suppress(OSError):  # a cache: the build does not depend on it
            _copy_built(dest, Path(reuse))
    return target


def _compile(dest: Path, log) -> Path:
    import numba
    from numba.core import cpu, types
    from numba.core.errors import NumbaPendingDeprecationWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NumbaPendingDeprecationWarning)
        import numba.pycc.compiler as pycc_compiler
        from numba.pycc import CC

    namespace = vars(types)
    flags_of, entries, constants = {}, {}, {}
    with tempfile.TemporaryDirectory(prefix="tinsmith-ahead-") as tmp:
        cc = CC(ahead.NAME)
        cc.output_dir = tmp
        for entry in ahead.ENTRIES:
            module_name, function = entry.split(":")
            module = importlib.import_module(module_name)
            dispatcher = getattr(module, function)
            if not isinstance(dispatcher, numba.core.dispatcher.Dispatcher):
                raise TypeError(f"{entry} is not a numba kernel")
            flags_of[dispatcher.py_func] = {k: v for k, v in dispatcher.targetoptions.items() if k != "cache"}
            entries[entry] = []
            for i, text in enumerate(ahead.signatures(entry)):
                signature = eval(text, {}, namespace)  # noqa: S307  (our own literal signatures, numba's notation)
                cc.export(ahead.symbol(entry, i), signature)(dispatcher.py_func)
                entries[entry].append([_spec(t) for t in signature.args])
            constants[module_name] = _constants(module)

        compile_extra = pycc_compiler.compile_extra

        def with_kernel_flags(typingctx, targetctx, func, args, return_type, flags, locals, library):
            # pycc compiles every entry with one set of flags: give each its jit decorator's own
            own = flags.copy()
            cpu.CPUTargetOptions.parse_as_flags(own, flags_of[func])
            own.no_compile = True
            return compile_extra(typingctx, targetctx, func, args, return_type, own, locals=locals, library=library)

        pycc_compiler.compile_extra = with_kernel_flags
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", NumbaPendingDeprecationWarning)
                cc.compile()
        finally:
            pycc_compiler.compile_extra = compile_extra
        # the kernel modules whose code the entries can hold: those loaded to compile them
        files = sorted(f"{name.rsplit('.', 1)[1]}.py" for name, module in sys.modules.items()
                       if name.startswith(f"{__package__}.") and getattr(module, "__file__", "").endswith(".py"))
        manifest = {"environment": ahead.environment(), "files": files, "sources": ahead.sources_digest(files),
                    "numba": numba.__version__, "cpu": "generic", "file": Path(cc.output_file).name,
                    "entries": entries, "constants": constants}
        (Path(tmp) / f"{ahead.NAME}.json").write_text(json.dumps(manifest, indent=1, sort_keys=True))
        target = _copy_built(Path(tmp), dest)
    log(f"tinsmith: {len(entries)} kernels compiled ahead of time into {target.name}")
    return target


if __name__ == "__main__":
    build(Path(sys.argv[1]) if len(sys.argv) > 1 else None, Path(sys.argv[2]) if len(sys.argv) > 2 else None)
