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
    """
    return grid_mesh(hf)
