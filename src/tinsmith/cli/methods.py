"""``tinsmith methods``: the registered methods and their options."""

from __future__ import annotations

import click

from ..algorithms import registry
from .options import verbose_json
from .text import echo_json


@click.command()
@verbose_json
def methods(verbose, as_json):
    """List the methods with their options."""
    records = [
        {
            "name": m.name,
            "description": m.description,
            "input": m.input,
            "stop_rules": list(m.stop_rules),
            "exact_budget": m.exact_budget,
            "options": [
                {"name": o.name, "type": o.type.__name__, "default": o.default, "doc": o.describe()}
                for o in m.options
            ],
            "paper": m.paper,
            "default": m.name == registry.DEFAULT_METHOD,
        }
        for m in registry.methods()
    ]
    if as_json:
        echo_json({"methods": records})
        return
    for r in records:
        flag = " (default)" if r["default"] else ""
        click.echo(f"{r['name']}{flag}: {r['description']}")
        if r["stop_rules"]:
            click.echo("  stop rules: " + ", ".join("--" + s.replace("_", "-") for s in r["stop_rules"])
                       + (" (the number of vertices it places)" if r["exact_budget"] else ""))
        for o in r["options"]:
            click.echo(f"  --{o['name'].replace('_', '-')} ({o['type']}): {o['doc']}")
        if r["paper"]:
            click.echo(f"  from: {r['paper']}")
