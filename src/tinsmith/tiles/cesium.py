"""Quantized-mesh pyramids for CesiumJS: geographic tiles, one error bound per zoom level.

Tiling scheme: Cesium's ``GeographicTilingScheme`` (EPSG:4326, TMS rows from
the south): level ``z`` has ``2**(z+1)`` x ``2**z`` tiles of ``180 / 2**z``
degrees.  Each tile is a grid of ``tile_cells + 1`` nodes a side sampled
from the DEM, meshed under the seam contract of :mod:`.seams` (a halo of one
node round the tile), and written as a gzipped ``{z}/{x}/{y}.terrain``.

Sampling is deterministic and the same for every tile: node ``k`` of a
level sits at longitude ``-180 + k * 180 / (2**z * tile_cells)`` whichever
tile asks; its height is the bilinear interpolation of the DEM averaged over
aligned blocks of ``2**d`` cells (``d`` chosen per level so that a block is
no wider than a node spacing).  Neighbours therefore sample their shared
edge identically and keep the same seam vertices.

Error per level: Cesium refines a tile when the screen-space error of its
level's geometric error, ``78271.52 / 2**z`` metres for quantized-mesh
terrain (its estimate for a 64-sample tile of the WGS84 ellipsoid), is too
large; each level is meshed to the larger of that and ``max_error`` (the
deepest level to ``max_error``).

Heights: quantized-mesh heights are metres above the WGS84 ellipsoid.  Most
DEMs are on a geoid (EGM96, NAVD88...), up to about 100 m away: a DEM whose
CRS has a vertical part (or given ``vertical_crs``) is converted by PROJ
(:mod:`.heights`, on each tile's nodes), then ``height_offset`` is added to
every height.  Heights are quantized on one step for the whole pyramid (the
DEM's height range / 32767), so that neighbours decode the same heights on
their shared edge; each header's maximum height is then a loose bound.
"""

from __future__ import annotations

import contextlib
import functools
import gzip
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import _checks
from ..core.heightfield import world_to_pixel
from ..errors import FileError, InvalidInputError, InvalidOptionError
from ..io import atomic_paths
from ..io.quantized_mesh import QUANT, encode_tile
from ..io.raster import RasterInfo, raster_info, read_window
from .heights import EllipsoidHeights, ellipsoid_heights
from .run import TileLog, execute, fingerprint_source
from .worker import TILE_METHODS, mesh_window

__all__ = [
    "LEVEL_ZERO_ERROR", "PyramidJob", "pyramid_job", "pyramid_tile", "quantized_mesh_pyramid", "tile_bounds", "tile_geometry",
]

#: Cesium's geometric error of a level-0 quantized-mesh tile (metres); level z has this / 2**z.
LEVEL_ZERO_ERROR = 6378137.0 * 2 * math.pi * 0.25 / (64 * 2)
_M_PER_DEG = 111_320.0
#: Cells read at once while sampling a tile (about 40 MB of float64 with its mask and sums).
_READ_CELLS = 4_000_000


def tile_bounds(z: int, x: int, y: int) -> tuple[float, float, float, float]:
    """(west, south, east, north) in degrees of tile (x, y) of level z, rows counted from the south."""
    size = 180.0 / 2 ** z
    return (-180.0 + x * size, -90.0 + y * size, -180.0 + (x + 1) * size, -90.0 + (y + 1) * size)


@dataclass(frozen=True)
class PyramidJob:
    """What every tile of a pyramid shares."""

    raster: RasterInfo
    method: str
    max_error: float
    options: dict
    tile_cells: int
    min_zoom: int
    max_zoom: int
    normals: bool
    height_offset: float
    h_min: float
    h_step: float
    cell_m: float
    heights: EllipsoidHeights  # the DEM's heights to the ellipsoid (or as given), before height_offset

    def level_error(self, z: int) -> float:
        return self.max_error if z >= self.max_zoom else max(self.max_error, LEVEL_ZERO_ERROR / 2 ** z)

    def decimation(self, z: int, cell_m: float) -> int:
        """Block size (cells, a power of two) averaged for level z: no wider than a node spacing."""
        spacing = 180.0 / 2 ** z / self.tile_cells * _M_PER_DEG
        d = 1
        while 2 * d * cell_m <= spacing:
            d *= 2
        return d


def _cell_metres(raster: RasterInfo) -> float:
    from pyproj import CRS

    a, b, _, d, e, _ = raster.transform
    size = math.sqrt(abs(a * e - b * d))
    crs = CRS.from_user_input(raster.crs)
    return size * _M_PER_DEG if crs.is_geographic else size * crs.axis_info[0].unit_conversion_factor


def _height_range(raster: RasterInfo) -> tuple[float, float]:
    """Exact min and max of the valid heights, read block row by block row (bounded memory)."""
    H, W = raster.shape
    lo, hi = math.inf, -math.inf
    step = max(1, 4_000_000 // W)
    for r in range(0, H, step):
        z, valid = read_window(raster, (r, min(H, r + step) - 1), (0, W - 1))
        if valid.any():
            lo, hi = min(lo, float(z[valid].min())), max(hi, float(z[valid].max()))
    if lo > hi:
        raise InvalidInputError(f"{raster.path!r} holds no valid heights")
    return lo, hi


def _lonlat_bounds(raster: RasterInfo) -> tuple[float, float, float, float]:
    from rasterio.warp import transform_bounds

    H, W = raster.shape
    a, b, c, d, e, f = raster.transform
    xs = [c, a * W + c, b * H + c, a * W + b * H + c]
    ys = [f, d * W + f, e * H + f, d * W + e * H + f]
    return transform_bounds(raster.crs, "EPSG:4326", min(xs), min(ys), max(xs), max(ys), densify_pts=21)


def _tiles_of_level(z: int, bounds) -> list[tuple[int, int, int]]:
    w, s, e, n = bounds
    size = 180.0 / 2 ** z
    x0, x1 = int((w + 180) // size), int(math.ceil((e + 180) / size)) - 1
    y0, y1 = int((s + 90) // size), int(math.ceil((n + 90) / size)) - 1
    x1, y1 = min(max(x0, x1), 2 ** (z + 1) - 1), min(max(y0, y1), 2 ** z - 1)
    return [(z, x, y) for y in range(y0, y1 + 1) for x in range(x0, x1 + 1)]


@functools.lru_cache(maxsize=4)
def _transformer(crs: str):
    from pyproj import Transformer

    return Transformer.from_crs("EPSG:4326", crs, always_xy=True)


def _sample(job: PyramidJob, z: int, x: int, y: int):
    """Heights (NaN: no data) of the tile's nodes plus a halo of one node, rows from the north."""
    N = job.tile_cells
    scale = 180.0 / (2 ** z * N)  # degrees per node
    ks = np.arange(x * N - 1, (x + 1) * N + 2)
    ls = np.arange((y + 1) * N + 1, y * N - 2, -1)  # north to south
    lon, lat = -180.0 + ks * scale, -90.0 + ls * scale
    LON, LAT = np.meshgrid(lon, lat)
    tr = _transformer(job.raster.crs)
    with np.errstate(invalid="ignore", over="ignore"):  # halo nodes beyond a pole do not transform (inf)
        X, Y = tr.transform(LON, LAT)
        row, col = world_to_pixel(job.raster.transform, X, Y)
    H, W = job.raster.shape
    dec = job.decimation(z, job.cell_m)
    # fractional block coordinates: block I holds rows I*dec .. I*dec+dec-1, its centre at I*dec + (dec-1)/2
    bi, bj = (row - (dec - 1) / 2) / dec, (col - (dec - 1) / 2) / dec
    nb_r, nb_c = -(-H // dec), -(-W // dec)
    inside = np.isfinite(bi) & np.isfinite(bj) & (bi >= 0) & (bi <= nb_r - 1) & (bj >= 0) & (bj <= nb_c - 1)
    out = np.full(LON.shape, np.nan)
    if not inside.any():
        return out
    i0, i1 = int(np.floor(bi[inside].min())), min(nb_r - 1, int(np.floor(bi[inside].max())) + 1)
    j0, j1 = int(np.floor(bj[inside].min())), min(nb_c - 1, int(np.floor(bj[inside].max())) + 1)
    blocks = np.full((i1 - i0 + 1, j1 - j0 + 1), np.nan)
    cols = (j0 * dec, min(W, (j1 + 1) * dec) - 1)
    width = cols[1] - cols[0] + 1
    per_read = max(1, _READ_CELLS // (dec * dec * (j1 - j0 + 1)))  # block rows per read: bounded memory
    for first in range(i0, i1 + 1, per_read):
        last = min(i1, first + per_read - 1)
        zz, valid = read_window(job.raster, (first * dec, min(H, (last + 1) * dec) - 1), cols)
        n_rows = last - first + 1
        pad_r, pad_c = n_rows * dec - zz.shape[0], -width % dec
        zz = np.pad(np.where(valid, zz, 0.0), ((0, pad_r), (0, pad_c)))
        valid = np.pad(valid, ((0, pad_r), (0, pad_c)))
        shape = (n_rows, dec, zz.shape[1] // dec, dec)
        s_ = zz.reshape(shape).sum(axis=(1, 3))
        n_ = valid.reshape(shape).sum(axis=(1, 3))
        blocks[first - i0:last - i0 + 1] = np.where(n_ > 0, s_ / np.maximum(n_, 1), np.nan)
    fi, fj = bi[inside] - i0, bj[inside] - j0
    r0 = np.minimum(np.floor(fi).astype(np.int64), blocks.shape[0] - 2) if blocks.shape[0] > 1 else np.zeros(len(fi), np.int64)
    c0 = np.minimum(np.floor(fj).astype(np.int64), blocks.shape[1] - 2) if blocks.shape[1] > 1 else np.zeros(len(fj), np.int64)
    tr_, tc_ = fi - r0, fj - c0
    r1, c1 = np.minimum(r0 + 1, blocks.shape[0] - 1), np.minimum(c0 + 1, blocks.shape[1] - 1)
    v = (blocks[r0, c0] * (1 - tr_) * (1 - tc_) + blocks[r0, c1] * (1 - tr_) * tc_
         + blocks[r1, c0] * tr_ * (1 - tc_) + blocks[r1, c1] * tr_ * tc_)
    out[inside] = job.heights.to_ellipsoid(X[inside], Y[inside], v) + job.height_offset
    return out


def tile_geometry(tile: tuple[int, int, int], job: PyramidJob) -> dict:
    """Sample and mesh one tile: its vertices (lon, lat, height; u, v, quantized height k) and triangles.

    ``k`` counts height steps from the pyramid's lowest height, so it is the
    same integer in every tile for the same height; the tile stores
    ``k - k_min`` above its own ``h_min``.  A tile without data is the flat
    ellipsoid (two triangles, ``data`` False).
    """
    z, x, y = tile
    N = job.tile_cells
    heights = _sample(job, z, x, y)
    valid = np.isfinite(heights)
    scale = 180.0 / (2 ** z * N)
    west, _, _, north = tile_bounds(z, x, y)
    transform = (scale, 0.0, west - 0.5 * scale, 0.0, -scale, north + 0.5 * scale)
    bound = job.level_error(z)
    out = mesh_window(heights, valid, (1, N + 1), (1, N + 1), transform, "EPSG:4326", job.method, bound, job.options)
    data = out is not None and len(out[3]) > 0
    if data:
        rows, cols, h, triangles, error, _ = out
        k = np.rint((h - job.h_min) / job.h_step).astype(np.int64)
        k_min = int(k.min())
        h_min = job.h_min + k_min * job.h_step
    else:
        # no data in this tile (the DEM falls between its nodes, or beside it): the flat ellipsoid,
        # so that every tile over the DEM's bounds exists and Cesium's descent never meets a gap
        rows, cols = np.array([0, 0, N, N]), np.array([0, N, 0, N])
        h, error, k, k_min, h_min = np.zeros(4), 0.0, np.zeros(4, np.int64), 0, 0.0
        triangles = np.array([[0, 2, 3], [0, 3, 1]])  # counter-clockwise seen from above
    # positions from global node indices, so that neighbours compute the same numbers
    return {"lon": -180.0 + (x * N + cols) * scale, "lat": -90.0 + ((y + 1) * N - rows) * scale, "height": h,
            "u": (cols * QUANT + N // 2) // N, "v": ((N - rows) * QUANT + N // 2) // N, "k": k, "k_min": k_min,
            "h_min": h_min, "triangles": triangles, "max_error": error, "bound": bound, "data": data}


def pyramid_tile(tile: tuple[int, int, int], job: PyramidJob):
    """Sample, mesh and encode one tile: (gzipped bytes, stats)."""
    start = time.perf_counter()
    g = tile_geometry(tile, job)
    data = encode_tile(g["lon"], g["lat"], g["height"], g["u"], g["v"], g["k"] - g["k_min"], g["triangles"],
                       g["h_min"], g["h_min"] + QUANT * job.h_step, normals=job.normals)
    stats = {"seconds": time.perf_counter() - start, "vertices": len(g["u"]), "triangles": len(g["triangles"]),
             "max_error": g["max_error"], "bound": g["bound"], "data": g["data"]}
    return gzip.compress(data, compresslevel=6, mtime=0), stats


def pyramid_job(source, *, max_error: float, method: str = "greedy", options: dict | None = None,
                tile_cells: int = 256, min_zoom: int = 0, max_zoom: int | None = None, normals: bool = False,
                height_offset: float = 0.0, vertical_crs: str | None = None, band: int = 1,
                nodata=None) -> PyramidJob:
    """Check the options and read what every tile shares (the raster's metadata and exact height range).

    ``vertical_crs`` is the DEM's vertical CRS when its file lacks it, or
    ``"none"`` to take heights as given (see :func:`.heights.ellipsoid_heights`).
    """
    if method not in TILE_METHODS:
        raise InvalidOptionError(f"method must be one of {', '.join(TILE_METHODS)}, got {method!r}")
    max_error = _checks.number("max_error", max_error)
    if not max_error > 0:
        raise InvalidOptionError(f"max_error must be > 0, got {max_error}")
    tile_cells = _checks.integer("tile_cells", tile_cells, minimum=2, maximum=4096)
    min_zoom = _checks.integer("min_zoom", min_zoom, minimum=0, maximum=24)
    height_offset = _checks.number("height_offset", height_offset)
    raster = raster_info(source, band=band, nodata=nodata)
    if raster.crs is None:
        raise InvalidInputError(f"{str(source)!r} has no CRS: a quantized-mesh pyramid needs to place it on the globe")
    heights = ellipsoid_heights(raster.crs, vertical_crs)
    cell_m = _cell_metres(raster)
    if max_zoom is None:  # the first level whose node spacing is as fine as the DEM
        max_zoom = 0
        while 180.0 / 2 ** max_zoom / tile_cells * _M_PER_DEG > cell_m and max_zoom < 24:
            max_zoom += 1
    max_zoom = _checks.integer("max_zoom", max_zoom, minimum=min_zoom, maximum=24)
    heights = heights.over(raster, *_height_range(raster))  # the range of the converted heights
    lo, hi = heights.low, heights.high
    step = max(hi - lo, 1e-3) / QUANT
    return PyramidJob(raster, method, float(max_error), dict(options or {}), tile_cells, min_zoom, max_zoom,
                      bool(normals), float(height_offset), lo + height_offset, step, cell_m, heights)


def quantized_mesh_pyramid(source, out_dir, *, max_error: float, method: str = "greedy", options: dict | None = None,
                           tile_cells: int = 256, min_zoom: int = 0, max_zoom: int | None = None,
                           normals: bool = False, height_offset: float = 0.0, vertical_crs: str | None = None,
                           workers: int | None = None,
                           scheduler: str | None = None, band: int = 1, nodata=None,
                           progress: Callable[[int, int], None] | None = None) -> dict:
    """Write a quantized-mesh pyramid of a DEM for CesiumJS into ``out_dir`` (``layer.json`` last).

    Tiles already in ``out_dir`` from the same job are kept (resume); the
    folder of another job is refused.  Returns a summary (levels, tiles,
    triangles, errors, the height step).  See the module's notes on heights.
    """
    job = pyramid_job(source, max_error=max_error, method=method, options=options, tile_cells=tile_cells,
                      min_zoom=min_zoom, max_zoom=max_zoom, normals=normals, height_offset=height_offset,
                      vertical_crs=vertical_crs, band=band, nodata=nodata)
    min_zoom, max_zoom, step = job.min_zoom, job.max_zoom, job.h_step
    bounds = _lonlat_bounds(job.raster)
    tiles = [t for z in range(min_zoom, max_zoom + 1) for t in _tiles_of_level(z, bounds)]
    out_dir = Path(out_dir)
    made = not out_dir.exists()
    done, log = _open_pyramid(out_dir, job, bounds)
    todo = [t for t in tiles if t not in done]
    count = len(tiles) - len(todo)
    if progress is not None:
        progress(count, len(tiles))
    try:
        for tile, (data, stats) in execute(pyramid_tile, todo, job, workers, scheduler):
            z, x, y = tile
            target = out_dir / str(z) / str(x) / f"{y}.terrain"
            target.parent.mkdir(parents=True, exist_ok=True)
            with atomic_paths(target) as (tmp,):
                tmp.write_bytes(data)
            done[tile] = stats
            log.append(f"{z}/{x}/{y}", stats)
            count += 1
            if progress is not None:
                progress(count, len(tiles))
    except BaseException:
        if not done:  # stopped or failed before any tile: nothing to resume from, nothing left
            _forget_pyramid(out_dir, log, made)
        raise
    layer = _layer_json(job, bounds, min_zoom, sorted(done))
    with atomic_paths(out_dir / "layer.json") as (tmp,):
        tmp.write_text(json.dumps(layer, indent=1))
    per_level = {}
    for (z, _, _), s in done.items():
        lvl = per_level.setdefault(z, {"tiles": 0, "empty": 0, "triangles": 0, "max_error": 0.0, "bound": s["bound"]})
        lvl["tiles"] += 1
        lvl["empty"] += not s["data"]
        lvl["triangles"] += s["triangles"]
        lvl["max_error"] = max(lvl["max_error"], s["max_error"])
    return {"levels": dict(sorted(per_level.items())), "tiles": len(done), "reused": len(tiles) - len(todo),
            "height_step": step, "bounds": bounds, "min_zoom": min_zoom, "max_zoom": max_zoom,
            "heights": job.heights.record(job.height_offset)}


def _job_record(job: PyramidJob, bounds) -> dict:
    return {"source": fingerprint_source(job.raster), "band": job.raster.band, "method": job.method,
            "max_error": job.max_error, "options": {k: str(v) for k, v in job.options.items()},
            "tile_cells": job.tile_cells, "max_zoom": job.max_zoom, "normals": job.normals,
            "height_offset": job.height_offset,
            **({"heights": job.heights.operation} if job.heights.operation else {})}


def _open_pyramid(out_dir: Path, job: PyramidJob, bounds) -> tuple[dict, TileLog]:
    """The finished tiles of this job in ``out_dir`` and its tile log (a folder of another job is refused)."""
    record = out_dir / ".tinsmith-job.json"
    log = TileLog(out_dir / ".tinsmith-tiles.jsonl")
    fingerprint = _job_record(job, bounds)
    try:
        if out_dir.exists() and any(out_dir.iterdir()):
            if not record.exists() or json.loads(record.read_text()).get("job") != fingerprint:
                raise FileError(f"{str(out_dir)!r} holds files of another job; give an empty or new folder")
            done = {tuple(int(p) for p in k.split("/")): s for k, s in log.read().items()
                    if (out_dir / f"{k}.terrain").exists()}
            return done, log
        out_dir.mkdir(parents=True, exist_ok=True)
        with atomic_paths(record) as (tmp,):
            tmp.write_text(json.dumps({"job": fingerprint}))
    except OSError as exc:
        raise FileError(f"cannot write to {str(out_dir)!r}: {exc.strerror or exc}") from None
    return {}, log


def _forget_pyramid(out_dir: Path, log: TileLog, made: bool) -> None:
    """Remove the job record and log of a pyramid with no tile, its empty level folders, and the folder if made."""
    (out_dir / ".tinsmith-job.json").unlink(missing_ok=True)
    log.clear()
    for folder, _, _ in sorted(os.walk(out_dir), key=lambda entry: -len(entry[0])):  # deepest first; only empty ones
        if folder != str(out_dir) or made:
            with contextlib.suppress(OSError):
                os.rmdir(folder)


def _layer_json(job: PyramidJob, bounds, min_zoom: int, written: list) -> dict:
    """Cesium's layer.json: format, scheme, levels, and the available tiles as row ranges."""
    available = []
    for z in range(job.max_zoom + 1):
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
        **({"extensions": ["octvertexnormals"]} if job.normals else {}),
        "tinsmith": {"height_min": job.h_min, "height_step": job.h_step, "cell_metres": job.cell_m,
                     "heights": job.heights.record(job.height_offset)},
        "description": (f"tinsmith {job.method}, max error {job.max_error} m at level {job.max_zoom} and "
                        f"max({job.max_error}, {LEVEL_ZERO_ERROR:.2f} / 2^z) above; heights: "
                        f"{job.heights.note(job.height_offset)}, quantized in steps of {job.h_step:.6g} m. Tiles are gzipped: "
                        "serve them with Content-Encoding: gzip."),
    }
