"""``tinsmith ground``: the ground (a DTM) under a surface model or a point cloud, as a GeoTIFF."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..io import check_output_path, georeferencing, read_heightfield
from ..io.paths import check_outputs
from .common import describe_source, inputs_of, naming
from .options import READ_KEYS, read_options, verbose_json
from .params import cloud_inputs
from .progress import Pipeline
from .text import echo_json, num


@click.command()
@click.argument("inputs", metavar="DSM...", nargs=-1)
@click.option("-o", "--output", "output", required=True, metavar="DTM.tif",
              help="The ground, a GeoTIFF on the grid of the DSM (of the cloud gridded at --cell-size).")
@click.option("--max-window", type=float, default=60.0, show_default=True,
              help="The widest window (world units): wider than the largest building.")
@click.option("--slope", type=float, help="Terrain slope (rise over run) the thresholds allow for (default 1).")
@click.option("--dh0", type=float, help="Threshold of the first window (z units; default 0.3 m).")
@click.option("--dh-max", type=float, help="Largest threshold (z units; default 1 m).")
@click.option("--wall-slope", type=float,
              help="Objects stand on walls steeper than this between neighbouring cells (rise over run; default 1).")
@read_options(gridding=False)
@verbose_json
def ground(inputs, output, verbose, as_json, **opts):
    """The ground under a surface model or a LiDAR survey: a progressive morphological filter (Zhang et al. 2003)
    that keeps hills, the rest filled from the ground.

    A point cloud is gridded at --cell-size, each cell its lowest point.  Nodata stays nodata.
    """
    from ..algorithms.urban.ground import ground as find_ground
    from ..algorithms.urban.urban import require_metres
    from ..io.gis_formats import write_grid
    from ..io.points import read_clouds

    reading = {k: opts.pop(k) for k in ("sample", *READ_KEYS)}
    options = {k: v for k, v in opts.items() if v is not None}
    if Path(output).suffix.lower() not in (".tif", ".tiff"):
        raise click.UsageError(f"-o {output!r}: the ground is written as GeoTIFF (.tif)")
    clouds = cloud_inputs(inputs) if inputs and not reading["sample"] else None
    path, label = inputs_of(inputs, reading.pop("sample"))
    check_output_path(output)
    check_outputs([output], clouds or [path])
    with naming(clouds if clouds is not None else path):  # degrees: refused from the header, before any read
        require_metres(*georeferencing(clouds if clouds is not None else path, reading["cell_size"]),
                       options["max_window"])
    pipeline = Pipeline({"read": 1, "ground": 4, "write": 1}, show=not as_json)
    start = time.perf_counter()
    with naming(path), pipeline:
        with pipeline.stage("read"):
            if clouds is not None:
                data = read_clouds(clouds, classes=reading["classes"])
            else:
                data = read_heightfield(path, **{k: reading[k] for k in READ_KEYS})
        with pipeline.stage("ground"):
            dtm = find_ground(data, cell_size=reading["cell_size"] if clouds is not None else None, **options)
        with pipeline.stage("write"):
            write_grid(dtm.z, output, dtm)
    changed = None
    if clouds is None:  # the cells the filter took off the ground, and by how much
        off = dtm.valid & (data.z != dtm.z)
        changed = {"cells": int(off.sum()), "share": float(off.sum() / max(1, dtm.n_valid))}
    summary = {"input": label, "rows": dtm.shape[0], "cols": dtm.shape[1], "valid": dtm.n_valid, "not_ground": changed,
               "output": output, "time": time.perf_counter() - start}
    if as_json:
        echo_json(summary)
        return
    click.echo(f"{describe_source(data, label)} -> the ground on {dtm.shape[0]:,} x {dtm.shape[1]:,} cells"
               + (f"; {changed['cells']:,} cells ({100 * changed['share']:.1f}%) filled from the ground"
                  if changed is not None else ""))
    click.echo(f"  wrote: {output}")
    click.echo(f"  time: {num(summary['time'])} s")
