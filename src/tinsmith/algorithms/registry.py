"""The method registry: one record per method, read by the API, the CLI and the docs.

A method module declares itself with :func:`register`::

    @register("grid", description="...", options=[Option("k", int, 1, "...", minimum=1)])
    def grid(hf, *, k, progress):
        ...

The decorator returns the public function.  Every call, direct or through
:func:`simplify`, goes through the same validation: option names, types and
ranges, stop rules, and the type of the input.  It then records ``method``,
``options`` and the method's run time in ``mesh.info``.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from .. import _checks, core
from ..core.stop import StopCriteria
from ..errors import InvalidInputError, InvalidOptionError, UnknownMethodError
from ..resources import check_memory, estimate_method

__all__ = ["Declaration", "Method", "Option", "declare", "get_method", "methods", "register", "simplify", "STOP_RULES"]

#: Names of the stop rules shared by every refining or decimating method.
STOP_RULES = ("max_error", "max_vertices", "max_triangles")

#: input kind -> the names of the data-model classes a method of that kind takes (resolved when it runs)
_INPUT_TYPES = {
    "heightfield": ("Heightfield",),
    "mesh": ("TerrainMesh",),
    "surface": ("Heightfield", "TerrainMesh"),
    "elevation": ("Heightfield", "PointCloud"),
    "points": ("PointCloud",),
}


#: Option kinds that take geometries (world coordinates in the API, a vector file on the command line).
GEOMETRY_KINDS = ("lines", "points", "polygons", "regions")


def fit_geometry(record, kwargs: dict, data) -> None:
    """Every geometry option (a file, a GeoDataFrame, shapely geometries or arrays) reprojected, cleaned and
    clipped to ``data``, in the method's own form (in place): :func:`tinsmith.io.geometry.prepare`."""
    for opt in record.options:
        if opt.kind in GEOMETRY_KINDS and kwargs.get(opt.name) is not None:
            from ..io.geometry import prepare

            kwargs[opt.name] = prepare(opt.kind, kwargs[opt.name], data, opt.name)


def _input_name(input: str) -> str:
    return " or ".join(_INPUT_TYPES[input])


@dataclass(frozen=True)
class Option:
    """A typed, validated, documented option of a method.

    Parameters
    ----------
    name : str
        Python keyword; the CLI flag is ``--name-with-dashes``.
    type : {float, int, bool, str, object}
        Value type; ``object`` for geometry inputs (see ``kind``), which the
        method itself checks.
    default : Any
        Value when not given (``None`` means "not set").
    doc : str
        One sentence for the docs and ``--help``; give the unit.
    minimum, maximum : float, optional
        Bounds for numbers; ``exclusive_min`` makes the lower bound strict.
    choices : tuple of str, optional
        Allowed values for strings.
    kind : {"value", "lines", "points", "polygons", "regions"}
        "lines", "points" and "polygons" mark geometry inputs: arrays or
        shapely geometries in world coordinates in the API, a vector file on
        the command line; "regions" polygons with attributes (``max_area``,
        ``name``): (polygon, max_area, name) items in the API.
    """

    name: str
    type: type
    default: Any
    doc: str
    minimum: float | None = None
    maximum: float | None = None
    exclusive_min: bool = False
    choices: tuple[str, ...] | None = None
    kind: str = "value"

    def validate(self, value):
        if value is None or self.type is object:
            return value
        if self.type is float:
            return _checks.number(
                self.name, value, minimum=self.minimum, exclusive_min=self.exclusive_min, maximum=self.maximum
            )
        if self.type is int:
            return _checks.integer(self.name, value, minimum=self.minimum, maximum=self.maximum)
        if self.type is bool:
            if not isinstance(value, bool):
                raise InvalidOptionError(f"{self.name} must be True or False, got {value!r}")
            return value
        if self.type is str:
            if not isinstance(value, str):
                raise InvalidOptionError(f"{self.name} must be a string, got {value!r}")
            return _checks.choice(self.name, value, self.choices) if self.choices else value
        raise TypeError(f"option {self.name!r} has an unsupported type {self.type!r}")  # pragma: no cover

    def describe(self) -> str:
        """The doc sentence with the range and default, for help texts."""
        parts = [self.doc]
        if self.choices:
            parts.append("one of " + ", ".join(self.choices))
        if self.default is not None:
            parts.append(f"default {self.default!r}")
        return "; ".join(parts)


@dataclass(frozen=True)
class Declaration:
    """A method as declared in :mod:`.catalogue`: everything but its code, which lives in ``module``."""

    name: str
    module: str
    description: str
    options: tuple[Option, ...] | list[Option] = ()
    stop_rules: bool | tuple[str, ...] = True  #: True: every rule of STOP_RULES; or the ones honoured
    input: str = "heightfield"
    paper: str = ""
    exact_budget: bool = False  #: max_vertices is the exact vertex count of the result, not a ceiling


def _rules(stop_rules) -> tuple[str, ...]:
    """The stop rules a method honours: True means all of STOP_RULES, False none."""
    if stop_rules is True:
        return STOP_RULES
    rules = tuple(stop_rules or ())
    unknown = [r for r in rules if r not in STOP_RULES]
    if unknown:
        raise ValueError(f"unknown stop rule(s) {unknown}; choose from {STOP_RULES}")
    return rules


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

    def accepted(self) -> list[str]:
        """Every keyword the method accepts."""
        return [o.name for o in self.options] + list(self.stop_rules)

    def bind(self, kwargs: dict) -> tuple[dict, StopCriteria | None]:
        """Validate keyword arguments; return (options with defaults, stop rules)."""
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
        options = {o.name: o.validate(kwargs.get(o.name, o.default)) for o in self.options}
        return options, (stop if self.stop_rules else None)


_REGISTRY: dict[str, Method] = {}
_FUNCTIONS: dict[str, Callable] = {}


def _check_record(name: str, options, input: str) -> None:
    if input not in _INPUT_TYPES:
        raise ValueError(f"input must be one of {sorted(_INPUT_TYPES)}")
    for opt in options:
        for other in _REGISTRY.values():
            for o in other.options:
                if o.name == opt.name and o.type is not opt.type:
                    raise ValueError(
                        f"option {opt.name!r} of {name!r} has type {opt.type.__name__}, "
                        f"but {other.name!r} already uses it as {o.type.__name__}"
                    )


def declare(d: Declaration) -> Method:
    """List a method without importing it; its module implements it with ``@register(d.name)``."""
    if d.name in _REGISTRY:
        raise ValueError(f"method {d.name!r} is registered twice")
    options = tuple(d.options)
    _check_record(d.name, options, d.input)
    record = Method(name=d.name, description=d.description, options=options, stop_rules=_rules(d.stop_rules),
                    input=d.input, paper=d.paper, module=d.module, exact_budget=d.exact_budget)
    _REGISTRY[d.name] = record
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
):
    """Register a method; returns a decorator that gives back the public function.

    The decorated function receives the input positionally and its options as
    keywords, plus ``stop`` (a :class:`StopCriteria`, when ``stop_rules``) and
    ``progress`` (a callable ``progress(fraction)`` or None).  A method
    declared in :mod:`.catalogue` is registered by name alone (its record is
    the declaration); any other takes its description and options here.
    """
    if description is None:
        declared = _REGISTRY.get(name)
        if declared is None or not declared.module:
            raise ValueError(f"method {name!r} is not declared; give its description and options")
        if name in _FUNCTIONS:
            raise ValueError(f"method {name!r} is registered twice")
    else:
        if name in _REGISTRY:
            raise ValueError(f"method {name!r} is registered twice")
        declared = None
        options = tuple(options)
        _check_record(name, options, input)

    def decorate(func):
        record = declared or Method(name=name, description=description, options=options,
                                    stop_rules=_rules(stop_rules), input=input, paper=paper, module=func.__module__,
                                    exact_budget=exact_budget)

        @functools.wraps(func)
        def public(data, *, progress=None, **kwargs):
            expected = tuple(getattr(core, t) for t in _INPUT_TYPES[record.input])
            if not isinstance(data, expected):  # an xarray DataArray, a rasterio dataset, a laspy LasData, ...
                from ..io.interop import as_data

                data = as_data(data)
            if not isinstance(data, expected):
                raise InvalidInputError(
                    f"method {record.name!r} takes a {_input_name(record.input)}, got {type(data).__name__}"
                )
            opts, stop = record.bind(kwargs)  # bad options fail before any vector is read
            fit_geometry(record, opts, data)
            _check_memory(record, data, opts, stop)
            call = dict(opts)
            if record.stop_rules:
                call["stop"] = stop
            start = time.perf_counter()
            mesh = func(data, progress=progress, **call)
            elapsed = time.perf_counter() - start
            mesh.info["method"] = record.name
            mesh.info["options"] = {**opts, **(stop.as_dict() if stop else {})}
            mesh.info.setdefault("timings", {})["method"] = elapsed
            return mesh

        params = [inspect.Parameter("data", inspect.Parameter.POSITIONAL_ONLY)]
        params += [
            inspect.Parameter(o.name, inspect.Parameter.KEYWORD_ONLY, default=o.default) for o in record.options
        ]
        if record.stop_rules:
            params += [inspect.Parameter(k, inspect.Parameter.KEYWORD_ONLY, default=None) for k in STOP_RULES]
        params.append(inspect.Parameter("progress", inspect.Parameter.KEYWORD_ONLY, default=None))
        public.__signature__ = inspect.Signature(params, return_annotation=core.TerrainMesh)
        public.__doc__ = _document(func.__doc__ or "", record.options, record.stop_rules, record.input, record.exact_budget)
        _REGISTRY[name] = record
        _FUNCTIONS[name] = public
        return public

    return decorate


def _check_memory(record: Method, data, opts: dict, stop) -> None:
    """Refuse a run whose estimated memory (input size, requested vertices) cannot fit, before it allocates."""
    key = record.name
    if isinstance(data, core.Heightfield):
        size, unit = data.n_cells, f"{data.shape[0]:,} x {data.shape[1]:,} cells"
    elif isinstance(data, core.PointCloud):
        size, unit, key = len(data), f"{len(data):,} points", f"{record.name}:points"
    else:
        size, unit = data.n_vertices, f"a mesh of {data.n_vertices:,} vertices"
    requested = 0  # the methods whose vertex count is an option: remesh's exact count, cvt's sites
    if record.name == "remesh":
        requested = opts["n_vertices"] or 0
    elif record.name == "cvt" and isinstance(data, core.Heightfield):
        asked = stop.max_vertices if stop is not None and stop.max_vertices else round(opts["ratio"] * data.n_valid)
        requested = min(asked, data.n_valid)
    hint = {
        "remesh": "ask for fewer --vertices",
        "cvt": "ask for fewer vertices (--max-vertices or --ratio)",
    }.get(record.name, "'tinsmith tile' meshes a DEM of any size in windows, in bounded memory")
    what = f"method {record.name!r} on {unit}" + (f" with {requested:,} vertices" if requested else "")
    check_memory(estimate_method(key, size, requested), what, hint)


def _document(doc: str, options, stop_rules: tuple[str, ...], input: str, exact_budget: bool = False) -> str:
    """Append a numpydoc Parameters section built from the option records."""
    lines = [inspect.cleandoc(doc), "", "Parameters", "----------"]
    lines += ["data : " + _input_name(input), "    The input."]
    for o in options:
        lines += [f"{o.name} : {o.type.__name__}, optional", "    " + o.describe().replace("|", "\\|")]  # RST
    rule_docs = {
        "max_error": ["max_error : float, optional", "    Stop when the largest vertical error is at most this (z units)."],
        "max_vertices": ["max_vertices : int, optional",
                         "    The number of vertices to place." if exact_budget
                         else "    Stop before the mesh would exceed this many vertices."],
        "max_triangles": ["max_triangles : int, optional", "    Stop before the mesh would exceed this many triangles."],
    }
    for rule in stop_rules:
        lines += rule_docs[rule]
    lines += [
        "progress : callable, optional",
        "    Called with the fraction done (0..1) as the run advances.",
        "",
        "Returns",
        "-------",
        "TerrainMesh",
    ]
    return "\n".join(lines)


def methods() -> list[Method]:
    """Every registered method, in registration order.

    Examples
    --------
    >>> import tinsmith
    >>> names = [record.name for record in tinsmith.methods()]
    >>> names[:3]
    ['grid', 'greedy', 'subsample']
    >>> all(record.description for record in tinsmith.methods())
    True
    """
    return list(_REGISTRY.values())


def get_method(name: str) -> Method:
    """The record of ``name``; :class:`UnknownMethodError` lists the valid names.

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
    data : Heightfield
        The input of the method.
    method : str, optional
        A name from :func:`methods`; default :data:`DEFAULT_METHOD`.
    progress : callable, optional
        Called with the fraction done (0..1).
    **options
        The method's options and stop rules (``max_error``, ``max_vertices``,
        ``max_triangles``); unknown names raise :class:`InvalidOptionError`.

    Returns
    -------
    TerrainMesh

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


def _declare_built_ins() -> None:
    from .catalogue import DECLARED

    for d in DECLARED:
        declare(d)


_declare_built_ins()
