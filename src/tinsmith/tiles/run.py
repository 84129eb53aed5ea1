"""Tiled runs: the layout, the executors (in process, process pool, Dask), resuming, merging.

A raster of any size is cut into square tiles that share their edge rows
and columns; each tile is read on its own (a window plus a halo) and meshed
under the seam contract of :mod:`.seams`, so the driver never holds more than
one tile's cells and the tiles join without cracks.  Finished tiles are
written to a parts folder as they arrive; a rerun of the same job skips
them.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import warnings
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from .. import _checks
from .._pool import process_pool, stop_pool
from .._version import __version__
from ..algorithms.registry import get_method, simplify
from ..core import Heightfield, TerrainMesh
from ..core.heightfield import pixel_to_world
from ..errors import FileError, InvalidOptionError, MissingDependencyError, TinsmithWarning
from ..io import atomic_paths
from ..io.crs import GEOGRAPHIC_WARNING, describe, is_geographic
from ..io.points import single_threaded_laz
from ..io.raster import RasterInfo, raster_info
from ..resources import check_memory, estimate_method
from .worker import TILE_METHODS, TileJob, TileResult, TileSpec, mesh_tile

__all__ = ["TileLog", "TiledRun", "independent_tiles", "layout", "tile_heightfield", "tile_raster"]


def layout(shape: tuple[int, int], tile_size: int) -> list[TileSpec]:
    """Tiles of ``tile_size`` cells a side that share their edge rows and columns, row by row.

    Tile ``(i, j)`` holds rows ``i*tile_size .. (i+1)*tile_size`` (inclusive),
    so neighbours share one line of cells; the last row and column of tiles
    stop at the raster's edge (a remainder of a single line joins the tile
    before it).

    Examples
    --------
    >>> from tinsmith.tiles import layout
    >>> tiles = layout((300, 500), 256)
    >>> [(t.i, t.j, t.r0, t.r1, t.c0, t.c1) for t in tiles]  # neighbours share their edge line
    [(0, 0, 0, 256, 0, 256), (0, 1, 0, 256, 256, 499), (1, 0, 256, 299, 0, 256), (1, 1, 256, 299, 256, 499)]
    """
    tile_size = _checks.integer("tile_size", tile_size, minimum=2)

    def cuts(n: int) -> list[tuple[int, int]]:
        starts = list(range(0, n - 1, tile_size))
        if len(starts) > 1 and n - 1 - starts[-1] < 2:
            starts.pop()
        return [(s, min(s + tile_size, n - 1) if k + 1 < len(starts) else n - 1) for k, s in enumerate(starts)]

    rows, cols = cuts(shape[0]), cuts(shape[1])
    return [TileSpec(i, j, r0, r1, c0, c1) for i, (r0, r1) in enumerate(rows) for j, (c0, c1) in enumerate(cols)]


class TileSummaries:
    """What a run tells of its tiles from their summaries (``self._summaries``: name -> stats)."""

    _summaries: dict

    @property
    def max_error(self) -> float:
        """Largest vertical error of any tile or seam (measured in the tiles)."""
        return max((s["max_error"] for s in self._summaries.values()), default=0.0)

    @property
    def tile_seconds(self) -> float:
        """Time spent meshing tiles, summed over the tiles (including reused ones' first run)."""
        return float(sum(s["seconds"] for s in self._summaries.values()))


class TiledRun(TileSummaries):
    """The outcome of :func:`tile_raster`: per-tile results (in memory or in the parts folder) and their merge.

    Examples
    --------
    >>> import tinsmith
    >>> from tinsmith.tiles import tile_raster
    >>> run = tile_raster(tinsmith.sample_path("st-helens"), max_error=20.0, tile_size=256, workers=1)
    >>> first = run.tile_mesh(run.specs[0])  # one tile, in world coordinates
    >>> merged = run.merge()
    >>> first.n_vertices < merged.n_vertices, merged.info["tiles"]
    (True, 4)
    """

    def __init__(self, raster: RasterInfo, specs: list[TileSpec], results: dict, summaries: dict,
                 parts: Path | None, reused: int, job: TileJob):
        self.raster, self.specs, self.parts, self.reused, self.job = raster, specs, parts, reused, job
        self._results = results
        self._summaries = summaries  # name -> {"max_error", "seconds", "triangles"}

    def result(self, spec: TileSpec) -> TileResult:
        if spec.name in self._results:
            return self._results[spec.name]
        with np.load(self.parts / f"{spec.name}.npz") as d:
            return TileResult.from_dict(d)

    def tile_mesh(self, spec: TileSpec) -> TerrainMesh:
        """One tile as a mesh in world coordinates."""
        r = self.result(spec)
        return TerrainMesh(self._world(r.rows, r.cols, r.z), r.triangles, crs=self.raster.crs,
                           info={"tile": [spec.i, spec.j], "error": {"max": r.max_error}})

    def _world(self, rows, cols, z) -> np.ndarray:
        x, y = pixel_to_world(self.raster.transform, rows, cols)
        return np.column_stack([x, y, z])

    def merge(self) -> TerrainMesh:
        """All tiles as one mesh: the seam vertices tiles share joined by their raster cell.

        A vertex inside a tile belongs to that tile alone, so only the
        vertices on tile sides are matched (a sort of those few, not of all).
        """
        W = self.raster.shape[1]
        results = [(spec, self.result(spec)) for spec in self.specs]
        sides = [(r.rows == s.r0) | (r.rows == s.r1) | (r.cols == s.c0) | (r.cols == s.c1) for s, r in results]
        triangles, first = weld(sides, [r.rows[m] * W + r.cols[m] for (_, r), m in zip(results, sides, strict=True)],
                                [r.triangles for _, r in results])

        def welded(values: list) -> np.ndarray:  # the vertices' values in weld's numbering
            on_sides = np.concatenate([v[m] for v, m in zip(values, sides, strict=True)])
            return np.concatenate([v[~m] for v, m in zip(values, sides, strict=True)] + [on_sides[first]])

        rows = welded([r.rows for _, r in results]).astype(np.int64)
        cols = welded([r.cols for _, r in results]).astype(np.int64)
        z = welded([r.z for _, r in results])
        info = {"error": {"max": self.max_error}, "tiles": len(self.specs), "tile_seconds": self.tile_seconds,
                "method": self.job.method, "max_error_used": self.job.max_error}
        return TerrainMesh(self._world(rows, cols, z), triangles, crs=self.raster.crs, info=info)


def weld(sides: list, keys: list, triangles: list) -> tuple[np.ndarray, np.ndarray]:
    """Join tiles' triangles into one vertex numbering: each tile's inner vertices, then the side vertices once.

    ``sides[k]`` marks tile k's vertices on its sides, ``keys[k]`` identifies
    those (a cell index, or x-y rows), equal keys are one vertex.  Returns the
    (T, 3) triangles over [inner vertices of every tile in order, distinct
    side vertices] and, for each distinct side vertex, its first place in the
    concatenated side vertices.
    """
    n_inner = sum(int((~m).sum()) for m in sides)
    all_keys = np.concatenate(keys) if keys else np.empty(0, np.int64)
    _, first, inverse = np.unique(all_keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    out, inner, offset = [], 0, 0
    for m, t in zip(sides, triangles, strict=True):
        local = np.empty(len(m), np.int64)
        k_in, k_side = int((~m).sum()), int(m.sum())
        local[~m] = inner + np.arange(k_in)
        local[m] = n_inner + inverse[offset:offset + k_side]
        inner += k_in
        offset += k_side
        out.append(local[t])
    return (np.concatenate(out) if out else np.empty((0, 3), np.int64)).reshape(-1, 3), first


def independent_tiles(hf, tile_size: int, method: str = "greedy", **options) -> TerrainMesh:
    """Each tile of an in-memory heightfield meshed on its own, without the seam contract, put side by side.

    The baseline the seam contract is judged against: vertices are joined by
    raster cell, and nothing makes the tiles' sides agree, so the result can
    hold cracks and T-junctions (:func:`tinsmith.metrics.seam_defects`).
    ``options`` go to the method (stop rules included).

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> from tinsmith.tiles import independent_tiles
    >>> mesh = independent_tiles(dem, 32, max_error=10.0)  # four tiles meshed apart, no seam contract
    >>> mesh.n_vertices < dem.n_valid
    True
    """
    W = hf.shape[1]
    ids, zs, tris, offset = [], [], [], 0
    for spec in layout(hf.shape, tile_size):
        sub = Heightfield(hf.z[spec.r0:spec.r1 + 1, spec.c0:spec.c1 + 1], cell_size=1, nodata=float("nan"))
        mesh = simplify(sub, method, **options)
        r, c = sub.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
        ids.append((np.rint(r).astype(np.int64) + spec.r0) * W + np.rint(c).astype(np.int64) + spec.c0)
        zs.append(mesh.vertices[:, 2])
        tris.append(mesh.triangles.astype(np.int64) + offset)
        offset += mesh.n_vertices
    cells, first, inverse = np.unique(np.concatenate(ids), return_index=True, return_inverse=True)
    x, y = hf.pixel_to_world(cells // W, cells % W)
    vertices = np.column_stack([x, y, np.concatenate(zs)[first]])
    return TerrainMesh(vertices, inverse.ravel()[np.concatenate(tris)], crs=hf.crs)


def tile_raster(source, *, max_error: float, method: str = "greedy", tile_size: int = 1024,
                options: dict | None = None, prefilter: dict | None = None, halo: int | None = None,
                workers: int | None = None, scheduler: str | None = None, parts=None,
                band: int = 1, nodata=None, progress: Callable[[int, int], None] | None = None) -> TiledRun:
    """Mesh a raster of any size tile by tile, in bounded memory, with seams that join.

    Parameters
    ----------
    source : path
        A georeferenced raster GDAL reads (only windows of it are ever read).
    max_error : float
        The vertical error bound of every tile and every seam, in z units.
    method : {"greedy", "quadtree", "cvt"}
        The tile-local method; see :data:`TILE_METHODS`.
    tile_size : int
        Cells along a tile's side (tiles share their edge line).
    options : dict, optional
        Options of the method (as for :func:`tinsmith.simplify`).
    prefilter : dict, optional
        Keyword arguments of :func:`tinsmith.wavelet_filter` (``landuse`` a
        vector file): each tile is filtered over its window plus the halo.
    halo : int, optional
        Cells read around each tile: 1 (what the seams need) by default, 64
        with a pre-filter.
    workers : int, optional
        Processes of the local pool (default: the machine's cores); 1 runs in
        this process.  With ``scheduler="local"``, the workers of a Dask
        ``LocalCluster``.
    scheduler : str, optional
        A Dask scheduler address (``tcp://host:8786``), or ``"local"`` for a
        ``LocalCluster`` on this machine.  Every worker must be able to read
        ``source``.
    parts : path, optional
        Folder of finished tiles: tiles already there from the same job are
        skipped (resume); a folder of another job is cleared first.  Without
        it, results stay in memory.
    progress : callable, optional
        Called with ``(done, total)`` tiles as they finish.

    Examples
    --------
    >>> import tinsmith
    >>> from tinsmith.tiles import tile_raster
    >>> run = tile_raster(tinsmith.sample_path("st-helens"), max_error=20.0, tile_size=128, workers=1)
    >>> len(run.specs), run.max_error <= 20.0
    (12, True)
    >>> mesh = run.merge()  # one mesh, the seams joined
    >>> tinsmith.vertical_error(mesh, tinsmith.sample("st-helens"))["max"] <= 20.0
    True
    """
    if method not in TILE_METHODS:
        raise InvalidOptionError(f"method must be one of {', '.join(TILE_METHODS)} for tiled runs, got {method!r}")
    max_error = _checks.number("max_error", max_error)
    if not max_error > 0:
        raise InvalidOptionError(f"max_error must be > 0 for tiled runs (the seams are simplified to it), got {max_error}")
    if workers is not None:
        workers = _checks.integer("workers", workers, minimum=1)
    if halo is None:
        halo = 64 if prefilter is not None else 1
    halo = _checks.integer("halo", halo, minimum=1)
    raster = raster_info(source, band=band, nodata=nodata)
    if is_geographic(raster.crs):
        warnings.warn(f"{str(source)!r}: {GEOGRAPHIC_WARNING.format(crs=describe(raster.crs))}", TinsmithWarning,
                      stacklevel=2)
    specs = layout(raster.shape, tile_size)
    _check_tile_memory(raster.shape, tile_size, halo, method, workers, scheduler)
    job = TileJob(raster, method, float(max_error), dict(options or {}), halo,
                  None if prefilter is None else dict(prefilter))
    _check_options(job)
    results: dict[str, TileResult] = {}
    summaries: dict[str, dict] = {}
    reused = 0
    parts = None if parts is None else Path(parts)
    opened = False
    with forget_if_idle(parts, lambda: opened and not summaries):
        if parts is not None:
            summaries = open_parts(parts, _fingerprint(job, tile_size))
            opened = True
            reused = sum(1 for s in specs if s.name in summaries)
        todo = [s for s in specs if s.name not in summaries]
        done = len(specs) - len(todo)
        if progress is not None:
            progress(done, len(specs))
        for spec, result in execute(mesh_tile, todo, job, workers, scheduler):
            results[spec.name] = result  # the merge follows: no need to read the part back
            if parts is None:
                summaries[spec.name] = result.summary()
            else:
                write_part(parts, spec, result, summaries)
            done += 1
            if progress is not None:
                progress(done, len(specs))
    return TiledRun(raster, specs, results, summaries, parts, reused, job)


def tile_heightfield(hf, *, max_error: float, workers: int, tile_size: int | None = None) -> TerrainMesh:
    """Greedy insertion on an in-memory heightfield in tiles on ``workers`` threads, seams shared.

    The tiles are cut by :func:`layout` and meshed under the seam contract of
    :mod:`.seams` (each tile's sides simplified once, within the bound, and
    fixed), so they join without cracks or T-junctions and the bound holds
    at every valid cell.  Greedy insertion's kernels release the GIL, so the
    tiles mesh in parallel on threads with no copy of the grid.
    ``tile_size`` default: the side that gives about four tiles a worker
    (256 cells at least), for balance.
    """
    h, w = hf.shape
    if tile_size is None:
        tile_size = max(256, int(np.ceil(np.sqrt(h * w / (4 * workers)))))
    specs = layout(hf.shape, tile_size)
    raster = RasterInfo("<memory>", hf.shape, tuple(hf.transform)[:6], hf.crs, None, str(hf.z.dtype), 1)
    job = TileJob(raster, "greedy", float(max_error))

    z, valid = hf.z, hf.valid  # the mask once, not once a tile

    def read(rows, cols):  # a window of the grid, as read_window gives one of a file (nodata is NaN in z)
        window = np.s_[rows[0]:rows[1] + 1, cols[0]:cols[1] + 1]
        return np.array(z[window], dtype=np.float64), valid[window]

    with ThreadPoolExecutor(max_workers=workers) as pool:
        results = dict(zip((s.name for s in specs), pool.map(lambda spec: mesh_tile(spec, job, read), specs), strict=True))
    summaries = {name: r.summary() for name, r in results.items()}
    return TiledRun(raster, specs, results, summaries, None, 0, job).merge()


def _check_tile_memory(shape, tile_size: int, halo: int, method: str, workers, scheduler) -> None:
    """Refuse tiles that cannot fit: a window with its halo, read as float64 with its mask, and the
    method's memory, on every local worker at once (a remote Dask cluster's workers have their own
    memory: there one tile is checked; ``scheduler="local"`` runs its workers here)."""
    rows, cols = (min(int(tile_size), n) + 2 * halo for n in shape)
    remote = scheduler is not None and scheduler != "local"
    parallel = 1 if remote else (workers or os.cpu_count() or 1)
    need = parallel * (rows * cols * 9 + estimate_method(method, rows * cols))
    check_memory(need, f"meshing tiles of {rows - 2 * halo:,} x {cols - 2 * halo:,} cells on {parallel} worker(s)",
                 "a smaller --tile-size or fewer --workers")


def _check_options(job: TileJob) -> None:
    """Fail before any tile runs on options the method does not know."""
    record = get_method(job.method)
    known = {o.name for o in record.options}
    unknown = sorted(set(job.options) - known)
    if unknown:
        raise InvalidOptionError(f"unknown option(s) for method {job.method!r}: {', '.join(unknown)} "
                                 f"(known: {', '.join(sorted(known)) or 'none'})")


def fingerprint_source(raster: RasterInfo) -> dict:
    """The raster's path, size and time of change (its path alone for a GDAL address such as /vsicurl/)."""
    path = Path(raster.path)
    try:
        stat = path.stat()
        return {"path": str(path.resolve()), "size": stat.st_size, "mtime_ns": stat.st_mtime_ns}
    except OSError:
        return {"path": raster.path}


def _fingerprint(job: TileJob, tile_size: int) -> dict:
    source = fingerprint_source(job.raster)
    prefilter = None if job.prefilter is None else {k: str(v) for k, v in sorted(job.prefilter.items())}
    return {"tinsmith": __version__, "source": source, "band": job.raster.band, "nodata": str(job.raster.nodata),
            "method": job.method, "max_error": job.max_error, "options": {k: str(v) for k, v in job.options.items()},
            "prefilter": prefilter, "halo": job.halo, "tile_size": tile_size}


class TileLog:
    """The finished tiles of a job: one JSON line per tile, appended as each finishes.

    Appending costs the same for the ten-thousandth tile as for the first, and
    an interrupted run loses at most its last, partial line (skipped when read).
    """

    def __init__(self, path: Path):
        self.path = path

    def read(self) -> dict:
        """name -> stats of every whole line."""
        done = {}
        try:
            lines = self.path.read_text().splitlines()
        except FileNotFoundError:
            return done
        for line in lines:
            try:
                entry = json.loads(line)
                done[entry.pop("name")] = entry
            except (ValueError, KeyError, AttributeError):
                continue
        return done

    def append(self, name: str, stats: dict) -> None:
        with open(self.path, "a") as f:
            f.write(json.dumps({"name": name, **stats}) + "\n")

    def clear(self) -> None:
        self.path.unlink(missing_ok=True)


#: What a parts folder holds: the job's fingerprint, the log, and one file per finished tile
#: (and, for a point cloud, the folder of the points bucketed by tile).
PART_NAME = re.compile(r"tile_\d{4,}_\d{4,}\.npz")
BUCKETS = "buckets"


def _own_files(parts: Path) -> tuple[list[Path], list[Path]]:
    """(files of a parts folder that tinsmith wrote, other entries) of an existing folder."""
    own, other = [], []
    for p in parts.iterdir():
        mine = p.is_file() and (p.name in ("job.json", "tiles.jsonl") or bool(PART_NAME.fullmatch(p.name))
                                or (p.name.startswith(".") and ".tmp" in p.name))  # a temporary of a stopped run
        mine = mine or (p.is_dir() and p.name == BUCKETS)
        (own if mine else other).append(p)
    return own, other


def remove_parts(parts, keep_folder: bool = False) -> None:
    """Remove a parts folder's own files, and the folder once nothing else is left in it (unless ``keep_folder``)."""
    parts = Path(parts)
    if not parts.is_dir():
        return
    own, other = _own_files(parts)
    for p in own:
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
    if not other and not keep_folder:
        with contextlib.suppress(OSError):
            parts.rmdir()


@contextlib.contextmanager
def forget_if_idle(parts: Path | None, nothing_done: Callable[[], bool]) -> Iterator[None]:
    """Around a run that fills the parts folder ``parts``: if the run fails (or is stopped) while
    ``nothing_done()``, remove what it put there, the folder too if it made it.

    A run that finished nothing (an unreachable scheduler, Ctrl-C before the
    first tile) has nothing to resume from; a run that finished some tiles keeps
    them.  Enter it before :func:`open_parts`, which makes the folder;
    ``nothing_done()`` must be false until that call succeeded (a folder it
    refused is not touched).
    """
    made = parts is not None and not Path(parts).exists()
    try:
        yield
    except BaseException:
        if parts is not None and nothing_done():
            remove_parts(parts, keep_folder=not made)
        elif made:  # a folder made but refused or never filled: gone if empty
            with contextlib.suppress(OSError):
                Path(parts).rmdir()
        raise


def open_parts(parts: Path, fingerprint: dict) -> dict:
    """The summaries of the finished tiles of this job in ``parts`` (a folder of another job is cleared).

    A folder that holds anything but parts (a user's data given as ``--parts``)
    is refused: clearing it, or removing it after success, would lose that data.
    """
    job_file, log = parts / "job.json", TileLog(parts / "tiles.jsonl")
    if parts.exists() and not parts.is_dir():
        raise FileError(f"the parts folder {str(parts)!r} is a file; give a new or empty folder")
    if parts.is_dir():
        other = _own_files(parts)[1]
        if other:
            raise FileError(
                f"the parts folder {str(parts)!r} holds {other[0].name!r}, which is no tile part; "
                "give a new or empty folder (it is cleared for another job and removed after success)"
            )
    try:
        parts.mkdir(parents=True, exist_ok=True)
        if job_file.exists() and json.loads(job_file.read_text()) == fingerprint:
            # a tile's line has its file; other lines (a point run's files bucketed, its max_edge) stand alone
            return {n: s for n, s in log.read().items() if not n.startswith("tile_") or (parts / f"{n}.npz").exists()}
        for old in parts.glob("tile_*.npz"):
            old.unlink()
        shutil.rmtree(parts / BUCKETS, ignore_errors=True)
        log.clear()
        _write_json(job_file, fingerprint)
    except OSError as exc:
        raise FileError(f"cannot use the parts folder {str(parts)!r}: {exc.strerror or exc}") from None
    return {}


def _write_json(path: Path, data) -> None:
    with atomic_paths(path) as (tmp,):
        tmp.write_text(json.dumps(data, indent=1))


def write_part(parts: Path, spec, result, summaries: dict) -> None:
    """The tile's arrays (atomic), then its line in the log: a line always has its file.

    ``result`` is a raster's :class:`TileResult` or a point cloud's tile result:
    anything with ``to_dict()`` and ``summary()``.
    """
    target = parts / f"{spec.name}.npz"
    with atomic_paths(target) as (tmp, ), open(tmp, "wb") as f:
        np.savez(f, **result.to_dict())
    summaries[spec.name] = result.summary()
    TileLog(parts / "tiles.jsonl").append(spec.name, summaries[spec.name])


def execute(func, specs: list, job, workers: int | None, scheduler: str | None) -> Iterator[tuple]:
    """Run ``func(spec, job)`` on every spec; yield ``(spec, result)`` as they finish."""
    if not specs:
        return
    if scheduler is not None:
        yield from _execute_dask(func, specs, job, workers, scheduler)
        return
    n = workers or os.cpu_count() or 1
    if n == 1 or len(specs) == 1:
        for spec in specs:
            yield spec, func(spec, job)
        return
    pool = process_pool(min(n, len(specs)), initializer=_worker_started)  # its workers die with this process
    try:
        futures = {pool.submit(func, spec, job): spec for spec in specs}
        for future in as_completed(futures):
            yield futures[future], future.result()
    except BaseException:  # Ctrl-C, SIGTERM (the command line's handler), a failed tile, the caller stopped
        stop_pool(pool)  # the waiting tiles cancelled, the running ones not waited for
        raise
    finally:
        pool.shutdown()


def _worker_started() -> None:
    """In each pool worker: LAZ decompressed on the worker's own thread (see ``single_threaded_laz``)."""
    with contextlib.suppress(Exception):  # no laspy: nothing to read LAZ with, nothing to set
        single_threaded_laz()


def _execute_dask(func, specs, job, workers, scheduler):
    try:
        from distributed import Client, LocalCluster
        from distributed import as_completed as dask_completed
    except ImportError:
        raise MissingDependencyError(
            "a Dask scheduler needs dask.distributed: pip install 'tinsmith[distributed]'"
        ) from None
    cluster = None
    try:
        if scheduler == "local":
            cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                                   processes=True, dashboard_address=None)
            client = Client(cluster)
        else:
            try:
                client = Client(scheduler)  # waits Dask's distributed.comm.timeouts.connect (30 s by default)
            except (OSError, TimeoutError) as exc:
                raise FileError(f"cannot reach the Dask scheduler {scheduler!r}: {exc}") from None
        with client:
            futures = {client.submit(func, spec, job, pure=False): spec for spec in specs}
            for future in dask_completed(list(futures)):
                yield futures[future], future.result()
    finally:
        if cluster is not None:
            cluster.close()
