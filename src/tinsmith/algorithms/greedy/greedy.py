"""Greedy insertion, the method: on a DEM, straight on a point cloud, or on a large DEM in tiles on threads.

On a DEM it runs the engine of :mod:`.engine`; on a point cloud, the one of
:mod:`.greedy_points` from the TIN of :mod:`tinsmith.triangulation.pointtin`.
The multi-worker path (``workers``) is a tiled run, so it lives with the tiled
runs, a layer above the methods (:func:`tinsmith.tiles.run.tile_heightfield`,
:func:`tinsmith.tiles.point_threads.tile_points`); this module reaches them
through the hooks ``tile_heightfield`` and ``tile_points`` of
:mod:`tinsmith._hooks`.
"""

from __future__ import annotations

import os

from ... import _hooks
from ...core import Heightfield, PointCloud, StopCriteria, TerrainMesh
from ...core.stop import default_max_error
from ...errors import InvalidOptionError
from ...triangulation.pointtin import is_hull, point_tin
from ..registry import register
from .engine import GreedyEngine
from .greedy_points import default_point_max_error, point_greedy

__all__ = ["greedy"]


#: Grids of at least this many cells mesh on every core by default (``workers=None``).
PARALLEL_CELLS = 4_000_000
#: Point clouds of at least this many points mesh in tiles on every core by default (``workers=None``).
PARALLEL_POINTS = 1_000_000


@register("greedy")
def greedy(data, *, breaklines, control_points, max_edge, duplicates, holes, flat, workers, stop: StopCriteria,
           progress=None) -> TerrainMesh:
    """Greedy insertion (HFPR) with an exact vertical error bound, on a DEM or straight on a point cloud.

    On a :class:`Heightfield`: without any stop rule, ``max_error`` is 1/1000
    of the height range.  Nodata holes are cut out along the outline of the
    data; breaklines and control points are snapped to the nearest cells
    (see :class:`.engine.GreedyEngine`).

    On a :class:`PointCloud` (:mod:`.greedy_points`): the run starts from the
    outline of :func:`tinsmith.tin` (``max_edge``, ``duplicates``, ``holes``,
    ``flat``, ``breaklines`` as there; control points are draped on the TIN
    and kept) and inserts the input point of largest vertical error, so the
    bound is exact at every input point inside the outline.  ``workers`` > 1
    (None: every core for a cloud of at least :data:`PARALLEL_POINTS`
    points), with an error bound alone (or no stop rule), no breaklines,
    control points, holes or flat polygons, and an outline to cut: the points
    are meshed in tiles on threads as a survey is
    (:func:`tinsmith.tiles.point_threads.tile_points`: the bound at every
    point inside the outline, a mesh about as large as the one-piece one,
    the same on any number of workers above one; it differs from one piece
    along the seams and by its outline's ``max_edge``, taken from a sample of
    the points when "auto").  Otherwise the run is in one piece, its TIN
    triangulated in strips on ``workers`` threads
    (:mod:`tinsmith.triangulation.strips`: the same TIN, so the same mesh, on
    any number) and the insertions on one.  The options of point clouds
    (``max_edge``, ``duplicates``, ``holes``, ``flat``) are refused with a
    raster.

    ``workers`` > 1 (a raster with a ``max_error`` stop, no breaklines or
    control points): the grid is cut into tiles meshed on threads under the
    seam contract of ``tinsmith tile`` (:func:`tinsmith.tiles.run.tile_heightfield`):
    the same bound at every valid cell, no crack, a mesh about as large as
    the one-piece one.  ``workers=1`` is the one-piece run.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> mesh = tinsmith.greedy(dem, max_error=10.0)
    >>> mesh.n_vertices < dem.n_valid, tinsmith.vertical_error(mesh, dem)["max"] <= 10.0
    (True, True)
    >>> tinsmith.greedy(dem, max_vertices=200).n_vertices <= 200
    True
    """
    if isinstance(data, PointCloud):
        if _tiles_points(data, workers, stop, max_edge, any(v is not None for v in (breaklines, control_points, holes, flat))):
            max_error = stop.max_error if stop.is_set else default_point_max_error(data.xyz)
            mesh = _hooks.call("tile_points", data, max_error=max_error, duplicates=duplicates, max_edge=max_edge,
                               workers=workers, progress=progress)
            if mesh is not None:  # (None: the points make one tile)
                mesh.info["max_error_used"] = max_error
                return mesh
        ptin = point_tin(data, duplicates=duplicates, max_edge=max_edge, breaklines=breaklines, holes=holes,
                         flat=flat, control_points=control_points, workers=workers)
        return point_greedy(ptin, stop, crs=data.crs, progress=progress)
    if not stop.is_set:  # (the registry refused the options of point clouds, max_edge to flat, with a raster)
        stop = StopCriteria(max_error=default_max_error(data))
    threads = _threads(data, workers, stop, breaklines is not None or control_points is not None)
    if threads > 1:
        mesh = _hooks.call("tile_heightfield", data, max_error=stop.max_error, workers=threads)
        mesh.info.update(max_error_used=stop.max_error, workers=threads)
        if progress is not None:
            progress(1.0)
        return mesh
    engine = GreedyEngine(data, breaklines=breaklines, control_points=control_points)
    engine.refine(stop.max_error, stop.max_vertices, stop.max_triangles, progress=progress)
    mesh = engine.to_mesh()
    mesh.info["max_error_used"] = stop.max_error
    return mesh


def _tiles_points(cloud: PointCloud, workers, stop: StopCriteria, max_edge, constrained: bool) -> bool:
    """Whether ``cloud`` is meshed in tiles on threads: ``workers`` > 1 (None: a cloud of at least
    :data:`PARALLEL_POINTS` points), an error bound alone, no constraint and an outline to cut."""
    if workers is None:
        workers = (os.cpu_count() or 1) if len(cloud) >= PARALLEL_POINTS else 1
    bound_only = stop.max_vertices is None and stop.max_triangles is None
    return workers > 1 and bound_only and not constrained and not is_hull(max_edge)


def _threads(hf: Heightfield, workers, stop: StopCriteria, constrained: bool) -> int:
    """How many threads mesh ``hf``: ``workers``, or every core for a large grid with an error bound."""
    tiled_rule = stop.max_error is not None and stop.max_vertices is None and stop.max_triangles is None
    if workers is None:
        return (os.cpu_count() or 1) if tiled_rule and not constrained and hf.n_cells >= PARALLEL_CELLS else 1
    if workers > 1 and not tiled_rule:
        raise InvalidOptionError(
            f"workers={workers} meshes tiles to an error bound: give max_error alone (or workers=1 for "
            "max_vertices / max_triangles)"
        )
    if workers > 1 and constrained:
        raise InvalidOptionError(f"workers={workers} does not take breaklines or control points; use workers=1")
    return workers
