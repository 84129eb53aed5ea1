"""A terrain tile's error certificate: its largest vertical error against the DEM at every cell it covers.

A tile is meshed from heights sampled at its nodes (block means of the DEM at
the coarse levels, bilinear between cell centres at the finest), so the
error its mesher reports is against those samples.  What a user can rely on
is the error against the DEM itself; this measures it.  Every valid cell
whose centre lies in the tile (longitude and latitude within its bounds, its
edges included) is placed in the tile's mesh as CesiumJS interpolates it
(barycentric in u, v, that is in longitude and latitude, over the decoded
heights: :func:`tinsmith.io.quantized_mesh.height_at`), and the largest
``|mesh - (DEM + offset)|`` is the certificate (the DEM's heights converted
to the ellipsoid first, as the tiles' are, when the pyramid converts them).

Cell centres are carried to longitude and latitude by pyproj on a lattice of
every :data:`LATTICE` cells and bilinearly between (the map from a projected
CRS to degrees bends by about ``d**2 / (8 R)`` over ``d``: 5 mm for 16 cells
of 30 m), so that the check costs about what reading the cells does.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.heightfield import pixel_to_world, world_to_pixel
from ..io.raster import read_window
from ..kernels import certificate, locate
from .lonlat import from_lonlat, to_lonlat

__all__ = ["LATTICE", "tile_cells", "tile_certificate"]

#: Cells between the points pyproj transforms exactly (bilinear between them).
LATTICE = 16
#: Cells read at once.
_READ_CELLS = 2_000_000


def _window(job, bounds) -> tuple[int, int, int, int] | None:
    """The rows and columns (inclusive) of the DEM whose cells may lie in the tile, or None.

    The tile's outline (21 points a side, the poles kept off) is carried to
    the DEM's CRS; a point that does not transform there is left out.
    """
    w, s, e, n = bounds
    s, n = max(s, -89.999999), min(n, 89.999999)
    t = np.linspace(0.0, 1.0, 21)
    lon = np.concatenate([w + (e - w) * t, np.full(21, e), e - (e - w) * t, np.full(21, w)])
    lat = np.concatenate([np.full(21, s), s + (n - s) * t, np.full(21, n), n - (n - s) * t])
    with np.errstate(invalid="ignore", over="ignore"):
        x, y = from_lonlat(job.raster.crs).transform(lon, lat, errcheck=False)
    ok = np.isfinite(x) & np.isfinite(y)
    if not ok.any():
        return None
    rows, cols = world_to_pixel(job.raster.transform, np.asarray(x)[ok], np.asarray(y)[ok])
    H, W = job.raster.shape
    r0, r1 = max(0, int(math.floor(rows.min())) - 1), min(H - 1, int(math.ceil(rows.max())) + 1)
    c0, c1 = max(0, int(math.floor(cols.min())) - 1), min(W - 1, int(math.ceil(cols.max())) + 1)
    if r0 > r1 or c0 > c1:
        return None
    return r0, r1, c0, c1


def _interval(lattice: np.ndarray, at: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The lattice interval of each of ``at`` and the weight of its far end; the step to that end (0 on one line)."""
    if len(lattice) == 1:
        return np.zeros(len(at), np.int64), np.zeros(len(at)), 0
    i = np.clip(np.searchsorted(lattice, at, side="right") - 1, 0, len(lattice) - 2)
    return i.astype(np.int64), (at - lattice[i]) / (lattice[i + 1] - lattice[i]), 1


def _lattice(job, r0: int, r1: int, c0: int, c1: int):
    """The lattice over cells rows r0..r1 x cols c0..c1 (see the module notes): longitude and latitude at its
    points, and each row's and column's interval and weight in it (:func:`_interval`)."""
    lr = np.unique(np.r_[np.arange(r0, r1 + 1, LATTICE), r1]).astype(np.float64)
    lc = np.unique(np.r_[np.arange(c0, c1 + 1, LATTICE), c1]).astype(np.float64)
    C, R = np.meshgrid(lc, lr)
    x, y = pixel_to_world(job.raster.transform, R, C)
    lon, lat = to_lonlat(job.raster.crs).transform(x, y)
    rows = _interval(lr, np.arange(r0, r1 + 1, dtype=np.float64))
    cols = _interval(lc, np.arange(c0, c1 + 1, dtype=np.float64))
    return np.asarray(lon, np.float64), np.asarray(lat, np.float64), rows, cols


def tile_certificate(job, bounds, geometry: dict, decoded_heights: np.ndarray) -> dict:
    """``{"max_error", "cells", "uncovered"}`` of a tile against the DEM (see the module notes).

    ``bounds`` is the tile's (west, south, east, north) in degrees, ``geometry``
    :func:`tinsmith.tiles.pyramid.tile_geometry`'s output and
    ``decoded_heights`` the heights a client decodes at its vertices.
    ``cells`` counts the valid cells checked; ``uncovered`` those in the
    tile's bounds that no triangle holds (beside nodata, where a coarse
    level's nodes are missing, or where a triangle reaches a node filled
    for lack of data: ``geometry["filled"]``).
    """
    west, south, east, north = bounds
    if not geometry["data"]:
        return {"max_error": 0.0, "cells": 0, "uncovered": 0}
    window = _window(job, bounds)
    if window is None:
        return {"max_error": 0.0, "cells": 0, "uncovered": 0}
    r0, r1, c0, c1 = window
    N = job.tile_cells
    scale = (east - west) / N
    uv = np.column_stack([geometry["cols"], geometry["rows"]]).astype(np.float64)  # node units, rows from the north
    tri = np.asarray(geometry["triangles"], dtype=np.int64)
    filled = geometry.get("filled")
    if filled is not None and filled.any():  # a triangle reaching a node without data is no surface of the DEM
        tri = tri[~filled[tri].any(axis=1)]
    tri = np.ascontiguousarray(tri)
    if len(tri):
        grid = locate.grid_for(uv, len(tri))
        start, items = locate.build(uv, tri, *grid)
    else:  # every triangle reaches beyond the DEM: the tile's cells are all uncovered
        grid, start, items = (0.0, 0.0, 1.0, 0, 0), np.zeros(1, np.int64), np.zeros(0, np.int64)
    heights = np.ascontiguousarray(decoded_heights, dtype=np.float64)
    worst, cells, uncovered = 0.0, 0, 0
    step = max(1, _READ_CELLS // (c1 - c0 + 1))
    for a in range(r0, r1 + 1, step):
        b = min(r1, a + step - 1)
        zz, valid = read_window(job.raster, (a, b), (c0, c1))
        if not valid.any():
            continue
        if job.heights.operation is not None:  # the DEM's heights to the ellipsoid, as the tiles' were
            rr, cc = np.nonzero(valid)
            x, y = pixel_to_world(job.raster.transform, rr + a, cc + c0)
            zz[valid] = job.heights.to_ellipsoid(x, y, zz[valid])
        lon, lat, (ri, rt, dr), (cj, cu, dc) = _lattice(job, a, b, c0, c1)
        err, hit, miss = certificate.cell_errors(zz, float(job.height_offset), lon, lat, ri, rt, dr, cj, cu, dc,
                                                 west, south, east, north, scale, uv, tri, heights, start, items,
                                                 *grid, 1e-9)
        worst, cells, uncovered = max(worst, err), cells + hit, uncovered + miss
    return {"max_error": worst, "cells": cells, "uncovered": uncovered}


def tile_cells(job, bounds) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(longitude, latitude, height) of every valid DEM cell whose centre lies in the tile ``bounds`` (edges
    included), placed as :func:`tile_certificate` places them and with the heights it compares against (on the
    ellipsoid when the pyramid converts, ``height_offset`` added).  Reads the tile's window whole: for tiles whose
    nodes sample the cells themselves (a few hundred thousand cells)."""
    west, south, east, north = bounds
    window = _window(job, bounds)
    if window is None:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    r0, r1, c0, c1 = window
    zz, valid = read_window(job.raster, (r0, r1), (c0, c1))
    rr, cc = np.nonzero(valid)
    h = zz[valid].astype(np.float64)
    if job.heights.operation is not None:
        x, y = pixel_to_world(job.raster.transform, rr + r0, cc + c0)
        h = job.heights.to_ellipsoid(x, y, h)
    lon, lat, (ri, rt, dr), (cj, cu, dc) = _lattice(job, r0, r1, c0, c1)
    i, t, j, u = ri[rr], rt[rr], cj[cc], cu[cc]
    out = []
    for grid in (lon, lat):  # the kernel's order: each lattice row at the column, then between the rows
        a = grid[i, j] * (1 - u) + grid[i, j + dc] * u
        b = grid[i + dr, j] * (1 - u) + grid[i + dr, j + dc] * u
        out.append(a * (1 - t) + b * t)
    inside = (out[0] >= west) & (out[0] <= east) & (out[1] >= south) & (out[1] <= north)
    return out[0][inside], out[1][inside], h[inside] + float(job.height_offset)
