"""Triangle shape quality in 3-D and in the x-y projection (METHODS.md conventions)."""

from __future__ import annotations

import numpy as np

from ..core import TerrainMesh
from ..triangulation.shape import aspect_ratios, triangle_angles

__all__ = ["triangle_angles", "aspect_ratios", "triangle_quality"]


def _summary(values: np.ndarray) -> dict:
    return {"min": float(values.min()), "median": float(np.median(values)), "max": float(values.max())}


def triangle_quality(mesh: TerrainMesh, dims: int = 3) -> dict:
    """Min angle, max angle and aspect ratio (min, median, max) and the share below 20 degrees.

    Parameters
    ----------
    mesh : TerrainMesh
    dims : {3, 2}
        3 for the triangles in space (what a simulation sees), 2 for their
        x-y projection.

    Returns
    -------
    dict
        ``min_angle``, ``max_angle``, ``aspect_ratio`` (each a dict of min,
        median, max) and ``share_min_angle_below_20`` (0..1).

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> flat = tinsmith.grid(tinsmith.Heightfield(np.zeros((4, 4)), cell_size=1.0))
    >>> quality = tinsmith.triangle_quality(flat, dims=2)  # right isosceles triangles
    >>> print(f'{quality["min_angle"]["min"]:.1f} {quality["max_angle"]["max"]:.1f}')
    45.0 90.0
    >>> quality["share_min_angle_below_20"]
    0.0
    """
    if mesh.n_triangles == 0:
        nan = {"min": np.nan, "median": np.nan, "max": np.nan}
        return {"min_angle": nan, "max_angle": nan, "aspect_ratio": nan, "share_min_angle_below_20": np.nan}
    angles = triangle_angles(mesh, dims)
    smallest = angles.min(axis=1)
    return {
        "min_angle": _summary(smallest),
        "max_angle": _summary(angles.max(axis=1)),
        "aspect_ratio": _summary(aspect_ratios(mesh, dims)),
        "share_min_angle_below_20": float(np.mean(smallest < 20.0)),
    }
