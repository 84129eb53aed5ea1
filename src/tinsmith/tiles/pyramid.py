"""The geographic pyramid both terrain formats share: its tiles, their samples of the DEM, their meshes.

Tiling scheme: Cesium's ``GeographicTilingScheme`` (EPSG:4326, TMS rows from
the south): level ``z`` has ``2**(z+1)`` x ``2**z`` tiles of ``180 / 2**z``
degrees.  Each tile is a grid of ``tile_cells + 1`` nodes a side sampled
from the DEM and meshed under the seam contract of :mod:`.seams` (a halo of
one node round the tile).  :mod:`.cesium` writes the tiles as quantized-mesh,
:mod:`.terrain3d` as 3D Tiles.

Sampling is deterministic and the same for every tile: node ``k`` of a
level sits at longitude ``-180 + k * 180 / (2**z * tile_cells)`` whichever
tile asks; its height is the bilinear interpolation of the DEM averaged over
aligned blocks of ``2**d`` cells (``d`` chosen per level so that a block is
no wider than a node spacing).  Neighbours therefore sample their shared
edge identically and keep the same seam vertices.  Nodes beyond the DEM's
extent stand on the ellipsoid, so a tile covers its whole rectangle.

Error per level: Cesium refines a tile when the screen-space error of its
level's geometric error, ``78271.52 / 2**z`` metres for quantized-mesh
terrain (its estimate for a 64-sample tile of the WGS84 ellipsoid), is too
large; each level is meshed to the larger of that and ``max_error`` (the
deepest level to ``max_error``).  The bound holds at the nodes; where the
deepest level's nodes sample the DEM's cells themselves, its tiles are then
refined until it holds at every cell centre strictly inside them as well
(:mod:`.refine`; ``bound_at="nodes"`` skips that).

Heights: terrain heights are metres above the WGS84 ellipsoid.  Most DEMs
are on a geoid (EGM96, NAVD88...), up to about 100 m away: a DEM whose CRS
has a vertical part (or given ``vertical_crs``) is converted by PROJ
(:mod:`.heights`, on each tile's nodes), then ``height_offset`` is added to
every height.  Heights are quantized on one step for the whole pyramid (the
height range, the ellipsoid included, / 32767), so that neighbours decode the
same heights on their shared edge.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import _checks
from ..core.heightfield import world_to_pixel
from ..errors import FileError, InvalidInputError, InvalidOptionError
from ..io import atomic_paths
from ..io.crs import M_PER_DEGREE, metres_per_unit
from ..io.quantized_mesh import QUANT, WGS84, ecef, ellipsoid_normals
from ..io.raster import RasterInfo, raster_info, read_window
from . import BOUND_AT
from .heights import EllipsoidHeights, ellipsoid_heights
from .lonlat import from_lonlat
from .refine import refine_at_cells
from .run import TileLog, execute, fingerprint_source
from .water import Water, water_of
from .worker import TILE_METHODS, mesh_window

__all__ = [
    "LEVEL_ZERO_ERROR", "METADATA_LEVELS", "PyramidJob", "ellipsoid_grid", "fill_height", "forget_pyramid",
    "from_lonlat", "job_record", "lonlat_bounds", "open_pyramid", "pyramid_job", "tile_bounds", "tile_geometry", "tiles_of_level",
    "write_tiles",
]

#: Cesium's geometric error of a level-0 quantized-mesh tile (metres); level z has this / 2**z.
LEVEL_ZERO_ERROR = 6378137.0 * 2 * math.pi * 0.25 / (64 * 2)
#: With availability in the tiles' metadata: the tiles of every this-many-th level list the next levels' tiles.
METADATA_LEVELS = 10
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
    heights: EllipsoidHeights  #: the DEM's heights to the ellipsoid (or as given), before height_offset
    bounds: tuple = (-180.0, -90.0, 180.0, 90.0)  #: the DEM's (west, south, east, north) in degrees
    water: Water | None = None
    metadata: bool = False  #: the metadata extension, which carries the availability (layer.json: level 0 only)
    certify: bool = True  #: measure every tile against the DEM's cells (:mod:`.certificate`)
    #: where the deepest level's bound holds: "cells" (refined at the DEM's cells, :mod:`.refine`) or "nodes"
    bound_at: str = "cells"

    def level_error(self, z: int) -> float:
        return self.max_error if z >= self.max_zoom else max(self.max_error, LEVEL_ZERO_ERROR / 2 ** z)

    def tiles(self, z: int) -> list[tuple[int, int, int]]:
        """The tiles of level z the pyramid writes: those over the DEM (at level 0 both, with availability in the
        metadata, where a client takes both as available)."""
        if z == 0 and self.metadata:
            return [(0, 0, 0), (0, 1, 0)]
        return tiles_of_level(z, self.bounds)

    def descendants(self, z: int, x: int, y: int) -> list[list[dict]]:
        """The metadata's ``available`` of tile (z, x, y): for each of the next levels up to the next metadata
        level, the range of written tiles below it."""
        out = []
        for k in range(1, METADATA_LEVELS + 1):
            if z + k > self.max_zoom:
                break
            level = self.tiles(z + k)
            xs = [t[1] for t in level]
            ys = [t[2] for t in level]
            x0, x1 = max(min(xs), x << k), min(max(xs), ((x + 1) << k) - 1)
            y0, y1 = max(min(ys), y << k), min(max(ys), ((y + 1) << k) - 1)
            out.append([{"startX": x0, "startY": y0, "endX": x1, "endY": y1}] if x0 <= x1 and y0 <= y1 else [])
        return out

    def decimation(self, z: int, cell_m: float) -> int:
        """Block size (cells, a power of two) averaged for level z: no wider than a node spacing."""
        spacing = 180.0 / 2 ** z / self.tile_cells * M_PER_DEGREE
        d = 1
        while 2 * d * cell_m <= spacing:
            d *= 2
        return d


def _cell_metres(raster: RasterInfo) -> float:
    a, b, _, d, e, _ = raster.transform
    return math.sqrt(abs(a * e - b * d)) * metres_per_unit(raster.crs)


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


def lonlat_bounds(raster: RasterInfo) -> tuple[float, float, float, float]:
    from rasterio.warp import transform_bounds

    H, W = raster.shape
    a, b, c, d, e, f = raster.transform
    xs = [c, a * W + c, b * H + c, a * W + b * H + c]
    ys = [f, d * W + f, e * H + f, d * W + e * H + f]
    return transform_bounds(raster.crs, "EPSG:4326", min(xs), min(ys), max(xs), max(ys), densify_pts=21)


def tiles_of_level(z: int, bounds) -> list[tuple[int, int, int]]:
    w, s, e, n = bounds
    size = 180.0 / 2 ** z
    x0, x1 = int((w + 180) // size), int(math.ceil((e + 180) / size)) - 1
    y0, y1 = int((s + 90) // size), int(math.ceil((n + 90) / size)) - 1
    x1, y1 = min(max(x0, x1), 2 ** (z + 1) - 1), min(max(y0, y1), 2 ** z - 1)
    return [(z, x, y) for y in range(y0, y1 + 1) for x in range(x0, x1 + 1)]


#: Nodes between the points whose DEM coordinates pyproj computes exactly (at most; a divisor of the tile's nodes).
NODE_LATTICE = 16
#: From this level down the lattice is used (a lattice cell of 16 nodes bends by 30 km / 4**z there: 7 cm at 10).
_LATTICE_FROM = 8


def _node_positions(crs: str, ks: np.ndarray, ls: np.ndarray, scale: float, z: int, N: int):
    """The DEM-CRS coordinates (X, Y) of nodes (column ``ks`` x row ``ls``, global indices of level z).

    pyproj transforms every node at the coarse levels; from :data:`_LATTICE_FROM` on, only the nodes whose
    indices are multiples of a lattice step (``gcd(NODE_LATTICE, N)``, so that every tile edge is a lattice line)
    and bilinearly between them, with weights from global indices: a node gets the same coordinates in every tile
    that holds it, so neighbours still sample their shared edge identically.  Halo nodes beyond a pole do not
    transform (inf).
    """
    tr = from_lonlat(crs)
    step = math.gcd(NODE_LATTICE, N) if z >= _LATTICE_FROM else 1
    if step == 1:
        LON, LAT = np.meshgrid(-180.0 + ks * scale, -90.0 + ls * scale)
        with np.errstate(invalid="ignore", over="ignore"):
            return tr.transform(LON, LAT)
    lk = np.arange(ks.min() // step * step, -(-ks.max() // step) * step + 1, step)
    ll = np.arange(ls.min() // step * step, -(-ls.max() // step) * step + 1, step)
    LON, LAT = np.meshgrid(-180.0 + lk * scale, -90.0 + ll * scale)
    with np.errstate(invalid="ignore", over="ignore"):
        LX, LY = (np.asarray(v) for v in tr.transform(LON, LAT))
    i = np.minimum((ls - ll[0]) // step, len(ll) - 2)  # the lattice cell of each row and column, and where in it
    j = np.minimum((ks - lk[0]) // step, len(lk) - 2)
    t, u = ((ls - ll[i]) / step)[:, None], (ks - lk[j]) / step
    out = []
    for V in (LX, LY):
        along = V[:, j] * (1 - u) + V[:, j + 1] * u  # each lattice row at every column, then between the rows
        out.append(along[i] * (1 - t) + along[i + 1] * t)
    return out[0], out[1]


def _sample(job: PyramidJob, z: int, x: int, y: int):
    """Heights (NaN: no data) of the tile's nodes plus a halo of one node, rows from the north, and which of them
    lie outside the DEM's extent."""
    N = job.tile_cells
    scale = 180.0 / (2 ** z * N)  # degrees per node
    ks = np.arange(x * N - 1, (x + 1) * N + 2)
    ls = np.arange((y + 1) * N + 1, y * N - 2, -1)  # north to south
    X, Y = _node_positions(job.raster.crs, ks, ls, scale, z, N)
    with np.errstate(invalid="ignore", over="ignore"):
        row, col = world_to_pixel(job.raster.transform, X, Y)
    H, W = job.raster.shape
    dec = job.decimation(z, job.cell_m)
    # fractional block coordinates: block I holds rows I*dec .. I*dec+dec-1, its centre at I*dec + (dec-1)/2
    bi, bj = (row - (dec - 1) / 2) / dec, (col - (dec - 1) / 2) / dec
    nb_r, nb_c = -(-H // dec), -(-W // dec)
    inside = np.isfinite(bi) & np.isfinite(bj) & (bi >= 0) & (bi <= nb_r - 1) & (bj >= 0) & (bj <= nb_c - 1)
    out = np.full(np.shape(X), np.nan)
    if not inside.any():
        return out, ~inside
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
    return out, ~inside


def fill_height(job: PyramidJob) -> float:
    """The height of the nodes beyond the DEM: the ellipsoid's, on the pyramid's height steps (within half a step
    of 0)."""
    return job.h_min + round(-job.h_min / job.h_step) * job.h_step


def tile_geometry(tile: tuple[int, int, int], job: PyramidJob, fill: float | None = None) -> dict:
    """Sample and mesh one tile: its vertices (lon, lat, height; u, v, quantized height k) and triangles.

    ``k`` counts height steps from the pyramid's lowest height, so it is the
    same integer in every tile for the same height; the tile stores
    ``k - k_min`` above its own ``h_min``.  Nodes beyond the DEM's extent take
    the ellipsoid's height (:func:`fill_height`), so that a tile over the
    DEM's edge covers its whole rectangle (a cliff at the edge, no hole to
    see through); nodata inside the DEM stays a hole.  A tile without data is
    the ellipsoid (:func:`ellipsoid_grid`, ``data`` False).  With ``fill``
    (metres), every node without data takes that height.  ``filled`` tells
    which vertices took a height not of the DEM.
    """
    z, x, y = tile
    N = job.tile_cells
    heights, outside = _sample(job, z, x, y)
    data = bool(np.isfinite(heights[1:N + 2, 1:N + 2]).any())
    missing = outside if fill is None else ~np.isfinite(heights)
    heights = np.where(missing, fill_height(job) if fill is None else fill, heights)
    valid = np.isfinite(heights)
    scale = 180.0 / (2 ** z * N)
    west, _, _, north = tile_bounds(z, x, y)
    transform = (scale, 0.0, west - 0.5 * scale, 0.0, -scale, north + 0.5 * scale)
    bound = job.level_error(z)
    out = mesh_window(heights, valid, (1, N + 1), (1, N + 1), transform, "EPSG:4326", job.method, bound,
                      job.options) if data else None
    data = out is not None and len(out[3]) > 0
    extra = None
    if data:
        rows, cols, h, triangles, error, _ = out
        filled = missing[rows + 1, cols + 1]
        if job.bound_at == "cells" and z == job.max_zoom and job.decimation(z, job.cell_m) == 1:
            extra = refine_at_cells(job, tile_bounds(z, x, y), heights, missing, rows, cols, h, triangles,
                                    filled, bound)
            triangles = extra.triangles
    else:
        # no data in this tile (the DEM falls between its nodes, or beside it): the ellipsoid, so that every tile
        # over the DEM's bounds exists and Cesium's descent never meets a gap
        rows, cols, triangles = ellipsoid_grid(z, N, bound)
        h, error, filled = np.full(len(rows), fill_height(job) if fill is None else fill), 0.0, np.ones(len(rows), bool)
    u, v = (cols * QUANT + N // 2) // N, ((N - rows) * QUANT + N // 2) // N
    nodes = len(rows)
    if extra is not None and len(extra.rows):
        rows, cols = np.concatenate([rows, extra.rows]), np.concatenate([cols, extra.cols])
        u, v = np.concatenate([u, extra.u]), np.concatenate([v, extra.v])
        h, filled = np.concatenate([h, extra.height]), np.concatenate([filled, np.zeros(len(extra.rows), bool)])
    k = np.rint((h - job.h_min) / job.h_step).astype(np.int64)
    k_min = int(k.min())
    h_min = job.h_min + k_min * job.h_step
    # positions from global node indices, so that neighbours compute the same numbers
    out = {"lon": -180.0 + (x * N + cols) * scale, "lat": -90.0 + ((y + 1) * N - rows) * scale, "height": h,
           "u": u, "v": v, "k": k, "k_min": k_min, "h_min": h_min, "triangles": triangles, "max_error": error,
           "bound": bound, "data": data, "rows": rows, "cols": cols, "filled": filled,
           "refined": 0 if extra is None else len(extra.rows)}
    if job.normals:  # from the sampled (and filled) nodes, whichever tile asks: the same on both sides of a seam
        out["normals"] = _grid_normals(heights, out, tile, N, nodes)
    return out


def ellipsoid_grid(z: int, N: int, bound: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rows, cols, triangles) of a tile of level z without data: a grid of its nodes whose chords stay within
    ``bound`` of the ellipsoid.

    ``n`` segments a side sag ``R * (a / n)**2 / 8`` below the ellipsoid over
    a tile of ``a`` radians; two triangles (``n`` = 1) wherever that is
    within the bound.  Two triangles over a level-0 tile would put all four
    corners on the poles: a plane through the Earth.
    """
    arc = math.pi / 2 ** z
    n = 1
    while n < N and WGS84[0] * (arc / n) ** 2 / 8 > bound:
        n *= 2
    idx = np.arange(n + 1) * (N // n) if N % n == 0 else np.rint(np.arange(n + 1) * N / n).astype(np.int64)
    rows, cols = np.meshgrid(idx[::-1], idx, indexing="ij")  # rows from the north
    k = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)  # node (i, j): i-th from the south, j-th from the west
    sw, se, ne, nw = k[:-1, :-1].ravel(), k[:-1, 1:].ravel(), k[1:, 1:].ravel(), k[1:, :-1].ravel()
    triangles = np.concatenate([np.column_stack([sw, se, ne]), np.column_stack([sw, ne, nw])])  # counter-clockwise
    return rows.ravel(), cols.ravel(), triangles


def _grid_normals(heights: np.ndarray, g: dict, tile: tuple[int, int, int], N: int, nodes: int) -> np.ndarray:
    """(V, 3) unit normals (ECEF) of the sampled surface at the vertices: from the nodes east and west, north and
    south of each (one side where the other has no data; the ellipsoid's normal where both lack it).

    ``heights`` are the tile's samples with their halo, so a vertex on a seam gets the same normal from both tiles.
    Vertices from ``nodes`` on, which refinement placed inside the tile, take the mesh's normal (its triangles'
    area-weighted).
    """
    z, x, y = tile
    scale = 180.0 / (2 ** z * N)
    rows, cols = (np.asarray(g[k][:nodes]).astype(np.int64) for k in ("rows", "cols"))
    everywhere = ecef(g["lon"], g["lat"], g["height"])
    here = everywhere[:nodes]

    def node(dr: int, dc: int):
        hh = heights[rows + 1 + dr, cols + 1 + dc]
        ok = np.isfinite(hh)
        p = ecef(-180.0 + (x * N + cols + dc) * scale, -90.0 + ((y + 1) * N - rows - dr) * scale, np.where(ok, hh, 0.0))
        return np.where(ok[:, None], p, here), ok

    (east, ok_e), (west, ok_w) = node(0, 1), node(0, -1)
    (north, ok_n), (south, ok_s) = node(-1, 0), node(1, 0)
    normal = np.cross(east - west, north - south)
    length = np.linalg.norm(normal, axis=1)
    up = ellipsoid_normals(here)
    flat = (length == 0) | ~(ok_e | ok_w) | ~(ok_n | ok_s)
    normal[~flat] /= length[~flat, None]
    normal[flat] = up[flat]
    if nodes == len(everywhere):
        return normal
    tri = np.asarray(g["triangles"], np.int64)
    a, b, c = everywhere[tri[:, 0]], everywhere[tri[:, 1]], everywhere[tri[:, 2]]
    face = np.cross(b - a, c - a)  # twice the area, outward for counter-clockwise (u, v)
    mesh = np.zeros_like(everywhere)
    for k in range(3):
        np.add.at(mesh, tri[:, k], face)
    mesh = mesh[nodes:] / np.linalg.norm(mesh[nodes:], axis=1)[:, None]
    return np.concatenate([normal, mesh])


def pyramid_job(source, *, max_error: float, method: str = "greedy", options: dict | None = None,
                tile_cells: int = 256, min_zoom: int = 0, max_zoom: int | None = None, normals: bool = False,
                height_offset: float = 0.0, vertical_crs: str | None = None, band: int = 1, nodata=None, water=None,
                metadata: bool | None = None, certify: bool = True, bound_at: str = "cells") -> PyramidJob:
    """Check the options and read what every tile shares (the raster's metadata and exact height range, the water).

    ``vertical_crs`` is the DEM's vertical CRS when its file lacks it, or
    ``"none"`` to take heights as given (see :func:`.heights.ellipsoid_heights`).
    ``bound_at``: where the deepest level holds ``max_error`` when its nodes
    sample the DEM's cells themselves: ``"cells"``, at every cell (the tiles
    refined there, :mod:`.refine`), or ``"nodes"``, at the nodes only.
    """
    if bound_at not in BOUND_AT:
        raise InvalidOptionError(f"bound_at must be one of {', '.join(BOUND_AT)}, got {bound_at!r}")
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
        while 180.0 / 2 ** max_zoom / tile_cells * M_PER_DEGREE > cell_m and max_zoom < 24:
            max_zoom += 1
    max_zoom = _checks.integer("max_zoom", max_zoom, minimum=min_zoom, maximum=24)
    if metadata is None:
        metadata = min_zoom == 0
    if not isinstance(metadata, bool):
        raise InvalidOptionError(f"metadata must be True, False or None (True from level 0), got {metadata!r}")
    if metadata and min_zoom > 0:
        raise InvalidOptionError(f"metadata needs min_zoom=0 (a client learns the levels below from the tiles "
                                 f"above), got min_zoom={min_zoom}; give metadata=False (--no-metadata)")
    heights = heights.over(raster, *_height_range(raster))  # the range of the converted heights
    # the ellipsoid too: the nodes beyond the DEM stand on it
    lo, hi = min(heights.low + height_offset, 0.0), max(heights.high + height_offset, 0.0)
    step = max(hi - lo, 1e-3) / QUANT
    bounds = tuple(lonlat_bounds(raster))
    water = None if water is None else water_of(water, raster, bounds, cell_m)
    return PyramidJob(raster, method, float(max_error), dict(options or {}), tile_cells, min_zoom, max_zoom,
                      bool(normals), float(height_offset), lo, step, cell_m, heights, bounds, water, metadata,
                      bool(certify), bound_at)


def job_record(job: PyramidJob, bounds) -> dict:
    return {"source": fingerprint_source(job.raster), "band": job.raster.band, "method": job.method,
            "max_error": job.max_error, "options": {k: str(v) for k, v in job.options.items()},
            "tile_cells": job.tile_cells, "max_zoom": job.max_zoom, "normals": job.normals,
            "height_offset": job.height_offset, "metadata": job.metadata, "certify": job.certify,
            "bound_at": job.bound_at,
            "water": None if job.water is None else [job.water.source, job.water.geometry.wkt[:10_000]],
            **({"heights": job.heights.operation} if job.heights.operation else {})}


def write_tiles(func, todo: list, job, out_dir: Path, tile_file, done: dict, log: TileLog, made: bool, workers,
                scheduler, progress, total: int) -> None:
    """Make the tiles ``todo`` (``func(tile, job)`` gives (bytes, stats)), each written atomically to
    ``tile_file(tile)`` and logged as it arrives, into ``done``; ``progress(done, total)`` from the tiles already
    there on; a run stopped before any tile leaves nothing."""
    count = total - len(todo)
    if progress is not None:
        progress(count, total)
    try:
        for tile, (data, stats) in execute(func, todo, job, workers, scheduler):
            target = out_dir / tile_file(tile)
            target.parent.mkdir(parents=True, exist_ok=True)
            with atomic_paths(target) as (tmp,):
                tmp.write_bytes(data)
            done[tile] = stats
            log.append("/".join(map(str, tile)), stats)
            count += 1
            if progress is not None:
                progress(count, total)
    except BaseException:
        if not done:  # stopped or failed before any tile: nothing to resume from, nothing left
            forget_pyramid(out_dir, log, made)
        raise


def open_pyramid(out_dir: Path, record: dict, tile_file: Callable[[tuple], str]) -> tuple[dict, TileLog]:
    """The finished tiles of the job ``record`` in ``out_dir`` (those logged whose file ``tile_file(tile)`` is there)
    and its tile log; a folder of another job is refused, a new one gets the record."""
    path = out_dir / ".tinsmith-job.json"
    log = TileLog(out_dir / ".tinsmith-tiles.jsonl")
    try:
        if out_dir.exists() and any(out_dir.iterdir()):
            if not path.exists() or json.loads(path.read_text()).get("job") != record:
                raise FileError(f"{str(out_dir)!r} holds files of another job; give an empty or new folder")
            done = {}
            for name, stats in log.read().items():
                tile = tuple(int(p) for p in name.split("/"))
                if (out_dir / tile_file(tile)).exists():
                    done[tile] = stats
            return done, log
        out_dir.mkdir(parents=True, exist_ok=True)
        with atomic_paths(path) as (tmp,):
            tmp.write_text(json.dumps({"job": record}))
    except OSError as exc:
        raise FileError(f"cannot write to {str(out_dir)!r}: {exc.strerror or exc}") from None
    return {}, log


def forget_pyramid(out_dir: Path, log: TileLog, made: bool) -> None:
    """Remove the job record and log of a pyramid with no tile, its empty level folders, and the folder if made."""
    (out_dir / ".tinsmith-job.json").unlink(missing_ok=True)
    log.clear()
    for folder, _, _ in sorted(os.walk(out_dir), key=lambda entry: -len(entry[0])):  # deepest first; only empty ones
        if folder != str(out_dir) or made:
            with contextlib.suppress(OSError):
                os.rmdir(folder)
