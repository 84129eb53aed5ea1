"""``tinsmith urban``: a city model from a surface model or a LiDAR survey (buildings, roofs, a CFD-ready solid)."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..io import check_output_path, georeferencing, read_heightfield, write
from ..io.paths import check_outputs
from .params import cloud_inputs
from .progress import Pipeline
from .report import echo_json
from .urban_runs import report_city, run_tiled

__all__ = ["add_urban_command"]

#: Options of the seed-000 block model (``--roofs levels``) and their defaults there.
THESIS_OPTIONS = {"lod": 4, "noise_factor": 10, "min_width": None, "max_roughness": None,
                  "relative_to_ground": False, "simplify_tolerance": 0.0}


def add_urban_command(cli) -> None:
    """Register ``urban`` on the command group."""
    from .common import inputs_of, naming, read_options, verbose_json

    @cli.command()
    @click.argument("inputs", metavar="DSM...", nargs=-1)
    @click.option("-o", "--output", "outputs", multiple=True, required=True, metavar="OUT",
                  help="City mesh file; the suffix picks the format (.stl: one named solid per patch; .obj: groups; "
                       ".json: CityJSON 2.0). Repeat for several.")
    @click.option("--buildings", metavar="FILE", help="Also write the building outlines (.geojson or .gpkg).")
    @click.option("--footprints", metavar="FILE",
                  help="Building footprints (any vector file, any CRS: reprojected): one prism each, instead of "
                       "finding the buildings.")
    @click.option("--roofs", type=click.Choice(["flat", "planes", "levels"]), default="flat", show_default=True,
                  help="flat: one height per building (LoD 1.2); planes: planar roof facets (LoD 2-like); levels: "
                       "the stepped block model of seed 000 over the building cells.")
    @click.option("--roof-height", default="p70", show_default=True,
                  help="Flat roofs: median, max or pNN (a percentile; p70 is the 3D BAG's LoD 1.2, p90 3dfier's).")
    @click.option("--ground", "ground_file", metavar="DTM",
                  help="The ground (a raster on the DSM's grid); default: the cloud's ground points, or estimated.")
    @click.option("--ground-window", type=float, default=60.0, show_default=True,
                  help="Window of the ground estimate (world units): wider than the buildings.")
    @click.option("--min-height", type=float, help="Least building height above the ground (z units; default 2.5 m).")
    @click.option("--max-residual", type=float,
                  help="Roof planarity: largest RMS residual of a 3 x 3 plane (z units; default 0.2 m).")
    @click.option("--step", type=float, help="Roof height jump that separates two buildings (z units; default 1 m).")
    @click.option("--min-area", type=float, help="Smallest building (world units squared; default 10 m2).")
    @click.option("--mask", "mask_file", metavar="RASTER",
                  help="Where buildings may be: a raster on the DSM's grid, non-zero for yes.")
    @click.option("--outlines", type=click.Choice(["regular", "cells"]), default="regular", show_default=True,
                  help="regular: straight walls at right angles along each building's dominant directions; "
                       "cells: the outline of the grid cells.")
    @click.option("--keep-rows", is_flag=True,
                  help="Do not cut rows of houses under one roof where the roof steps or falls into a valley.")
    @click.option("--ground-error", type=float, help="Vertical error of the ground between buildings (z units; default 0.5 m).")
    @click.option("--solid", is_flag=True, help="Close the model into a watertight volume: sides down to a base and a bottom.")
    @click.option("--base-height", type=float,
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
    @click.option("--relative-to-ground", is_flag=True, default=None, help="[levels] Thresholds on the height above the ground.")
    @click.option("--simplify-tolerance", type=float,
                  help="[levels] Simplify the block model's outlines to this distance (world units).")
    @read_options(gridding=False)
    @verbose_json
    def urban(inputs, outputs, buildings, footprints, roofs, roof_height, ground_file, ground_window, min_height,
              max_residual, step, min_area, mask_file, outlines, keep_rows, ground_error, solid, base_height, margin,
              tile_size, workers, scheduler, verbose, as_json, **opts):
        """A city model of a surface model or LiDAR survey: buildings (found, or your footprints), roofs and terrain.

        Trees are told from roofs per cell (height above ground, planarity, the cloud's classes and returns),
        buildings split where roofs jump, outlines straightened; with --solid the model is a watertight volume
        for a CFD mesher.  --roofs levels gives the stepped block model of seed 000 (ch. 4) over the building
        cells.
        """
        from ..algorithms.urban.buildings import building_cells, class_shares
        from ..algorithms.urban.city import city, ground_from_cloud
        from ..algorithms.urban.roofs import parse_statistic
        from ..algorithms.urban.urban import require_metres
        from ..algorithms.urban.urban import urban as thesis
        from ..io.gis_formats import BUILDING_DRIVERS, write_buildings, write_footprints
        from ..io.points import read_clouds

        thesis_given = {k: opts.pop(k) for k in THESIS_OPTIONS}
        if roofs != "levels":
            given = [k for k, v in thesis_given.items() if v is not None]
            if given:
                raise click.UsageError(f"--{given[0].replace('_', '-')} is an option of --roofs levels")
        else:
            for flag, value in (("--solid", solid or None), ("--footprints", footprints), ("--base-height", base_height)):
                if value is not None:
                    raise click.UsageError(f"{flag} needs --roofs flat or planes (the levels model is a surface)")
        if base_height is not None and not solid:
            raise click.UsageError("--base-height is the bottom of a --solid")
        if tile_size is None and (workers is not None or scheduler is not None):
            raise click.UsageError("--workers and --scheduler go with --tile-size")
        if tile_size is not None:
            refused = [flag for flag, value in (("--roofs planes/levels", roofs != "flat" or None),
                                                ("--footprints", footprints), ("--mask", mask_file),
                                                ("--margin", margin or None))
                       if value is not None]
            if refused:
                raise click.UsageError(f"--tile-size finds buildings window by window with flat roofs: not with {refused[0]}")
            if opts["band"] is not None:
                raise click.UsageError("--tile-size reads band 1 of the DSM, not --band: extract the band first "
                                       "(gdal_translate -b N)")
        parse_statistic(roof_height)
        clouds = cloud_inputs(inputs) if inputs and not opts.get("sample") else None
        path, label = inputs_of(inputs, opts.pop("sample"))
        for out in outputs:
            check_output_path(out)
        if buildings is not None:
            if Path(buildings).suffix.lower() not in BUILDING_DRIVERS:
                raise click.UsageError(
                    f"--buildings {buildings!r}: use a suffix of {', '.join(sorted(BUILDING_DRIVERS))}"
                )
            check_output_path(buildings)
        sources = clouds if clouds is not None else [path]
        check_outputs([*outputs, buildings], [*sources, ground_file, footprints, mask_file])
        with naming(clouds if clouds is not None else path):  # degrees: refused from the header, before any read
            require_metres(*georeferencing(clouds if clouds is not None else path, opts["cell_size"]), ground_window)
        if tile_size is not None:
            if clouds is not None:
                raise click.UsageError("--tile-size takes a raster DSM (grid a survey first, or tile it with tinsmith tile)")
            run_tiled(path, label, outputs, buildings, tile_size, workers, scheduler, ground_file, ground_window, solid,
                   base_height, as_json, naming, dict(
                       min_height=min_height, max_residual=max_residual, step=step, min_area=min_area,
                       roof_height=roof_height, regularize=outlines == "regular", split_rows=not keep_rows),
                   ground_error)
            return
        pipeline = Pipeline({"read": 1, "urban": 4, "write": 1}, show=not as_json)
        start = time.perf_counter()
        shares = ground = None
        with naming(path), pipeline:
            with pipeline.stage("read"):
                if clouds is not None:
                    cloud = read_clouds(clouds, classes=opts["classes"])
                    hf = cloud.to_heightfield(opts["cell_size"], statistic="max")
                    shares = class_shares(cloud, hf)
                    if ground_file is None:
                        ground = ground_from_cloud(cloud, hf)
                else:
                    hf = read_heightfield(path, statistic="max", **{k: opts[k] for k in (
                        "nodata", "band", "cell_size", "classes", "encoding", "tile")})
                if ground_file is not None:
                    ground = read_heightfield(ground_file)
                mask = None
                if mask_file is not None:
                    m = read_heightfield(mask_file)
                    mask = m.valid & (m.z != 0)
            with pipeline.stage("urban"):
                if roofs == "levels":
                    settings = {k: (THESIS_OPTIONS[k] if v is None else v) for k, v in thesis_given.items()}
                    from ..algorithms.urban.urban import estimate_ground

                    base_ground = ground if ground is not None else estimate_ground(hf, ground_window)
                    cells, _ = building_cells(hf, base_ground, min_height=min_height, max_residual=max_residual,
                                              shares=shares, mask=mask)
                    model = thesis(hf, ground=ground if settings["relative_to_ground"] else None,
                                   ground_window=ground_window, ground_error=ground_error, mask=cells, **settings)
                    mesh, stats = model.mesh, model.stats
                else:
                    model = city(hf, ground=ground, ground_window=ground_window, footprints=footprints, shares=shares,
                                 mask=mask, min_height=min_height, max_residual=max_residual, step=step,
                                 min_area=min_area, roofs=roofs, roof_height=roof_height,
                                 regularize=outlines == "regular", split_rows=not keep_rows,
                                 ground_error=ground_error, solid=solid,
                                 base=base_height, margin=margin)
                    mesh, stats = model.mesh, model.stats
            with pipeline.stage("write"):
                for out in outputs:
                    write(mesh, out, grid=hf)
                if buildings is not None:
                    if roofs == "levels":
                        write_buildings(model.tree, buildings, crs=hf.crs)
                    else:
                        write_footprints(model.buildings, buildings, crs=hf.crs)
        summary = {"input": label, **stats, "outputs": list(outputs),
                   "buildings_file": buildings, "time": time.perf_counter() - start}
        if as_json:
            echo_json(summary)
            return
        report_city(label, hf, roofs, stats, outputs, buildings, summary["time"])
