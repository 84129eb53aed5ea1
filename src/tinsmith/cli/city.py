"""``tinsmith city``: a city model from a surface model or a LiDAR survey (buildings, roofs, a CFD-ready solid)."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..io import check_output_path, georeferencing, read_heightfield, write
from ..io.paths import check_outputs
from .city_runs import report_city, run_tiled
from .common import inputs_of, naming
from .options import READ_KEYS, outputs, read_options, verbose_json
from .params import cloud_inputs
from .progress import Pipeline
from .text import echo_json


@click.command()
@click.argument("inputs", metavar="DSM...", nargs=-1)
@outputs(help="City mesh file; the suffix picks the format (.stl: one named solid per patch; .obj: groups; "
              ".json: CityJSON 2.0). Repeat for several.")
@click.option("--buildings", metavar="FILE", help="Also write the building outlines (.geojson or .gpkg).")
@click.option("--footprints", metavar="FILE",
              help="Building footprints (GeoPackage, GeoJSON, Shapefile, FlatGeobuf, GeoParquet, any vector file GDAL "
                   "reads; any CRS: reprojected): one building each, instead of finding them. Cut to the DSM's data; "
                   "those with no building in the DSM are left out and listed.")
@click.option("--roofs", type=click.Choice(["flat", "planes", "levels"]), default="flat", show_default=True,
              help="flat: LoD 1.2, one height per building; planes: LoD 2.2, planar roof faces from the cells inside "
                   "each building; levels: the stepped block model of the Salt Lake City thesis over the building cells.")
@click.option("--roof-height", default="p70", show_default=True,
              help="The statistic of the cells inside a building that gives its height (flat roofs, and every "
                   "building's measuredHeight): median, max or pNN (a percentile; p70 is the 3D BAG's LoD 1.2, "
                   "p90 3dfier's).")
@click.option("--ground", "ground_file", metavar="DTM",
              help="The ground (a raster on the DSM's grid); default: the cloud's ground points, or estimated.")
@click.option("--ground-window", type=float, default=60.0, show_default=True,
              help="Window of the ground estimate (world units): wider than the buildings.")
@click.option("--min-height", type=float,
              help="Least building height above the ground (z units; default 2.5 m, 2.2 m above a ground estimated "
                   "from the DSM: a storey less what the ground filter may leave it high).")
@click.option("--max-residual", type=float,
              help="Roof planarity: largest RMS residual of a 3 x 3 plane (z units; default 0.2 m).")
@click.option("--step", type=float, help="Roof height jump that separates two buildings (z units; default 1 m).")
@click.option("--min-area", type=float, help="Smallest building (world units squared; default 10 m2).")
@click.option("--mask", "mask_file", metavar="RASTER",
              help="Where buildings may be: a raster on the DSM's grid, non-zero for yes.")
@click.option("--outlines", "regularize", type=click.Choice(["regular", "cells"]), default="regular",
              show_default=True, callback=lambda ctx, param, value: value == "regular",
              help="regular: straight walls at right angles along each building's dominant directions; "
                   "cells: the outline of the grid cells.")
@click.option("--keep-rows", "split_rows", is_flag=True, callback=lambda ctx, param, value: not value,
              help="Do not cut rows of houses under one roof where the roof steps or falls into a valley.")
@click.option("--ground-error", type=float,
              help="Vertical error of the ground between buildings (z units; default 0.5 m).")
@click.option("--solid", is_flag=True,
              help="Close the model into a watertight volume: sides down to a base and a bottom.")
@click.option("--base-height", "base", type=float,
              help="Height of the solid's bottom; default the lowest ground less a tenth of the height range.")
@click.option("--margin", type=float, default=0.0, show_default=True,
              help="Grow the domain by this much on every side (world units), the ground held at its edge height.")
@click.option("--tile-size", type=int,
              help="Find the buildings window by window, this many cells a side (a DSM of any size; flat roofs).")
@click.option("--workers", type=int, help="With --tile-size: processes (default: every core).")
@click.option("--scheduler", metavar="ADDRESS",
              help="With --tile-size: a Dask scheduler's address, or 'local' for a local cluster.")
@click.option("--lod", type=int, help="[levels] Slices of the band of one standard deviation (default 4).")
@click.option("--noise-factor", type=int, help="[levels] Drop regions with fewer grid points (default 10).")
@click.option("--min-width", type=float, help="[levels] Drop regions narrower than this (world units).")
@click.option("--max-roughness", type=float, help="[levels] Drop regions rougher than this (z units).")
@click.option("--relative-to-ground", is_flag=True, default=None,
              help="[levels] Thresholds on the height above the ground.")
@click.option("--simplify-tolerance", type=float,
              help="[levels] Simplify the block model's outlines to this distance (world units).")
@read_options(gridding=False)
@verbose_json
def city(inputs, outputs, buildings, ground_file, mask_file, tile_size, workers, scheduler, verbose, as_json, **opts):
    """A city model of a surface model or LiDAR survey: buildings (found, or your footprints), roofs and terrain.

    Trees are told from roofs per cell (height above ground, planarity, the cloud's classes and returns),
    buildings split where roofs jump, outlines straightened; with --solid the model is a watertight volume
    for a CFD mesher.  --roofs levels gives the stepped block model of the Salt Lake City thesis (ch. 4) over the building
    cells.
    """
    from ..algorithms.urban.city import city_model, city_options
    from ..algorithms.urban.urban import require_metres

    reading = {k: opts.pop(k) for k in ("sample", *READ_KEYS)}
    city_options(**opts)  # which options go together: before any reading
    if tile_size is None and (workers is not None or scheduler is not None):
        raise click.UsageError("--workers and --scheduler go with --tile-size")
    clouds = cloud_inputs(inputs) if inputs and not reading["sample"] else None
    path, label = inputs_of(inputs, reading.pop("sample"))
    _check_outputs(outputs, buildings, [*(clouds or [path]), ground_file, opts["footprints"], mask_file])
    with naming(clouds if clouds is not None else path):  # degrees: refused from the header, before any read
        require_metres(*georeferencing(clouds if clouds is not None else path, reading["cell_size"]),
                       opts["ground_window"])
    if tile_size is not None:
        run_tiled(path if clouds is None else clouds, label, outputs, buildings, tile_size, workers, scheduler,
                  ground_file, mask_file, reading, opts, as_json)
        return
    pipeline = Pipeline({"read": 1, "urban": 4, "write": 1}, show=not as_json)
    start = time.perf_counter()
    with naming(path), pipeline:
        with pipeline.stage("read"):
            dsm, cloud, ground, mask = _read(clouds, path, reading, ground_file, mask_file)
        with pipeline.stage("urban"):
            model = city_model(dsm, cloud=cloud, ground=ground, mask=mask, **opts)
        with pipeline.stage("write"):
            for out in outputs:
                write(model.mesh, out, grid=dsm)
            _write_buildings(model, buildings, dsm.crs)
    summary = {"input": label, **model.stats, "outputs": list(outputs), "buildings_file": buildings,
               "time": time.perf_counter() - start}
    if as_json:
        echo_json(summary)
        return
    report_city(label, dsm, opts["roofs"], model.stats, outputs, buildings, summary["time"])


def _check_outputs(outputs, buildings, inputs) -> None:
    """The meshes' and the outlines' files, checked before any work (against the inputs too)."""
    from ..io.gis_formats import BUILDING_DRIVERS

    for out in outputs:
        check_output_path(out)
    if buildings is not None:
        if Path(buildings).suffix.lower() not in BUILDING_DRIVERS:
            raise click.UsageError(f"--buildings {buildings!r}: use a suffix of {', '.join(sorted(BUILDING_DRIVERS))}")
        check_output_path(buildings)
    check_outputs([*outputs, buildings], inputs)


def _read(clouds, path, reading, ground_file, mask_file):
    """The surface model (a raster, or the point clouds gridded: their highest point a cell) and the clouds, the
    ground and the mask rasters."""
    from ..io.points import read_clouds

    cloud = None
    if clouds is not None:
        cloud = read_clouds(clouds, classes=reading["classes"])
        dsm = cloud.to_heightfield(reading["cell_size"], statistic="max")
    else:
        dsm = read_heightfield(path, statistic="max", **{k: reading[k] for k in READ_KEYS})
    ground = read_heightfield(ground_file) if ground_file is not None else None
    mask = read_heightfield(mask_file) if mask_file is not None else None
    return dsm, cloud, ground, mask


def _write_buildings(model, buildings, crs) -> None:
    """The outlines, when asked for."""
    from ..io.gis_formats import write_city_outlines

    if buildings is not None:
        write_city_outlines(model, buildings, crs=crs)
