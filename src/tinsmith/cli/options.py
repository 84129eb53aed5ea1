"""The options commands share, as decorators: inputs and their reading, outputs, verbosity and JSON, an old flag
kept hidden; and the method options, built from the method registry (one flag per method option)."""

from __future__ import annotations

import click

from ..algorithms.registry import GEOMETRY_KINDS, get_method, methods
from ..samples import SAMPLES
from .params import parse_classes

__all__ = ["NUMBER_OR_WORD", "MethodCommand", "click_option", "geometry_names", "method_options", "outputs",
           "pop_method_kwargs", "read_options", "record_options", "renamed", "renamed_value", "verbose_json"]

_CLICK_TYPES = {float: click.FLOAT, int: click.INT, str: click.STRING}

#: The keywords of the readers (see tinsmith.io.registry.READ_OPTIONS) that :func:`read_options` adds.
READ_KEYS = ("nodata", "band", "cell_size", "classes", "encoding", "tile")


# -- inputs, outputs, verbosity ----------------------------------------------------------
def verbose_json(func):
    """``-v/--verbose`` and ``--json``."""
    func = click.option("--json", "as_json", is_flag=True, help="Print a JSON report instead of text.")(func)
    return click.option("-v", "--verbose", is_flag=True, help="Per-stage timings; tracebacks on errors.")(func)


def outputs(func=None, *, help: str = "Mesh file; the suffix picks the format (repeat for several).",
            metavar: str = "OUT"):
    """``-o/--output`` (repeatable, required) as the parameter ``outputs``."""
    if func is None:
        return lambda f: outputs(f, help=help, metavar=metavar)
    return click.option("-o", "--output", "outputs", multiple=True, required=True, metavar=metavar, help=help)(func)


def read_options(func=None, *, gridding: bool = True):
    """--sample and the options of the readers (``READ_KEYS``); ``gridding`` adds --statistic."""
    if func is None:
        return lambda f: read_options(f, gridding=gridding)
    decorators = [
        click.option("--sample", metavar="NAME", help=f"Use an embedded sample: {', '.join(SAMPLES)}."),
        click.option("--nodata", type=float, help="Height that marks missing data (nan for NaN)."),
        click.option("--band", type=click.IntRange(min=1), help="Raster band to read (default 1)."),
        click.option("--cell-size", type=float, help="Cell size: georeferences .npy arrays, grids point clouds."),
        click.option("--classes", callback=parse_classes, help="Point classes to keep, e.g. 2 or 2,9."),
        click.option("--encoding", type=click.Choice(["terrarium", "mapbox", "raw"]), help="PNG tile encoding."),
        click.option("--tile", metavar="Z/X/Y", help="Web-mercator tile index of a PNG tile."),
        click.option(
            "--statistic",
            type=click.Choice(["max", "min", "mean"]),
            default="max",
            show_default=True,
            help="How point heights in a cell are combined when gridding a point cloud.",
        ),
    ][: None if gridding else -1]
    for decorator in reversed(decorators):
        func = decorator(func)
    return func


def renamed(old: str, new: str, **kwargs):
    """The old spelling ``old`` of the flag ``new``, hidden: a value given under it says so in one note line, and
    the command takes it with :func:`renamed_value`."""
    name = new.lstrip("-").replace("-", "_")

    def take(ctx, param, value):
        if value is not None:
            click.echo(f"tinsmith: note: {old} is now {new}; the old name goes in a later release", err=True)
            ctx.meta[f"renamed {name}"] = (old, new, value)
        return value

    return click.option(old, f"renamed_{name}", hidden=True, expose_value=False, callback=take, **kwargs)


def renamed_value(name: str, value):
    """The value of the option ``name``, or the one given under its old flag (:func:`renamed`); not both."""
    ctx = click.get_current_context()
    if f"renamed {name}" not in ctx.meta:
        return value
    old, new, given = ctx.meta[f"renamed {name}"]
    if ctx.get_parameter_source(name) is click.core.ParameterSource.COMMANDLINE:
        raise click.UsageError(f"{old} is the old name of {new}: give one of them")
    return given


# -- method options, from the registry ----------------------------------------------------
class _NumberOrWord(click.ParamType):
    """A number, or a word such as 'auto' or 'none' (passed on as written, lower case)."""

    name = "NUMBER|auto|none"

    def convert(self, value, param, ctx):
        try:
            return float(value)
        except (TypeError, ValueError):
            return str(value).strip().lower()


NUMBER_OR_WORD = _NumberOrWord()


def geometry_names(record, kwargs: dict) -> dict:
    """The file names given for the geometry options (breaklines, control points, ...), by option name."""
    return {o.name: kwargs[o.name] for o in record.options if o.kind in GEOMETRY_KINDS and kwargs.get(o.name) is not None}


def pop_method_kwargs(opts: dict, extra=()) -> dict:
    """Take the method options (and the ``extra`` names) out of the parsed options; only those the user typed."""
    taken = {name: opts.pop(name) for name in [*extra, *method_option_specs()]}
    return {k: v for k, v in taken.items() if v is not None}


#: Method options that ``simplify``'s own flags give (``--streams``: the segments' stream lines, and flood's).
SEGMENT_NAMES = ("streams",)


def method_option_specs() -> dict:
    """Union of the registered methods' options (the registry guarantees one type per name), less those a command
    gives through flags of its own (:data:`SEGMENT_NAMES`)."""
    from .wavelet_options import REGISTRY_NAMES  # the filter's flags serve --method wavelet as well

    specs = {}
    for m in methods(deprecated=True):  # a deprecated method keeps its flags for its last release
        for o in m.options:
            if o.name not in REGISTRY_NAMES and o.name not in SEGMENT_NAMES:
                specs.setdefault(o.name, []).append((m.name, o))
    return specs


def click_option(opt, flag: str, help_text: str, required: bool = False):
    """The click option of a registered method option; default None, so that the method's own default applies."""
    if opt.type is bool:
        return click.option(f"{flag}/--no-{flag[2:]}", opt.name, default=None, help=help_text)
    if opt.kind in GEOMETRY_KINDS:
        return click.option(flag, opt.name, type=click.Path(dir_okay=False), default=None, metavar="FILE",
                            required=required, help=help_text)
    if opt.type is object:  # a number or a word ('auto', 'none'): the method checks it
        return click.option(flag, opt.name, type=NUMBER_OR_WORD, default=None, required=required, help=help_text)
    ptype = click.Choice(opt.choices) if opt.choices else _CLICK_TYPES[opt.type]
    if opt.type is int and (opt.minimum is not None or opt.maximum is not None):  # click names the flag
        ptype = click.IntRange(min=opt.minimum, max=opt.maximum, min_open=opt.exclusive_min)
    return click.option(flag, opt.name, type=ptype, default=None, required=required, help=help_text)


def method_options(func):
    """A click option per registered method option; values reach only the chosen method."""
    for name, owners in reversed(list(method_option_specs().items())):
        _, opt = owners[0]
        who = ", ".join(m for m, _ in owners)
        func = click_option(opt, "--" + name.replace("_", "-"), f"[{who}] {opt.describe()}")(func)
    return func


class MethodCommand(click.Command):
    """A command with :func:`method_options`: those of methods registered after the command was made (a plugin's,
    a test's) are added when it runs, before --help."""

    def get_params(self, ctx):
        params = super().get_params(ctx)
        known = {p.name for p in params}

        def holder():
            pass

        method_options(holder)
        added = [p for p in reversed(holder.__click_params__) if p.name not in known]
        return [*params[:-1], *added, *params[-1:]] if added else params


def record_options(method: str, *, flags=None, required=()):
    """The options of one registered method for its own command (``flags`` renames some)."""
    def decorate(func):
        for opt in reversed(get_method(method).options):
            if opt.replaced_by:  # a former name: the command has the new one
                continue
            flag = (flags or {}).get(opt.name, "--" + opt.name.replace("_", "-"))
            func = click_option(opt, flag, opt.describe(), required=opt.name in required)(func)
        return func

    return decorate
