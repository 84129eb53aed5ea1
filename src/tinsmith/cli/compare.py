"""``tinsmith compare``: several methods on one input, side by side."""

from __future__ import annotations

import click

from ..algorithms.registry import get_method, methods
from ..core.stop import StopCriteria
from .common import compare_methods, inputs_of, load_heightfield, naming
from .options import read_options, verbose_json
from .progress import Pipeline
from .text import echo_json, format_comparison, num


@click.command()
@click.argument("inputs", metavar="INPUT...", nargs=-1)
@click.option(
    "--methods", "method_names", metavar="M1,M2,...",
    help="Methods to compare, separated by commas (default: every method with stop rules).",
)
@click.option("--max-error", type=float, help="The error bound every method gets (z units).")
@click.option("--max-vertices", type=int, help="The vertex budget every method gets.")
@click.option("--max-triangles", type=int, help="The triangle budget every method gets.")
@click.option("--markdown", is_flag=True, help="Print a Markdown table.")
@read_options
@verbose_json
def compare(inputs, method_names, max_error, max_vertices, max_triangles, markdown, verbose, as_json, **opts):
    """Run several methods on INPUT under one stop rule and print one table of their metrics."""
    path, label = inputs_of(inputs, opts.pop("sample"))
    rule = dict(max_error=max_error, max_vertices=max_vertices, max_triangles=max_triangles)
    given_keys = [k for k, v in rule.items() if v is not None]
    names = (  # by default every method that honours the rule given
        [n.strip() for n in method_names.split(",") if n.strip()] if method_names
        else [m.name for m in methods() if m.stop_rules and set(given_keys) <= set(m.stop_rules)]
    )
    for name in names:
        get_method(name)  # unknown names fail before anything is read
    if sum(v is not None for v in rule.values()) != 1:
        raise click.UsageError("give exactly one of --max-error, --max-vertices, --max-triangles")
    StopCriteria(**{k: v for k, v in rule.items() if v is not None})  # a bad value fails before reading
    pipeline = Pipeline({"read": 1, "methods": 6}, show=not (as_json or markdown))
    with naming(path), pipeline:
        with pipeline.stage("read"):
            hf = load_heightfield(path, opts)
        with pipeline.stage("methods"):
            rows = compare_methods(hf, names, **rule)
    given = {k: v for k, v in rule.items() if v is not None}
    if as_json:
        echo_json({"input": label, "rule": given, "rows": rows})
        return
    if not markdown:
        (key, value), = given.items()
        click.echo(f"{label}: {hf.n_valid:,} valid cells, {key.replace('_', ' ')} {num(value)}")
    click.echo(format_comparison(rows, markdown=markdown))
