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
    _serve(folder, host, port, cesium, open_browser)


def _serve(folder, host, port, cesium, open_browser) -> None:
    from ..viz.serve import serve_pyramid

    try:
        serve_pyramid(folder, host=host, port=port, cesium=cesium, open_browser=open_browser,
                      echo=lambda line: click.echo(f"tinsmith serve: {line}", err=True))
    except KeyboardInterrupt:
        click.echo("tinsmith serve: stopped", err=True)


#: The formats of ``tinsmith tile`` whose output ``--serve`` can serve.
SERVED_FORMATS = ("quantized-mesh", "3dtiles-terrain")


def serve_options(func):
    """``--serve`` and ``--open/--no-open`` of a command that writes a pyramid (``tinsmith tile``)."""
    func = click.option("--open/--no-open", "open_browser", default=True, show_default=True,
                        help="[--serve] Open the page in a browser (when there is a display).")(func)
    return click.option("--serve", "serve_after", is_flag=True,
                        help=f"[{', '.join(SERVED_FORMATS)}] Then serve the pyramid and its CesiumJS page on a free "
                             "port of 127.0.0.1, as tinsmith serve does (Ctrl-C stops).")(func)


def serve_after(opts: dict, fmt: str):
    """Take ``--serve``/``--open`` out of a command's options: a function of the output folder that serves it, or does nothing."""
    wanted, open_browser = opts.pop("serve_after"), opts.pop("open_browser")
    if not wanted:
        return lambda output: None
    if fmt not in SERVED_FORMATS:
        raise click.UsageError(f"--serve goes with --format {' or '.join(SERVED_FORMATS)}")
    return lambda output: _serve(output, "127.0.0.1", 0, None, open_browser)
