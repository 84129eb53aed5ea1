"""``tinsmith view``: look at a mesh in 3-D."""

from __future__ import annotations

from pathlib import Path

import click

from ..io import read_mesh
from ..io.paths import check_outputs
from .common import check_html_output
from .options import verbose_json
from .text import echo_json


@click.command()
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

    out = check_html_output(output) if output else None
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
