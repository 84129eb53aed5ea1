"""``tinsmith lod``: several levels of detail of one input in one run."""

from __future__ import annotations

import json
import time
from pathlib import Path

import click

from .. import core
from ..algorithms.registry import DEFAULT_METHOD, get_method
from ..io import write, writer_for
from ..io._atomic import atomic_paths
from ..io.paths import check_outputs
from .common import inputs_of, levels_of_detail, load_source, measure, naming, parse_levels
from .options import MethodCommand, geometry_names, method_options, pop_method_kwargs, read_options, verbose_json
from .progress import Pipeline
from .text import _plain, echo_json, num


@click.command(cls=MethodCommand)
@click.argument("inputs", metavar="INPUT...", nargs=-1)
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR",
              help="Folder for the levels and index.json (made if missing; its parent must exist).")
@click.option("--method", default=DEFAULT_METHOD, show_default=True, help="Method name (see `tinsmith methods`).")
@click.option("--levels", "error_levels", metavar="E1,E2,...", help="Error bounds of the levels (z units).")
@click.option("--vertices", "vertex_levels", metavar="N1,N2,...", help="Vertex budgets of the levels.")
@click.option("--format", "suffix", default="ply", show_default=True, help="Suffix of the level files.")
@method_options
@read_options
@verbose_json
def lod(inputs, outdir, method, error_levels, vertex_levels, suffix, verbose, as_json, **opts):
    """Write several levels of detail of INPUT at once, with an index.json that describes them."""
    path, label = inputs_of(inputs, opts.pop("sample"))
    record = get_method(method)
    method_kwargs = pop_method_kwargs(opts)
    key, values = _levels(error_levels, vertex_levels)
    record.bind({**method_kwargs, key: values[0]})
    out = _folder(outdir)
    files = [out / f"level_{i}.{suffix.lstrip('.')}" for i in range(len(values))]
    writer_for(files[0])  # an unknown suffix fails before any work
    geometry = geometry_names(record, method_kwargs)
    check_outputs([*files, out / "index.json"], [*(path if isinstance(path, list) else [path]), *geometry.values()])
    pipeline = Pipeline({"read": 1, "levels": 4, "metrics": 2, "write": 2}, show=not as_json)
    start = time.perf_counter()
    with naming(path, geometry), pipeline:
        with pipeline.stage("read"):
            source = load_source(path, opts, record)
        with pipeline.stage("levels"):
            levels = {"max_errors" if key == "max_error" else "max_vertices": values}
            meshes = levels_of_detail(source, record.name, **levels, **method_kwargs)
        with pipeline.stage("metrics"):
            for mesh in meshes:
                mesh.info["error"] = measure(mesh, source)
        with pipeline.stage("write"):
            out.mkdir(exist_ok=True)
            grid = source if isinstance(source, core.Heightfield) else None
            for mesh, file in zip(meshes, files, strict=True):
                write(mesh, file, grid=grid)
            index = _index(label, record.name, key, values, meshes, files)
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


def _levels(error_levels, vertex_levels) -> tuple[str, list]:
    """``("max_error", bounds)`` or ``("max_vertices", budgets)``: the one of --levels and --vertices given."""
    if (error_levels is None) == (vertex_levels is None):
        raise click.UsageError("give the levels with --levels (error bounds) or --vertices (budgets)")
    if error_levels is not None:
        return "max_error", parse_levels(error_levels, float, "--levels")
    return "max_vertices", parse_levels(vertex_levels, int, "--vertices")


def _folder(outdir: str) -> Path:
    out = Path(outdir)
    if out.exists() and not out.is_dir():
        raise click.UsageError(f"output {outdir!r} is a file, expected a folder")
    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise click.UsageError(f"the parent folder of {outdir!r} does not exist")
    return out


def _index(label, method, key, values, meshes, files) -> dict:
    """What index.json says of the levels."""
    return {
        "input": label,
        "method": method,
        "levels": [
            {
                "level": i, key: v, "n_vertices": m.n_vertices, "n_triangles": m.n_triangles,
                "vertical_error": {k: m.info["error"][k] for k in ("max", "rmse", "coverage")},
                "file": f.name,
            }
            for i, (m, v, f) in enumerate(zip(meshes, values, files, strict=True))
        ],
    }
