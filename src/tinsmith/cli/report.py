"""``tinsmith report``: one HTML page judging meshes against their DEM."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..io import read_mesh
from ..io.paths import check_outputs
from .common import check_html_output, input_path, load_heightfield
from .options import read_options, verbose_json
from .text import echo_json, format_comparison, num

__all__ = ["format_comparison", "parse_window", "report"]  # format_comparison: its old home, for scripts


def parse_window(ctx, param, value):
    if value is None:
        return None
    try:
        x0, y0, x1, y1 = (float(v) for v in value.split(","))
    except ValueError:
        raise click.BadParameter(f"expected XMIN,YMIN,XMAX,YMAX in world units, got {value!r}") from None
    if not (x1 > x0 and y1 > y0):
        raise click.BadParameter(f"expected XMIN < XMAX and YMIN < YMAX, got {value!r}")
    return (x0, y0, x1, y1)


@click.command()
@click.argument("dem", metavar="DEM", required=False)
@click.argument("meshes", metavar="MESH...", nargs=-1)
@click.option("-o", "--output", "output", required=True, metavar="REPORT.html", help="The HTML report to write.")
@click.option("--detail", callback=parse_window, metavar="XMIN,YMIN,XMAX,YMAX",
              help="World window of the wireframe close-ups (default: the steepest part of the DEM).")
@read_options(gridding=True)
@verbose_json
def report(dem, meshes, output, detail, verbose, as_json, **opts):
    """One self-contained HTML page judging every MESH against DEM: metrics, hillshades, errors, quality."""
    from ..viz.report import write_report

    out = check_html_output(output)
    if opts.get("sample") and dem is not None:  # with --sample every argument is a mesh
        meshes, dem = (dem, *meshes), None
    if not meshes:
        raise click.UsageError("give at least one MESH after the DEM (or after --sample NAME)")
    path, label = input_path(dem, opts.pop("sample"))
    check_outputs([out], [path, *meshes])
    start = time.perf_counter()
    hf = load_heightfield(path, opts)
    loaded = {}
    for name in meshes:
        key = Path(name).name if Path(name).name not in loaded else name
        loaded[key] = read_mesh(name)
    metrics = write_report(out, hf, loaded, dem_name=label, detail=detail,
                           settings={"command": "tinsmith report", "dem": label, "meshes": list(meshes)})
    size = out.stat().st_size
    if as_json:
        echo_json({"report": str(out), "bytes": size, "metrics": metrics, "time": time.perf_counter() - start})
        return
    click.echo(f"{label}: {len(loaded)} mesh{'es' if len(loaded) > 1 else ''} -> {out} ({size / 1e6:.1f} MB)")
    for name, m in metrics.items():
        e = m["vertical_error"]
        click.echo(f"  {name}: {m['n_triangles']:,} triangles, max error {num(e['max'])}, RMSE {num(e['rmse'])}")
    click.echo(f"  time: {num(time.perf_counter() - start)} s")
