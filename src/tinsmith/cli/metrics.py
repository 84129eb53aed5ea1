"""``tinsmith metrics``: the vertical error and triangle quality of any mesh."""

from __future__ import annotations

import click

from ..io import (
    read_mesh,
    reader_for,
)
from .common import inputs_of, load_heightfield, measure, mesh_metrics, read_clouds
from .options import read_options, verbose_json
from .progress import Pipeline
from .text import echo_json, format_metrics, format_timings


@click.command()
@click.argument("mesh_file", metavar="MESH")
@click.argument("sources", metavar="DEM...", nargs=-1)
@read_options
@verbose_json
def metrics(mesh_file, sources, verbose, as_json, **opts):
    """Judge MESH against DEM (a raster, or point clouds: the error at every point): vertical error, quality, counts."""
    path, label = inputs_of(sources, opts.pop("sample"))
    pipeline = Pipeline({"read mesh": 1, "read dem": 1, "metrics": 3}, show=not as_json)
    try:
        with pipeline.stage("read mesh"):
            mesh = read_mesh(mesh_file)
        with pipeline.stage("read dem"):
            clouds = path if isinstance(path, list) else [path] if reader_for(path).kind == "points" else None
            on_points = clouds is not None and opts["cell_size"] is None
            source = read_clouds(clouds, classes=opts["classes"]) if on_points else load_heightfield(path, opts)
        with pipeline.stage("metrics"):
            if on_points:  # at every point (one a x-y: the lowest, as the TIN keeps it)
                result = mesh_metrics(mesh)
                result["vertical_error"] = measure(mesh, source)
            else:
                result = mesh_metrics(mesh, source)
    finally:
        pipeline.close()
    result = {"mesh": mesh_file, "dem": label, **result}
    if as_json:
        result["timings"] = pipeline.timings
        echo_json(result)
        return
    click.echo(f"{mesh_file} against {label}:")
    click.echo(format_metrics(result, "points" if on_points else "valid cells"))
    if verbose:
        click.echo(format_timings(pipeline.timings))
