"""Where a terrain pyramid's deepest level holds its bound: at the DEM's cells, with and without refinement.

    python benchmarks/tiles_cells.py        # writes benchmarks/RESULTS_tiles_cells.md

For each DEM and bound E, the deepest level's tiles are made as
``quantized_mesh_pyramid`` makes them (``tile_geometry``), with
``bound_at="nodes"`` (as meshed on the nodes) and ``"cells"`` (refined at the
cells, the default), and every valid DEM cell whose centre lies in a tile is
placed in its mesh as a client interpolates it (the decoded heights; the
triangles that reach a node filled for lack of data left out, as the
certificate does).  The cells are split by where they lie: within half a
quantum (1/65,534 of the tile's width) of a tile edge, where a vertex would
lie on the seam both neighbours share, or inside.  Reported: cells, the
largest error and the cells beyond E in each part, and the triangles of the
level.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _common import HERE, SHARED, ST_HELENS, machine

TUJUNGA = SHARED / "data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"
#: (label, DEM, E, tile_cells)
CASES = [
    ("St. Helens sample (30 m)", ST_HELENS, 2.0, 128),
    ("Big Tujunga (SRTM 30 m)", TUJUNGA, 1.0, 256),
    ("Big Tujunga (SRTM 30 m)", TUJUNGA, 5.0, 256),
]


def deepest_errors(dem, max_error: float, tile_cells: int, bound_at: str) -> dict:
    from tinsmith.io.quantized_mesh import QUANT
    from tinsmith.kernels import locate
    from tinsmith.tiles.certificate import tile_cells as cells_of
    from tinsmith.tiles.pyramid import pyramid_job, tile_bounds, tile_geometry

    job = pyramid_job(dem, max_error=max_error, tile_cells=tile_cells, bound_at=bound_at)
    z, N = job.max_zoom, job.tile_cells
    out = {"zoom": z, "triangles": 0, "cells": 0, "band": 0, "over_inside": 0, "over_band": 0,
           "worst_inside": 0.0, "worst_band": 0.0}
    start = time.perf_counter()
    for tile in job.tiles(z):
        g = tile_geometry(tile, job)
        out["triangles"] += len(g["triangles"])
        if not g["data"]:
            continue
        w, s, e, n = tile_bounds(*tile)
        scale = (e - w) / N
        lon, lat, h = cells_of(job, (w, s, e, n))
        x, y = (lon - w) / scale, (n - lat) / scale
        uv = np.column_stack([np.asarray(g["cols"], float), np.asarray(g["rows"], float)])
        tri = np.asarray(g["triangles"], np.int64)
        tri = tri[~np.asarray(g["filled"])[tri].any(axis=1)]
        if not len(tri):
            continue
        grid = locate.grid_for(uv, len(tri))
        found, bary = locate.locate(uv, tri, *locate.build(uv, tri, *grid), *grid, np.column_stack([x, y]), 1e-9)
        ok = found >= 0
        decoded = job.h_min + g["k"] * job.h_step
        err = np.abs((decoded[tri[found[ok]]] * bary[ok]).sum(axis=1) - h[ok])
        u, v = np.rint(x[ok] * QUANT / N), np.rint((N - y[ok]) * QUANT / N)
        band = (u <= 0) | (u >= QUANT) | (v <= 0) | (v >= QUANT)
        out["cells"] += int(ok.sum())
        out["band"] += int(band.sum())
        out["over_inside"] += int((err[~band] > max_error).sum())
        out["over_band"] += int((err[band] > max_error).sum())
        out["worst_inside"] = max(out["worst_inside"], float(err[~band].max(initial=0.0)))
        out["worst_band"] = max(out["worst_band"], float(err[band].max(initial=0.0)))
    out["seconds"] = time.perf_counter() - start
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "RESULTS_tiles_cells.md"))
    args = ap.parse_args()
    lines = [
        "# The deepest level of a terrain pyramid against the DEM's cells: as meshed on the nodes, and refined",
        "",
        f"{machine()}. Rerun: `python benchmarks/tiles_cells.py` (writes this file).",
        "",
        "Every valid DEM cell whose centre lies in a deepest-level tile, interpolated in the tile's mesh as a client "
        "does (decoded heights). *Band*: cells within half a quantum (1/65,534 of the tile's width) of a tile edge, "
        "whose vertex would lie on the seam both neighbours share; *inside*: the rest.",
        "",
        "| DEM | E (m) | tile cells | zoom | bound at | triangles | cells | worst inside (m) | beyond E inside "
        "| band cells | worst in the band (m) | beyond E in the band | seconds |",
        "|---" * 13 + "|",
    ]
    for label, dem, max_error, tile_cells in CASES:
        for bound_at in ("nodes", "cells"):
            r = deepest_errors(dem, max_error, tile_cells, bound_at)
            print(label, max_error, bound_at, r, flush=True)
            lines.append(f"| {label} | {max_error:g} | {tile_cells} | {r['zoom']} | {bound_at} | {r['triangles']:,} "
                         f"| {r['cells']:,} | {r['worst_inside']:.3f} | {r['over_inside']:,} | {r['band']:,} "
                         f"| {r['worst_band']:.3f} | {r['over_band']:,} | {r['seconds']:.1f} |")
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
