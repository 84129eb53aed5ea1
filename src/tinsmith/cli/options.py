"""Click options built from the method registry: one flag per method option, geometry files loaded."""

from __future__ import annotations

import click

from ..algorithms.registry import GEOMETRY_KINDS, get_method, methods

_CLICK_TYPES = {float: click.FLOAT, int: click.INT, str: click.STRING}


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


def method_option_specs() -> dict:
    """Union of the registered methods' options (the registry guarantees one type per name)."""
    from .wavelet_options import REGISTRY_NAMES  # the filter's flags serve --method wavelet as well

    specs = {}
    for m in methods():
        for o in m.options:
            if o.name not in REGISTRY_NAMES:
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


def record_options(method: str, *, flags=None, required=()):
    """The options of one registered method for its own command (``flags`` renames some)."""
    def decorate(func):
        for opt in reversed(get_method(method).options):
            flag = (flags or {}).get(opt.name, "--" + opt.name.replace("_", "-"))
            func = click_option(opt, flag, opt.describe(), required=opt.name in required)(func)
        return func

    return decorate

