"""What ``tinsmith city`` runs beside the model itself: the tiled run and the report."""

from __future__ import annotations

import time

import click

from ..io import write
from .common import naming
from .text import echo_json, num

#: The building options a tiled run takes (see tinsmith.tiles.city.BUILDING_OPTIONS), as the command names them.
BUILDING_KEYS = ("min_height", "max_residual", "step", "min_area", "roof_height", "regularize", "split_rows")


def run_tiled(source, label, outputs, buildings, tile_size, workers, scheduler, ground_file, mask_file, reading, opts,
              as_json) -> None:
    """``tinsmith city --tile-size``: :func:`tinsmith.tiles.city.city_tiles` on a raster DSM, then the outputs."""
    from ..io.gis_formats import write_footprints
    from ..tiles.city import city_tiles

    if isinstance(source, list):
        raise click.UsageError("--tile-size takes a raster DSM (grid a survey first, or tile it with tinsmith tile)")
    if reading["band"] is not None:
        raise click.UsageError("--tile-size reads band 1 of the DSM, not --band: extract the band first "
                               "(gdal_translate -b N)")
    options = {k: opts[k] for k in BUILDING_KEYS}
    # what a tiled run does not do (planar or stepped roofs, footprints, a mask, a margin): city_tiles refuses it
    options.update({k: v for k, v in (("roofs", None if opts["roofs"] == "flat" else opts["roofs"]),
                                      ("footprints", opts["footprints"]), ("mask", mask_file),
                                      ("margin", opts["margin"] or None)) if v is not None})
    start = time.perf_counter()
    with naming(source):
        model = city_tiles(source, tile_size=tile_size, ground=ground_file, ground_window=opts["ground_window"],
                           ground_error=opts["ground_error"], solid=opts["solid"], base=opts["base"], workers=workers,
                           scheduler=scheduler, **options)
        for out in outputs:
            write(model.mesh, out)
        if buildings is not None:
            write_footprints(model.buildings, buildings, crs=model.mesh.crs, statistic=model.stats["roof_height"])
    st = model.stats
    elapsed = time.perf_counter() - start
    if as_json:
        echo_json({"input": label, **st, "outputs": list(outputs), "buildings_file": buildings, "time": elapsed})
        return
    click.echo(f"{label}: {st['tiles']} tiles of {tile_size} cells (halo {st['halo']}) -> {st['n_buildings']:,} buildings, "
               f"flat roofs at {st['roof_height']}; mesh {st['n_vertices']:,} vertices, {st['n_triangles']:,} triangles"
               + (f", a closed solid down to {num(st['base'])}" if st["solid"] else ""))
    if st.get("note"):
        click.echo(f"  {st['note']}")
    click.echo("  wrote: " + ", ".join(list(outputs) + ([buildings] if buildings else [])))
    click.echo(f"  time: {num(elapsed)} s")


def report_city(label, hf, roofs, st, outputs, buildings, elapsed) -> None:
    if roofs == "levels":
        click.echo(
            f"{label}: {hf.n_valid:,} valid cells -> {st['n_buildings']:,} buildings, {st['n_regions']:,} regions "
            f"({st['n_leaves']:,} roof tops); block model {st['n_vertices']:,} vertices "
            f"({100 * st['points_kept']:.1f}% of the cells), {st['n_triangles']:,} triangles"
        )
        click.echo("  thresholds: " + ", ".join(num(t) for t in st["thresholds"])
                   + (" (height above ground)" if st["relative_to_ground"] else ""))
        click.echo("  dropped by the noise controller: " + ", ".join(f"{k} {v}" for k, v in st["dropped"].items()))
    else:
        source = "from the footprints" if st["footprints"] else "found"
        kind = "flat roofs" if roofs == "flat" else "planar roofs"
        click.echo(
            f"{label}: {hf.n_valid:,} valid cells -> {st['n_buildings']:,} buildings ({source}), LoD {st['lod']} "
            f"{kind} (heights at {st['roof_height']})"
            + f"; mesh {st['n_vertices']:,} vertices, {st['n_triangles']:,} triangles"
            + (f", a closed solid down to {num(st['base'])}" if st["solid"] else "")
        )
        if st.get("note"):
            click.echo(f"  {st['note']}")
        if st["footprints"]:
            click.echo(footprint_line(st["footprints"]))
        else:
            click.echo("  cells: " + ", ".join(f"{k.replace('_', ' ')} {v:,}" for k, v in st["cells"].items()))
        if st.get("roof_cells"):
            click.echo(f"  roof RMSE (mesh minus DSM) over {st['roof_cells']:,} building cells, one cell in from the "
                       f"walls: {num(st['roof_rmse'])} m")
    click.echo("  wrote: " + ", ".join(list(outputs) + ([buildings] if buildings else [])))
    click.echo(f"  time: {num(elapsed)} s")


def footprint_line(fp: dict, most: int = 20) -> str:
    """What became of the footprints, in one line: read, modelled, outside, cut, skipped, and the positions in the
    input (0-based) of those without a building in the DSM or covered by higher ones (the first ``most``)."""

    def listed(ids) -> str:
        shown = ", ".join(f"#{i}" for i in ids[:most])
        return shown + (f", ... ({len(ids) - most} more)" if len(ids) > most else "")

    parts = [f"{fp['read']:,} read", f"{fp['modelled']:,} modelled"]
    if fp["outside"]:
        parts.append(f"{fp['outside']:,} entirely outside the DSM")
    if fp["cut"]:
        parts.append(f"{fp['cut']:,} cut at its edge")
    if fp["skipped"]:
        parts.append(f"{fp['skipped']:,} empty or invalid")
    if fp["unmatched"]:
        parts.append(f"{len(fp['unmatched']):,} without a building in the DSM (left out): {listed(fp['unmatched'])}")
    if fp["covered"]:
        parts.append(f"{len(fp['covered']):,} covered by higher footprints: {listed(fp['covered'])}")
    return "  footprints: " + "; ".join(parts)
