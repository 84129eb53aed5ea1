"""Triangle shape quality in 3-D and in the x-y projection (METHODS.md conventions)."""

from __future__ import annotations

import numpy as np

from ..core import TerrainMesh

__all__ = ["triangle_angles", "aspect_ratios", "triangle_quality"]


def _corners(mesh: TerrainMesh, dims: int) -> np.ndarray:
    if dims not in (2, 3):
        raise ValueError(f"dims must be 2 or 3, got {dims!r}")
    p = mesh.vertices[mesh.triangles][:, :, :dims]
    return p - p[:, :1, :]  # relative to the first corner: no cancellation at world offsets


def _cross_norm(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    if u.shape[-1] == 2:
        return np.abs(u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0])
    return np.linalg.norm(np.cross(u, v), axis=-1)


def triangle_angles(mesh: TerrainMesh, dims: int = 3) -> np.ndarray:
    """(M, 3) interior angles in degrees at each corner (``atan2(|u x v|, u . v)``)."""
    p = _corners(mesh, dims)
    angles = np.empty(p.shape[:2])
    for k in range(3):
        u = p[:, (k + 1) % 3] - p[:, k]
        v = p[:, (k + 2) % 3] - p[:, k]
        angles[:, k] = np.degrees(np.arctan2(_cross_norm(u, v), np.einsum("ij,ij->i", u, v)))
    return angles


def aspect_ratios(mesh: TerrainMesh, dims: int = 3) -> np.ndarray:
    """(M,) ``longest_edge * perimeter / (4 sqrt(3) area)``: 1 for equilateral, inf if degenerate."""
    p = _corners(mesh, dims)
    edges = np.stack([np.linalg.norm(p[:, (k + 1) % 3] - p[:, k], axis=1) for k in range(3)], axis=1)
    area = 0.5 * _cross_norm(p[:, 1], p[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = edges.max(axis=1) * edges.sum(axis=1) / (4.0 * np.sqrt(3.0) * area)
    ratio[area == 0] = np.inf
    return ratio


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
