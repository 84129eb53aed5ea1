"""Quantized-mesh pyramids for CesiumJS: the tiles of :mod:`.pyramid`, gzipped ``{z}/{x}/{y}.terrain``.

Extensions (each listed in layer.json's ``extensions``; a client takes the
ones it asks for):

- ``octvertexnormals``: each vertex's normal is that of the sampled surface
  at its node (east-west and north-south neighbours, the halo included), not
  of the tile's own triangles, so the two tiles of a seam give its vertices
  the same normal and the light shows no seam;
- ``watermask``: from water polygons, the DEM's flat lakes or the water
  points of point clouds (:mod:`.water`);
- ``metadata`` (the default when the pyramid starts at level 0): every
  tile's JSON holds its error certificate (``tinsmith``: the largest vertical
  error against the DEM at every cell it covers, :mod:`.certificate`), and
  the tiles of every :data:`~.pyramid.METADATA_LEVELS`-th level list the
  tiles available in the levels below them (``available``); layer.json then
  lists only level 0, with ``metadataAvailability``, as Cesium ion's terrain
  does.  Without it layer.json lists every level.  The two go together:
  CesiumJS (1.145) fails on a tile with metadata when layer.json has no
  ``metadataAvailability``.  ``certificate.csv`` lists every tile's
  certificate either way.

Each header's maximum height is a loose bound: heights are quantized on the
pyramid's one step (see :mod:`.pyramid`).
"""

from __future__ import annotations

import gzip
import json
import time
from collections.abc import Callable
from pathlib import Path

from ..io import atomic_paths
from ..io.quantized_mesh import QUANT, encode_tile
from .certificate import tile_certificate
from .pyramid import (
    LEVEL_ZERO_ERROR,
    METADATA_LEVELS,
    PyramidJob,
    job_record,
    open_pyramid,
    pyramid_job,
    tile_bounds,
    tile_geometry,
    write_tiles,
)
from .water import tile_water_mask

__all__ = ["pyramid_tile", "quantized_mesh_pyramid"]


def pyramid_tile(tile: tuple[int, int, int], job: PyramidJob):
    """Sample, mesh, certify and encode one tile: (gzipped bytes, stats).

    ``stats["max_error"]`` is the certificate (against the DEM at every cell
    the tile covers), ``stats["mesh_error"]`` the mesher's own (against the
    tile's samples).
    """
    start = time.perf_counter()
    g = tile_geometry(tile, job)
    bounds = tile_bounds(*tile)
    decoded = job.h_min + g["k"] * job.h_step  # what a client decodes
    cert = tile_certificate(job, bounds, g, decoded) if job.certify else None
    stats = {"vertices": len(g["u"]), "triangles": len(g["triangles"]),
             "max_error": g["max_error"] if cert is None else cert["max_error"], "mesh_error": g["max_error"],
             "cells": 0 if cert is None else cert["cells"], "uncovered": 0 if cert is None else cert["uncovered"],
             "bound": g["bound"], "data": g["data"], "certified": cert is not None, "refined": g["refined"]}
    metadata = None
    if job.metadata:
        keys = ("max_error", "mesh_error", "bound", "cells", "uncovered") if job.certify else ("mesh_error", "bound")
        metadata = {"tinsmith": {k: stats[k] for k in keys}}
        if tile[0] % METADATA_LEVELS == 0:
            metadata["available"] = job.descendants(*tile)
    data = encode_tile(g["lon"], g["lat"], g["height"], g["u"], g["v"], g["k"] - g["k_min"], g["triangles"],
                       g["h_min"], g["h_min"] + QUANT * job.h_step,
                       normals=job.normals if g.get("normals") is None else g["normals"],
                       water=tile_water_mask(job.water, bounds), metadata=metadata)
    stats["seconds"] = time.perf_counter() - start
    return gzip.compress(data, compresslevel=6, mtime=0), stats


def quantized_mesh_pyramid(source, out_dir, *, max_error: float, method: str = "greedy", options: dict | None = None,
                           tile_cells: int = 256, min_zoom: int = 0, max_zoom: int | None = None,
                           normals: bool = False, height_offset: float = 0.0, vertical_crs: str | None = None,
                           workers: int | None = None, scheduler: str | None = None, band: int = 1, nodata=None,
                           water=None, metadata: bool | None = None, attribution: str | None = None,
                           certify: bool = True, bound_at: str = "cells",
                           progress: Callable[[int, int], None] | None = None) -> dict:
    """Write a quantized-mesh pyramid of a DEM for CesiumJS into ``out_dir`` (``layer.json`` last).

    ``water`` (polygons in any CRS, or ``"flat"``) adds the water mask;
    ``metadata`` the metadata extension with each tile's error certificate
    and the availability (default: when ``min_zoom`` is 0).  ``certify=False``
    skips the certificate (about a third of the time: every tile's DEM cells
    are read and placed in its mesh); ``max_error`` is then the mesher's own,
    at the tile's nodes.  ``bound_at="nodes"`` leaves the deepest level's
    tiles as meshed on their nodes, without refinement at the DEM's cells
    (:func:`.pyramid.pyramid_job`).  See the module notes.
    Tiles already in ``out_dir`` from the same job are kept (resume); the
    folder of another job is refused.  Returns a summary (levels, tiles,
    triangles, certified errors, the height step) and writes every tile's
    certificate to ``certificate.csv``.
    """
    job = pyramid_job(source, max_error=max_error, method=method, options=options, tile_cells=tile_cells,
                      min_zoom=min_zoom, max_zoom=max_zoom, normals=normals, height_offset=height_offset,
                      vertical_crs=vertical_crs, band=band, nodata=nodata, water=water, metadata=metadata,
                      certify=certify, bound_at=bound_at)
    min_zoom, max_zoom, step = job.min_zoom, job.max_zoom, job.h_step
    bounds = job.bounds
    tiles = [t for z in range(min_zoom, max_zoom + 1) for t in job.tiles(z)]
    out_dir = Path(out_dir)
    made = not out_dir.exists()
    done, log = open_pyramid(out_dir, job_record(job, bounds), _terrain_file)
    todo = [t for t in tiles if t not in done]
    write_tiles(pyramid_tile, todo, job, out_dir, _terrain_file, done, log, made, workers, scheduler,
                progress, len(tiles))
    if job.certify:
        with atomic_paths(out_dir / "certificate.csv") as (tmp,):
            tmp.write_text(_certificate_csv(done))
    layer = _layer_json(job, bounds, min_zoom, sorted(done), attribution)
    with atomic_paths(out_dir / "layer.json") as (tmp,):
        tmp.write_text(json.dumps(layer, indent=1))
    per_level = {}
    for (z, _, _), s in done.items():
        lvl = per_level.setdefault(z, {"tiles": 0, "empty": 0, "triangles": 0, "max_error": 0.0, "mesh_error": 0.0,
                                       "cells": 0, "bound": s["bound"]})
        lvl["tiles"] += 1
        lvl["certified"] = job.certify
        lvl["empty"] += not s["data"]
        lvl["triangles"] += s["triangles"]
        lvl["refined"] = lvl.get("refined", 0) + s.get("refined", 0)
        lvl["cells"] += s.get("cells", 0)
        lvl["uncovered"] = lvl.get("uncovered", 0) + s.get("uncovered", 0)
        lvl["max_error"] = max(lvl["max_error"], s["max_error"])
        lvl["mesh_error"] = max(lvl["mesh_error"], s.get("mesh_error", s["max_error"]))
    return {"levels": dict(sorted(per_level.items())), "tiles": len(done), "reused": len(tiles) - len(todo),
            "height_step": step, "bounds": bounds, "min_zoom": min_zoom, "max_zoom": max_zoom,
            "extensions": _extensions(job), "heights": job.heights.record(job.height_offset), "certified": job.certify,
            "bound_at": job.bound_at,
            "water": None if job.water is None else job.water.source}


def _certificate_csv(done: dict) -> str:
    """Every tile's certificate, one line each (level, x, y from the south)."""
    lines = ["z,x,y,max_error_m,mesh_error_m,bound_m,cells,uncovered_cells,vertices,triangles"]
    for (z, x, y), s in sorted(done.items()):
        lines.append(f"{z},{x},{y},{s['max_error']:.6g},{s.get('mesh_error', s['max_error']):.6g},{s['bound']:.6g},"
                     f"{s.get('cells', 0)},{s.get('uncovered', 0)},{s['vertices']},{s['triangles']}")
    return "\n".join(lines) + "\n"


def _extensions(job: PyramidJob) -> list[str]:
    return ((["octvertexnormals"] if job.normals else []) + (["watermask"] if job.water is not None else [])
            + (["metadata"] if job.metadata else []))


def _terrain_file(tile: tuple[int, int, int]) -> str:
    return f"{tile[0]}/{tile[1]}/{tile[2]}.terrain"


def _layer_json(job: PyramidJob, bounds, min_zoom: int, written: list, attribution: str | None) -> dict:
    """Cesium's layer.json: format, scheme, levels, extensions, and the available tiles as row ranges (level 0 only
    when the tiles' metadata carries the rest, with ``metadataAvailability``)."""
    available = []
    for z in range(1 if job.metadata else job.max_zoom + 1):
        rows: dict[int, list[int]] = {}
        for (tz, x, y) in written:
            if tz == z:
                rows.setdefault(y, []).append(x)
        ranges = []
        for y, xs in sorted(rows.items()):
            xs = sorted(xs)
            start = prev = xs[0]
            for x in xs[1:] + [None]:
                if x is not None and x == prev + 1:
                    prev = x
                    continue
                ranges.append({"startX": start, "startY": y, "endX": prev, "endY": y})
                if x is not None:
                    start = prev = x
        available.append(ranges)
    return {
        "tilejson": "2.1.0", "name": Path(job.raster.path).stem, "version": "1.0.0",
        "format": "quantized-mesh-1.0", "scheme": "tms", "projection": "EPSG:4326",
        "tiles": ["{z}/{x}/{y}.terrain?v={version}"], "minzoom": min_zoom, "maxzoom": job.max_zoom,
        "bounds": list(bounds), "available": available,
        **({"metadataAvailability": METADATA_LEVELS} if job.metadata else {}),
        **({"extensions": _extensions(job)} if _extensions(job) else {}),
        **({"attribution": attribution} if attribution else {}),
        "tinsmith": {"height_min": job.h_min, "height_step": job.h_step, "cell_metres": job.cell_m,
                     "heights": job.heights.record(job.height_offset)},
        "description": (f"tinsmith {job.method}, max error {job.max_error} m at level {job.max_zoom} and "
                        f"max({job.max_error}, {LEVEL_ZERO_ERROR:.2f} / 2^z) above; heights: "
                        f"{job.heights.note(job.height_offset)}, quantized in steps of {job.h_step:.6g} m. Tiles are gzipped: "
                        "serve them with Content-Encoding: gzip."),
    }
