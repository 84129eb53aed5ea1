"""Quantized-mesh pyramids for CesiumJS: tinsmith against the pipeline users build today, in one run.

    pip install -e ".[test]" pydelatin quantized-mesh-encoder rio-tiler morecantile
    python benchmarks/tiles_web.py                     # writes benchmarks/RESULTS_tiles_web.md
    python benchmarks/tiles_web.py --quick             # Big Tujunga only
    python benchmarks/tiles_web.py --dems large --large-size 4097 --max-error 1

Ours: ``quantized_mesh_pyramid(dem, out, max_error=E, workers=2)`` with its
defaults (greedy insertion under the seam contract, heights quantized on one
step for the whole pyramid, nodes beyond the DEM on the ellipsoid, the
metadata extension with the tile availability and each tile's error
certificate, measured against every DEM cell the tile covers; the deepest
level's tiles refined until every DEM cell inside them is within E; gzip
level 6), then without the certificate, then without either
(``certify=False, bound_at="nodes"``: the tiles as meshed on their nodes, as
the peers').  The peers write no metadata and measure nothing.

The peer: the pipeline of pydelatin's and quantized-mesh-encoder's READMEs
(both MIT), on exactly the same tiles: the same geographic tiling scheme and
levels (``pyramid_job`` and its ``tiles``), the same per-level bound
(``PyramidJob.level_error(z)``) and the same sampled heights (each tile's
grid of ``tile_cells + 1`` nodes from ``tinsmith.tiles.pyramid._sample``, the
halo cut off).  Nodes without data are filled from the nearest valid node
(pydelatin takes no nodata); each tile is meshed by ``Delatin(heights,
max_error=bound)``, its vertices put on the tile's bounds with
``pydelatin.util.rescale_positions`` and encoded by
``quantized_mesh_encoder.encode(f, positions, triangles, bounds=tile)``, then
gzipped at level 6; a tile without data is the flat ellipsoid of two
triangles, as ours.  The tiles run on a process pool of two (the same pool as
ours); the main process writes each tile atomically into ``z/x/y.terrain``
and a ``layer.json`` at the end, as ours does.  This peer measures the
mesher and encoder alone.

The peer with rio-tiler: the whole pipeline as users build it today (a
terrain tile server in the style of kylebarron's dem-tiler): rio-tiler
(BSD-3-Clause; with morecantile, MIT) reads each tile's heights from the DEM
file, ``rio_tiler.io.Reader(dem).part(bbox, dst_crs=EPSG:4326,
bounds_crs=EPSG:4326, width=N + 1, height=N + 1, resampling_method=...,
reproject_method="bilinear")`` with ``N = tile_cells`` and the tile's bounds
grown by half a node each side, so that the pixel centres fall on
tinsmith's nodes, the tile's edges included.  Resampling: ``bilinear`` at
the level whose node spacing is at most the DEM's cell, ``average`` at the
coarser ones (GDAL's warp reads overviews where the file has them; the
shared DEMs have none and none are added).  Nodata comes from the reader's
mask; the grid is then meshed, encoded, gzipped and written as the first
peer, on the same pool.  Its heights are GDAL's (warped in the DEM's own
data type, so an integer DEM comes back in whole units), not tinsmith's
sampled ones.  At the averaged levels rio-tiler warps each tile on a grid
of its own at about the DEM's resolution, so neighbouring tiles may read
different heights at the nodes of their shared edge.

All wall times cover the whole call: job set-up (the DEM's height range),
sampling, meshing, encoding, gzip, writing.  tinsmith's kernels are compiled
(cached) before the clock starts; the three take turns.  Afterwards every
tile of the three pyramids is gunzipped and decoded by
``tinsmith.io.quantized_mesh.decode_tile`` (the peers' tiles are thus
checked to decode), and its surface as a client interpolates it (barycentric
in u, v over the dequantized heights) is compared with tinsmith's sampled
grid at every node of a cell with data at its four corners: the measured
maximum error, and those nodes no triangle covers.  For the rio-tiler peer
too: its error thus includes the difference of its heights from tinsmith's.  Wall time
and CPU time (the main process and its reaped pool workers) are both given:
on a shared machine the second moves less with other jobs' load.  The deepest
level of every pyramid is measured against the DEM's cells too, by
``tinsmith.tiles.certificate`` on the decoded tiles.
"""

from __future__ import annotations

import argparse
import gzip
import io
import json
import os
import resource
import shutil
import tempfile
import time
import warnings
from concurrent.futures import as_completed
from pathlib import Path

import numpy as np
from _common import HERE, SHARED, large_dem, machine

TUJUNGA = SHARED / "data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"
#: max_error per DEM when --max-error is not given: 1 m, and the DEM's typical value (a tenth of its cell or so)
DEFAULT_ERRORS = {"tujunga": (1.0, 5.0), "large": (1.0,)}


# ---------------------------------------------------------------- the peer pipeline


def _fill_nearest(h: np.ndarray, valid: np.ndarray) -> np.ndarray:
    from scipy import ndimage

    if valid.all():
        return h
    idx = ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
    return h[tuple(idx)]


def _mesh_and_encode(heights: np.ndarray, bound: float, bounds) -> tuple[bytes, dict]:
    """A tile's node grid (rows from the north, NaN: no data) meshed by pydelatin and encoded by
    quantized-mesh-encoder: (gzipped bytes, stats)."""
    from pydelatin import Delatin
    from pydelatin.util import rescale_positions
    from quantized_mesh_encoder import encode

    valid = np.isfinite(heights)
    if valid.any():
        tin = Delatin(_fill_nearest(heights, valid).astype(np.float32), max_error=bound)
        vertices, triangles = tin.vertices, tin.triangles  # x = column, y = row counted from the south
        # the high-water-mark coding of the indices wants the vertices in the order of their first use, and
        # quantized-mesh-encoder takes them as given: renumber them (without this step such tiles decode wrong)
        used, first = np.unique(triangles.ravel(), return_index=True)
        order = used[np.argsort(first)]
        renumbered = not np.array_equal(order, np.arange(len(vertices)))
        if renumbered:
            new = np.empty(len(vertices), np.uint32)
            new[order] = np.arange(len(order), dtype=np.uint32)
            vertices, triangles = vertices[order], new[triangles]
        positions = rescale_positions(vertices, bounds, flip_y=False)
    else:  # the flat ellipsoid, as ours
        positions = np.array([[bounds[0], bounds[1], 0], [bounds[2], bounds[1], 0], [bounds[2], bounds[3], 0],
                              [bounds[0], bounds[3], 0]], np.float32)
        triangles = np.array([[0, 1, 2], [0, 2, 3]], np.uint32)
        renumbered = False
    buf = io.BytesIO()
    encode(buf, positions, triangles, bounds=bounds)
    stats = {"vertices": len(positions), "triangles": len(triangles), "data": bool(valid.any()),
             "renumbered": renumbered}
    return gzip.compress(buf.getvalue(), compresslevel=6, mtime=0), stats


def peer_tile(tile, job):
    """One tile by pydelatin + quantized-mesh-encoder on tinsmith's sampled grid: (gzipped bytes, stats)."""
    from tinsmith.tiles.pyramid import _sample, tile_bounds

    z, x, y = tile
    N = job.tile_cells
    heights = _sample(job, z, x, y)[0][1:N + 2, 1:N + 2]  # the tile's nodes, rows from the north
    return _mesh_and_encode(heights, job.level_error(z), tile_bounds(z, x, y))


def riotiler_resampling(job, z: int) -> str:
    """rio-tiler's resampling for level z: ``bilinear`` where a node spacing is at most the DEM's cell (the deepest
    level, by ``pyramid_job``'s choice of it), ``average`` above, where a node stands for several cells."""
    from tinsmith.io.crs import M_PER_DEGREE

    spacing = 180.0 / 2 ** z / job.tile_cells * M_PER_DEGREE
    return "bilinear" if spacing <= job.cell_m else "average"


def riotiler_heights(job, z: int, x: int, y: int) -> np.ndarray:
    """The tile's ``tile_cells + 1`` nodes a side read by rio-tiler from the DEM file (rows from the north, NaN
    where the reader's mask says no data).

    The box is the tile grown by half a node each side, at ``tile_cells + 1`` pixels a side, so that the pixel
    centres fall on the nodes (on the tile's edges too).  The DEM is opened for each tile, as a tile server does.
    """
    from rasterio.crs import CRS
    from rio_tiler.errors import NoOverviewWarning
    from rio_tiler.io import Reader

    from tinsmith.tiles.pyramid import tile_bounds

    N = job.tile_cells
    west, south, east, north = tile_bounds(z, x, y)
    half = (east - west) / N / 2
    wgs84 = CRS.from_epsg(4326)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoOverviewWarning)  # the shared DEMs have none; none is added
        reader = Reader(str(job.raster.path))
    with reader:
        img = reader.part((west - half, south - half, east + half, north + half), dst_crs=wgs84, bounds_crs=wgs84,
                          width=N + 1, height=N + 1, resampling_method=riotiler_resampling(job, z),
                          reproject_method="bilinear")
    return np.where(img.mask > 0, img.array[0].astype(np.float64), np.nan)


def riotiler_tile(tile, job):
    """One tile by rio-tiler (heights read from the DEM file) + pydelatin + quantized-mesh-encoder."""
    from tinsmith.tiles.pyramid import tile_bounds

    z, x, y = tile
    return _mesh_and_encode(riotiler_heights(job, z, x, y), job.level_error(z), tile_bounds(z, x, y))


def peer_pyramid(source, out_dir: Path, max_error: float, workers: int = 2, tile_func=peer_tile) -> dict:
    """The peer's pyramid of ``source`` in ``out_dir``: the same tiles, levels and bounds as ours, each tile made by
    ``tile_func`` (:func:`peer_tile` or :func:`riotiler_tile`)."""
    from tinsmith._pool import process_pool
    from tinsmith.io import atomic_paths
    from tinsmith.tiles.cesium import _layer_json
    from tinsmith.tiles.pyramid import pyramid_job

    # the tiles ours writes (both of level 0, with the availability in its metadata), and a layer.json that
    # lists them all (the peer writes no metadata)
    job = pyramid_job(source, max_error=max_error, metadata=False)
    bounds = job.bounds
    tiles = [t for z in range(job.min_zoom, job.max_zoom + 1) for t in job.tiles(z)]
    tiles = sorted(set(tiles) | {(0, 0, 0), (0, 1, 0)})
    done = {}
    with process_pool(workers) as pool:
        futures = {pool.submit(tile_func, t, job): t for t in tiles}
        for future in as_completed(futures):
            (z, x, y), (data, stats) = futures[future], future.result()
            target = out_dir / str(z) / str(x) / f"{y}.terrain"
            target.parent.mkdir(parents=True, exist_ok=True)
            with atomic_paths(target) as (tmp,):
                tmp.write_bytes(data)
            done[(z, x, y)] = stats
    with atomic_paths(out_dir / "layer.json") as (tmp,):
        tmp.write_text(json.dumps(_layer_json(job, bounds, job.min_zoom, sorted(done), None), indent=1))
    return {"tiles": len(done), "triangles": sum(s["triangles"] for s in done.values()),
            "renumbered": sum(s["renumbered"] for s in done.values())}


# ---------------------------------------------------------------- measuring


def _error_kernel():
    import numba

    @numba.njit(cache=True)
    def node_errors(gu, gv, gh, tri, grid, valid, N, tol):
        """Max |surface - grid| over the valid nodes inside a triangle, and the valid nodes inside none.

        ``gu``, ``gv``: vertices in node units (column from the west, row from the south);
        ``grid`` rows from the north.
        """
        best = np.full(grid.shape, np.inf)  # per node: the smallest error over the triangles that hold it
        for t in range(tri.shape[0]):
            a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
            det = (gv[b] - gv[c]) * (gu[a] - gu[c]) + (gu[c] - gu[b]) * (gv[a] - gv[c])
            if det == 0.0:
                continue
            len_a = np.hypot(gu[b] - gu[c], gv[b] - gv[c])  # the edges opposite a, b, c
            len_b = np.hypot(gu[c] - gu[a], gv[c] - gv[a])
            len_c = np.hypot(gu[a] - gu[b], gv[a] - gv[b])
            c0 = max(0, int(np.ceil(min(gu[a], gu[b], gu[c]) - tol)))
            c1 = min(N, int(np.floor(max(gu[a], gu[b], gu[c]) + tol)))
            r0 = max(0, int(np.ceil(min(gv[a], gv[b], gv[c]) - tol)))
            r1 = min(N, int(np.floor(max(gv[a], gv[b], gv[c]) + tol)))
            for s in range(r0, r1 + 1):
                for col in range(c0, c1 + 1):
                    l1 = ((gv[b] - gv[c]) * (col - gu[c]) + (gu[c] - gu[b]) * (s - gv[c])) / det
                    l2 = ((gv[c] - gv[a]) * (col - gu[c]) + (gu[a] - gu[c]) * (s - gv[c])) / det
                    l3 = 1.0 - l1 - l2
                    # inside, or within ``tol`` nodes of an edge: a node on the mesh's outline stays covered when
                    # the quantization of u, v moves that outline by a fraction of a node
                    if l1 * abs(det) < -tol * len_a or l2 * abs(det) < -tol * len_b or l3 * abs(det) < -tol * len_c:
                        continue
                    row = N - s
                    if not valid[row, col]:
                        continue
                    # weights clamped to the triangle: a node just outside a sliver (a triangle made flat by the
                    # rounding of its vertices) takes a height of that triangle, not an extrapolation
                    l1, l2, l3 = max(l1, 0.0), max(l2, 0.0), max(l3, 0.0)
                    e = abs((l1 * gh[a] + l2 * gh[b] + l3 * gh[c]) / (l1 + l2 + l3) - grid[row, col])
                    if e < best[row, col]:
                        best[row, col] = e
        worst, missed = 0.0, 0
        for row in range(grid.shape[0]):
            for col in range(grid.shape[1]):
                if valid[row, col]:
                    if best[row, col] == np.inf:
                        missed += 1
                    elif best[row, col] > worst:
                        worst = best[row, col]
        return worst, missed

    return node_errors


def measure_tile(args):
    """Decode one gzipped tile and measure it against the sampled grid: (level, error, bound, missed, triangles,
    error against the DEM's cells at the deepest level, else NaN)."""
    from tinsmith.io.quantized_mesh import QUANT, decode_tile
    from tinsmith.tiles.pyramid import _sample

    path, tile, job, ours = args
    z, x, y = tile
    N = job.tile_cells
    t = decode_tile(gzip.decompress(Path(path).read_bytes()))
    tri = t["triangles"].astype(np.int64)
    n = len(t["u"])
    if len(tri) and (tri.min() < 0 or tri.max() >= n):
        raise ValueError(f"{path}: a triangle index out of range")
    hdr = t["header"]
    gh = hdr["min_height"] + t["h"] / QUANT * (hdr["max_height"] - hdr["min_height"])
    gu, gv = t["u"] * (N / QUANT), t["v"] * (N / QUANT)
    grid = _sample(job, z, x, y)[0][1:N + 2, 1:N + 2]
    valid = np.isfinite(grid)
    # judged: the nodes of the cells whose four corners hold data (the area a mesh must cover); data in lines
    # or points alone has no area (ours leaves it out, a tile of such data only is the flat ellipsoid)
    cell = valid[:-1, :-1] & valid[1:, :-1] & valid[:-1, 1:] & valid[1:, 1:]
    area = np.zeros_like(valid)
    area[:-1, :-1] |= cell
    area[1:, :-1] |= cell
    area[:-1, 1:] |= cell
    area[1:, 1:] |= cell
    err, missed = _error_kernel()(gu, gv, gh, tri, np.where(valid, grid, 0.0), area, N, 0.01)
    cells = np.nan
    if z == job.max_zoom:  # the deepest level against every DEM cell as well, as tinsmith's certificate measures
        from tinsmith.tiles.certificate import tile_certificate
        from tinsmith.tiles.pyramid import fill_height, tile_bounds

        # ours puts the nodes beyond the DEM on the ellipsoid (its fill height): triangles reaching them are no
        # surface of the DEM; the peers fill such nodes from the nearest one with data, a surface they claim
        filled = np.abs(gh - fill_height(job)) < 0.5 * job.h_step if ours else np.zeros(n, bool)
        geometry = {"data": True, "cols": gu, "rows": N - gv, "triangles": tri, "filled": filled}
        cells = tile_certificate(job, tile_bounds(z, x, y), geometry, gh)["max_error"]
    return z, float(err), job.level_error(z), int(missed), len(tri), cells


def measure(out_dir: Path, job, workers: int = 2, ours: bool = False) -> dict:
    """Every tile of a pyramid decoded and measured: the worst error, the worst error / bound, the missed nodes, and
    the deepest level's worst error against the DEM's cells (``ours``: the pyramid puts nodes beyond the DEM on the
    ellipsoid)."""
    from tinsmith._pool import process_pool

    tiles = sorted((int(p.parts[-3]), int(p.parts[-2]), int(p.stem)) for p in
                   (q.relative_to(out_dir) for q in out_dir.rglob("*.terrain")))
    _error_kernel()  # compiled before the pool forks
    todo = [(out_dir / str(z) / str(x) / f"{y}.terrain", (z, x, y), job, ours) for z, x, y in tiles]
    with process_pool(workers) as pool:
        results = list(pool.map(measure_tile, todo, chunksize=8))
    deepest = max(r[0] for r in results)
    return {
        "decoded": len(results),
        "triangles": sum(r[4] for r in results),
        "max_error_deepest": max(r[1] for r in results if r[0] == deepest),
        "worst_ratio": max(r[1] / r[2] for r in results),
        "missed": sum(r[3] for r in results),
        "cells_deepest": max(r[5] for r in results if r[0] == deepest),
    }


def pyramid_bytes(out_dir: Path) -> int:
    return sum(p.stat().st_size for p in out_dir.rglob("*.terrain"))


# ---------------------------------------------------------------- the run


def warm_up(source) -> None:
    """Compile (or load) tinsmith's kernels and import both pipelines before any clock starts."""
    import quantized_mesh_encoder  # noqa: F401
    import rio_tiler.io  # noqa: F401
    from pydelatin import Delatin  # noqa: F401

    from tinsmith.tiles.cesium import pyramid_tile, quantized_mesh_pyramid
    from tinsmith.tiles.pyramid import pyramid_job

    with tempfile.TemporaryDirectory() as tmp:  # Big Tujunga's tiles take every path: full, partial, without data
        quantized_mesh_pyramid(TUJUNGA, Path(tmp) / "warm", max_error=5.0, max_zoom=11, workers=1)
    job = pyramid_job(source, max_error=1.0)
    tile = job.tiles(job.max_zoom)[0]
    pyramid_tile(tile, job)
    peer_tile(tile, job)
    riotiler_tile(tile, job)
    _error_kernel()


def cpu_seconds() -> float:
    """User + system CPU time of this process and of its finished (reaped) children, such as a closed pool's workers."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def run_one(source, max_error: float, work: Path, repeat: int, certify: bool = True, bound_at: str = "cells") -> dict:
    from tinsmith.tiles.cesium import quantized_mesh_pyramid
    from tinsmith.tiles.pyramid import pyramid_job

    tools = ("ours", "peer", "riotiler")
    times, cpu, load, peers = {t: [] for t in tools}, {t: [] for t in tools}, [], {}
    for k in range(repeat):  # taking turns: a slow spell of the shared machine hits all three
        for tool in tools:
            out = work / f"{tool}-{max_error:g}-{k}"
            load.append(os.getloadavg()[0])
            cpu0, start = cpu_seconds(), time.perf_counter()
            if tool == "ours":
                summary = quantized_mesh_pyramid(source, out, max_error=max_error, workers=2, certify=certify,
                                                 bound_at=bound_at)
            else:
                peers[tool] = peer_pyramid(source, out, max_error, workers=2,
                                           tile_func=peer_tile if tool == "peer" else riotiler_tile)
            times[tool].append(time.perf_counter() - start)
            cpu[tool].append(cpu_seconds() - cpu0)
            load.append(os.getloadavg()[0])
            print(f"  {tool} E={max_error:g} run {k}: {times[tool][-1]:.2f} s, CPU {cpu[tool][-1]:.2f} s", flush=True)
            if k < repeat - 1:
                shutil.rmtree(out)
    last = repeat - 1
    job = pyramid_job(source, max_error=max_error)
    result = {"max_error": max_error, "levels": f"{summary['min_zoom']}..{summary['max_zoom']}",
              "load": (min(load), max(load)), "certify": certify, "bound_at": bound_at}
    for tool in tools:
        out = work / f"{tool}-{max_error:g}-{last}"
        m = measure(out, job, ours=tool == "ours")
        best = int(np.argmin(times[tool]))
        result[tool] = {"time": times[tool][best], "times": times[tool], "cpu": cpu[tool][best], "cpus": cpu[tool],
                        "bytes": pyramid_bytes(out), **m}
    result["ours"]["tiles"] = summary["tiles"]
    assert result["ours"]["triangles"] == sum(lv["triangles"] for lv in summary["levels"].values())
    for tool in ("peer", "riotiler"):
        result[tool]["tiles"], result[tool]["renumbered"] = peers[tool]["tiles"], peers[tool]["renumbered"]
        assert result[tool]["triangles"] == peers[tool]["triangles"]
    return result


def dem_info(source) -> str:
    from tinsmith.tiles.pyramid import pyramid_job

    job = pyramid_job(source, max_error=1.0)
    H, W = job.raster.shape
    return f"{H:,} x {W:,} ({H * W / 1e6:.1f}M cells, {job.cell_m:.2f} m cells)"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dems", nargs="+", choices=("tujunga", "large"), default=["tujunga", "large"])
    ap.add_argument("--max-error", type=float, nargs="+", help="these max_error values on every DEM (default: per DEM)")
    ap.add_argument("--quick", action="store_true", help="Big Tujunga only")
    ap.add_argument("--large-size", type=int, default=10001, help="rows and columns of the make_large_dem.py DEM")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each pipeline on DEMs under 5M cells (best kept)")
    ap.add_argument("--cache", default=str(Path(tempfile.gettempdir()) / "tinsmith-bench"),
                    help="folder for the generated DEM (kept between runs)")
    ap.add_argument("--out", default=str(HERE / "RESULTS_tiles_web.md"))
    args = ap.parse_args()
    dems = ["tujunga"] if args.quick else args.dems
    rows = []
    for dem in dems:
        if dem == "tujunga":
            source, name = TUJUNGA, "Big Tujunga (SRTM 30 m, UTM 11N)"
        else:
            Path(args.cache).mkdir(parents=True, exist_ok=True)
            source, name = large_dem(Path(args.cache), size=args.large_size), "make_large_dem.py from St. Helens"
        name = f"{name}, {dem_info(source)}"
        from tinsmith.tiles.pyramid import pyramid_job

        job = pyramid_job(source, max_error=1.0)
        repeat = args.repeat if job.raster.shape[0] * job.raster.shape[1] < 5_000_000 else 1
        warm_up(source)
        for max_error in args.max_error or DEFAULT_ERRORS[dem]:
            # ours as it comes (the certificate, the bound at every cell), without the certificate, and with
            # neither (the bound at the tiles' nodes only, as the peers)
            for certify, bound_at in ((True, "cells"), (False, "cells"), (False, "nodes")):
                print(name, max_error, "certificate" if certify else "no certificate", bound_at, flush=True)
                with tempfile.TemporaryDirectory(dir=args.cache if dem == "large" else None) as work:
                    r = run_one(source, max_error, Path(work), repeat, certify, bound_at)
                r["name"], r["repeat"] = name, repeat
                print(json.dumps(r, default=str), flush=True)
                rows.append(r)
                write_table(rows, args)  # after every row: a long run keeps what it measured


def write_table(rows, args) -> None:
    cmd = "python benchmarks/tiles_web.py" + (" --quick" if args.quick else "")
    if not args.quick and args.dems != ["tujunga", "large"]:
        cmd += " --dems " + " ".join(args.dems)
    if args.max_error:
        cmd += " --max-error " + " ".join(f"{e:g}" for e in args.max_error)
    if args.large_size != 10001:
        cmd += f" --large-size {args.large_size}"
    lines = [
        "# Quantized-mesh pyramids: tinsmith against pydelatin + quantized-mesh-encoder (with tinsmith's sampler, "
        "and with rio-tiler reading the DEM)",
        "",
        machine(),
        "",
        f"Rerun: `{cmd}` (writes this file).",
        "",
        "Both pyramids hold the same tiles: the same geographic tiling scheme and levels, the same bound per level "
        "(`PyramidJob.level_error(z)`: E at the deepest level, max(E, 78271.52 / 2^z) above) and the same sampled "
        "heights (tinsmith's 257 x 257 node grid of each tile, `tile_cells=256`). "
        "Ours: `quantized_mesh_pyramid(dem, out, max_error=E, workers=2)` with its defaults: nodes beyond the DEM on "
        "the ellipsoid, the metadata extension (availability and each tile's error certificate), and the "
        "certificate measured against every DEM cell each tile covers (*ours*: certificate yes), or without it "
        "(`certify=False`, *no*); *bound at cells* (the default, `bound_at='cells'`): the deepest level's tiles "
        "refined until every DEM cell strictly inside them is within E, *nodes*: left as meshed on their nodes, as "
        "the peers' are; the peer measures and writes no metadata. "
        "Peer: each tile's grid (nodes without data filled from the nearest valid node) meshed by "
        "`pydelatin.Delatin(grid, max_error=bound)`, put on the tile's bounds by `pydelatin.util.rescale_positions` "
        "and encoded by `quantized_mesh_encoder.encode(f, positions, triangles, bounds=tile)`, on a process pool of "
        "two; both gzip at level 6 and write each tile atomically from the main process, and a layer.json. "
        "Peer (rio-tiler): the whole pipeline as users build it: each tile's 257 x 257 nodes read from the DEM file "
        "by `rio_tiler.io.Reader(dem).part(tile grown by half a node each side, dst_crs=EPSG:4326, width=height=257, "
        "reproject_method='bilinear', resampling_method='bilinear' at the deepest level (nodes no wider apart than "
        "a DEM cell), 'average' above)` (pixel centres on tinsmith's nodes; the DEM opened per tile, as a tile server "
        "does; no overviews in the DEMs), nodata from the reader's mask filled from the nearest valid node, then "
        "meshed, encoded and written as the peer. Its heights are not ours (GDAL's warp and average, on the DEM's "
        "own data type), so its measured error, against tinsmith's sampled grid as the others, includes that "
        "difference besides the mesh's own.",
        "Wall time: the whole call, set-up to layer.json, after tinsmith's kernels are compiled and loaded in the main "
        "process (a warm-up pyramid before the clock; the pool's workers are forked from it); the best of the "
        "runs (the tools taking turns). Time ratio = ours / peer (< 1: ours faster); bytes ratio = ours / peer "
        "(gzipped tiles on disk).",
        "Measured max error: every tile of both pyramids gunzipped, decoded by tinsmith's `decode_tile` (so each "
        "peer tile is checked to decode) and interpolated as a client does (barycentric in u, v over the "
        "dequantized heights) at every node of the sampled grid that is a corner of a cell with data at all four "
        "corners (data in lines or points alone covers no area: ours leaves it out); *deepest* is the worst at the "
        "deepest level (bound E), *worst / bound* the worst ratio over all levels, *uncovered* those nodes inside no "
        "triangle nor within 0.01 node of one (summed over the tiles); a node held by several triangles takes the "
        "smallest error, a node within 0.01 node of a triangle its nearest height on it. The measured error "
        "includes the format's quantization of u, v (a node moves by up to 1/256 of its spacing in ours) and of "
        "heights, so it may pass E by a little. *Deepest against the DEM's cells*: the same decoded tiles of the "
        "deepest level measured at every DEM cell whose centre they cover, by `tinsmith.tiles.certificate` (the "
        "cell placed by pyproj, interpolated as a client does; ours leaves out its triangles reaching nodes it put "
        "on the ellipsoid beyond the DEM, the peers' nodes there are filled from the nearest and measured): what a "
        "user gets from the DEM, not from the nodes sampled from it.",
        "",
        "CPU s: user + system time of the main process and the pool's workers in that run (less sensitive than wall "
        "time to other jobs on the machine); load: the 1-minute load average seen at the runs' starts and ends.",
        "",
        "| DEM | E (m) | ours: certificate, bound at | levels | runs | ours s | peer s | time ratio | ours CPU s | peer CPU s "
        "| CPU ratio | load "
        "| tiles | ours MB | peer MB | ours B/tile "
        "| peer B/tile | bytes ratio | ours triangles | peer triangles | ours max error deepest (m) / worst/bound "
        "| peer max error deepest (m) / worst/bound | uncovered ours / peer | peer tiles renumbered "
        "| rio-tiler s | time ratio ours / rio-tiler | rio-tiler CPU s | CPU ratio ours / rio-tiler | rio-tiler MB "
        "| rio-tiler B/tile | rio-tiler triangles | rio-tiler max error deepest (m) / worst/bound "
        "| rio-tiler uncovered | deepest against the DEM's cells (m): ours / peer / rio-tiler |",
        "|---" * 34 + "|",
    ]
    for r in rows:
        o, p, q = r["ours"], r["peer"], r["riotiler"]
        tiles = (f"{o['tiles']:,}" if o["tiles"] == p["tiles"] == q["tiles"]
                 else f"{o['tiles']:,} / {p['tiles']:,} / {q['tiles']:,}")
        lines.append(
            f"| {r['name']} | {r['max_error']:g} | {'yes' if r.get('certify', True) else 'no'}, "
            f"{r.get('bound_at', 'nodes')} | {r['levels']} "
            f"| {r['repeat']} | {o['time']:.2f} | {p['time']:.2f} "
            f"| {o['time'] / p['time']:.2f} | {o['cpu']:.1f} | {p['cpu']:.1f} | {o['cpu'] / p['cpu']:.2f} "
            f"| {r['load'][0]:.1f}–{r['load'][1]:.1f} | {tiles} | {o['bytes'] / 1e6:.2f} | {p['bytes'] / 1e6:.2f} "
            f"| {o['bytes'] / o['tiles']:,.0f} | {p['bytes'] / p['tiles']:,.0f} | {o['bytes'] / p['bytes']:.3f} "
            f"| {o['triangles']:,} | {p['triangles']:,} | {o['max_error_deepest']:.3f} / {o['worst_ratio']:.3f} "
            f"| {p['max_error_deepest']:.3f} / {p['worst_ratio']:.3f} | {o['missed']:,} / {p['missed']:,} | {p['renumbered']:,} "
            f"| {q['time']:.2f} | {o['time'] / q['time']:.2f} | {q['cpu']:.1f} | {o['cpu'] / q['cpu']:.2f} "
            f"| {q['bytes'] / 1e6:.2f} | {q['bytes'] / q['tiles']:,.0f} | {q['triangles']:,} "
            f"| {q['max_error_deepest']:.3f} / {q['worst_ratio']:.3f} | {q['missed']:,} "
            f"| {o['cells_deepest']:.3f} / {p['cells_deepest']:.3f} / {q['cells_deepest']:.3f} |"
        )
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
