"""A TIN on a grid: its heights at the cell centres of a heightfield.

What the vertical error is measured on (:mod:`tinsmith.metrics`), what the
GeoTIFF writer and ``TerrainMesh.to_xarray`` write, and what the methods that
compare a mesh with its grid read (the wavelet method's levels, the city
model's ground).
"""

from __future__ import annotations

import numpy as np

from ..core import Heightfield, TerrainMesh
from ..errors import InvalidInputError
from ..kernels.raster import rasterize_triangles

__all__ = ["rasterize"]

#: Pixel coordinates closer than this to a whole number are snapped to it, so a
#: vertex placed on a cell centre reproduces that cell's height exactly.
_SNAP = 1e-6


def rasterize(mesh: TerrainMesh, grid: Heightfield) -> np.ndarray:
    """Heights of ``mesh`` at the cell centres of ``grid``.

    Parameters
    ----------
    mesh : TerrainMesh
        Any triangle mesh in the CRS of ``grid``.
    grid : Heightfield
        The grid to sample on (its heights are not used).

    Returns
    -------
    (H, W) ndarray of float64
        Linear interpolation inside the covering triangle; NaN where no triangle
        covers the cell centre.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> import numpy as np
    >>> heights = tinsmith.rasterize(tinsmith.grid(dem), dem)
    >>> heights.shape, bool(np.allclose(heights, dem.z))  # the full-resolution mesh gives the DEM back
    ((64, 64), True)
    """
    if not isinstance(mesh, TerrainMesh) or not isinstance(grid, Heightfield):
        raise InvalidInputError(
            f"rasterize needs a TerrainMesh and a Heightfield, got {type(mesh).__name__} and {type(grid).__name__}"
        )
    row, col = grid.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    row, col = _snap(row), _snap(col)
    h, w = grid.shape
    return rasterize_triangles(col, row, mesh.vertices[:, 2].copy(), mesh.triangles, h, w)


def _snap(a: np.ndarray) -> np.ndarray:
    r = np.round(a)
    return np.where(np.abs(a - r) < _SNAP, r, a)
