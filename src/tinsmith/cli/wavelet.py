"""``tinsmith wavelet``: spline and wavelet filtering steered by land use (Goebbels and Pohle-Fröhlich 2015)."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..io import check_output_path, write
from ..io.paths import check_outputs
from .common import describe_source, input_path, load_heightfield, naming, vertical_error, wavelet_mesh
from .options import outputs, read_options, renamed, renamed_value, verbose_json
from .progress import Pipeline
from .text import echo_json, num
from .wavelet_options import wavelet_kwargs, wavelet_options


@click.command()
@click.argument("input_file", metavar="DEM", required=False)
@outputs
@click.option("--max-error", type=float, default=0.2, show_default=True,
              help="Accuracy of the quadtree against the filtered heights (z units).")
@renamed("--epsilon", "--max-error", type=float)
@click.option("--filtered", metavar="TIF", help="Also write the filtered heights (GeoTIFF).")
@click.option("--class-map", metavar="TIF", help="Also write the class of every grid point (GeoTIFF; codes in the docs).")
@wavelet_options
@read_options
@verbose_json
def wavelet(input_file, outputs, max_error, filtered, class_map, verbose, as_json, **opts):
    """A city terrain meshed where its land use needs detail: spline, Haar wavelets, quadtree
    (Goebbels and Pohle-Fröhlich 2015)."""
    from ..io.gis_formats import write_grid

    max_error = renamed_value("max_error", max_error)
    path, label = input_path(input_file, opts.pop("sample"))
    kwargs = wavelet_kwargs(opts)
    rasters = [f for f in (filtered, class_map) if f is not None]
    for raster in rasters:
        if Path(raster).suffix.lower() not in (".tif", ".tiff"):
            raise click.UsageError(f"{raster!r}: --filtered and --class-map write GeoTIFF (.tif)")
    for out in [*outputs, *rasters]:
        check_output_path(out)
    check_outputs([*outputs, *rasters], [path, kwargs.get("landuse")])
    pipeline = Pipeline({"read": 1, "wavelet": 4, "write": 1}, show=not as_json)
    start = time.perf_counter()
    with naming(path), pipeline:
        with pipeline.stage("read"):
            hf = load_heightfield(path, opts)
        with pipeline.stage("wavelet"):
            mesh, result = wavelet_mesh(hf, max_error=max_error, **kwargs)
        with pipeline.stage("write"):
            for out in outputs:
                write(mesh, out, grid=hf)
            if filtered is not None:
                write_grid(result.heightfield.z, filtered, hf)
            if class_map is not None:
                write_grid(result.classes, class_map, hf, nodata=0)
    info = mesh.info["wavelet"]
    summary = {"input": label, "cells": hf.n_cells, "n_vertices": mesh.n_vertices, "n_triangles": mesh.n_triangles,
               **info, "vertical_error": vertical_error(mesh, hf), "outputs": [*outputs, *rasters],
               "time": time.perf_counter() - start}
    if as_json:
        echo_json(summary)
        return
    tried = info["triangles_by_iterations"]
    click.echo(f"{describe_source(hf, label)} -> {mesh.n_vertices:,} vertices, {mesh.n_triangles:,} triangles "
               f"at max error {num(max_error)}, {info['spline_iterations']} spline iterations"
               + (" (auto: " + ", ".join(f"{k}: {v:,}" for k, v in tried.items()) + ")" if tried else ""))
    click.echo("  classes: " + ", ".join(f"{name} {n:,}" for name, n in info["classes"].items() if n))
    click.echo("  error against the unfiltered heights, by class (max / RMS):")
    for name, e in info["error_by_class"].items():
        click.echo(f"    {name}: {num(e['max'])} / {num(e['rmse'])}")
    click.echo("  wrote: " + ", ".join(summary["outputs"]))
    click.echo(f"  time: {num(summary['time'])} s")
