"""Vertical error of a mesh against a heightfield, over every valid cell."""

from __future__ import annotations

import numpy as np

from ..core import Heightfield, TerrainMesh
from ..errors import InvalidInputError
from ..kernels.raster import sample_triangles
from ..triangulation.sampling import rasterize

__all__ = ["rasterize", "source_error", "vertical_error", "vertical_error_at_points"]


def vertical_error(mesh: TerrainMesh, hf: Heightfield) -> dict:
    """TIN height minus DEM height at every valid cell centre the mesh covers.

    Returns
    -------
    dict
        ``max`` (max |e|), ``rmse``, ``mean_abs``, ``bias`` (mean e),
        ``p99`` (99th percentile of |e|), ``coverage`` (share of valid cells the
        mesh covers, 0..1), ``n_valid`` and ``n_covered``.  Error statistics are
        NaN when the mesh covers no valid cell.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> error = tinsmith.vertical_error(tinsmith.quadtree(dem, max_error=5.0), dem)
    >>> error["max"] <= 5.0, error["rmse"] <= error["max"], error["coverage"]
    (True, True, 1.0)
    >>> error["n_valid"] == dem.n_valid
    True
    """
    tin = rasterize(mesh, hf)
    valid = hf.valid
    covered = valid & ~np.isnan(tin)
    return _statistics(tin[covered] - hf.z[covered], int(valid.sum()))


def vertical_error_at_points(mesh: TerrainMesh, points) -> dict:
    """TIN height minus the point's height at every point ``(x, y, z)`` the mesh covers (a dense mesh's vertices, say).

    Returns the dict of :func:`vertical_error`, ``n_valid`` counting the points.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> dense = tinsmith.grid(dem)  # a dense mesh: every cell a vertex
    >>> coarse = tinsmith.decimate(dense, max_error=5.0)
    >>> error = tinsmith.vertical_error_at_points(coarse, dense.vertices)
    >>> error["n_valid"] == dense.n_vertices, error["max"] <= 5.0
    (True, True)
    """
    if not isinstance(mesh, TerrainMesh):
        raise InvalidInputError(f"vertical_error_at_points needs a TerrainMesh, got {type(mesh).__name__}")
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InvalidInputError(f"points must have shape (N, 3), got {p.shape}")
    v = mesh.vertices
    tin = sample_triangles(v[:, 0].copy(), v[:, 1].copy(), v[:, 2].copy(), mesh.triangles, p[:, 0].copy(), p[:, 1].copy())
    covered = ~np.isnan(tin)
    return _statistics(tin[covered] - p[covered, 2], len(p))


def _statistics(e: np.ndarray, n_valid: int) -> dict:
    out = {"n_valid": n_valid, "n_covered": int(e.size), "coverage": e.size / n_valid if n_valid else np.nan}
    if e.size == 0:
        out.update(max=np.nan, rmse=np.nan, mean_abs=np.nan, bias=np.nan, p99=np.nan)
        return out
    a = np.abs(e)
    out.update(
        max=float(a.max()),
        rmse=float(np.sqrt(np.mean(e * e))),
        mean_abs=float(a.mean()),
        bias=float(e.mean()),
        p99=float(np.percentile(a, 99)),
    )
    return out


def source_error(mesh: TerrainMesh, source, options: dict | None = None) -> dict:
    """The vertical error of ``mesh`` against what it was made of, as the command line reports it.

    Every valid cell of a :class:`Heightfield`; every point of a :class:`PointCloud`, one a x-y by the
    ``duplicates`` rule of ``options`` (default ``"lowest"``, as the TIN of the points keeps them), not
    those inside its ``holes`` or ``flat`` polygons; every vertex of a :class:`TerrainMesh`.
    """
    from ..core import PointCloud

    if isinstance(source, Heightfield):
        return vertical_error(mesh, source)
    if isinstance(source, PointCloud):
        from ..triangulation.pointtin import checked_points

        options = options or {}
        return vertical_error_at_points(mesh, checked_points(source, options.get("duplicates", "lowest"),
                                                             holes=options.get("holes"), flat=options.get("flat")))
    return vertical_error_at_points(mesh, source.vertices)

