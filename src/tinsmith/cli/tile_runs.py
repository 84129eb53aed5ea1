"""What ``tinsmith tile`` runs: a progress bar over tiles, the output checks, writing a run, the point-cloud path."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import click

from .. import _lazy
from ..errors import FileError
from ..io import check_output_path, write, writer_for
from ..io.paths import check_outputs
from .text import echo_json, num

# the tiled runs load when a command first calls them, not at start-up
tile_raster = _lazy.function("tinsmith.tiles.run", "tile_raster")
remove_parts = _lazy.function("tinsmith.tiles.run", "remove_parts")
quantized_mesh_pyramid = _lazy.function("tinsmith.tiles.cesium", "quantized_mesh_pyramid")
terrain_3dtiles = _lazy.function("tinsmith.tiles.terrain3d", "terrain_3dtiles")


class TileBar:
    """A progress bar over tiles on standard error, only when it is a terminal."""

    def __init__(self, show: bool, label: str = "tiles"):
        self.bar = None
        self.label = label
        self.show = show and sys.stderr.isatty()

    def __call__(self, done: int, total: int) -> None:
        if not self.show:
            return
        if self.bar is None:
            self.bar = click.progressbar(length=total, label=self.label, file=sys.stderr, width=30, show_pos=True)
            self.bar.__enter__()
        self.bar.update(done - self.bar.pos)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)


def positive(ctx, param, value):
    if value is not None and not (value > 0 and value < float("inf")):
        raise click.BadParameter(f"{value} is not a length > 0")
    return value


def tile_points(clouds, output, method, max_error, tile_size, classes, max_edge, duplicates, pyramid, keep_tiles, suffix,
                 workers, scheduler, parts, keep_parts, as_json, raster_only) -> None:
    """``tinsmith tile CLOUDS``: greedy insertion on the points, tile by tile (:func:`tinsmith.tiles.tile_cloud`);
    with ``pyramid`` (the quantized-mesh options), a pyramid of the result (:func:`tinsmith.tiles.points.cloud_pyramid`)."""
    from ..tiles.points import cloud_pyramid, tile_cloud

    if method != "greedy" or raster_only:
        given = [f"--method {method}"] if method != "greedy" else []
        raise click.UsageError(f"{', '.join(given + raster_only)}: point clouds are tiled with greedy insertion "
                               "into one mesh, its tiles (--keep-tiles) or a quantized-mesh pyramid")
    out = Path(output)
    edge = max_edge if max_edge.lower() in ("auto", "none") else length(max_edge)

    def run_tiles(parts_dir, bar):
        return tile_cloud(clouds, max_error=max_error, classes=classes, duplicates=duplicates, max_edge=edge,
                          tile_size=tile_size, workers=workers, scheduler=scheduler, parts=parts_dir, progress=bar)

    if pyramid is not None:
        if keep_tiles:
            raise click.UsageError("--keep-tiles goes with --format mesh")
        parts_dir = Path(parts) if parts else out.with_name(out.name + ".parts")
        bar = TileBar(not as_json, label="files, tiles")
        start = time.perf_counter()
        try:
            run = run_tiles(parts_dir, bar)
        finally:
            bar.close()
        bar = TileBar(not as_json)
        try:
            summary = cloud_pyramid(run, out, max_error=max_error, workers=workers, scheduler=scheduler, progress=bar,
                                    **pyramid)
        finally:
            bar.close()
        if not keep_parts:
            remove_parts(parts_dir)
        summary["time"] = time.perf_counter() - start
        report_pyramid(summary, f"{len(clouds)} cloud file(s), {run.points:,} points", output, as_json)
        return
    parts_dir = checked_output(out, keep_tiles, suffix, clouds, parts)
    bar = TileBar(not as_json, label="files, tiles")
    start = time.perf_counter()
    run, meshed, (n_vertices, n_triangles, written) = run_and_write(
        lambda: run_tiles(parts_dir, bar), bar, start, out, keep_tiles, suffix, None if keep_parts else parts_dir)
    label = str(clouds[0]) if len(clouds) == 1 else f"{len(clouds)} files ({clouds[0].name}, ...)"
    summary = {"input": [str(c) for c in clouds], "points": run.points, "points_covered": run.covered,
               "tiles": len(run.specs), "reused_tiles": run.reused, "method": "greedy", "max_edge": run.max_edge,
               "max_error_bound": max_error, "max_error": run.max_error, "n_vertices": n_vertices,
               "n_triangles": n_triangles, "output": written, "time": time.perf_counter() - start,
               "time_tiles": meshed, "tile_seconds": run.tile_seconds}
    if as_json:
        echo_json(summary)
        return
    click.echo(f"{label}: {run.points:,} points -> {len(run.specs):,} tiles ({run.reused:,} reused), greedy on the "
               f"points: {n_vertices:,} vertices, {n_triangles:,} triangles" + (" (tiles kept apart)" if keep_tiles else ""))
    click.echo(f"  vertical error at every point (z units): max {num(run.max_error)} (bound {num(max_error)}); "
               f"{run.covered:,} points inside the outline (max_edge {num(run.max_edge)})")
    click.echo(f"  wrote: {written}")
    click.echo(f"  time: {num(summary['time'])} s (tiles {num(meshed)} s, {num(run.tile_seconds)} s of tile work)")


def report_pyramid(summary: dict, label: str, output, as_json: bool, fmt: str = "quantized-mesh") -> None:
    """What a pyramid run wrote (``fmt``: quantized-mesh or 3dtiles-terrain), level by level with its certificate."""
    if as_json:
        echo_json(summary)
        return
    what = "quantized-mesh pyramid" if fmt == "quantized-mesh" else "3D Tiles terrain"
    subtrees = f", {summary['subtrees']:,} subtree files" if "subtrees" in summary else ""
    click.echo(f"{label} -> {what}, levels {summary['min_zoom']}..{summary['max_zoom']}: "
               f"{summary['tiles']:,} tiles ({summary['reused']:,} reused){subtrees}")
    for z, lvl in summary["levels"].items():
        click.echo(f"  level {z}: {lvl['tiles']:,} tiles ({lvl['empty']:,} without data), "
                   f"{lvl['triangles']:,} triangles, " + _certified(lvl)
                   + f", {num(lvl['mesh_error'])} at the tile nodes (bound {num(lvl['bound'])})"
                   + (f"; {lvl['refined']:,} vertices added at the DEM's cells" if lvl.get("refined") else ""))
    extensions = summary.get("extensions") or []
    if extensions:
        water = f" (water: {summary['water']})" if summary.get("water") else ""
        click.echo(f"  extensions: {', '.join(extensions)}{water}")
    source = "the DEM" if "cell_size" not in summary else f"the points' TIN on a {num(summary['cell_size'])} grid"
    click.echo(f"  heights of {source}: {summary['heights']['note']}, in steps of {num(summary['height_step'])} m; "
               "CesiumJS expects metres above the WGS84 ellipsoid (see --vertical-crs, --height-offset)")
    if fmt == "quantized-mesh":
        click.echo(f"  wrote: {output}/layer.json, {output}/{{z}}/{{x}}/{{y}}.terrain (gzipped) and every tile's error "
                   f"in {output}/certificate.csv")
    else:
        click.echo(f"  wrote: {output}/tileset.json, subtrees and one glb per tile (each tile's geometric error: its "
                   "error against the DEM)")
    click.echo(f"  time: {num(summary['time'])} s")


def _certified(lvl: dict) -> str:
    """A level's certificate in words: the error against the DEM's cells, or why none was measured."""
    if lvl.get("certified") is False:
        return "not measured against the DEM (--no-certificate)"
    if lvl.get("cells", 0):
        return f"max error {num(lvl['max_error'])} against the DEM at {lvl['cells']:,} cells"
    if lvl.get("uncovered", 0):
        return (f"no error measured against the DEM (its {lvl['uncovered']:,} cells here lie in triangles that reach "
                "beyond it)")
    return "no cell of the DEM"


def length(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise click.BadParameter(f"expected 'auto', 'none' or a length > 0, got {text!r}",
                                 param_hint="'--max-edge'") from None


def checked_output(out: Path, keep_tiles: bool, suffix: str, inputs: list, parts) -> Path:
    """Check a tiled run's output (a mesh file, or with ``keep_tiles`` a folder of tile files) before any
    work, against its inputs too; the parts folder: ``parts``, else one beside (or in) the output."""
    if keep_tiles:
        if not out.parent.is_dir():
            raise FileError(f"output folder {str(out.parent)!r} does not exist (for {out.name!r})")
        if out.exists() and not out.is_dir():
            raise FileError(f"output {str(out)!r} is a file; --keep-tiles writes into a folder")
        writer_for(Path(f"tile.{suffix}"))  # the suffix names a writer
    else:
        check_output_path(out)
    check_outputs([None if keep_tiles else out], inputs)
    return Path(parts) if parts else (out / ".parts" if keep_tiles else out.with_name(out.name + ".parts"))


def run_and_write(call, bar, start: float, out: Path, keep_tiles: bool, suffix: str, remove):
    """Run a tiled job (``call()``) with its progress bar, write it, remove the parts folder ``remove``.

    Returns (run, seconds of the run since ``start``, what :func:`write_run` returns).
    """
    try:
        run = call()
    finally:
        bar.close()
    meshed = time.perf_counter() - start
    written = write_run(run, out, keep_tiles, suffix)
    if remove is not None:
        remove_parts(remove)
    return run, meshed, written


def write_run(run, out: Path, keep_tiles: bool, suffix: str) -> tuple[int, int, str]:
    """Write the merged mesh, or each tile into the folder ``out``; (vertices, triangles, what was written)."""
    if keep_tiles:
        out.mkdir(exist_ok=True)
        n_vertices = n_triangles = 0
        for spec in run.specs:
            mesh = run.tile_mesh(spec)
            if mesh.n_triangles:
                write(mesh, out / f"{spec.name}.{suffix}")
            n_vertices += mesh.n_vertices
            n_triangles += mesh.n_triangles
        return n_vertices, n_triangles, f"{out}/tile_*.{suffix}"
    mesh = run.merge()
    write(mesh, out)
    return mesh.n_vertices, mesh.n_triangles, str(out)
