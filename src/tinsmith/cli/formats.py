"""``tinsmith formats``: the file formats tinsmith reads and writes."""

from __future__ import annotations

import click

from .options import verbose_json
from .text import echo_json


@click.command()
@verbose_json
def formats(verbose, as_json):
    """List the file formats tinsmith reads and writes."""
    from ..io import READERS, WRITERS
    from ..io.registry import CLAIMS

    readers = {}
    claimed = [(suffix, rec) for suffix, recs in CLAIMS.items() for rec in recs]
    for suffix, rec in claimed + list(READERS.items()):
        readers.setdefault(rec.description, {"kind": rec.kind, "suffixes": [], "options": list(rec.options)})
        readers[rec.description]["suffixes"].append(suffix)
    writers = {}
    for suffix, rec in WRITERS.items():
        writers.setdefault(rec.description, {"suffixes": [], "crs": "embedded" if rec.carries_crs else ".prj sidecar"})
        writers[rec.description]["suffixes"].append(suffix)
    if as_json:
        echo_json({"readers": readers, "writers": writers})
        return
    click.echo("read:")
    for desc, r in readers.items():
        suffixes = " ".join(s if s != "*" else "(any other GDAL raster)" for s in r["suffixes"])
        click.echo(f"  {suffixes}: {desc} [{r['kind']}]")
    click.echo("write:")
    for desc, w in writers.items():
        click.echo(f"  {' '.join(w['suffixes'])}: {desc} [CRS: {w['crs']}]")
