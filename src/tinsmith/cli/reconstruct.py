"""``tinsmith reconstruct``: a surface from point clouds (Gopi and Krishnan 2002)."""

from __future__ import annotations

import time

import click

from ..errors import InvalidInputError
from ..io import check_output_path, write
from ..io.paths import check_outputs
from .common import label_of, naming, read_clouds
from .options import outputs, verbose_json
from .params import cloud_inputs, parse_classes
from .progress import Pipeline
from .text import echo_json, num


@click.command()
@click.argument("inputs", metavar="CLOUD...", nargs=-1, required=True)
@outputs
@click.option("--mode", type=click.Choice(["auto", "heightfield", "general"]), default="auto", show_default=True,
              help="heightfield: one point per dexel, for terrain and single-view scans; general: any surface.")
@click.option("--mu", type=float, default=2.5, show_default=True,
              help="Neighbours lie within mu times a point's distance to its second-nearest point (general mode).")
@click.option("--max-angle", type=float, default=120.0, show_default=True,
              help="Degrees; wider gaps between neighbours stay open as borders (general mode).")
@click.option("--min-angle", type=float, default=10.0, show_default=True,
              help="Degrees; drop neighbours that make smaller angles where no point gets trapped (general mode).")
@click.option("--dexel-size", type=float, help="Dexel width (world units); heightfield mode keeps one point per dexel.")
@click.option("--view", type=click.Choice(["any", "above"]), default="any", show_default=True,
              help="above: an airborne scan; no face grows turned down (roofs do not fold over), then gaps close.")
@click.option("--workers", type=click.IntRange(min=1),
              help="Threads for general mode (default: every core); the mesh is the same on any number.")
@click.option("--classes", callback=parse_classes, help="Point classes to keep, e.g. 2 or 2,9.")
@verbose_json
def reconstruct(inputs, outputs, classes, verbose, as_json, **options):
    """Mesh a point cloud (LAS/LAZ, XYZ; several files, folders, globs) in one pass, without gridding it
    (Gopi and Krishnan 2002)."""
    from ..algorithms.reconstruct.reconstruct import reconstruct as build
    from ..metrics import surface_problems

    clouds = cloud_inputs(inputs)
    if clouds is None:
        raise InvalidInputError(f"{inputs[0]!r} is not a point cloud; give LAS/LAZ or XYZ files")
    input_file = label_of(clouds)
    for out in outputs:
        check_output_path(out)
    check_outputs(outputs, clouds)
    pipeline = Pipeline({"read": 1, "reconstruct": 4, "write": 1}, show=not as_json)
    start = time.perf_counter()
    with naming(clouds), pipeline:
        with pipeline.stage("read"):
            cloud = read_clouds(clouds, classes=classes)  # the reader of tinsmith.read, one file or many
        with pipeline.stage("reconstruct"):
            mesh = build(cloud, **options)  # mode, mu, max_angle, min_angle, dexel_size, view, workers
        with pipeline.stage("write"):
            for out in outputs:
                write(mesh, out)
    problems = surface_problems(mesh)
    info = mesh.info["reconstruct"]
    summary = {"input": input_file, "points": len(cloud), **info, "n_vertices": mesh.n_vertices,
               "n_triangles": mesh.n_triangles, "border_edges": problems.pop("border"), "problems": problems,
               "outputs": list(outputs), "time": time.perf_counter() - start}
    if as_json:
        echo_json(summary)
        return
    click.echo(f"{input_file}: {len(cloud):,} points -> {info['mode']} mode: {mesh.n_vertices:,} vertices, "
               f"{mesh.n_triangles:,} triangles, {summary['border_edges']:,} border edges"
               + ("" if not any(problems.values()) else f"; problems: {problems}"))
    click.echo("  wrote: " + ", ".join(outputs))
    click.echo(f"  time: {num(summary['time'])} s")
