"""``tinsmith report`` and ``tinsmith view``: look at what a method made."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..errors import FileError
from ..io import read_mesh
from ..io.paths import check_outputs
from .report import echo_json, num

__all__ = ["add_see_commands", "parse_window"]


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


def _check_html_output(path: str) -> Path:
    out = Path(path)
    if out.suffix.lower() not in (".html", ".htm"):
        raise click.BadParameter(f"expected a .html file name, got {path!r}", param_hint="'-o'")
    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise FileError(f"output folder {str(out.parent)!r} does not exist (for {out.name!r})")
    return out


def add_see_commands(cli) -> None:
    """Register ``report`` and ``view`` on the command group."""
    from .common import input_path, load_heightfield, read_options, verbose_json

    @cli.command()
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

        out = _check_html_output(output)
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

    @cli.command()
    @click.argument("mesh_file", metavar="MESH")
    @click.option("-o", "--output", "output", metavar="VIEW.html",
                  help="Write the offline HTML viewer here (default: MESH with .html, when there is no window).")
    @click.option("--exaggeration", type=click.FloatRange(min=0, min_open=True), default=1.0, show_default=True,
                  help="Vertical exaggeration.")
    @click.option("--html", "force_html", is_flag=True, help="Write the HTML viewer even when a window could open.")
    @verbose_json
    def view(mesh_file, output, exaggeration, force_html, verbose, as_json):
        """Look at MESH in 3-D: a pyvista window where there is a screen, else an offline HTML page."""
        from ..viz.viewer import show, write_viewer

        out = _check_html_output(output) if output else None
        check_outputs([out or Path(mesh_file).with_suffix(".html")], [mesh_file])
        mesh = read_mesh(mesh_file)
        title = Path(mesh_file).name
        if out is None and not force_html and show(mesh, title=title, exaggeration=exaggeration):
            return
        out = out or Path(mesh_file).with_suffix(".html")
        write_viewer(mesh, out, title=title, exaggeration=exaggeration)
        if as_json:
            echo_json({"viewer": str(out), "bytes": out.stat().st_size})
            return
        click.echo(f"{mesh_file}: {mesh.n_triangles:,} triangles -> {out} (open it in a browser; it needs no network)")
