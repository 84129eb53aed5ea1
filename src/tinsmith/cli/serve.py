"""``tinsmith serve``: serve a terrain pyramid on this machine, with a CesiumJS page that shows it."""

from __future__ import annotations

import click


@click.command()
@click.argument("folder", metavar="DIR")
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to listen on (0.0.0.0: every interface, so other machines can reach it).")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True,
              help="Port to listen on (0: any free one).")
@click.option("--cesium", metavar="PATH", type=click.Path(),
              help="CesiumJS's Build/Cesium folder (npm install cesium); default $TINSMITH_CESIUM, "
                   "else node_modules/cesium/Build/Cesium here or in a parent folder.")
@click.option("--open/--no-open", "open_browser", default=True, show_default=True,
              help="Open the page in a browser (when there is a display).")
def serve(folder, host, port, cesium, open_browser):
    """Serve the terrain pyramid in DIR (layer.json or tileset.json) and a page that shows it in CesiumJS.

    Read-only: GET and HEAD of the files under DIR, with the headers CesiumJS expects (gzipped .terrain tiles,
    CORS). Ctrl-C stops it.
    """
    from ..viz.serve import serve_pyramid

    try:
        serve_pyramid(folder, host=host, port=port, cesium=cesium, open_browser=open_browser,
                      echo=lambda line: click.echo(f"tinsmith serve: {line}", err=True))
    except KeyboardInterrupt:
        click.echo("tinsmith serve: stopped", err=True)
