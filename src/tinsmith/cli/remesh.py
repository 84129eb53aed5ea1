"""``tinsmith remesh``: isotropic remeshing to exactly N vertices (Alliez et al. 2003)."""

from __future__ import annotations

import time

import click

from .. import core
from ..algorithms.registry import get_method
from ..io import check_output_path, write
from ..io.paths import check_outputs
from .common import describe_source, input_path, load_source, measure, naming
from .options import geometry_names, outputs, read_options, record_options, verbose_json
from .progress import Pipeline
from .text import echo_json, format_error, format_quality, num


@click.command()
@click.argument("input_file", metavar="INPUT", required=False)
@outputs
@click.option("--vertices", "max_vertices", type=click.IntRange(min=3), required=True,
              help="the exact number of vertices of the result (the method's max_vertices)")
@record_options("remesh")
@read_options
@verbose_json
def remesh(input_file, outputs, max_vertices, verbose, as_json, **opts):
    """Remesh INPUT (a DEM or a disk-like mesh) with exactly --vertices well-shaped vertices (Alliez et al. 2003)."""
    path, label = input_path(input_file, opts.pop("sample"))
    record = get_method("remesh")
    # only what the user typed reaches the method, so its own defaults apply
    kwargs = {k: v for k, v in ((o.name, opts.pop(o.name)) for o in record.options if o.name in opts)
              if v is not None}
    kwargs["max_vertices"] = max_vertices
    record.bind(kwargs)  # bad options fail before any reading
    for out in outputs:
        check_output_path(out)
    check_outputs(outputs, [path, *geometry_names(record, kwargs).values()])
    pipeline = Pipeline({"read": 1, "remesh": 4, "write": 1}, show=not as_json)
    start = time.perf_counter()
    with naming(path, geometry_names(record, kwargs)), pipeline:
        with pipeline.stage("read"):
            source = load_source(path, opts, record)
        with pipeline.stage("remesh") as report:
            mesh = record.function(source, progress=report, **kwargs)
        with pipeline.stage("write"):
            grid = source if isinstance(source, core.Heightfield) else None
            for out in outputs:
                write(mesh, out, grid=grid)
    summary = _summary(mesh, source, label, outputs)
    summary["time"] = time.perf_counter() - start
    if as_json:
        echo_json(summary)
        return
    _print(summary, mesh, source, label)


def _summary(mesh, source, label, outputs) -> dict:
    from ..metrics import triangle_quality

    flat = mesh.info["remesh"]["parameterization"] == "xy"
    error = measure(mesh, source) if flat else surface_distance(mesh, source)
    return {"input": label, "n_vertices": mesh.n_vertices, "n_triangles": mesh.n_triangles, **mesh.info["remesh"],
            "quality": triangle_quality(mesh, 3), ("vertical_error" if flat else "surface_distance"): error,
            "outputs": list(outputs)}


def _print(summary, mesh, source, label) -> None:
    info = mesh.info["remesh"]
    click.echo(f"{describe_source(source, label)} -> {mesh.n_vertices:,} vertices ({info['corners']:,} corners, "
               f"{info['feature_samples']:,} on features), {mesh.n_triangles:,} triangles; "
               f"{info['parameterization']} parameter space"
               + (f" ({info['charts']} charts, seams relaxed)" if "charts" in info else "")
               + f", {info['lloyd_iterations']} Lloyd iterations")
    if "vertical_error" in summary:
        of = "valid cells" if isinstance(source, core.Heightfield) else "input vertices"
        click.echo("  vertical error (z units): " + format_error(summary["vertical_error"], of))
    else:
        error = summary["surface_distance"]
        click.echo(f"  distance of the input's vertices to the result: max {num(error['max'])}, "
                   f"mean {num(error['mean'])} ({num(error['max_relative'])} of the bounding-box diagonal)")
    click.echo("  quality 3-D: " + format_quality(summary["quality"]))
    click.echo("  wrote: " + ", ".join(summary["outputs"]))
    click.echo(f"  time: {num(summary['time'])} s")


def surface_distance(mesh, source) -> dict:
    """Distances of the input's vertices to the result's surface (exact, point to triangle): a surface that is
    not a terrain has no vertical error."""
    import numpy as np

    from ..metrics.surface import closest_points

    vertices = source.vertices if not isinstance(source, core.Heightfield) else mesh.vertices
    d = np.linalg.norm(closest_points(mesh.vertices, mesh.triangles, vertices) - vertices, axis=1)
    diagonal = float(np.linalg.norm(np.ptp(vertices, axis=0))) or 1.0
    return {"max": float(d.max()), "mean": float(d.mean()), "max_relative": float(d.max()) / diagonal}
