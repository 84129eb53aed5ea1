"""Mean curvature of a DEM and the curvature density of the cCVT (Duan et al. 2016, section 2; Meyer et al. 2003).

The curvature is computed on the full-resolution grid mesh (every valid
cell a vertex, :func:`tinsmith.triangulation.grid.grid_mesh`) with the cotangent formula and mixed areas
of Meyer, Desbrun, Schroeder and Barr (2003), the estimate Duan et al. (2016) uses:
``H = K . n / 2`` with ``K`` the mean curvature normal and ``n`` the upward
vertex normal, so peaks and ridges are positive, pits and valleys negative,
in 1 / (z units), the x-y units taken equal to z units.  At the border of
the data, where a vertex has triangles on one side only, the formula does
not hold: there the curvature is the mean of the interior neighbours'.
"""

from __future__ import annotations

import numpy as np

from ... import _checks
from ...core import Heightfield
from ...kernels.curvature import mean_curvature_normal
from ...triangulation.edges import fill_from_neighbours
from ...triangulation.grid import grid_mesh

__all__ = ["curvature_density", "mean_curvature"]


def mean_curvature(hf: Heightfield) -> np.ndarray:
    """(H, W) signed mean curvature at every valid cell (NaN at nodata); see the module docstring."""
    mesh = grid_mesh(hf)
    k, area, normal = mean_curvature_normal(mesh.vertices - mesh.vertices.mean(axis=0), mesh.triangles)
    length = np.linalg.norm(normal, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        h = 0.5 * np.einsum("ij,ij->i", k, normal) / (length * 2.0 * area)
    # border vertices: an edge of one triangle touches them
    e = np.sort(np.concatenate([mesh.triangles[:, [0, 1]], mesh.triangles[:, [1, 2]], mesh.triangles[:, [2, 0]]]), axis=1)
    edges, counts = np.unique(e, axis=0, return_counts=True)
    border = np.zeros(mesh.n_vertices, bool)
    border[edges[counts == 1].ravel()] = True
    h[border | ~np.isfinite(h)] = np.nan
    # the border takes the mean of its neighbours that have a value, inwards first (corners need two rounds)
    h = fill_from_neighbours(h, edges)  # a vertex with no interior vertex near (a sliver of data): 0
    out = np.full(hf.shape, np.nan)
    rows, cols = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    out[np.round(rows).astype(int), np.round(cols).astype(int)] = h
    return out


def curvature_density(hf: Heightfield, *, gamma: float = 1.0, floor: float = 0.1) -> np.ndarray:
    """(H, W) density of the cCVT: ``max(|H|, floor * mean |H|) ** gamma``, normalised to mean 1 (NaN at nodata).

    ``gamma`` sharpens (> 1) or flattens (< 1) the contrast between curved
    and flat terrain; ``floor`` (a share of the mean absolute curvature)
    keeps flat areas sampled.
    """
    gamma = _checks.number("density_gamma", gamma, minimum=0.0)
    floor = _checks.number("floor", floor, minimum=0.0, exclusive_min=True)
    h = np.abs(mean_curvature(hf))
    level = np.nanmean(h)
    rho = np.maximum(h, floor * level if level > 0 else 1.0) ** gamma
    return rho / np.nanmean(rho)
