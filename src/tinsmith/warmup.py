"""Compile the numerical kernels up front: ``tinsmith warmup`` and :func:`warmup`.

numba compiles each kernel on its first call and caches it on disk (see
:mod:`tinsmith.kernels.portable` for the cache shipped with the package).
:func:`warmup` runs every method once on a small piece of the embedded
sample (float32 and float64 heights, with a nodata hole), the metrics, the
point cloud, city, filter, drainage, reconstruction and tiled paths, so that later
runs load every kernel from the cache.  It prints nothing itself; ``progress(name)`` is called before
each job.  Each job imports the method modules it runs when it runs, so a job loads only its own kernels.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from .algorithms import methods, simplify
from .core import Heightfield, PointCloud
from .errors import InvalidOptionError
from .io import read_heightfield
from .metrics import mesh_metrics
from .samples import sample_path
from .shapes import ellipsoid

__all__ = ["JOBS", "warmup"]


def _pieces():
    """The sample and a 48 x 64 piece of it with a nodata hole, with float32 and with float64 heights.

    (A heightfield keeps the heights of a float32 or smaller array as float32, others as float64.)
    """
    hf = read_heightfield(sample_path("st-helens"))
    z = np.array(hf.z[100:148, 200:264], dtype=np.float64)
    z[20:26, 30:37] = np.nan
    pieces = [Heightfield(values, cell_size=hf.cell_size, crs=hf.crs, nodata=float("nan"))
              for values in (z.astype(np.float32), z)]
    return hf, pieces


def _default_job() -> None:
    """The README's first command: greedy insertion at its default stop on the sample, with the metrics."""
    hf, pieces = _pieces()
    for h in (hf, *pieces):
        mesh = simplify(h)
        mesh_metrics(mesh, h)


def _methods_job() -> None:
    """Every registered method on the pieces, and the metrics of each mesh."""
    from .algorithms.grid.grid import grid

    _, pieces = _pieces()
    for h in pieces:
        for method in methods():
            if method.input == "points":  # a cloud: the reconstruction job compiles it
                continue
            data = grid(h) if method.input == "mesh" else h
            mesh = simplify(data, method=method.name, **_stop(method, h))
            mesh_metrics(mesh, h)
    _closed_remesh()


def _stop(method, h: Heightfield) -> dict:
    """A stop rule ``method`` declares: 300 vertices where it takes a budget, else a twentieth of the relief.

    The quality mesher runs to its error bound even though it takes a budget, so that its improvement passes
    run (a budget stop skips them).
    """
    if not method.stop_rules:
        return {}
    if "max_vertices" in method.stop_rules and method.name != "quality":
        return {"max_vertices": 300}
    lo, hi = h.z_range
    return {"max_error": (hi - lo) / 20}


def _closed_remesh() -> None:
    """The remesher's chart path (flips, walls by the even-odd rule) on a small closed surface."""
    simplify(ellipsoid(400), method="remesh", max_vertices=120)


def _points_job() -> None:
    """Point clouds: a TIN of every point (in strips, and in one piece; the triangles alone, and with twins as
    greedy starts from) and greedy insertion on the points."""
    from .triangulation.pointtin import build_point_tin, tin
    from .triangulation.strips import STRIP_POINTS

    hf, _ = _pieces()
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 1000, size=(2 * STRIP_POINTS + 3000, 2))
    cloud = PointCloud(np.column_stack([xy, np.sin(xy[:, 0] / 90) * 20 + xy[:, 1] * 0.01]), crs=hf.crs)
    tin(cloud, workers=1)
    build_point_tin(cloud.xyz, workers=1)
    small = PointCloud(cloud.xyz[:3000], crs=hf.crs)
    tin(small, workers=1)
    simplify(small, method="greedy", max_error=1.0)


def _city_job() -> None:
    """The city model on a small synthetic block of buildings."""
    from .algorithms.urban.city import city

    z = np.zeros((60, 60))
    z[10:25, 10:30] = 9.0
    z[30:50, 35:55] = np.linspace(6.0, 12.0, 20)[None, :]
    city(Heightfield(z, cell_size=1.0, origin=(0.0, 0.0)), solid=True)


def _filters_job() -> None:
    """Goebbels and Pohle-Fröhlich (2015)'s wavelet filter and mesh, and the Salt Lake City thesis' block model."""
    from .algorithms.urban.urban import blocks
    from .algorithms.wavelet.wavelet import wavelet

    _, pieces = _pieces()
    for h in pieces:
        wavelet(h)
        blocks(h)


def _hydrology_job() -> None:
    """Drainage on the pieces: the filled surface, flow, stream lines and the height above them."""
    from .hydrology import height_above_drainage, stream_lines

    _, pieces = _pieces()
    for h in pieces:
        stream_lines(h, min_area=20 * h.cell_size[0] * h.cell_size[1])
        height_above_drainage(h, min_area=20 * h.cell_size[0] * h.cell_size[1])


def _reconstruct_job() -> None:
    """Gopi and Krishnan (2002)'s reconstruction: a height field of points and a closed surface (a sphere)."""
    from .algorithms.reconstruct.reconstruct import reconstruct

    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 100, size=(4000, 2))
    reconstruct(np.column_stack([xy, np.sin(xy[:, 0] / 9) * 3]))
    v = rng.normal(size=(4000, 3))
    reconstruct(20 * v / np.linalg.norm(v, axis=1)[:, None], mode="general")
    # the strips' pieces turned before the joining front (a cloud of 200,000 points or more): on one triangle
    from .kernels import front_mesh

    p = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    tri, nxt = np.array([[0, 1, 2]], np.int32), np.full(3, -1, np.int32)
    first, end = np.zeros(1, np.int64), np.ones(1, np.int64)
    label, _ = front_mesh.pieces(p, tri, first, end)
    front_mesh.turn_pieces(tri, nxt, first, end, label, np.zeros(3, np.bool_))


def _tiles_job() -> None:
    """Tiled runs of the sample file, greedy and quadtree (the seams)."""
    from .tiles.run import tile_raster

    for method in ("greedy", "quadtree"):
        tile_raster(sample_path("st-helens"), max_error=20.0, method=method, tile_size=200, workers=1).merge()


#: name -> (description, job); :func:`warmup` runs them in this order.
JOBS: dict[str, tuple[str, Callable[[], None]]] = {
    "default": ("greedy insertion and the metrics (the README's first command)", _default_job),
    "methods": ("every registered method", _methods_job),
    "points": ("point clouds", _points_job),
    "city": ("city models", _city_job),
    "filters": ("the wavelet filter and the block model", _filters_job),
    "hydrology": ("drainage: filled surface, flow, streams, height above them", _hydrology_job),
    "reconstruct": ("surface reconstruction", _reconstruct_job),
    "tiles": ("tiled runs", _tiles_job),
}


def warmup(jobs=None, progress: Callable[[str], None] | None = None) -> dict[str, float]:
    """Run the jobs ``jobs`` (names of :data:`JOBS`, default all); return the seconds each took."""
    names = list(JOBS) if jobs is None else list(jobs)
    unknown = [n for n in names if n not in JOBS]
    if unknown:
        raise InvalidOptionError(f"warmup job {unknown[0]!r} is unknown; the jobs are: {', '.join(JOBS)}")
    seconds = {}
    for name in names:
        if progress is not None:
            progress(name)
        start = time.perf_counter()
        JOBS[name][1]()
        seconds[name] = time.perf_counter() - start
    return seconds
