"""The ``grid`` method: the full-resolution triangulation of :mod:`tinsmith.triangulation.grid`, registered."""

from __future__ import annotations

from ...core import Heightfield, TerrainMesh
from ...triangulation.grid import grid_mesh
from ..registry import register

__all__ = ["grid"]


@register("grid")
def grid(hf: Heightfield, *, progress=None) -> TerrainMesh:
    """Triangulate every valid cell of the heightfield (no simplification).

    The vertical error against ``hf`` is zero at every valid cell centre.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> dem = tinsmith.Heightfield(np.arange(12.0).reshape(3, 4), cell_size=1.0)
    >>> mesh = tinsmith.grid(dem)
    >>> mesh.n_vertices, mesh.n_triangles  # every cell a vertex, two triangles a square of cells
    (12, 12)
    >>> print(tinsmith.vertical_error(mesh, dem)["max"])
    0.0
    """
    return grid_mesh(hf)
