"""The ``tinsmith`` command: thin, in the manner of rasterio's ``rio``.

Each command parses its arguments, calls the public API and reports; no
numerics live here.  Every failure the user can cause ends with one line on
standard error and exit code 1 (``-v`` adds the traceback).
"""

from __future__ import annotations

import contextlib
import json
import re
import sys
import warnings
from pathlib import Path
import time
import traceback

import click

from .. import _lazy
from .._version import __version__
from ..algorithms.registry import DEFAULT_METHOD, GEOMETRY_KINDS, STOP_RULES, get_method, methods
from .. import core
from ..kernels import compiling
from ..core.stop import StopCriteria
from ..errors import InvalidInputError, InvalidOptionError, TinsmithError, TinsmithWarning
from ..io import (
    check_output_path, read, read_heightfield, read_mesh, reader_for, write, writer_for,
)
from ..io.paths import check_outputs
from ..io._atomic import atomic_paths
from ..io._errors import file_named_errors
from ..samples import SAMPLES, sample_path
from .progress import Pipeline
from .see import _check_html_output, add_see_commands
from .params import cloud_inputs, parse_classes
from .tile import add_tile_command
from .urban import add_urban_command
from .wavelet_options import wavelet_kwargs, wavelet_options
from .report import (
    _plain,
    describe_data,
    describe_survey,
    echo_json,
    format_comparison,
    format_error,
    format_info,
    format_metrics,
    format_quality,
    format_timings,
    num,
)

# numba, scipy and the methods load when a command first calls them, not at start-up
compare_methods = _lazy.function("tinsmith.algorithms.compare", "compare_methods")
fit = _lazy.function("tinsmith.algorithms.cvt.fit", "fit_heights")
levels_of_detail = _lazy.function("tinsmith.algorithms.lod", "levels_of_detail")
wavelet_mesh = _lazy.function("tinsmith.algorithms.wavelet.wavelet", "wavelet")
wavelet_filter = _lazy.function("tinsmith.algorithms.wavelet.wavelet", "wavelet_filter")
checked_points = _lazy.function("tinsmith.algorithms.greedy.pointtin", "checked_points")
read_clouds = _lazy.function("tinsmith.io.points", "read_clouds")
mesh_metrics = _lazy.function("tinsmith.metrics", "mesh_metrics")
vertical_error = _lazy.function("tinsmith.metrics.vertical", "vertical_error")
vertical_error_at_points = _lazy.function("tinsmith.metrics.vertical", "vertical_error_at_points")

_CLICK_TYPES = {float: click.FLOAT, int: click.INT, str: click.STRING}


# -- shared options ----------------------------------------------------------------------
def _verbose_json(func):
    func = click.option("--json", "as_json", is_flag=True, help="Print a JSON report instead of text.")(func)
    return click.option("-v", "--verbose", is_flag=True, help="Per-stage timings; tracebacks on errors.")(func)


def _read_options(func=None, *, gridding: bool = True):
    """Options of the readers (see tinsmith.io.registry.READ_OPTIONS); ``gridding`` adds --statistic."""
    if func is None:
        return lambda f: _read_options(f, gridding=gridding)
    decorators = [
        click.option("--sample", metavar="NAME", help=f"Use an embedded sample: {', '.join(SAMPLES)}."),
        click.option("--nodata", type=float, help="Height that marks missing data (nan for NaN)."),
        click.option("--band", type=click.IntRange(min=1), help="Raster band to read (default 1)."),
        click.option("--cell-size", type=float, help="Cell size: georeferences .npy arrays, grids point clouds."),
        click.option("--classes", callback=parse_classes, help="Point classes to keep, e.g. 2 or 2,9."),
        click.option("--encoding", type=click.Choice(["terrarium", "mapbox", "raw"]), help="PNG tile encoding."),
        click.option("--tile", metavar="Z/X/Y", help="Web-mercator tile index of a PNG tile."),
        click.option(
            "--statistic",
            type=click.Choice(["max", "min", "mean"]),
            default="max",
            show_default=True,
            help="How point heights in a cell are combined when gridding a point cloud.",
        ),
    ][: None if gridding else -1]
    for decorator in reversed(decorators):
        func = decorator(func)
    return func


def _input_path(path, sample):
    if path and sample:
        raise click.UsageError("give an input file or --sample, not both")
    if sample:
        return str(sample_path(sample)), f"sample {sample}"
    if not path:
        raise click.UsageError("missing input: give a file or --sample NAME")
    return path, path


def _inputs(inputs, sample):
    """``(path, label)`` of one input, or ``(files, label)`` of several point clouds (files, folders, globs)."""
    clouds = _cloud_inputs(inputs, sample)
    if clouds is not None and (len(inputs) > 1 or len(clouds) > 1 or not Path(inputs[0]).is_file()):
        return clouds, _label(clouds)
    return _input_path(inputs[0] if inputs else None, sample)


def _reader_options(opts) -> dict:
    return {k: opts[k] for k in ("nodata", "band", "cell_size", "classes", "encoding", "tile")}


def _load_heightfield(path, opts):
    """A raster, or point clouds gridded (``path`` a list of cloud files: read as one)."""
    if isinstance(path, list):
        return read_clouds(path, classes=opts["classes"]).to_heightfield(opts["cell_size"], statistic=opts["statistic"])
    return read_heightfield(path, statistic=opts["statistic"], **_reader_options(opts))


def _load_source(path, opts, record):
    """The input of the method: a heightfield, or a mesh when the file holds one and the method takes meshes."""
    if isinstance(path, list) or reader_for(path).kind != "mesh":
        return _load_heightfield(path, opts)
    if record.input in ("heightfield", "elevation"):
        takes_meshes = ", ".join(m.name for m in methods() if m.input in ("mesh", "surface"))
        raise InvalidInputError(
            f"{str(path)!r} is a mesh, but method {record.name!r} takes a raster or a point cloud; "
            f"methods that take meshes: {takes_meshes}"
        )
    return read(path, **_reader_options(opts))


def _measure(mesh, source, kwargs=None) -> dict:
    """The vertical error against the source: every valid cell of a heightfield, every vertex of a mesh,
    every point of a cloud (one a x-y, by the ``duplicates`` rule; not those inside holes or flat polygons)."""
    if isinstance(source, core.Heightfield):
        return vertical_error(mesh, source)
    if isinstance(source, core.PointCloud):
        kwargs = kwargs or {}
        return vertical_error_at_points(mesh, checked_points(source, kwargs.get("duplicates", "lowest"),
                                                             holes=kwargs.get("holes"), flat=kwargs.get("flat")))
    return vertical_error_at_points(mesh, source.vertices)


def _cloud_inputs(inputs, sample=None) -> list | None:
    """The files of point-cloud inputs (several files, folders, globs), or None for one file of another kind."""
    if inputs and sample:
        raise click.UsageError("give an input file or --sample, not both")
    return cloud_inputs(inputs)


def _label(files) -> str:
    return str(files[0]) if len(files) == 1 else f"{len(files)} files ({files[0].name}, ...)"


def _describe_source(source, label) -> str:
    if isinstance(source, core.Heightfield):
        rows, cols = source.shape
        return f"{label}: {rows:,} x {cols:,} = {source.n_cells:,} cells ({source.n_valid:,} valid)"
    if isinstance(source, core.PointCloud):
        return f"{label}: {len(source):,} points"
    return f"{label}: a mesh of {source.n_vertices:,} vertices, {source.n_triangles:,} triangles"


# -- commands ------------------------------------------------------------------------------
def build_cli() -> click.Group:
    """The command group, with ``simplify``'s method options taken from the registry."""

    @click.group(context_settings={"help_option_names": ["-h", "--help"]})
    @click.version_option(__version__, prog_name="tinsmith")
    def cli():
        """tinsmith: elevation data to compact, well-shaped triangle meshes (TINs)."""

    @cli.command()
    @click.argument("files", metavar="FILE...", nargs=-1)
    @_read_options(gridding=False)
    @_verbose_json
    def info(files, verbose, as_json, **opts):
        """Describe a raster, point cloud or mesh: size, CRS, z range, nodata; a survey of many clouds from their headers."""
        path, label = _inputs(files, opts.pop("sample"))
        report = describe_survey(files, path) if isinstance(path, list) else describe_data(read(path, **opts), label)
        echo_json(report) if as_json else click.echo(format_info(report))

    @cli.command()
    @click.argument("input_files", metavar="INPUT...", nargs=-1)
    @click.option(
        "-o", "--output", "outputs", multiple=True, required=True, metavar="OUT",
        help="Output file; the suffix picks the format (repeat for several).",
    )
    @click.option("--method", default=DEFAULT_METHOD, show_default=True, help="Method name (see `tinsmith methods`).")
    @click.option("--grid", "grid_points", is_flag=True,
                  help="Point clouds: grid the points first (at --cell-size) instead of meshing them as they are.")
    @click.option("--max-error", type=float, help="Stop when the vertical error is at most this (z units).")
    @click.option("--max-vertices", type=int, help="Stop before exceeding this many vertices.")
    @click.option("--max-triangles", type=int, help="Stop before exceeding this many triangles.")
    @click.option("--fit-heights", is_flag=True,
                  help="Replace the vertex heights by their least-squares fit to every covered cell (approximating, lower RMS).")
    @click.option("--prefilter", type=click.Choice(["wavelet"]),
                  help="Filter the heights first: wavelet, seed 004's land-use steered spline and Haar filter (options below).")
    @click.option("--report", "report_path", metavar="REPORT.html",
                  help="Also write the HTML report of the mesh against the input raster (see `tinsmith report`).")
    @_method_options
    @wavelet_options(required=False)
    @_read_options
    @_verbose_json
    def simplify(input_files, outputs, method, grid_points, fit_heights, prefilter, report_path, verbose, as_json,
                 **opts):
        """Make a mesh of INPUT with a method and write it to every OUT.

        Point clouds (LAS/LAZ, XYZ) may be several files, folders or globs, read as one cloud; the
        default method meshes their points as they are (greedy insertion on points), --grid grids them.
        """
        sample = opts.pop("sample")
        clouds = _cloud_inputs(input_files, sample)
        if clouds is not None:
            path, label = str(clouds[0]), _label(clouds)
        else:
            path, label = _input_path(input_files[0] if input_files else None, sample)
        prefilter_kwargs = wavelet_kwargs(opts)
        if prefilter is None and any(prefilter_kwargs[k] is not None for k in ("landuse", "roles", "attribute", "thresholds")):
            raise click.UsageError("--landuse, --role, --attribute and --thresholds go with --prefilter wavelet")
        record = get_method(method)
        # only what the user typed reaches the method, so its own defaults apply
        method_kwargs = _pop_method_kwargs(opts, STOP_RULES)
        record.bind(method_kwargs)  # fail on bad options before any reading
        for out in outputs:
            check_output_path(out)
        if report_path:
            _check_html_output(report_path)
        files = _geometry_names(record, method_kwargs)
        check_outputs([*outputs, report_path], [*(clouds or [path]), *files.values(), prefilter_kwargs.get("landuse")])
        on_points = clouds is not None and record.input == "elevation" and not grid_points and opts["cell_size"] is None
        weights = {"read": 1, **({"prefilter": 2} if prefilter else {}), "method": 4,
                   **({"fit heights": 1} if fit_heights else {}), "metrics": 2,
                   **{f"write {out}": 1 for out in outputs}}
        pipeline = Pipeline(weights, show=not as_json)
        start = time.perf_counter()
        with _naming(path, files), pipeline:
            with pipeline.stage("read") as report:
                if clouds is not None:
                    source = read_clouds(clouds, classes=opts["classes"], progress=lambda n, total: report(n / total))
                    if not on_points:
                        source = source.to_heightfield(opts["cell_size"], opts["statistic"])
                else:
                    source = _load_source(path, opts, record)
                _load_geometry(record, method_kwargs, source)
            data = source
            if prefilter:
                if not isinstance(source, core.Heightfield):
                    raise click.UsageError("--prefilter wavelet needs a raster input")
                with pipeline.stage("prefilter"):
                    epsilon = method_kwargs.get("max_error", 0.2)  # what "auto" counts quadtree triangles at
                    data = wavelet_filter(source, epsilon=epsilon, **prefilter_kwargs).heightfield
            with pipeline.stage("method") as report:
                mesh = record.function(data, progress=report, **method_kwargs)
            if fit_heights:
                if not isinstance(source, core.Heightfield):
                    raise click.UsageError("--fit-heights needs a raster input (the cells to fit)")
                with pipeline.stage("fit heights"):
                    mesh = fit(mesh, source)
            mesh.info["name"] = sample or Path(path).stem  # files that hold a name (2DM, LandXML)
            with pipeline.stage("metrics"):
                mesh.info["error"] = _measure(mesh, source, method_kwargs)
            grid = source if isinstance(source, core.Heightfield) else None
            for out in outputs:
                with pipeline.stage(f"write {out}"):
                    write(mesh, out, grid=grid)
            if report_path:
                if grid is None:
                    raise click.UsageError("--report needs a raster input (the DEM to judge the mesh against)")
                with pipeline.stage("report"):
                    from ..viz.report import write_report

                    write_report(report_path, source, {record.name: mesh}, dem_name=label,
                                 settings={"method": record.name, "options": mesh.info.get("options", {}),
                                           "outputs": list(outputs)})
        total = time.perf_counter() - start
        size = (
            {"cells": source.n_cells, "valid_cells": source.n_valid} if grid is not None
            else {"points": len(source)} if isinstance(source, core.PointCloud)
            else {"input_vertices": source.n_vertices, "input_triangles": source.n_triangles}
        )
        summary = {
            "input": label,
            **size,
            "method": record.name,
            **({"prefilter": {"wavelet": {k: v for k, v in prefilter_kwargs.items() if v is not None}}} if prefilter else {}),
            "options": {**mesh.info.get("options", {}), **files},  # geometry options by file name
            "n_vertices": mesh.n_vertices,
            "n_triangles": mesh.n_triangles,
            "vertical_error": mesh.info["error"],
            "outputs": list(outputs),
            **({"report": report_path} if report_path else {}),
            **({"quality": mesh.info["quality"]} if "quality" in mesh.info else {}),
            "time": total,
            "timings": {**pipeline.timings, **{f"method: {k}": v for k, v in mesh.info["timings"].items() if k != "method"}},
        }
        if as_json:
            echo_json(summary)
            return
        click.echo(
            f"{_describe_source(source, label)} "
            f"-> method {record.name}: {mesh.n_vertices:,} vertices, {mesh.n_triangles:,} triangles"
        )
        what = "valid cells" if grid else "points" if isinstance(source, core.PointCloud) else "input vertices"
        click.echo("  vertical error (z units): " + format_error(mesh.info["error"], what + (", unfiltered" if prefilter else "")))
        if "quality" in mesh.info:
            q = mesh.info["quality"]
            click.echo(f"  plan-view angles: min {num(q['min_plan_angle'])} deg for a bound of {num(q['min_angle'])}"
                       + (f"; {q['below_min_angle']:,} triangles below it, at input angles under 60 deg or edges under "
                          "0.05 cells" if q["below_min_angle"] else ""))
        click.echo("  wrote: " + ", ".join(outputs) + (f"; report {report_path}" if report_path else ""))
        click.echo(f"  time: {num(total)} s")
        if verbose:
            click.echo(format_timings(summary["timings"]))

    @cli.command()
    @click.argument("inputs", metavar="INPUT...", nargs=-1)
    @click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR",
                  help="Folder for the levels and index.json (made if missing; its parent must exist).")
    @click.option("--method", default=DEFAULT_METHOD, show_default=True, help="Method name (see `tinsmith methods`).")
    @click.option("--levels", "error_levels", metavar="E1,E2,...", help="Error bounds of the levels (z units).")
    @click.option("--vertices", "vertex_levels", metavar="N1,N2,...", help="Vertex budgets of the levels.")
    @click.option("--format", "suffix", default="ply", show_default=True, help="Suffix of the level files.")
    @_method_options
    @_read_options
    @_verbose_json
    def lod(inputs, outdir, method, error_levels, vertex_levels, suffix, verbose, as_json, **opts):
        """Write several levels of detail of INPUT at once, with an index.json that describes them."""
        sample = opts.pop("sample")
        path, label = _inputs(inputs, sample)
        record = get_method(method)
        method_kwargs = _pop_method_kwargs(opts)
        if (error_levels is None) == (vertex_levels is None):
            raise click.UsageError("give the levels with --levels (error bounds) or --vertices (budgets)")
        key, raw = ("max_error", error_levels) if error_levels is not None else ("max_vertices", vertex_levels)
        values = _parse_levels(raw, float if key == "max_error" else int, "--levels" if key == "max_error" else "--vertices")
        record.bind({**method_kwargs, key: values[0]})
        out = Path(outdir)
        if out.exists() and not out.is_dir():
            raise click.UsageError(f"output {outdir!r} is a file, expected a folder")
        if not (out.parent if str(out.parent) else Path(".")).is_dir():
            raise click.UsageError(f"the parent folder of {outdir!r} does not exist")
        files = [out / f"level_{i}.{suffix.lstrip('.')}" for i in range(len(values))]
        writer_for(files[0])  # an unknown suffix fails before any work
        check_outputs([*files, out / "index.json"],
                      [*(path if isinstance(path, list) else [path]), *_geometry_names(record, method_kwargs).values()])
        pipeline = Pipeline({"read": 1, "levels": 4, "metrics": 2, "write": 2}, show=not as_json)
        start = time.perf_counter()
        with _naming(path, _geometry_names(record, method_kwargs)), pipeline:
            with pipeline.stage("read"):
                source = _load_source(path, opts, record)
                _load_geometry(record, method_kwargs, source)
            with pipeline.stage("levels"):
                levels = {"max_errors" if key == "max_error" else "max_vertices": values}
                meshes = levels_of_detail(source, record.name, **levels, **method_kwargs)
            with pipeline.stage("metrics"):
                for mesh in meshes:
                    mesh.info["error"] = _measure(mesh, source)
            with pipeline.stage("write"):
                out.mkdir(exist_ok=True)
                grid = source if isinstance(source, core.Heightfield) else None
                for mesh, file in zip(meshes, files):
                    write(mesh, file, grid=grid)
                index = {
                    "input": label,
                    "method": record.name,
                    "levels": [
                        {
                            "level": i, key: v, "n_vertices": m.n_vertices, "n_triangles": m.n_triangles,
                            "vertical_error": {k: m.info["error"][k] for k in ("max", "rmse", "coverage")},
                            "file": f.name,
                        }
                        for i, (m, v, f) in enumerate(zip(meshes, values, files))
                    ],
                }
                with atomic_paths(out / "index.json") as (tmp,):
                    tmp.write_text(json.dumps(_plain(index), indent=2) + "\n")
        if as_json:
            echo_json({**index, "time": time.perf_counter() - start})
            return
        click.echo(f"{label} -> method {record.name}, {len(meshes)} levels in {outdir}:")
        for row in index["levels"]:
            click.echo(
                f"  {row['file']}: {key.replace('_', ' ')} {num(row[key])}, {row['n_vertices']:,} vertices, "
                f"{row['n_triangles']:,} triangles, measured max {num(row['vertical_error']['max'])}"
            )
        click.echo(f"  index: {out / 'index.json'}")
        click.echo(f"  time: {num(time.perf_counter() - start)} s")

    @cli.command()
    @click.argument("inputs", metavar="INPUT...", nargs=-1)
    @click.option(
        "--methods", "method_names", metavar="M1,M2,...",
        help="Methods to compare, separated by commas (default: every method with stop rules).",
    )
    @click.option("--max-error", type=float, help="The error bound every method gets (z units).")
    @click.option("--max-vertices", type=int, help="The vertex budget every method gets.")
    @click.option("--max-triangles", type=int, help="The triangle budget every method gets.")
    @click.option("--markdown", is_flag=True, help="Print a Markdown table.")
    @_read_options
    @_verbose_json
    def compare(inputs, method_names, max_error, max_vertices, max_triangles, markdown, verbose, as_json, **opts):
        """Run several methods on INPUT under one stop rule and print one table of their metrics."""
        path, label = _inputs(inputs, opts.pop("sample"))
        names = (
            [n.strip() for n in method_names.split(",") if n.strip()] if method_names
            else [m.name for m in methods() if m.stop_rules]
        )
        rule = dict(max_error=max_error, max_vertices=max_vertices, max_triangles=max_triangles)
        for name in names:
            get_method(name)  # unknown names fail before anything is read
        if sum(v is not None for v in rule.values()) != 1:
            raise click.UsageError("give exactly one of --max-error, --max-vertices, --max-triangles")
        StopCriteria(**{k: v for k, v in rule.items() if v is not None})  # a bad value fails before reading
        pipeline = Pipeline({"read": 1, "methods": 6}, show=not (as_json or markdown))
        with _naming(path), pipeline:
            with pipeline.stage("read"):
                hf = _load_heightfield(path, opts)
            with pipeline.stage("methods"):
                rows = compare_methods(hf, names, **rule)
        given = {k: v for k, v in rule.items() if v is not None}
        if as_json:
            echo_json({"input": label, "rule": given, "rows": rows})
            return
        if not markdown:
            (key, value), = given.items()
            click.echo(f"{label}: {hf.n_valid:,} valid cells, {key.replace('_', ' ')} {num(value)}")
        click.echo(format_comparison(rows, markdown=markdown))

    @cli.command()
    @click.argument("inputs", metavar="CLOUD...", nargs=-1, required=True)
    @click.option("-o", "--output", "outputs", multiple=True, required=True, metavar="OUT",
                  help="Mesh file; the suffix picks the format (repeat for several).")
    @click.option("--mode", type=click.Choice(["auto", "heightfield", "general"]), default="auto", show_default=True,
                  help="heightfield: one point per dexel, for terrain and single-view scans; general: any surface.")
    @click.option("--mu", type=float, default=2.5, show_default=True,
                  help="Neighbours lie within mu times a point's distance to its second-nearest point (general mode).")
    @click.option("--max-angle", type=float, default=120.0, show_default=True,
                  help="Degrees; wider gaps between neighbours stay open as borders (general mode).")
    @click.option("--min-angle", type=float, default=10.0, show_default=True,
                  help="Degrees; drop neighbours that make smaller angles where no point gets trapped (general mode).")
    @click.option("--dexel-size", type=float, help="Dexel width (world units); heightfield mode keeps one point per dexel.")
    @click.option("--classes", callback=parse_classes, help="Point classes to keep, e.g. 2 or 2,9.")
    @_verbose_json
    def reconstruct(inputs, outputs, mode, mu, max_angle, min_angle, dexel_size, classes, verbose, as_json):
        """Mesh a point cloud (LAS/LAZ, XYZ; several files, folders, globs) in one pass, without gridding it (seed 001)."""
        from ..algorithms.reconstruct.reconstruct import reconstruct as build
        from ..metrics import surface_problems

        clouds = cloud_inputs(inputs)
        if clouds is None:
            raise InvalidInputError(f"{inputs[0]!r} is not a point cloud; give LAS/LAZ or XYZ files")
        input_file = _label(clouds)
        for out in outputs:
            check_output_path(out)
        check_outputs(outputs, clouds)
        pipeline = Pipeline({"read": 1, "reconstruct": 4, "write": 1}, show=not as_json)
        start = time.perf_counter()
        with _naming(input_file), pipeline:
            with pipeline.stage("read"):
                # one file: its reader's messages (an empty class names the classes present with their counts)
                cloud = read(clouds[0], classes=classes) if len(clouds) == 1 else read_clouds(clouds, classes=classes)
            with pipeline.stage("reconstruct"):
                mesh = build(cloud, mode=mode, mu=mu, max_angle=max_angle, min_angle=min_angle, dexel_size=dexel_size)
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

    @cli.command()
    @click.argument("input_file", metavar="INPUT", required=False)
    @click.option("-o", "--output", "outputs", multiple=True, required=True, metavar="OUT",
                  help="Mesh file; the suffix picks the format (repeat for several).")
    @_record_options("remesh", flags={"n_vertices": "--vertices"}, required=("n_vertices",))
    @_read_options
    @_verbose_json
    def remesh(input_file, outputs, verbose, as_json, **opts):
        """Remesh INPUT (a DEM or a disk-like mesh) with exactly --vertices well-shaped vertices (seed 003)."""
        from ..metrics import triangle_quality

        path, label = _input_path(input_file, opts.pop("sample"))
        record = get_method("remesh")
        # only what the user typed reaches the method, so its own defaults apply
        kwargs = {k: v for k, v in ((o.name, opts.pop(o.name)) for o in record.options) if v is not None}
        record.bind(kwargs)  # bad options fail before any reading
        for out in outputs:
            check_output_path(out)
        check_outputs(outputs, [path, *_geometry_names(record, kwargs).values()])
        pipeline = Pipeline({"read": 1, "remesh": 4, "write": 1}, show=not as_json)
        start = time.perf_counter()
        with _naming(path, _geometry_names(record, kwargs)), pipeline:
            with pipeline.stage("read"):
                source = _load_source(path, opts, record)
                _load_geometry(record, kwargs, source)
            with pipeline.stage("remesh") as report:
                mesh = record.function(source, progress=report, **kwargs)
            with pipeline.stage("write"):
                grid = source if isinstance(source, core.Heightfield) else None
                for out in outputs:
                    write(mesh, out, grid=grid)
        quality = triangle_quality(mesh, 3)
        error = _measure(mesh, source)
        summary = {"input": label, "n_vertices": mesh.n_vertices, "n_triangles": mesh.n_triangles,
                   **mesh.info["remesh"], "quality": quality, "vertical_error": error, "outputs": list(outputs),
                   "time": time.perf_counter() - start}
        if as_json:
            echo_json(summary)
            return
        info = mesh.info["remesh"]
        click.echo(f"{_describe_source(source, label)} -> {mesh.n_vertices:,} vertices ({info['corners']:,} corners, "
                   f"{info['feature_samples']:,} on features), {mesh.n_triangles:,} triangles; "
                   f"{info['parameterization']} parameter space, {info['lloyd_iterations']} Lloyd iterations")
        click.echo("  vertical error (z units): " + format_error(error, "valid cells" if grid else "input vertices"))
        click.echo("  quality 3-D: " + format_quality(quality))
        click.echo("  wrote: " + ", ".join(outputs))
        click.echo(f"  time: {num(summary['time'])} s")

    @cli.command()
    @click.argument("input_file", metavar="DEM", required=False)
    @click.option("-o", "--output", "outputs", multiple=True, required=True, metavar="OUT",
                  help="Mesh file; the suffix picks the format (repeat for several).")
    @click.option("--epsilon", type=float, default=0.2, show_default=True,
                  help="Accuracy of the quadtree against the filtered heights (z units).")
    @click.option("--filtered", metavar="TIF", help="Also write the filtered heights (GeoTIFF).")
    @click.option("--class-map", metavar="TIF", help="Also write the class of every grid point (GeoTIFF; codes in the docs).")
    @wavelet_options
    @_read_options
    @_verbose_json
    def wavelet(input_file, outputs, epsilon, filtered, class_map, verbose, as_json, **opts):
        """A city terrain meshed where its land use needs detail: spline, Haar wavelets, quadtree (seed 004)."""
        from ..io.gis_formats import write_grid

        path, label = _input_path(input_file, opts.pop("sample"))
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
        with _naming(path), pipeline:
            with pipeline.stage("read"):
                hf = _load_heightfield(path, opts)
            with pipeline.stage("wavelet"):
                mesh, result = wavelet_mesh(hf, epsilon=epsilon, return_filter=True, **kwargs)
            with pipeline.stage("write"):
                for out in outputs:
                    write(mesh, out, grid=hf)
                if filtered is not None:
                    write_grid(result.heightfield.z, filtered, hf)
                if class_map is not None:
                    write_grid(result.classes, class_map, hf, nodata=0)
        info = mesh.info["wavelet"]
        error = vertical_error(mesh, hf)
        summary = {"input": label, "cells": hf.n_cells, "n_vertices": mesh.n_vertices, "n_triangles": mesh.n_triangles,
                   **info, "vertical_error": error, "outputs": [*outputs, *rasters], "time": time.perf_counter() - start}
        if as_json:
            echo_json(summary)
            return
        tried = info["triangles_by_iterations"]
        click.echo(f"{_describe_source(hf, label)} -> {mesh.n_vertices:,} vertices, {mesh.n_triangles:,} triangles "
                   f"at epsilon {num(epsilon)}, {info['spline_iterations']} spline iterations"
                   + (" (auto: " + ", ".join(f"{k}: {v:,}" for k, v in tried.items()) + ")" if tried else ""))
        click.echo("  classes: " + ", ".join(f"{name} {n:,}" for name, n in info["classes"].items() if n))
        click.echo("  error against the unfiltered heights, by class (max / RMS):")
        for name, e in info["error_by_class"].items():
            click.echo(f"    {name}: {num(e['max'])} / {num(e['rmse'])}")
        click.echo("  wrote: " + ", ".join(summary["outputs"]))
        click.echo(f"  time: {num(summary['time'])} s")

    @cli.command()
    @click.argument("mesh_file", metavar="MESH")
    @click.argument("sources", metavar="DEM...", nargs=-1)
    @_read_options
    @_verbose_json
    def metrics(mesh_file, sources, verbose, as_json, **opts):
        """Judge MESH against DEM (a raster, or point clouds: the error at every point): vertical error, quality, counts."""
        path, label = _inputs(sources, opts.pop("sample"))
        pipeline = Pipeline({"read mesh": 1, "read dem": 1, "metrics": 3}, show=not as_json)
        try:
            with pipeline.stage("read mesh"):
                mesh = read_mesh(mesh_file)
            with pipeline.stage("read dem"):
                clouds = path if isinstance(path, list) else [path] if reader_for(path).kind == "points" else None
                on_points = clouds is not None and opts["cell_size"] is None
                source = read_clouds(clouds, classes=opts["classes"]) if on_points else _load_heightfield(path, opts)
            with pipeline.stage("metrics"):
                if on_points:  # at every point (one a x-y: the lowest, as the TIN keeps it)
                    result = mesh_metrics(mesh)
                    result["vertical_error"] = vertical_error_at_points(mesh, checked_points(source))
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

    @cli.command("methods")
    @_verbose_json
    def methods_cmd(verbose, as_json):
        """List the methods with their options."""
        records = [
            {
                "name": m.name,
                "description": m.description,
                "input": m.input,
                "stop_rules": list(STOP_RULES) if m.stop_rules else [],
                "options": [
                    {"name": o.name, "type": o.type.__name__, "default": o.default, "doc": o.describe()}
                    for o in m.options
                ],
                "paper": m.paper,
                "default": m.name == DEFAULT_METHOD,
            }
            for m in methods()
        ]
        if as_json:
            echo_json({"methods": records})
            return
        for r in records:
            flag = " (default)" if r["default"] else ""
            click.echo(f"{r['name']}{flag}: {r['description']}")
            if r["stop_rules"]:
                click.echo("  stop rules: " + ", ".join("--" + s.replace("_", "-") for s in r["stop_rules"]))
            for o in r["options"]:
                click.echo(f"  --{o['name'].replace('_', '-')} ({o['type']}): {o['doc']}")
            if r["paper"]:
                click.echo(f"  from: {r['paper']}")

    @cli.command()
    @click.option("--jobs", metavar="J1,J2,...",
                  help="Warm up only these jobs: default (the README's first command), methods, points, city, "
                       "filters, reconstruct, tiles.")
    def warmup(jobs):
        """Compile every numerical kernel now, once, so that later runs start at once.

        The package ships the compiled kernels of these jobs for the numba, Python and platform it
        was built with; elsewhere (or after a kernel changes) they compile on first use and are
        cached. This runs each job once on a small piece of the sample.
        """
        from ..kernels import compiling
        from ..warmup import JOBS, warmup as run

        names = [j for j in jobs.replace(" ", "").split(",") if j] if jobs else None

        def say(name):
            click.echo(f"{name}: {JOBS[name][0]} ...", err=True)

        seconds = run(names, progress=say)
        count, spent = compiling.compiled()
        click.echo(f"warmed up {', '.join(seconds)} in {num(sum(seconds.values()))} s; "
                   f"{count} kernel(s) compiled ({num(spent)} s), the rest loaded from the cache")

    @cli.command()
    @_verbose_json
    def samples(verbose, as_json):
        """List the embedded sample datasets (use them with --sample NAME)."""
        rows = [{"name": s.name, "description": s.description, "licence": s.licence} for s in SAMPLES.values()]
        if as_json:
            echo_json({"samples": rows})
            return
        for r in rows:
            click.echo(f"{r['name']}: {r['description']} [{r['licence']}]")

    @cli.command()
    @_verbose_json
    def formats(verbose, as_json):
        """List the file formats tinsmith reads and writes."""
        from ..io import READERS, WRITERS

        readers = {}
        for suffix, rec in READERS.items():
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

    add_tile_command(cli, _click_option, _verbose_json)
    add_urban_command(cli, _read_options, _verbose_json, _inputs, _naming)
    add_see_commands(cli, _read_options, _verbose_json, _input_path, _load_heightfield)
    return cli


def _parse_levels(raw: str, kind, flag: str) -> list:
    try:
        values = [kind(v) for v in raw.replace(" ", "").split(",") if v]
    except ValueError:
        raise click.BadParameter(f"{flag} takes numbers separated by commas, e.g. 20,5,1; got {raw!r}") from None
    if not values:
        raise click.BadParameter(f"{flag} takes at least one level")
    repeated = sorted({v for v in values if values.count(v) > 1})
    if repeated:
        raise click.BadParameter(f"{flag} lists the level {repeated[0]:g} more than once ({raw}); give each level once")
    return values


#: The validators' messages about a value (tinsmith._checks): ``NAME must be ...``.
_OPTION_MESSAGE = re.compile(r"^[A-Za-z_][\w\[\]]* must ")


@contextlib.contextmanager
def _naming(path, geometry=None):
    """Name the input in the errors its data causes (no points, no area, a bad mesh) that do not name it yet.

    ``geometry`` maps option names (``breaklines``) to the files they came
    from: an error about them names that file.  Option errors are left as
    they are: they name the option, not the file.
    """
    if isinstance(path, list):  # several point-cloud files read as one
        path = _label(path)
    try:
        yield
    except InvalidOptionError:
        raise
    except InvalidInputError as exc:
        text = str(exc)
        if text.startswith("'") or str(path) in text or Path(str(path)).name in text:  # names a file already
            raise
        if _OPTION_MESSAGE.match(text):  # "mu must be a finite number > 1, got 0": about an option, not the file
            raise
        about = next((f for name, f in (geometry or {}).items() if text.startswith(name)), path)
        raise type(exc)(f"{str(about)!r}: {text}") from exc


class _NumberOrWord(click.ParamType):
    """A number, or a word such as 'auto' or 'none' (passed on as written, lower case)."""

    name = "NUMBER|auto|none"

    def convert(self, value, param, ctx):
        try:
            return float(value)
        except (TypeError, ValueError):
            return str(value).strip().lower()


_NUMBER_OR_WORD = _NumberOrWord()



def _geometry_names(record, kwargs: dict) -> dict:
    """The file names given for the geometry options (breaklines, control points, ...), by option name."""
    return {o.name: kwargs[o.name] for o in record.options if o.kind in GEOMETRY_KINDS and kwargs.get(o.name) is not None}


def _load_geometry(record, kwargs: dict, hf) -> None:
    """Replace the file names given for geometry options (breaklines, ...) by their coordinates."""
    from ..io import vector

    for opt in record.options:
        if opt.kind in GEOMETRY_KINDS and kwargs.get(opt.name) is not None:
            if opt.kind == "regions":  # polygons with their fields (max_area, name), reprojected
                items, crs = vector.read_regions(kwargs[opt.name])
                with file_named_errors(kwargs[opt.name]):
                    moved = vector.reproject([g for g, _, _ in items], crs, hf.crs)
                    kwargs[opt.name] = [(g, a, n) for g, (_, a, n) in zip(moved, items)]
                continue
            if opt.kind == "polygons":  # areas are reprojected to the data's CRS
                polygons, crs = vector.read_polygons(kwargs[opt.name])
                with file_named_errors(kwargs[opt.name]):
                    kwargs[opt.name] = list(vector.reproject(polygons, crs, hf.crs))
                continue
            reader = vector.read_lines if opt.kind == "lines" else vector.read_points
            coords, crs = reader(kwargs[opt.name])
            with file_named_errors(kwargs[opt.name]):
                vector.check_same_crs(opt.name, crs, hf.crs)
            kwargs[opt.name] = coords


def _pop_method_kwargs(opts: dict, extra=()) -> dict:
    """Take the method options (and the ``extra`` names) out of the parsed options; only those the user typed."""
    taken = {name: opts.pop(name) for name in [*extra, *_method_option_specs()]}
    return {k: v for k, v in taken.items() if v is not None}


def _method_option_specs() -> dict:
    """Union of the registered methods' options (the registry guarantees one type per name)."""
    specs = {}
    for m in methods():
        for o in m.options:
            specs.setdefault(o.name, []).append((m.name, o))
    return specs


def _click_option(opt, flag: str, help_text: str, required: bool = False):
    """The click option of a registered method option; default None, so that the method's own default applies."""
    if opt.type is bool:
        return click.option(f"{flag}/--no-{flag[2:]}", opt.name, default=None, help=help_text)
    if opt.kind in GEOMETRY_KINDS:
        return click.option(flag, opt.name, type=click.Path(dir_okay=False), default=None, metavar="FILE",
                            required=required, help=help_text)
    if opt.type is object:  # a number or a word ('auto', 'none'): the method checks it
        return click.option(flag, opt.name, type=_NUMBER_OR_WORD, default=None, required=required, help=help_text)
    ptype = click.Choice(opt.choices) if opt.choices else _CLICK_TYPES[opt.type]
    if opt.type is int and (opt.minimum is not None or opt.maximum is not None):  # click names the flag
        ptype = click.IntRange(min=opt.minimum, max=opt.maximum, min_open=opt.exclusive_min)
    return click.option(flag, opt.name, type=ptype, default=None, required=required, help=help_text)


def _method_options(func):
    """A click option per registered method option; values reach only the chosen method."""
    for name, owners in reversed(list(_method_option_specs().items())):
        _, opt = owners[0]
        who = ", ".join(m for m, _ in owners)
        func = _click_option(opt, "--" + name.replace("_", "-"), f"[{who}] {opt.describe()}")(func)
    return func


def _record_options(method: str, *, flags=None, required=()):
    """The options of one registered method for its own command (``flags`` renames some)."""
    def decorate(func):
        for opt in reversed(get_method(method).options):
            flag = (flags or {}).get(opt.name, "--" + opt.name.replace("_", "-"))
            func = _click_option(opt, flag, opt.describe(), required=opt.name in required)(func)
        return func

    return decorate


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """tinsmith's own warnings as one line on stderr; others as Python shows them."""
    if issubclass(category, TinsmithWarning):
        click.echo(f"tinsmith: warning: {message}", err=True)
    else:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


def main(argv=None) -> int:
    """Console entry point: one clear line and exit code 1 on any failure."""
    args = sys.argv[1:] if argv is None else list(argv)
    verbose = "-v" in args or "--verbose" in args
    # a first run may compile kernels for a minute: say so on standard error rather than sit silent
    compiling.announce_with(lambda message: click.echo(f"tinsmith: {message}", err=True))
    cli = build_cli()
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            code = cli.main(args=args, prog_name="tinsmith", standalone_mode=False)
        return code if isinstance(code, int) else 0
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except click.exceptions.Abort:
        click.echo("tinsmith: aborted", err=True)
        return 1
    except click.ClickException as exc:  # usage errors: unknown option, missing argument, ...
        command = f" {exc.ctx.info_name}" if getattr(exc, "ctx", None) and exc.ctx.parent else ""
        click.echo(f"tinsmith{command}: error: {exc.format_message()}", err=True)
        return 1
    except (TinsmithError, OSError, MemoryError) as exc:
        if verbose:
            traceback.print_exc()
        click.echo(f"tinsmith: error: {exc}", err=True)
        return 1
    except Exception as exc:  # a bug: still one line, the traceback with -v
        if verbose:
            traceback.print_exc()
        click.echo(
            f"tinsmith: internal error: {type(exc).__name__}: {exc} (run with -v for the traceback)", err=True
        )
        return 1
