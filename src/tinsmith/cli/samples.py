"""``tinsmith samples``: the embedded sample datasets."""

from __future__ import annotations

import click

from ..samples import SAMPLES
from .options import verbose_json
from .text import echo_json


@click.command()
@verbose_json
def samples(verbose, as_json):
    """List the embedded sample datasets (use them with --sample NAME)."""
    rows = [{"name": s.name, "description": s.description, "licence": s.licence} for s in SAMPLES.values()]
    if as_json:
        echo_json({"samples": rows})
        return
    for r in rows:
        click.echo(f"{r['name']}: {r['description']} [{r['licence']}]")
