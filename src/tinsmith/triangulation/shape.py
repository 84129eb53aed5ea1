"""The shape of triangles: interior angles and aspect ratios, in 3-D or seen from above (x, y).

Below both the metrics (:mod:`tinsmith.metrics.quality`, which reports them)
and the writers (:mod:`tinsmith.io.slivers`, which warns of slivers in a
solver's file), which are layers side by side.
"""

from __future__ import annotations

import numpy as np

from ..core import TerrainMesh

__all__ = ["triangle_angles", "aspect_ratios"]


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
