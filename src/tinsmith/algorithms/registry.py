"""The method registry: one record per method, read by the API, the CLI and the docs.

A method module declares itself with :func:`register`::

    @register("grid", description="...", options=[Option("k", int, 1, "...", minimum=1)])
    def grid(hf, *, k, progress):
        ...

The decorator returns the public function, whose contract is the same for
every method: ``method(data, *, max_error=None, max_vertices=None,
max_triangles=None, <its options>, progress=None) -> TerrainMesh``.  Every
call, direct or through :func:`simplify`, goes through the same validation:
option names, types and ranges, the input kind an option applies to, stop
rules (one the method cannot honour is refused by name), and the type of
the input.  It then records ``method``, ``options`` and the method's run
time in ``mesh.info``.  Deprecated option names and methods still work for
one release, with a :class:`DeprecationWarning` pointing at the caller.

The records themselves (:class:`Option`, :class:`Declaration`) live in
:mod:`.declaration`, below this module and :mod:`.catalogue`.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from .. import _deprecation, core
from ..core.stop import StopCriteria
from ..errors import InvalidInputError, InvalidOptionError, UnknownMethodError
from ..resources import check_memory, estimate_method
from .catalogue import DECLARED
from .declaration import GEOMETRY_KINDS, INPUT_TYPES, STOP_RULES, Declaration, Option, input_words
from .declaration import stop_rules as _rules

__all__ = ["DEFAULT_METHOD", "GEOMETRY_KINDS", "STOP_RULES", "Declaration", "Method", "Option", "declare",
           "fit_geometry", "get_method", "methods", "register", "simplify"]


def fit_geometry(record, kwargs: dict, data) -> None:
    """Every file option, in the method's own form (in place): geometries (a file, a GeoDataFrame, shapely
    geometries or arrays) reprojected, cleaned and clipped to ``data`` by :func:`tinsmith.io.geometry.prepare`;
    rasters given as a file read as a Heightfield (the method checks its grid)."""
    for opt in record.options:
        value = kwargs.get(opt.name)
        if opt.kind not in GEOMETRY_KINDS or value is None:
            continue
        if opt.kind == "raster":
            if isinstance(value, (str, bytes)) or hasattr(value, "__fspath__"):
                from ..io import read_heightfield

                kwargs[opt.name] = read_heightfield(value)
            continue
        from ..io.geometry import prepare

        kwargs[opt.name] = prepare(opt.kind, value, data, opt.name)


def _deprecated(message: str) -> None:
    """A DeprecationWarning attributed to the first caller outside this module (the user's line)."""
    _deprecation.warn(message, depth=0)


def _kind(data) -> str | None:
    """The input kind of a data object, as options name it (None for anything else)."""
    for kind, cls in (("heightfield", core.Heightfield), ("points", core.PointCloud), ("mesh", core.TerrainMesh)):
        if isinstance(data, cls):
            return kind
    return None


@dataclass(frozen=True)
class Method:
    """A registered method: its name, options, a one-line description, and the module that runs it.

    ``function`` (the public, validating function) imports ``module`` on
    first use, so listing methods and checking options import no method.
    """

    name: str
    description: str
    options: tuple[Option, ...]
    stop_rules: tuple[str, ...]  #: the stop rules honoured (empty: the method takes none)
    input: str
    paper: str
    module: str = field(default="", repr=False)
    exact_budget: bool = False  #: max_vertices is met exactly (the method places that many vertices)
    legacy: Mapping[str, str] = field(default_factory=dict, repr=False)  #: deprecated keyword -> what instead
    deprecated: str = ""  #: non-empty: the method is deprecated (what to use instead)

    def describe_stop_rules(self) -> str:
        """The stop rules in words, as help texts and errors give them."""
        if not self.stop_rules:
            return "no stop rule"
        words = ", ".join(self.stop_rules)
        return words + (" (the number of vertices it places)" if self.exact_budget else "")

    @property
    def function(self) -> Callable:
        func = _FUNCTIONS.get(self.name)
        if func is None:
            importlib.import_module(self.module)
            func = _FUNCTIONS[self.name]
        return func

    def option(self, name: str) -> Option:
        for opt in self.options:
            if opt.name == name:
                return opt
        raise KeyError(name)

    def current_options(self) -> tuple[Option, ...]:
        """The options under their current names (no deprecated name): the signature's and the docs'."""
        return tuple(o for o in self.options if not o.replaced_by)

    def accepted(self) -> list[str]:
        """Every keyword the method accepts under its current name."""
        return [o.name for o in self.current_options()] + list(self.stop_rules)

    def bind(self, kwargs: dict, data=None) -> tuple[dict, StopCriteria | None]:
        """Validate keyword arguments; return (options with defaults, stop rules).

        With ``data`` the options limited to one input kind are checked
        against it too.  Deprecated names are accepted with a warning.
        """
        options, stop, _ = self._bind(kwargs, data)
        return options, stop

    def _bind(self, kwargs: dict, data=None) -> tuple[dict, StopCriteria | None, dict]:
        """:meth:`bind`, and the legacy keywords given (for the method's code)."""
        kwargs = dict(kwargs)
        legacy = {}
        for name, instead in self.legacy.items():
            if name in kwargs:
                _deprecated(f"{name} of {self.name} is deprecated and will be removed: {instead}")
                legacy[name] = kwargs.pop(name)
        self._rename(kwargs)
        kwargs = {k: v for k, v in kwargs.items() if not (k in STOP_RULES and v is None)}
        given_stop = {k: kwargs[k] for k in STOP_RULES if k in kwargs}
        stop = StopCriteria(**given_stop)  # bad values are reported before misplaced names
        if given_stop and not self.stop_rules:
            raise InvalidOptionError(
                f"method {self.name!r} takes no stop rules, got {', '.join(given_stop)}; "
                "choose a simplifying method (see `tinsmith methods`)"
            )
        foreign = [k for k in given_stop if k not in self.stop_rules]
        if foreign:
            raise InvalidOptionError(
                f"method {self.name!r} takes {self.describe_stop_rules()}, not {', '.join(foreign)}"
            )
        accepted = self.accepted()
        unknown = sorted(set(kwargs) - set(accepted))
        if unknown:
            valid = ", ".join(accepted) if accepted else "none"
            raise InvalidOptionError(
                f"method {self.name!r} has no option {unknown[0]!r}; its options are: {valid}"
            )
        self._check_input_kind(kwargs, data)
        options = {o.name: o.validate(kwargs.get(o.name, o.default)) for o in self.current_options()}
        return options, (stop if self.stop_rules else None), legacy

    def _rename(self, kwargs: dict) -> None:
        """Deprecated option names given in ``kwargs``: checked under their own name, moved to the new one."""
        for opt in self.options:
            if not opt.replaced_by or opt.name not in kwargs:
                continue
            given = kwargs.pop(opt.name)
            if given is None:  # a flag the user did not type
                continue
            _deprecated(f"{opt.name} of {self.name} is deprecated and will be removed: use {opt.replaced_by}")
            value = opt.validate(given)
            if kwargs.get(opt.replaced_by) not in (None, value):
                raise InvalidOptionError(
                    f"{opt.name} (deprecated) and {opt.replaced_by} name the same thing and differ: "
                    f"{value!r} and {kwargs[opt.replaced_by]!r}; give {opt.replaced_by} alone"
                )
            kwargs[opt.replaced_by] = value

    def _check_input_kind(self, kwargs: dict, data) -> None:
        """Refuse an option given for one input kind with another (``workers`` with a point cloud)."""
        kind = _kind(data)
        for opt in self.current_options():
            value = kwargs.get(opt.name)
            if not opt.applies_to(kind) and value is not None and value != opt.default:
                raise InvalidOptionError(
                    f"option {opt.name!r} of method {self.name!r} applies to a {input_words(opt.input)} only; "
                    f"the input is a {type(data).__name__}"
                )


_REGISTRY: dict[str, Method] = {}
_DEPRECATED: dict[str, Method] = {}
_FUNCTIONS: dict[str, Callable] = {}


def _check_record(name: str, options, input: str) -> None:
    if input not in INPUT_TYPES:
        raise ValueError(f"input must be one of {sorted(INPUT_TYPES)}")
    for opt in options:
        if opt.input is not None and opt.input not in INPUT_TYPES:
            raise ValueError(f"option {opt.name!r} of {name!r}: input must be one of {sorted(INPUT_TYPES)}")
        for other in [*_REGISTRY.values(), *_DEPRECATED.values()]:
            for o in other.options:
                if o.name == opt.name and o.type is not opt.type:
                    raise ValueError(
                        f"option {opt.name!r} of {name!r} has type {opt.type.__name__}, "
                        f"but {other.name!r} already uses it as {o.type.__name__}"
                    )


def declare(d: Declaration) -> Method:
    """List a method without importing it; its module implements it with ``@register(d.name)``."""
    if d.name in _REGISTRY or d.name in _DEPRECATED:
        raise ValueError(f"method {d.name!r} is registered twice")
    options = tuple(d.options)
    _check_record(d.name, options, d.input)
    record = Method(name=d.name, description=d.description, options=options, stop_rules=_rules(d.stop_rules),
                    input=d.input, paper=d.paper, module=d.module, exact_budget=d.exact_budget,
                    legacy=dict(d.legacy), deprecated=d.deprecated)
    (_DEPRECATED if d.deprecated else _REGISTRY)[d.name] = record
    return record


def register(
    name: str,
    *,
    description: str | None = None,
    options=(),
    stop_rules: bool | tuple[str, ...] = True,
    input: str = "heightfield",
    paper: str = "",
    exact_budget: bool = False,
) -> Callable[[Callable[..., Any]], Callable[..., core.TerrainMesh]]:
    """Register a method; returns a decorator that gives back the public function.

    The decorated function receives the input positionally and its options as
    keywords, plus ``stop`` (a :class:`StopCriteria`, when ``stop_rules``),
    ``progress`` (a callable ``progress(fraction)`` or None) and the legacy
    keywords of its declaration that the caller gave.  A method declared in
    :mod:`.catalogue` is registered by name alone (its record is the
    declaration); any other takes its description and options here.
    """
    if description is None:
        declared = _REGISTRY.get(name) or _DEPRECATED.get(name)
        if declared is None or not declared.module:
            raise ValueError(f"method {name!r} is not declared; give its description and options")
        if name in _FUNCTIONS:
            raise ValueError(f"method {name!r} is registered twice")
    else:
        if name in _REGISTRY or name in _DEPRECATED:
            raise ValueError(f"method {name!r} is registered twice")
        declared = None
        options = tuple(options)
        _check_record(name, options, input)

    def decorate(func: Callable[..., Any]) -> Callable[..., core.TerrainMesh]:
        record = declared or Method(name=name, description=description, options=options,
                                    stop_rules=_rules(stop_rules), input=input, paper=paper, module=func.__module__,
                                    exact_budget=exact_budget)

        @functools.wraps(func)
        def public(data, *, progress=None, **kwargs):
            data = _as_input(record, data)
            opts, stop, legacy = record._bind(kwargs, data)  # bad options fail before any vector is read
            fit_geometry(record, opts, data)
            _check_memory(record, data, opts, stop)
            call = {**opts, **legacy}
            if record.stop_rules:
                call["stop"] = stop
            start = time.perf_counter()
            result = func(data, progress=progress, **call)
            elapsed = time.perf_counter() - start
            mesh = result[0] if isinstance(result, tuple) else result  # a legacy keyword's richer return
            mesh.info["method"] = record.name
            mesh.info["options"] = {**opts, **(stop.as_dict() if stop else {})}
            mesh.info.setdefault("timings", {})["method"] = elapsed
            return result

        public.__signature__ = _signature(record)
        public.__doc__ = _document(func.__doc__ or "", record)
        if not record.deprecated:
            _REGISTRY[name] = record
        _FUNCTIONS[name] = public
        return public

    return decorate


def _as_input(record: Method, data):
    """``data`` as the method takes it: GIS-stack objects converted, (N, 3) arrays made clouds; else refused."""
    expected = tuple(getattr(core, t) for t in INPUT_TYPES[record.input])
    if not isinstance(data, expected):  # an xarray DataArray, a rasterio dataset, a laspy LasData, ...
        from ..io.interop import as_data

        data = as_data(data)
    if not isinstance(data, expected) and record.input == "points" and (
            isinstance(data, (list, tuple)) or hasattr(data, "__array__")):
        data = core.PointCloud(data)  # x, y, z rows: its own errors name a wrong shape
    if not isinstance(data, expected):
        raise InvalidInputError(f"method {record.name!r} takes a {input_words(record.input)}, got {type(data).__name__}")
    return data


def _signature(record: Method) -> inspect.Signature:
    """``(data, /, *, max_error=None, max_vertices=None, max_triangles=None, <options>, progress=None)``."""
    keyword = inspect.Parameter.KEYWORD_ONLY
    params = [inspect.Parameter("data", inspect.Parameter.POSITIONAL_ONLY)]
    params += [inspect.Parameter(k, keyword, default=None) for k in STOP_RULES]
    params += [inspect.Parameter(o.name, keyword, default=o.default) for o in record.current_options()]
    params.append(inspect.Parameter("progress", keyword, default=None))
    return inspect.Signature(params, return_annotation=core.TerrainMesh)


def _check_memory(record: Method, data, opts: dict, stop) -> None:
    """Refuse a run whose estimated memory (input size, requested vertices) cannot fit, before it allocates."""
    key = record.name
    if isinstance(data, core.Heightfield):
        size, unit = data.n_cells, f"{data.shape[0]:,} x {data.shape[1]:,} cells"
    elif isinstance(data, core.PointCloud):
        size, unit, key = len(data), f"{len(data):,} points", f"{record.name}:points"
    else:
        size, unit = data.n_vertices, f"a mesh of {data.n_vertices:,} vertices"
    requested = 0  # the methods whose vertex count is chosen up front: remesh's exact count, cvt's sites
    if record.name == "remesh":
        requested = stop.max_vertices or 0
    elif record.name == "cvt" and isinstance(data, core.Heightfield):
        asked = stop.max_vertices if stop is not None and stop.max_vertices else round(opts["ratio"] * data.n_valid)
        requested = min(asked, data.n_valid)
    hint = {
        "remesh": "ask for fewer vertices (max_vertices)",
        "cvt": "ask for fewer vertices (--max-vertices or --ratio)",
    }.get(record.name, "'tinsmith tile' meshes a DEM of any size in windows, in bounded memory")
    what = f"method {record.name!r} on {unit}" + (f" with {requested:,} vertices" if requested else "")
    check_memory(estimate_method(key, size, requested), what, hint)


_RULE_DOCS = {
    "max_error": "Stop when the largest vertical error is at most this (z units).",
    "max_vertices": "Stop before the mesh would exceed this many vertices.",
    "max_triangles": "Stop before the mesh would exceed this many triangles.",
}


def _document(doc: str, record: Method) -> str:
    """Append a numpydoc Parameters section built from the option records."""
    lines = [inspect.cleandoc(doc), "", "Parameters", "----------"]
    lines += ["data : " + input_words(record.input), "    The input."]
    for rule in STOP_RULES:
        if rule not in record.stop_rules:
            continue
        text = "The number of vertices to place." if rule == "max_vertices" and record.exact_budget else _RULE_DOCS[rule]
        lines += [f"{rule} : {'float' if rule == 'max_error' else 'int'}, optional", "    " + text]
    refused = [r for r in STOP_RULES if r not in record.stop_rules]
    if refused:
        lines += [", ".join(refused), "    Not honoured by this method: giving one raises InvalidOptionError."]
    for o in record.current_options():
        lines += [f"{o.name} : {o.type.__name__}, optional", "    " + o.describe().replace("|", "\\|")]  # RST
    lines += [
        "progress : callable, optional",
        "    Called with the fraction done (0..1) as the run advances.",
        "",
        "Returns",
        "-------",
        "TerrainMesh",
    ]
    return "\n".join(lines)


def methods(deprecated: bool = False) -> list[Method]:
    """Every registered method, in registration order; with ``deprecated`` the deprecated ones after them.

    Examples
    --------
    >>> import tinsmith
    >>> names = [record.name for record in tinsmith.methods()]
    >>> names[:3]
    ['grid', 'greedy', 'subsample']
    >>> all(record.description for record in tinsmith.methods())
    True
    """
    return list(_REGISTRY.values()) + (list(_DEPRECATED.values()) if deprecated else [])


def get_method(name: str) -> Method:
    """The record of ``name``; :class:`UnknownMethodError` lists the valid names.

    A deprecated method's record is returned with a :class:`DeprecationWarning`.

    Examples
    --------
    >>> import tinsmith
    >>> record = tinsmith.get_method("quadtree")
    >>> record.stop_rules, record.input
    (('max_error', 'max_vertices', 'max_triangles'), 'heightfield')
    >>> record.function is tinsmith.quadtree
    True
    >>> tinsmith.get_method("marching")
    Traceback (most recent call last):
    ...
    tinsmith.errors.UnknownMethodError: unknown method 'marching'; choose one of: ...
    """
    if isinstance(name, str) and name in _DEPRECATED:
        record = _DEPRECATED[name]
        _deprecated(f"method {name!r} is deprecated and will be removed: {record.deprecated}")
        return record
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        valid = ", ".join(sorted(_REGISTRY))
        raise UnknownMethodError(f"unknown method {name!r}; choose one of: {valid}") from None


#: The method ``simplify`` uses when none is named.
DEFAULT_METHOD = "greedy"


def simplify(data, method: str | None = None, *, progress=None, **options) -> core.TerrainMesh:
    """Turn ``data`` into a mesh with a registered method.

    Parameters
    ----------
    data : Heightfield, PointCloud or TerrainMesh
        The input of the method (see :func:`methods` for what each takes).
    method : str, optional
        A name from :func:`methods`; default :data:`DEFAULT_METHOD`.
    progress : callable, optional
        Called with the fraction done (0..1).
    **options
        The method's options and stop rules (``max_error``, ``max_vertices``,
        ``max_triangles``); unknown names, and stop rules the method cannot
        honour, raise :class:`InvalidOptionError`.

    Returns
    -------
    TerrainMesh
        The same as ``tinsmith.<method>(data, **options)``.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> mesh = tinsmith.simplify(dem, max_error=10.0)  # the default method, greedy insertion
    >>> mesh.info["method"], tinsmith.vertical_error(mesh, dem)["max"] <= 10.0
    ('greedy', True)
    >>> tinsmith.simplify(dem, method="subsample", step=4).n_vertices  # 17 x 17 of the 64 x 64 cells
    289
    """
    record = get_method(DEFAULT_METHOD if method is None else method)
    return record.function(data, progress=progress, **options)


for _declaration in DECLARED:
    declare(_declaration)
del _declaration
