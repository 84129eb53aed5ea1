"""``tinsmith info``: what a raster, point cloud or mesh holds; a survey of many clouds from their headers."""

from __future__ import annotations

import click

from ..io import read
from .common import inputs_of
from .options import read_options, verbose_json
from .text import describe_data, describe_survey, echo_json, format_info


@click.command()
@click.argument("files", metavar="FILE...", nargs=-1)
@read_options(gridding=False)
@verbose_json
def info(files, verbose, as_json, **opts):
    """Describe a raster, point cloud or mesh: size, CRS, z range, nodata; a survey of many clouds from their headers."""
    path, label = inputs_of(files, opts.pop("sample"))
    report = describe_survey(files, path) if isinstance(path, list) else describe_data(read(path, **opts), label)
    echo_json(report) if as_json else click.echo(format_info(report))
