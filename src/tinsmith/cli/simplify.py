"""``tinsmith simplify``: one input, one method, one mesh (written to one or more files)."""

from __future__ import annotations

import time
from pathlib import Path

import click

from .. import core
from ..algorithms.registry import DEFAULT_METHOD, STOP_RULES, fit_geometry, get_method
from ..io import check_output_path, write
from ..io.paths import check_outputs
from .common import (
    check_html_output,
    cloud_files,
    describe_source,
    fit,
    input_path,
    label_of,
    load_source,
    measure,
    naming,
    read_clouds,
    wavelet_filter,
)
from .options import MethodCommand, geometry_names, method_options, outputs, pop_method_kwargs, read_options, verbose_json
from .progress import Pipeline
from .segments import apply as apply_segments
from .segments import note_outputs, parse, segment_options
from .text import echo_json, format_error, format_timings, num
from .wavelet_options import wavelet_kwargs, wavelet_options


@click.command(cls=MethodCommand)
@click.argument("input_files", metavar="INPUT...", nargs=-1)
@outputs(help="Output file; the suffix picks the format (repeat for several).")
@click.option("--method", default=DEFAULT_METHOD, show_default=True, help="Method name (see `tinsmith methods`).")
@click.option("--grid", "grid_points", is_flag=True,
              help="Point clouds: grid the points first (at --cell-size) instead of meshing them as they are.")
@click.option("--max-error", type=float, help="Stop when the vertical error is at most this (z units).")
@click.option("--max-vertices", type=int, help="Stop before exceeding this many vertices.")
@click.option("--max-triangles", type=int, help="Stop before exceeding this many triangles.")
@click.option("--fit-heights", is_flag=True,
              help="Replace the vertex heights by their least-squares fit to every covered cell (approximating, "
                   "lower RMS).")
@click.option("--prefilter", type=click.Choice(["wavelet"]),
              help="Filter the heights first: wavelet, Goebbels and Pohle-Fröhlich (2015)'s land-use steered spline and "
                   "Haar filter (options below).")
@click.option("--report", "report_path", metavar="REPORT.html",
              help="Also write the HTML report of the mesh against the input raster (see `tinsmith report`).")
@segment_options
@method_options
@wavelet_options(required=False)
@read_options
@verbose_json
def simplify(input_files, outputs, method, grid_points, fit_heights, prefilter, report_path, streams, boundaries,
             verbose, as_json, **opts):
    """Make a mesh of INPUT with a method and write it to every OUT.

    Point clouds (LAS/LAZ, XYZ) may be several files, folders or globs, read as one cloud; the
    default method meshes their points as they are (greedy insertion on points), --grid grids them.

    For a 2-D flood solver, --streams FILE cuts the mesh's outline into named boundary segments
    (inflow_N / outflow_N where the streams cross it, wall_N, hole_N) and --boundary NAME=FILE names
    the border along a line of your own; 2DM, Gmsh, ADCIRC and TELEMAC outputs carry them (--method
    flood: also its breaklines; without --streams, flood derives them and cuts the outline itself).
    """
    sample = opts.pop("sample")
    clouds = cloud_files(input_files, sample)
    if clouds is not None:
        path, label = str(clouds[0]), label_of(clouds)
    else:
        path, label = input_path(input_files[0] if input_files else None, sample)
    record, method_kwargs, prefilter_kwargs = _method(method, prefilter, opts, streams)
    files = geometry_names(record, method_kwargs)
    segment_files = parse(streams, boundaries)
    _check_outputs(outputs, report_path, [*(clouds or [path]), *files.values(), prefilter_kwargs.get("landuse"),
                                          *(segment_files or {}).values()])
    note_outputs(segment_files, outputs)
    on_points = clouds is not None and (record.input == "points" or (
        record.input == "elevation" and not grid_points and opts["cell_size"] is None))
    weights = {"read": 1, **({"prefilter": 2} if prefilter else {}), "method": 4,
               **({"fit heights": 1} if fit_heights else {}), "metrics": 2,
               **({"segments": 1} if segment_files else {}), **{f"write {out}": 1 for out in outputs}}
    pipeline = Pipeline(weights, show=not as_json)
    start = time.perf_counter()
    with naming(path, files), pipeline:
        with pipeline.stage("read") as report:
            source = _read(clouds, path, opts, record, on_points, report)
            fit_geometry(record, method_kwargs, source)  # what the method and the measures below take
        data = _prefiltered(source, prefilter and prefilter_kwargs, method_kwargs, pipeline)
        with pipeline.stage("method") as report:
            mesh = record.function(data, progress=report, **method_kwargs)
        if fit_heights:
            if not isinstance(source, core.Heightfield):
                raise click.UsageError("--fit-heights needs a raster input (the cells to fit)")
            with pipeline.stage("fit heights"):
                mesh = fit(mesh, source)
        mesh.info["name"] = sample or Path(path).stem  # files that hold a name (2DM, LandXML)
        with pipeline.stage("metrics"):
            mesh.info["error"] = measure(mesh, source, method_kwargs)
        if segment_files:
            with pipeline.stage("segments"):
                mesh = apply_segments(mesh, segment_files)
        _write(mesh, source, outputs, report_path, record.name, label, pipeline)
    summary = _summary(label, source, record.name, prefilter and prefilter_kwargs, mesh, files, outputs, report_path)
    if segment_files:
        summary["segments"] = list(mesh.node_strings)
    summary["time"] = time.perf_counter() - start
    summary["timings"] = {**pipeline.timings, **{f"method: {k}": v for k, v in mesh.info["timings"].items()
                                                 if k != "method"}}
    if as_json:
        echo_json(summary)
        return
    _print(summary, source, mesh, prefilter, verbose)


def _method(method, prefilter, opts, streams=None):
    """The method's record, its options (only those typed, so its own defaults apply; ``streams``, the segments'
    file, for a method that takes stream lines) and the filter's options."""
    prefilter_kwargs = wavelet_kwargs(opts)
    record = get_method(method)
    if prefilter is None and record.name != "wavelet" and any(
            prefilter_kwargs[k] is not None for k in ("landuse", "roles", "attribute", "thresholds")):
        raise click.UsageError("--landuse, --role, --attribute and --thresholds go with --prefilter wavelet "
                               "or --method wavelet")
    method_kwargs = pop_method_kwargs(opts, STOP_RULES)
    if record.name == "wavelet":  # the filter's flags are the method's options
        if prefilter:
            raise click.UsageError("--method wavelet filters already: leave out --prefilter")
        method_kwargs.update({k: v for k, v in prefilter_kwargs.items() if v is not None})
    if streams is not None and any(o.name == "streams" for o in record.options):
        method_kwargs["streams"] = streams  # flood's breaklines: the same lines as the segments'
    record.bind(method_kwargs)  # fail on bad options before any reading
    return record, method_kwargs, prefilter_kwargs


def _check_outputs(outputs, report_path, inputs) -> None:
    for out in outputs:
        check_output_path(out)
    if report_path:
        check_html_output(report_path)
    check_outputs([*outputs, report_path], inputs)


def _read(clouds, path, opts, record, on_points, report):
    """The input: point clouds as points or gridded, else a raster or a mesh (as the method takes it)."""
    if record.name == "flood":  # its flow and time step are metres: degrees refused from the header, before reading
        from ..algorithms.flood.flood import refuse_degrees
        from ..io import georeferencing

        refuse_degrees(*georeferencing(clouds if clouds is not None else path, opts["cell_size"])[:2])
    if clouds is None:
        return load_source(path, opts, record)
    source = read_clouds(clouds, classes=opts["classes"], progress=lambda n, total: report(n / total))
    return source if on_points else source.to_heightfield(opts["cell_size"], opts["statistic"])


def _prefiltered(source, prefilter_kwargs, method_kwargs, pipeline):
    """The heights the method meshes: the source's, or (``prefilter_kwargs``) the wavelet filter's."""
    if not prefilter_kwargs:
        return source
    if not isinstance(source, core.Heightfield):
        raise click.UsageError("--prefilter wavelet needs a raster input")
    with pipeline.stage("prefilter"):
        bound = method_kwargs.get("max_error", 0.2)  # what "auto" counts quadtree triangles at
        return wavelet_filter(source, max_error=bound, **prefilter_kwargs).heightfield


def _write(mesh, source, outputs, report_path, method, label, pipeline) -> None:
    grid = source if isinstance(source, core.Heightfield) else None
    for out in outputs:
        with pipeline.stage(f"write {out}"):
            write(mesh, out, grid=grid)
    if report_path:
        if grid is None:
            raise click.UsageError("--report needs a raster input (the DEM to judge the mesh against)")
        with pipeline.stage("report"):
            from ..viz.report import write_report

            write_report(report_path, source, {method: mesh}, dem_name=label,
                         settings={"method": method, "options": mesh.info.get("options", {}), "outputs": list(outputs)})


def _summary(label, source, method, prefilter_kwargs, mesh, files, outputs, report_path) -> dict:
    size = (
        {"cells": source.n_cells, "valid_cells": source.n_valid} if isinstance(source, core.Heightfield)
        else {"points": len(source)} if isinstance(source, core.PointCloud)
        else {"input_vertices": source.n_vertices, "input_triangles": source.n_triangles}
    )
    return {
        "input": label,
        **size,
        "method": method,
        **({"prefilter": {"wavelet": {k: v for k, v in prefilter_kwargs.items() if v is not None}}}
           if prefilter_kwargs else {}),
        "options": {**mesh.info.get("options", {}), **files},  # geometry options by file name
        "n_vertices": mesh.n_vertices,
        "n_triangles": mesh.n_triangles,
        "vertical_error": mesh.info["error"],
        "outputs": list(outputs),
        **({"report": report_path} if report_path else {}),
        **({"quality": mesh.info["quality"]} if "quality" in mesh.info else {}),
        **({"flood": mesh.info["flood"], "segments": list(mesh.node_strings)} if "flood" in mesh.info else {}),
    }


def _print(summary, source, mesh, prefilter, verbose) -> None:
    click.echo(f"{describe_source(source, summary['input'])} "
               f"-> method {summary['method']}: {mesh.n_vertices:,} vertices, {mesh.n_triangles:,} triangles")
    what = ("valid cells" if isinstance(source, core.Heightfield) else "points" if isinstance(source, core.PointCloud)
            else "input vertices")
    click.echo("  vertical error (z units): " + format_error(mesh.info["error"],
                                                             what + (", unfiltered" if prefilter else "")))
    if "quality" in mesh.info:
        q = mesh.info["quality"]
        click.echo(f"  plan-view angles: min {num(q['min_plan_angle'])} deg for a bound of {num(q['min_angle'])}"
                   + (f"; {q['below_min_angle']:,} triangles below it, at input angles under 60 deg or edges under "
                      "0.05 cells" if q["below_min_angle"] else ""))
        imp = q.get("improvement")
        if imp and imp["passes"]:
            click.echo(f"  improvement: {imp['removed']:,} vertices taken back in {imp['passes']} passes, "
                       + ("both bounds kept" if "flood" not in summary else "the angle bound and the error bound "
                          "(where the time step allows it) kept"))
    if "flood" in summary:
        _print_flood(summary["flood"])
    if "segments" in summary:
        click.echo("  boundary segments: " + (", ".join(summary["segments"]) or "none"))
    report = summary.get("report")
    click.echo("  wrote: " + ", ".join(summary["outputs"]) + (f"; report {report}" if report else ""))
    click.echo(f"  time: {num(summary['time'])} s")
    if verbose:
        click.echo(format_timings(summary["timings"]))


def _print_flood(f: dict) -> None:
    """The flood method's report: the time step it sized for, and where the error bound gave way to it."""
    click.echo(f"  time step (CFL 1, expected flow): {'auto ' if f['time_step_auto'] else ''}{num(f['time_step'])} s; "
               f"smallest {num(f['min_step'])} s" + (f", {f['below_step']:,} triangles below the target (angle bound, "
                                                      "segments)" if f["below_step"] else ""))
    r = f["relaxed"]
    if r["triangles"]:
        w = r["worst_cell"]
        click.echo(f"  error bound {num(r['bound'])} relaxed by the time step in {r['triangles']:,} triangles "
                   f"({100 * r['area_share']:.1f}% of the area), worst {num(r['max_error'])} at x {num(w['x'])}, "
                   f"y {num(w['y'])}")
    click.echo(f"  streams: {f['streams']:,} ({'derived from the DEM' if f['streams_derived'] else 'given'}), "
               f"{f['stream_breaklines']:,} kept as breaklines")
