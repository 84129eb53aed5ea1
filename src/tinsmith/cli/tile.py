"""``tinsmith tile``: any size, in tiles that join, on this machine or a Dask cluster."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..algorithms import get_method
from ..algorithms.catalogue import TILE_METHODS
from ..samples import SAMPLES
from ..tiles import BOUND_AT, POINTS_PER_TILE
from .common import input_path
from .options import click_option, verbose_json
from .params import cloud_inputs, parse_classes
from .serve import serve_after, serve_options
from .text import echo_json, num
from .tile_runs import (
    TileBar,
    checked_output,
    positive,
    quantized_mesh_pyramid,
    report_pyramid,
    run_and_write,
    terrain_3dtiles,
    tile_points,
    tile_raster,
)
from .wavelet_options import wavelet_kwargs, wavelet_options

#: Options of a tiled run (the parameters of run_and_write, tile_points) and of a quantized-mesh pyramid.
RUN_KEYS = ("keep_tiles", "suffix", "workers", "scheduler", "parts", "keep_parts")
PYRAMID_KEYS = ("tile_cells", "min_zoom", "max_zoom", "normals", "height_offset", "vertical_crs", "water", "metadata",
                "attribution", "certify", "bound_at")


def _tile_method(ctx, param, value):
    """A method tiles can run, or one line saying why not."""
    get_method(value)  # an unknown name: the valid ones listed
    if value not in TILE_METHODS:
        raise click.BadParameter(
            f"{value!r} cannot run in tiles: tiles join without cracks because each tile's method takes the seam "
            f"vertices it shares with its neighbours, which {', '.join(TILE_METHODS)} do")
    return value


def _tile_method_options(func):
    """The value options of the tile-local methods (quadtree's, cvt's), reaching only the chosen one."""
    seen = {}
    for name in TILE_METHODS:
        for opt in get_method(name).options:
            if opt.kind == "value" and opt.name != "workers":  # the tile command's own --workers
                seen.setdefault(opt.name, (opt, []))[1].append(name)
    for opt, owners in reversed(list(seen.values())):
        func = click_option(opt, "--" + opt.name.replace("_", "-"), f"[{', '.join(owners)}] {opt.describe()}")(func)
    return func


@click.command()
@click.argument("inputs", metavar="INPUT...", nargs=-1)
@click.option("--sample", metavar="NAME", help=f"Use an embedded sample: {', '.join(SAMPLES)}.")
@click.option("-o", "--output", "output", required=True, metavar="OUT",
              help="Merged mesh file (suffix picks the format); with --keep-tiles a folder of tile files; "
                   "with --format quantized-mesh the folder of the pyramid.")
@click.option("--method", default="greedy", show_default=True, callback=_tile_method,
              help="Tile-local method; quadtree and cvt pick a tile's inner vertices, greedy insertion joins them "
                   "to the seams in a Delaunay triangulation and meets the bound.")
@click.option("--max-error", type=float, required=True, help="Vertical error bound of every tile and seam (z units).")
@click.option("--tile-size", type=float, callback=positive,
              help="A tile's side: cells of a raster (default 1024), world units of a point cloud "
                   f"(default: about {POINTS_PER_TILE:,} points a tile).")
@click.option("--classes", callback=parse_classes, help="[point clouds] Classes to keep, e.g. 2 for ground.")
@click.option("--format", "fmt", type=click.Choice(["mesh", "quantized-mesh", "3dtiles-terrain"]), default="mesh",
              show_default=True, help="One mesh (or its tiles), or (rasters) a quantized-mesh pyramid or 3D Tiles terrain "
                                      "(Cesium3DTilesTerrainProvider) for CesiumJS: the same tiles.")
@click.option("--keep-tiles", is_flag=True, help="Write each tile as its own file into the OUT folder instead of merging.")
@click.option("--suffix", default="ply", show_default=True, help="Format of the tile files with --keep-tiles.")
@click.option("--workers", type=click.IntRange(min=1),
              help="Processes (default: the machine's cores); 1 runs in this process.")
@click.option("--scheduler", metavar="ADDRESS",
              help="Run on a Dask cluster: its scheduler address (tcp://host:8786), or 'local' for a LocalCluster "
                   "of --workers processes. Every worker must be able to read DEM. An unreachable address fails after "
                   "Dask's connect timeout (distributed.comm.timeouts.connect, 30 s by default).")
@click.option("--parts", type=click.Path(file_okay=False), metavar="DIR",
              help="Folder of finished tiles, for resuming (default OUT.parts; removed after success "
                   "unless --keep-parts).")
@click.option("--keep-parts", is_flag=True, help="Keep the parts folder after success.")
@click.option("--halo", type=click.IntRange(min=1), help="Cells read round each tile (default 1; 64 with a pre-filter).")
@click.option("--band", type=click.IntRange(min=1), help="Raster band to read (default 1; a warning when there are more).")
@click.option("--nodata", type=float, help="Height that marks missing data (nan for NaN).")
@click.option("--prefilter", type=click.Choice(["wavelet"]), help="Filter each tile (with its halo) first.")
@click.option("--tile-cells", type=click.IntRange(2, 4096), default=256, show_default=True,
              help="[quantized-mesh] Grid cells a side sampled per tile.")
@click.option("--min-zoom", type=click.IntRange(0, 24), default=0, show_default=True, help="[quantized-mesh] First level.")
@click.option("--max-zoom", type=click.IntRange(0, 24),
              help="[quantized-mesh] Last level (default: the first as fine as the DEM).")
@click.option("--normals", is_flag=True, help="[quantized-mesh, 3dtiles-terrain] Add vertex normals.")
@click.option("--water", metavar="FILE|flat|class",
              help="[quantized-mesh] Add a water mask: from water polygons (any vector file, any CRS), 'flat' "
                   "for the DEM's flat (hydro-flattened) lakes, or 'class' for point clouds' water points (class 9).")
@click.option("--metadata/--no-metadata", default=None,
              help="[quantized-mesh] The metadata extension: each tile's error certificate, and the tile "
                   "availability (layer.json then lists level 0 only). Default: on when --min-zoom is 0.")
@click.option("--attribution", metavar="TEXT", help="[quantized-mesh] Attribution shown by the client (layer.json).")
@click.option("--certificate/--no-certificate", "certify", default=True, show_default=True,
              help="[quantized-mesh] Measure every tile against every DEM cell it covers (certificate.csv, the "
                   "metadata); without it a third faster, the errors at the tile nodes only.")
@click.option("--bound-at", type=click.Choice(BOUND_AT), default="cells", show_default=True,
              help="[quantized-mesh, 3dtiles-terrain] Where the deepest level holds --max-error: at every DEM "
                   "cell (its tiles refined there), or at the nodes the tiles sample only (smaller tiles; between "
                   "the nodes a cell may stand further off).")
@click.option("--height-offset", type=float, default=0.0, show_default=True,
              help="[quantized-mesh] Metres added to every height (after the conversion of --vertical-crs): the "
                   "geoid undulation for a DEM on a geoid without a vertical CRS (quantized-mesh heights are above "
                   "the WGS84 ellipsoid).")
@click.option("--vertical-crs", metavar="CRS",
              help="[quantized-mesh] The DEM's vertical CRS when its file lacks it (e.g. EPSG:5703 for NAVD88): "
                   "heights are converted to the WGS84 ellipsoid by PROJ, then --height-offset is added; 'none' "
                   "takes them as given even when the file has one. A compound CRS in the file is used by default.")
@_tile_method_options
@wavelet_options(required=False)
@serve_options
@verbose_json
def tile(inputs, sample, output, method, max_error, tile_size, classes, fmt, halo, band, nodata, prefilter, verbose,
         as_json, **opts):
    """Mesh a DEM or a point cloud of any size in tiles that join without cracks.

    INPUT is one raster, or point clouds (LAS/LAZ, XYZ: several files, folders or globs) meshed by
    greedy insertion on their points. The output is one mesh, its tiles, or (rasters) a Cesium pyramid.
    """
    if sample or not inputs:  # one input file or a sample, said once
        if len(inputs) > 1:
            raise click.UsageError("give input files or --sample, not both")
        inputs = (input_path(inputs[0] if inputs else None, sample)[0],)
    prefilter_kwargs = wavelet_kwargs(opts)
    served = serve_after(opts, fmt)
    run = {k: opts.pop(k) for k in RUN_KEYS}
    pyramid = {k: opts.pop(k) for k in PYRAMID_KEYS}
    pyramid = pyramid if fmt in ("quantized-mesh", "3dtiles-terrain") else None
    clouds = cloud_inputs(inputs)
    if clouds is not None and fmt == "3dtiles-terrain":
        raise click.UsageError("--format 3dtiles-terrain goes with a raster; point clouds: --format quantized-mesh")
    if clouds is not None:
        max_edge, duplicates = opts.pop("max_edge", None) or "auto", opts.pop("duplicates", None) or "lowest"
        raster_only = [name for name, given in (("--halo", halo), ("--prefilter", prefilter),
                                                ("--landuse", prefilter_kwargs.get("landuse"))) if given]
        raster_only += [f"--{k.replace('_', '-')}" for k, v in opts.items() if v is not None]
        tile_points(clouds, output, method, max_error, tile_size, classes, str(max_edge), duplicates, pyramid,
                    run["keep_tiles"], run["suffix"], run["workers"], run["scheduler"], run["parts"],
                    run["keep_parts"], as_json, raster_only)
        served(output)
        return
    if len(inputs) > 1:
        raise click.UsageError(f"give one raster, or point clouds; got {len(inputs)} inputs of which "
                               f"{inputs[0]!r} is no point cloud")
    if classes is not None:
        raise click.UsageError("--classes goes with point clouds")
    tile_size = _cells(tile_size)
    prefilter_arg = _prefilter(prefilter, prefilter_kwargs)
    options = {k: v for k, v in opts.items() if v is not None}
    foreign = sorted(set(options) - {o.name for o in get_method(method).options})
    if foreign:
        raise click.UsageError(f"option(s) {', '.join('--' + k.replace('_', '-') for k in foreign)} "
                               f"do not belong to method {method}")
    reading = {"band": band, "nodata": nodata, "workers": run["workers"], "scheduler": run["scheduler"]}
    if pyramid is not None:
        if prefilter:
            raise click.UsageError("--prefilter goes with --format mesh")
        if fmt == "3dtiles-terrain":
            given = [f"--{k}" for k in ("water", "metadata", "attribution") if pyramid.pop(k) is not None]
            if not pyramid.pop("certify"):
                given.append("--no-certificate")  # 3D Tiles terrain's geometric error is the certificate
            if given:
                raise click.UsageError(f"{', '.join(given)} go(es) with --format quantized-mesh")
        _dem_pyramid(inputs[0], output, max_error, method, options, pyramid, reading, as_json, fmt)
        served(output)
        return
    _dem_tiles(inputs[0], output, max_error, method, tile_size, options, prefilter_arg, halo, run, reading, as_json)


def _cells(tile_size) -> int:
    """A raster's tile size: a whole number of cells >= 2 (default 1024)."""
    if tile_size is None:
        return 1024
    if tile_size != int(tile_size) or tile_size < 2:
        raise click.BadParameter(f"{tile_size:g} is not a whole number of cells >= 2 (a raster's tiles)",
                                 param_hint="'--tile-size'")
    return int(tile_size)


def _prefilter(prefilter, prefilter_kwargs) -> dict | None:
    """The filter's options given to a raster's tiles (with --prefilter wavelet), or None."""
    if prefilter is None and any(prefilter_kwargs[k] is not None for k in ("landuse", "roles", "attribute", "thresholds")):
        raise click.UsageError("--landuse, --role, --attribute and --thresholds go with --prefilter wavelet")
    if prefilter and prefilter_kwargs.get("landuse") is None:
        raise click.UsageError("--prefilter wavelet needs --landuse FILE")
    return {k: v for k, v in prefilter_kwargs.items() if v is not None} if prefilter else None


def _dem_pyramid(dem, output, max_error, method, options, pyramid, reading, as_json, fmt) -> None:
    """Web terrain of a raster, then the report: a quantized-mesh pyramid
    (:func:`tinsmith.tiles.cesium.quantized_mesh_pyramid`) or 3D Tiles terrain
    (:func:`tinsmith.tiles.terrain3d.terrain_3dtiles`)."""
    write = terrain_3dtiles if fmt == "3dtiles-terrain" else quantized_mesh_pyramid
    bar = TileBar(not as_json)
    start = time.perf_counter()
    try:
        summary = write(dem, output, max_error=max_error, method=method, options=options, **pyramid, **reading,
                        progress=bar)
    finally:
        bar.close()
    summary["time"] = time.perf_counter() - start
    report_pyramid(summary, dem, output, as_json, fmt=fmt)


def _dem_tiles(dem, output, max_error, method, tile_size, options, prefilter, halo, run, reading, as_json) -> None:
    """A raster in tiles (:func:`tinsmith.tiles.run.tile_raster`): one mesh, or its tiles, then the report."""
    out = Path(output)
    keep_tiles, suffix = run["keep_tiles"], run["suffix"]
    parts_dir = checked_output(out, keep_tiles, suffix, [dem, (prefilter or {}).get("landuse")], run["parts"])
    bar = TileBar(not as_json)
    start = time.perf_counter()
    job, meshed, (n_vertices, n_triangles, written) = run_and_write(
        lambda: tile_raster(dem, max_error=max_error, method=method, tile_size=tile_size, options=options,
                            prefilter=prefilter, halo=halo, parts=parts_dir, **reading, progress=bar),
        bar, start, out, keep_tiles, suffix, None if run["keep_parts"] else parts_dir)
    H, W = job.raster.shape
    summary = {"input": dem, "cells": H * W, "tiles": len(job.specs), "reused_tiles": job.reused,
               "method": method, "max_error_bound": max_error, "max_error": job.max_error,
               "n_vertices": n_vertices, "n_triangles": n_triangles, "output": written,
               "time": time.perf_counter() - start, "time_tiles": meshed, "tile_seconds": job.tile_seconds}
    if as_json:
        echo_json(summary)
        return
    click.echo(f"{dem}: {H:,} x {W:,} cells -> {len(job.specs):,} tiles of {tile_size} ({job.reused:,} reused), "
               f"method {method}: {n_vertices:,} vertices, {n_triangles:,} triangles"
               + (" (tiles kept apart)" if keep_tiles else ""))
    click.echo(f"  vertical error (z units): max {num(job.max_error)} (bound {num(max_error)}, every tile and seam)")
    click.echo(f"  wrote: {written}")
    click.echo(f"  time: {num(summary['time'])} s (tiles {num(meshed)} s, {num(job.tile_seconds)} s of tile work)")
