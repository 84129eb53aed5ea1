#!/usr/bin/env python3
"""Make a large, realistic synthetic airborne-LiDAR survey as a folder of tiled LAZ files.

    python benchmarks/make_large_cloud.py OUTDIR --points 100e6 --files 5x5 --seed 1
        [--source DEM.tif] [--density-pts-per-m2 4]

For scale benchmarks of the point-cloud paths (reading many files, ground filtering, TINs of
tens of millions of points) with data that behaves like a real survey delivery.

What it makes
-------------
``OUTDIR/cloud_RR_CC.laz``: a ROWS x COLS grid of square tiles (``--files ROWSxCOLS``; RR counts
from the north, CC from the west), LAS 1.4 point format 6, scale 0.001 m, x-y offsets at the
tile's south-west corner and z offset 0, exact header bounds, the CRS of the source DEM as a
WKT VLR, compressed with lazrs.  Points are in a flight-like order (north-south strips 500 m
wide, scan lines 0.5 m apart, zig-zag across) with increasing GPS time, so they compress like
real data.  Classes (ASPRS):

* 2 ground: random x-y (never two at one x-y in a file, never on a whole metre in x or y) with
  z = the fine terrain, interpolated bilinearly, plus 3 cm noise;
* 3, 4, 5 low, medium and high vegetation (height above ground < 0.5 m, 0.5-2 m, > 2 m): forest
  patches (a thresholded smooth noise field, a little more likely in valleys; ``--forest-cover``,
  35% of the land by default) hold individual trees (stand height 8-26 m, single trees up to
  30 m, ellipsoid crowns, about one tree per 25 m2) and understorey; open land has a few
  low-vegetation returns (4%);
* 9 water: up to ``--lakes`` (default 2) small lakes in closed depressions dug into flat valley
  floors, one constant level each, sparse returns (15% of the open-land density), no ground
  below.

The terrain is the source DEM (default: the 30 m SRTM of the Big Tujunga canyon, San Gabriel
Mountains, CA; the 30 m St. Helens DEM works too), cropped to the survey, upsampled with a
cubic spline to a 1 m grid (coarser only past 8192 cells a side) and given fractal (fBm,
Hurst 0.8) detail at the scales finer than a source cell, like ``make_large_dem.py``: its
standard deviation is ``--detail-std`` (0.8 m) on 30-degree slopes, 0.4 of that on flat land.

Why these numbers
-----------------
* Density: ``--density-pts-per-m2`` (default 4) is the mean over the survey, all returns, as
  in current state and national programmes (USGS 3DEP asks >= 2 pulses/m2 for QL2, >= 8 for
  QL1).  The
  extent follows from it: area = points / density, so 100 million points at 4 pts/m2 make a
  25 km2 survey, 5 x 5 tiles of 1 km (tile sides are rounded to 10 m).  Forest gets about 1.9
  times the returns per m2 of open land (multiple returns), ground under canopy 20% of the
  open-ground density (gaps under trees, as in real leaf-on surveys), so with 35% forest some
  52-55% of the points are ground; open ground is then at about 3 pts/m2, ground under canopy
  at about 0.6.
* Files: each file holds the points of its tile, so the counts follow the tile's land cover
  (3.1 to 5.0 million points a file for 100e6 in 5 x 5, 4 million on average); the split is computed from a 5 m map of
  the land cover before any point is made, so a rerun knows the expected count of every file.
* Memory: the fine terrain (5001 x 5001 float32, 95 MB for the default 100e6 survey) is the
  only large array kept; points are made, written and freed one file at a time, so the peak
  does not grow with the number of files: 1.1 GB (max RSS) for 100e6 points in 5 x 5 files,
  whose largest file has 5 million points.  The peak is printed at the end.

Measured on 2 cores: 100e6 points in 5 x 5 files take about 5 minutes and 770 MB of LAZ
(about 8 bytes a point); 52.6% of the points are ground, 0.1% water.

Deterministic: the same arguments give byte-identical files (every random generator is seeded
from ``--seed``, a purpose number and the tile's row and column; the header date is fixed).
Rerun-friendly: a file that exists with the expected point count is kept; each file is written
to ``.cloud_RR_CC.laz.partial`` in OUTDIR and then renamed.  Progress goes to stderr.

Needs numpy, scipy, rasterio, pyproj, laspy and lazrs.
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import resource
import sys
import time
from pathlib import Path

import laspy
import numpy as np
import pyproj
import rasterio
from scipy import fft, ndimage
from scipy.interpolate import RectBivariateSpline
from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SOURCE = ROOT.parent / "shared/data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"

# -- survey design (see the docstring) ---------------------------------------------------------
MAX_FINE_CELLS = 8192  # fine-terrain cells a side at most; the cell grows past it
FINE_CELLS = (1.0, 2.0, 2.5, 5.0, 10.0)  # candidate fine cells (m), first that fits
COARSE_CELLS = (5.0, 10.0, 20.0, 25.0, 50.0)  # land-cover map cells (m), at most 2000 a side
TILE_STEP = 10.0  # tile sides are multiples of this (m)
OPEN_GROUND = 0.96  # share of ground among the returns on open land (the rest: low vegetation)
UNDER_CANOPY = 0.20  # ground density under canopy relative to open ground
VEGETATION = 1.70  # vegetation returns per m2 in forest, relative to all returns on open land
WATER = 0.15  # water returns per m2, relative to all returns on open land
#: relative returns per m2 of open land, forest and water: the intensity of the point process
WEIGHTS = np.array([1.0, OPEN_GROUND * UNDER_CANOPY + VEGETATION, WATER])
GROUND_NOISE = 0.03  # m, standard deviation of ground z about the surface
TREE_AREA = 25.0  # m2 of forest per tree
STRIP = 500.0  # m, flight-strip width (north-south strips)
SCAN_LINE = 0.5  # m between scan lines along the flight
SPEED = 60.0  # m/s over ground
TURN = 120.0  # s between strips
GPS_START = 3.6e8  # adjusted standard GPS time of the first strip (s)
HEADER_DATE = datetime.date(2024, 6, 1)  # fixed, for byte-identical files
# purposes, for the seeds
DETAIL, FOREST, STAND, LAKES, TREES, POINTS = range(6)


def log(start: float, message: str) -> None:
    print(f"[{time.perf_counter() - start:8.1f} s] {message}", file=sys.stderr, flush=True)


def rng_for(seed: int, purpose: int, *more: int) -> np.random.Generator:
    return np.random.default_rng([seed, purpose, *more])


def spectral_noise(shape, rng, hurst, highpass=None, lowpass=None) -> np.ndarray:
    """Zero-mean, unit-std float32 fBm by spectral synthesis (amplitude f^-(hurst+1)).

    ``highpass`` / ``lowpass`` are Gaussian sigmas in cells: the highpass keeps only the scales
    finer than about 5 sigma (1 - the transfer of a Gaussian filter, as subtracting a
    Gaussian-smoothed copy would), the lowpass drops the scales finer than about 5 sigma.
    The field is made on a larger, FFT-friendly grid and cropped, so it does not wrap around.
    """
    ny, nx = shape
    py = fft.next_fast_len(ny + ny // 8 + 8, real=True)
    px = fft.next_fast_len(nx + nx // 8 + 8, real=True)
    fy = np.fft.fftfreq(py).astype(np.float32)[:, None]
    fx = np.fft.rfftfreq(px).astype(np.float32)[None, :]
    f2 = fy * fy + fx * fx
    f2[0, 0] = 1.0
    amp = f2 ** np.float32(-(hurst + 1.0) / 2.0)
    k = np.float32(2.0 * math.pi**2)
    if highpass:
        amp *= -np.expm1(-k * np.float32(highpass) ** 2 * f2)
    if lowpass:
        amp *= np.exp(-k * np.float32(lowpass) ** 2 * f2)
    amp[0, 0] = 0.0
    del f2
    phase = rng.random(amp.shape, dtype=np.float32) * np.float32(2.0 * math.pi)
    spec = np.empty(amp.shape, dtype=np.complex64)
    spec.real = amp * np.cos(phase)
    spec.imag = amp * np.sin(phase)
    del amp, phase
    z = fft.irfft2(spec, s=(py, px), workers=1)
    del spec
    z = np.ascontiguousarray(z[:ny, :nx])
    z -= np.float32(z.mean(dtype=np.float64))
    z /= np.float32(z.std(dtype=np.float64))
    return z


def bilinear(grid: np.ndarray, x0: float, y0: float, cell: float, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear interpolation in a south-up node grid (node [i, j] at x0 + j cell, y0 + i cell)."""
    fx = (x - x0) / cell
    fy = (y - y0) / cell
    ix = np.clip(fx.astype(np.int64), 0, grid.shape[1] - 2)
    iy = np.clip(fy.astype(np.int64), 0, grid.shape[0] - 2)
    tx = fx - ix
    ty = fy - iy
    south = grid[iy, ix] * (1.0 - tx) + grid[iy, ix + 1] * tx
    north = grid[iy + 1, ix] * (1.0 - tx) + grid[iy + 1, ix + 1] * tx
    return south * (1.0 - ty) + north * ty


def nearest(grid: np.ndarray, x0: float, y0: float, cell: float, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    ix = np.clip(np.rint((x - x0) / cell).astype(np.int64), 0, grid.shape[1] - 1)
    iy = np.clip(np.rint((y - y0) / cell).astype(np.int64), 0, grid.shape[0] - 1)
    return grid[iy, ix]


# -- the source DEM and the survey extent ------------------------------------------------------
class Source:
    """The DEM, nodata filled from the nearest valid cell, with its valid inner window."""

    def __init__(self, path: Path):
        with rasterio.open(path) as src:
            z = src.read(1, masked=True).astype(np.float64)
            self.crs = pyproj.CRS.from_wkt(src.crs.to_wkt())
            t = src.transform
        if abs(t.b) > 0 or abs(t.d) > 0 or not math.isclose(abs(t.a), abs(t.e)):
            raise SystemExit(f"{path}: needs a north-up DEM with square cells")
        missing = np.ma.getmaskarray(z)
        z = z.filled(np.nan)
        # the inner window without nodata (USGS DEMs have ragged nodata edges), at least 4 cells in
        k = 4
        while missing[k:-k or None, k:-k or None].any():
            k += 1
            if 2 * k >= min(z.shape) // 2:
                raise SystemExit(f"{path}: too much nodata for a survey")
        if missing.any():
            idx = ndimage.distance_transform_edt(missing, return_distances=False, return_indices=True)
            z = z[tuple(idx)]
        self.cell = abs(t.a)
        # south-up: row 0 is the southernmost
        self.z = z[::-1].copy()
        ny, nx = z.shape
        self.xs = t.c + (np.arange(nx) + 0.5) * t.a
        self.ys = (t.f + (np.arange(ny) + 0.5) * t.e)[::-1].copy()
        self.inner = (self.xs[k], self.ys[k], self.xs[-1 - k], self.ys[-1 - k])  # xmin, ymin, xmax, ymax

    def window(self, x0, y0, x1, y1, margin=4):
        """The source rows/cols covering [x0, x1] x [y0, y1] with ``margin`` cells more."""
        j0 = max(int(np.searchsorted(self.xs, x0)) - margin, 0)
        j1 = min(int(np.searchsorted(self.xs, x1)) + margin, self.xs.size)
        i0 = max(int(np.searchsorted(self.ys, y0)) - margin, 0)
        i1 = min(int(np.searchsorted(self.ys, y1)) + margin, self.ys.size)
        return slice(i0, i1), slice(j0, j1)


def place(lo: float, hi: float, size: float, step: float) -> float:
    """A start in [lo, hi - size], a multiple of ``step`` (or of 10 m, 1 m), near the middle."""
    middle = (lo + hi - size) / 2
    for s in (step, TILE_STEP, 1.0):
        for start in (round(middle / s) * s, math.ceil(lo / s) * s):
            if lo <= start and start + size <= hi:
                return float(start)
    raise SystemExit("the survey does not fit in the DEM")


class Survey:
    def __init__(self, args, source: Source, start: float):
        self.seed = args.seed
        self.rows, self.cols = args.files
        self.points = args.points
        ntiles = self.rows * self.cols
        xmin, ymin, xmax, ymax = source.inner
        tile = max(round(math.sqrt(args.points / args.density / ntiles) / TILE_STEP) * TILE_STEP, TILE_STEP)
        fit = math.floor(min((xmax - xmin) / self.cols, (ymax - ymin) / self.rows) / TILE_STEP) * TILE_STEP
        if tile > fit:
            log(start, f"warning: the survey at {args.density} pts/m2 does not fit in the DEM; tiles of {fit:g} m "
                       f"give {args.points / (fit * fit * ntiles):.1f} pts/m2")
            tile = fit
        self.tile = tile
        self.width, self.height = tile * self.cols, tile * self.rows
        self.x0 = place(xmin, xmax, self.width, tile)
        self.y0 = place(ymin, ymax, self.height, tile)
        self.density = args.points / (self.width * self.height)
        self.crs = source.crs
        self.source = source
        self.detail_std = args.detail_std
        self.fine_cell = next((c for c in FINE_CELLS if max(self.width, self.height) / c <= MAX_FINE_CELLS),
                              max(self.width, self.height) / MAX_FINE_CELLS)
        self.fine = None  # built on demand: only when a file has to be written
        win = source.window(self.x0, self.y0, self.x0 + self.width, self.y0 + self.height)
        self.spline = RectBivariateSpline(source.ys[win[0]], source.xs[win[1]], source.z[win], kx=3, ky=3)
        gy, gx = np.gradient(source.z[win], source.cell)
        slope = np.degrees(np.arctan(np.hypot(gx, gy)))
        # detail amplitude factor: 0.4 on flat land, 1 at 30 degrees, at most 1.6
        self.roughness = RectBivariateSpline(source.ys[win[0]], source.xs[win[1]],
                                             0.4 + 0.6 * np.clip(slope / 30.0, 0.0, 2.0), kx=1, ky=1)
        self._land_cover(args, start)

    # -- land cover on a coarse grid: terrain, lakes, forest, stand height ----------------------
    def _land_cover(self, args, start):
        cc = next((c for c in COARSE_CELLS if max(self.width, self.height) / c <= 2000), COARSE_CELLS[-1])
        self.cc = cc
        nx, ny = round(self.width / cc) + 1, round(self.height / cc) + 1
        xs, ys = self.x0 + np.arange(nx) * cc, self.y0 + np.arange(ny) * cc
        terrain = self.spline(ys, xs)
        self.lakes = []  # (x, y, depth, a, b, cos, sin, level)
        self.lake_id = np.zeros((ny, nx), dtype=np.int8)
        self._dig_lakes(terrain, xs, ys, args.lakes, rng_for(self.seed, LAKES))
        self.levels = np.array([np.nan] + [lake[-1] for lake in self.lakes])
        water = self.lake_id > 0
        water &= terrain < np.nan_to_num(self.levels[self.lake_id], nan=-np.inf)
        # forest: band-limited noise (patches of a few hundred metres), a little more in valleys
        noise = spectral_noise((ny, nx), rng_for(self.seed, FOREST), 1.0, highpass=0.19 * 2000 / cc,
                               lowpass=0.19 * 60 / cc).astype(np.float64)
        relief = terrain - ndimage.gaussian_filter(terrain, 400 / cc, mode="nearest")
        noise -= 0.4 * relief / max(relief.std(), 1e-9)
        self.forest_field = noise.astype(np.float32)
        self.forest_threshold = float(np.quantile(noise[~water], 1.0 - args.forest_cover))
        stand = spectral_noise((ny, nx), rng_for(self.seed, STAND), 1.0, highpass=0.19 * 3000 / cc,
                               lowpass=0.19 * 100 / cc)
        self.stand = np.clip(18.0 + 4.0 * stand, 8.0, 26.0).astype(np.float32)
        # expected returns per tile, from the land cover at the coarse cell centres
        kind = np.where(noise > self.forest_threshold, 1, 0)
        kind[water] = 2
        w = WEIGHTS[kind]
        w = (w[:-1, :-1] + w[1:, :-1] + w[:-1, 1:] + w[1:, 1:]) / 4
        cx, cy = xs[:-1] + cc / 2, ys[:-1] + cc / 2
        col = np.minimum(((cx - self.x0) // self.tile).astype(int), self.cols - 1)
        row_from_south = np.minimum(((cy - self.y0) // self.tile).astype(int), self.rows - 1)
        row = self.rows - 1 - row_from_south
        weight = np.zeros((self.rows, self.cols))
        np.add.at(weight, (row[:, None], col[None, :]), w)
        cells = np.zeros((self.rows, self.cols))
        np.add.at(cells, (row[:, None], col[None, :]), 1.0)
        self.accept = weight / cells / WEIGHTS.max()  # expected acceptance of a uniform candidate
        share = self.points * weight.ravel() / weight.sum()
        counts = np.floor(share).astype(np.int64)
        rest = self.points - counts.sum()
        order = np.argsort(-(share - counts), kind="stable")
        counts[order[:rest]] += 1
        self.counts = counts.reshape(self.rows, self.cols)
        self.cover = {"forest": float((kind == 1).mean()), "water": float((kind == 2).mean())}
        log(start, f"land cover: forest {self.cover['forest']:.1%}, water {self.cover['water']:.2%}, "
                   f"{len(self.lakes)} lake(s), map cell {cc:g} m")

    def _dig_lakes(self, terrain, xs, ys, nlakes, rng):
        """Dig up to ``nlakes`` Gaussian bowls into flat valley floors; flood each to below its spill level."""
        cc = self.cc
        side = min(self.width, self.height)
        if nlakes <= 0 or side < 500:
            return
        smooth = ndimage.gaussian_filter(terrain, 100 / cc, mode="nearest")
        gy, gx = np.gradient(smooth, cc)
        slope = np.hypot(gx, gy)
        relief = terrain - ndimage.gaussian_filter(terrain, 400 / cc, mode="nearest")
        border = max(400.0, 0.1 * side)
        X, Y = np.meshgrid(xs, ys)
        inner = ((X - self.x0 > border) & (self.x0 + self.width - X > border)
                 & (Y - self.y0 > border) & (self.y0 + self.height - Y > border))
        ok = inner & (relief < 0)
        if not ok.any():
            return
        flat = ok & (slope <= np.quantile(slope[ok], 0.02))
        candidates = np.flatnonzero(flat)
        candidates = candidates[rng.permutation(candidates.size)]
        apart = max(1000.0, 0.3 * side)
        for c in candidates[:50]:
            if len(self.lakes) >= nlakes:
                break
            cy, cx = np.unravel_index(c, terrain.shape)
            x, y = xs[cx], ys[cy]
            if any(math.hypot(x - lake[0], y - lake[1]) < apart for lake in self.lakes):
                continue
            radius = float(np.clip(0.04 * side, 40.0, 200.0) * rng.uniform(0.8, 1.2))
            stretch, angle = rng.uniform(1.0, 1.6), rng.uniform(0.0, math.pi)
            depth = 6.0 + 2.0 * float(slope[cy, cx]) * radius
            lake = (x, y, depth, radius * stretch, radius / stretch, math.cos(angle), math.sin(angle))
            dug = terrain - self._bowl(lake, X, Y)
            level, region = self._flood(dug, X, Y, x, y, 3 * radius)
            if region is None or region.sum() * cc * cc < 0.25 * math.pi * radius**2:
                continue
            terrain[...] = dug
            self.lakes.append(lake + (level,))
            self.lake_id[ndimage.binary_dilation(region, iterations=2)] = len(self.lakes)

    @staticmethod
    def _bowl(lake, x, y):
        x0, y0, depth, a, b, cos, sin = lake[:7]
        u = ((x - x0) * cos + (y - y0) * sin) / a
        v = (-(x - x0) * sin + (y - y0) * cos) / b
        return depth * np.exp(-0.5 * (u * u + v * v))

    def _flood(self, dug, X, Y, x, y, reach):
        """The highest level (minus 0.25 m) whose flooded region around (x, y) stays closed, and the region."""
        cx, cy = np.searchsorted(X[0], x), np.searchsorted(Y[:, 0], y)
        k = int(reach / self.cc) + 2
        win = (slice(max(cy - k, 0), cy + k + 1), slice(max(cx - k, 0), cx + k + 1))
        local, near = dug[win], np.hypot(X[win] - x, Y[win] - y)
        seed = np.unravel_index(np.argmin(np.where(near < reach / 3, local, np.inf)), local.shape)
        lo, hi = local[seed], local[seed] + 100.0

        def region(h):
            labels, _ = ndimage.label(local < h)
            r = labels == labels[seed]
            return None if near[r].max() > reach else r

        for _ in range(40):
            mid = (lo + hi) / 2
            if region(mid) is None:
                hi = mid
            else:
                lo = mid
        level = lo - 0.25
        found = region(level) if level > local[seed] else None
        if found is None:
            return level, None
        full = np.zeros(dug.shape, bool)
        full[win] = found
        return level, full

    # -- fine terrain --------------------------------------------------------------------------
    def fine_terrain(self, start):
        if self.fine is None:
            c = self.fine_cell
            nx, ny = round(self.width / c) + 1, round(self.height / c) + 1
            xs, ys = self.x0 + np.arange(nx) * c, self.y0 + np.arange(ny) * c
            # detail at scales finer than a source cell: fBm minus its Gaussian smoothing (sigma half a cell)
            fine = spectral_noise((ny, nx), rng_for(self.seed, DETAIL), 0.8, highpass=self.source.cell / c / 2)
            for i in range(0, ny, 256):
                b = slice(i, min(i + 256, ny))
                amp = self.detail_std * self.roughness(ys[b], xs)
                fine[b] = self.spline(ys[b], xs) + fine[b] * amp
            for lake in self.lakes:
                r = 4 * max(lake[3], lake[4])
                jb = slice(*np.searchsorted(xs, [lake[0] - r, lake[0] + r]))
                ib = slice(*np.searchsorted(ys, [lake[1] - r, lake[1] + r]))
                X, Y = np.meshgrid(xs[jb], ys[ib])
                fine[ib, jb] -= self._bowl(lake, X, Y).astype(np.float32)
            self.fine = fine
            log(start, f"fine terrain: {ny} x {nx} nodes, cell {c:g} m, {fine.nbytes / 2**20:.0f} MB")
        return self.fine

    def ground(self, x, y):
        return bilinear(self.fine, self.x0, self.y0, self.fine_cell, x, y)

    def forest(self, x, y):
        return bilinear(self.forest_field, self.x0, self.y0, self.cc, x, y) > self.forest_threshold

    def lake_level(self, x, y):
        """The water level at each point (NaN outside the lakes' neighbourhoods)."""
        return self.levels[nearest(self.lake_id, self.x0, self.y0, self.cc, x, y)]

    def tile_bounds(self, row, col):
        """West, south, east, north of a tile (row 0 is the northernmost)."""
        x0 = self.x0 + col * self.tile
        y0 = self.y0 + (self.rows - 1 - row) * self.tile
        return x0, y0, x0 + self.tile, y0 + self.tile

    # -- trees ---------------------------------------------------------------------------------
    def tile_trees(self, row, col):
        """The trees rooted in a tile: x, y, height, crown radius, crown base."""
        rng = rng_for(self.seed, TREES, row, col)
        w, s, _, _ = self.tile_bounds(row, col)
        count = rng.poisson(self.tile * self.tile / TREE_AREA)
        x = w + rng.random(count) * self.tile
        y = s + rng.random(count) * self.tile
        h = rng.lognormal(0.0, 0.12, count)
        radius = rng.uniform(0.8, 1.2, count)
        base = rng.uniform(0.3, 0.5, count)
        keep = self.forest(x, y) & np.isnan(self.lake_level(x, y))
        x, y = x[keep], y[keep]
        h = np.clip(bilinear(self.stand, self.x0, self.y0, self.cc, x, y) * h[keep], 3.0, 30.0)
        radius = (0.8 + 0.11 * h) * radius[keep]
        return x, y, h, radius, h * base[keep]

    def trees_near(self, row, col, margin=10.0):
        w, s, e, n = self.tile_bounds(row, col)
        parts = []
        for r in range(max(row - 1, 0), min(row + 2, self.rows)):
            for c in range(max(col - 1, 0), min(col + 2, self.cols)):
                t = self.tile_trees(r, c)
                keep = (t[0] > w - margin) & (t[0] < e + margin) & (t[1] > s - margin) & (t[1] < n + margin)
                parts.append([a[keep] for a in t])
        return [np.concatenate(a) for a in zip(*parts, strict=True)]


# -- the points of one tile --------------------------------------------------------------------
def tile_points(survey: Survey, row: int, col: int):
    """x, y (integer mm), z (m), class, return number, number of returns of one tile, unordered."""
    n = int(survey.counts[row, col])
    rng = rng_for(survey.seed, POINTS, row, col)
    w, s, e, nb = (round(v * 1000) for v in survey.tile_bounds(row, col))
    span = nb - s + 1
    accept = max(float(survey.accept[row, col]), 0.05)
    X = np.empty(0, np.int64)
    Y = np.empty(0, np.int64)
    kind = np.empty(0, np.int8)
    zg = np.empty(0, np.float64)
    while X.size < n:
        m = min(int((n - X.size) / accept * 1.02) + 1000, 2_000_000)
        cx = rng.integers(w + 1, e, m)  # strictly inside the tile
        cy = rng.integers(s + 1, nb, m)
        keep = (cx % 1000 != 0) & (cy % 1000 != 0)  # never on a whole metre
        cx, cy = cx[keep], cy[keep]
        x, y = cx / 1000.0, cy / 1000.0
        z = survey.ground(x, y)
        level = survey.lake_level(x, y)
        k = np.where(survey.forest(x, y), 1, 0).astype(np.int8)
        k[z < np.nan_to_num(level, nan=-np.inf)] = 2
        keep = rng.random(k.size) * WEIGHTS.max() < WEIGHTS[k]  # thinning to the relative densities
        X, Y = np.concatenate((X, cx[keep])), np.concatenate((Y, cy[keep]))
        kind, zg = np.concatenate((kind, k[keep])), np.concatenate((zg, z[keep]))
        _, first = np.unique((X - w) * span + (Y - s), return_index=True)  # one point a x-y
        if first.size < X.size:
            first.sort()
            X, Y, kind, zg = X[first], Y[first], kind[first], zg[first]
    X, Y, kind, zg = X[:n], Y[:n], kind[:n], zg[:n]
    x, y = X / 1000.0, Y / 1000.0

    cls = np.full(n, 2, np.uint8)
    hag = np.zeros(n)  # height above ground of vegetation returns
    nret = np.ones(n, np.uint8)
    ret = np.ones(n, np.uint8)
    u = rng.random(n)
    # open land: a few low-vegetation returns
    low = (kind == 0) & (u >= OPEN_GROUND)
    hag[low] = np.minimum(0.05 + rng.exponential(0.35, low.sum()), 1.9)
    # forest: ground (the last return of a pulse) or vegetation from the trees
    forest = kind == 1
    ground_share = OPEN_GROUND * UNDER_CANOPY / WEIGHTS[1]
    fg = forest & (u < ground_share)
    nret[fg] = rng.integers(2, 5, fg.sum())
    ret[fg] = nret[fg]
    veg = np.flatnonzero(forest & (u >= ground_share))
    tx, ty, th, trad, tbase = survey.trees_near(row, col)
    hag[veg] = understorey(rng, veg.size)
    if tx.size:
        d, t = cKDTree(np.column_stack((tx, ty))).query(np.column_stack((x[veg], y[veg])), workers=1)
        inside = d < trad[t]
        vi, ti, di = veg[inside], t[inside], d[inside]
        top = tbase[ti] + (th[ti] - tbase[ti]) * np.sqrt(1.0 - (di / trad[ti]) ** 2)
        v = rng.random(vi.size)
        crown = v < 0.70  # the outer crown, a little below its surface
        depth = rng.exponential(0.08, vi.size) * (th[ti] - tbase[ti])
        inner = (v >= 0.70) & (v < 0.85)  # branches and stem below the crown surface
        h = np.where(crown, np.maximum(top - depth, 0.8 * tbase[ti]), hag[vi])
        h = np.where(inner, rng.uniform(0.5, 1.0, vi.size) * np.maximum(tbase[ti], top - depth), h)
        hag[vi] = h
    nret[veg] = rng.integers(2, 5, veg.size)
    ret[veg] = np.where(hag[veg] > 5.0, 1, np.minimum(rng.integers(2, 4, veg.size), nret[veg]))
    vegetation = low.copy()
    vegetation[veg] = True
    cls[vegetation] = np.where(hag[vegetation] < 0.5, 3, np.where(hag[vegetation] < 2.0, 4, 5))
    nret[low] = 2
    water = kind == 2
    cls[water] = 9
    z = zg + hag
    ground = cls == 2
    z[ground] += rng.normal(0.0, GROUND_NOISE, ground.sum())
    z[water] = survey.lake_level(x[water], y[water])
    return X, Y, z, cls, ret, nret, rng


def understorey(rng, n):
    """Heights of returns from the understorey: mostly below 1 m, shrubs to 4 m."""
    h = 0.05 + rng.exponential(0.5, n)
    shrubs = rng.random(n) < 0.3
    h[shrubs] = rng.uniform(0.5, 3.0, shrubs.sum())
    return np.minimum(h, 4.0)


def flight_order(survey: Survey, x: np.ndarray, y: np.ndarray):
    """Order and GPS time of points flown in north-south strips with a zig-zag scanner."""
    strip = np.floor((x - survey.x0) / STRIP).astype(np.int64)
    along = y - survey.y0
    north = strip % 2 == 0  # even strips fly north, odd ones south
    along = np.where(north, along, survey.height - along)
    line = np.floor(along / SCAN_LINE).astype(np.int64)
    across = (x - survey.x0) - strip * STRIP
    across = np.where(line % 2 == 0, across, STRIP - across)
    order = np.lexsort((across, line, strip))
    strip_time = survey.height / SPEED + TURN
    t = GPS_START + strip * strip_time + (line + across / STRIP) * (SCAN_LINE / SPEED)
    centre = (x - survey.x0) - (strip + 0.5) * STRIP
    angle = np.degrees(np.arctan2(centre, 1000.0))  # 1000 m above ground
    return order, t, angle, strip, line


def write_tile(survey: Survey, row: int, col: int, path: Path) -> np.ndarray:
    """Write one tile atomically; the counts per class."""
    X, Y, z, cls, ret, nret, rng = tile_points(survey, row, col)
    order, t, angle, strip, line = flight_order(survey, X / 1000.0, Y / 1000.0)
    n = X.size
    w, s, _, _ = survey.tile_bounds(row, col)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = np.array([w, s, 0.0])
    header.system_identifier = "tinsmith synthetic ALS"
    header.generating_software = "make_large_cloud.py"
    header.creation_date = HEADER_DATE
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    header.add_crs(survey.crs)
    las = laspy.LasData(header)
    las.points = laspy.ScaleAwarePointRecord.zeros(n, header=header)
    las.X = (X[order] - round(w * 1000)).astype(np.int32)
    las.Y = (Y[order] - round(s * 1000)).astype(np.int32)
    las.Z = np.rint(z[order] * 1000.0).astype(np.int32)
    las.classification = cls[order]
    las.return_number = ret[order]
    las.number_of_returns = nret[order]
    las.gps_time = t[order]
    las.scan_angle = np.rint(angle[order] / 0.006).astype(np.int16)
    las.scan_direction_flag = (line[order] % 2).astype(np.uint8)
    las.point_source_id = (strip[order] + 1).astype(np.uint16)
    base = np.select([cls == 2, cls == 9, cls == 5], [24000.0, 3000.0, 12000.0], 16000.0)
    spread = np.where(cls == 9, 800.0, 3000.0)
    intensity = base - 1500.0 * (ret - 1) + spread * rng.standard_normal(n)
    las.intensity = np.clip(np.rint(intensity), 0, 65535).astype(np.uint16)[order]
    las.update_header()
    tmp = path.parent / f".{path.name}.partial"
    try:
        with open(tmp, "wb") as out:
            las.write(out, do_compress=True, laz_backend=laspy.LazBackend.LazrsParallel)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return np.bincount(cls, minlength=10)


def point_count(path: Path) -> int | None:
    try:
        with laspy.open(path) as f:
            return f.header.point_count
    except Exception:  # a damaged file is made again
        return None


# -- command line ------------------------------------------------------------------------------
def files_arg(text: str) -> tuple[int, int]:
    try:
        rows, cols = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected ROWSxCOLS such as 5x5, got {text!r}") from None
    if rows < 1 or cols < 1:
        raise argparse.ArgumentTypeError("ROWS and COLS must be at least 1")
    return rows, cols


def count_arg(text: str) -> int:
    value = float(text)
    if not value >= 1 or value != math.floor(value):
        raise argparse.ArgumentTypeError(f"expected a whole number of points such as 100e6, got {text!r}")
    return int(value)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("outdir", type=Path)
    ap.add_argument("--points", type=count_arg, default=100_000_000, help="total points (default 100e6)")
    ap.add_argument("--files", type=files_arg, default=(5, 5), help="ROWSxCOLS grid of tiles (default 5x5)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--source", type=Path, default=DEFAULT_SOURCE, help=f"DEM (default {DEFAULT_SOURCE})")
    ap.add_argument("--density-pts-per-m2", dest="density", type=float, default=4.0,
                    help="mean density of all returns; sets the extent (default 4)")
    ap.add_argument("--forest-cover", type=float, default=0.35, help="share of the land in forest (default 0.35)")
    ap.add_argument("--lakes", type=int, default=2, help="lakes at most (default 2)")
    ap.add_argument("--detail-std", type=float, default=0.8,
                    help="std (m) of the sub-cell fBm detail on 30-degree slopes (default 0.8)")
    args = ap.parse_args(argv)
    if not 0.0 < args.forest_cover < 1.0 or args.density <= 0:
        ap.error("--forest-cover must be in (0, 1) and the density positive")

    start = time.perf_counter()
    source = Source(args.source)
    survey = Survey(args, source, start)
    log(start, f"survey: {survey.width:g} x {survey.height:g} m from ({survey.x0:.0f}, {survey.y0:.0f}), "
               f"{survey.rows} x {survey.cols} tiles of {survey.tile:g} m, {args.points:,} points, "
               f"{survey.density:.2f} pts/m2, CRS {survey.crs.name}")
    args.outdir.mkdir(parents=True, exist_ok=True)
    classes = np.zeros(10, np.int64)
    written = kept = 0
    for row in range(survey.rows):
        for col in range(survey.cols):
            path = args.outdir / f"cloud_{row:02d}_{col:02d}.laz"
            n = int(survey.counts[row, col])
            if path.exists() and point_count(path) == n:
                kept += 1
                log(start, f"{path.name}: kept ({n:,} points)")
                continue
            survey.fine_terrain(start)
            t0 = time.perf_counter()
            classes += write_tile(survey, row, col, path)
            written += 1
            log(start, f"{path.name}: wrote {n:,} points in {time.perf_counter() - t0:.1f} s")

    total = int(survey.counts.sum())
    size = sum(p.stat().st_size for p in args.outdir.glob("cloud_*_*.laz"))
    print(f"{args.outdir}: {survey.rows * survey.cols} files ({written} written, {kept} kept), "
          f"{total:,} points, {size / 2**20:,.1f} MB")
    print(f"extent: x {survey.x0:.0f} .. {survey.x0 + survey.width:.0f}, y {survey.y0:.0f} .. "
          f"{survey.y0 + survey.height:.0f} ({survey.width * survey.height / 1e6:g} km2), "
          f"mean density {survey.density:.2f} pts/m2, CRS {survey.crs.name}")
    if written:
        made = classes.sum()
        shares = ", ".join(f"{c}: {classes[c] / made:.2%}" for c in np.flatnonzero(classes))
        print(f"classes of the written points: {shares}")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    print(f"time {time.perf_counter() - start:.1f} s, peak memory (max RSS) {peak / 2**20:,.0f} MB")


if __name__ == "__main__":
    main()
