"""Fitted heights: the least-squares heights of a mesh's vertices against every cell it covers.

As in Duan et al. (2016)'s TINs, and for other meshes too.

Every method here interpolates: a vertex takes the height of its cell.
With the triangles fixed, the heights that minimise the sum of squared
vertical errors over all covered cells solve a sparse linear least-squares
problem (each cell's height is a barycentric combination of three
vertices).  It is solved by conjugate gradients on the normal equations,
matrix-free (numba), started from the interpolating heights, with a tiny
pull towards them (1e-9 of the mean weight) so that a vertex no cell sees
keeps its height.  The RMS error over the cells can only fall; the largest
error may rise: the mesh becomes approximating, not interpolating.
"""

from __future__ import annotations

import numpy as np

from ...core import Heightfield, TerrainMesh
from ...errors import InvalidInputError
from ...kernels.fit import normal_product, right_side
from ...kernels.raster import cell_weights

__all__ = ["fit_heights"]


def fit_heights(mesh: TerrainMesh, hf: Heightfield, *, tol: float = 1e-10, max_iter: int = 2000) -> TerrainMesh:
    """A copy of ``mesh`` with the vertex heights that minimise the squared vertical error over the valid cells it covers.

    The copy carries the mesh's attributes and edge data.  ``mesh.info["fit"]``
    reports the conjugate-gradient iterations and the final relative residual.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> mesh = tinsmith.greedy(dem, max_vertices=150)
    >>> fitted = tinsmith.fit_heights(mesh, dem)
    >>> bool((fitted.vertices[:, :2] == mesh.vertices[:, :2]).all())  # the same x-y, new heights
    True
    >>> tinsmith.vertical_error(fitted, dem)["rmse"] < tinsmith.vertical_error(mesh, dem)["rmse"]
    True
    """
    if not isinstance(mesh, TerrainMesh) or not isinstance(hf, Heightfield):
        raise InvalidInputError(
            f"fit_heights needs a TerrainMesh and a Heightfield, got {type(mesh).__name__} and {type(hf).__name__}"
        )
    rows, cols = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    h, w = hf.shape
    owner, bary = cell_weights(np.round(cols, 9), np.round(rows, 9), mesh.triangles, h, w)
    owner_flat, bary_flat = owner.ravel(), bary.reshape(-1, 3)
    cells = np.flatnonzero((owner_flat >= 0) & hf.valid.ravel())
    if len(cells) == 0:
        raise InvalidInputError("the mesh covers no valid cell of the heightfield: nothing to fit")
    target = hf.z.ravel()[cells].astype(np.float64)
    z0 = mesh.vertices[:, 2].astype(np.float64)
    shift = float(target.mean())  # solve for heights about the mean: better conditioned
    reg = 1e-9 * len(cells) / max(mesh.n_vertices, 1)
    b = right_side(mesh.triangles, owner_flat, bary_flat, cells, target - shift, z0 - shift, reg)
    z = z0 - shift
    az = np.empty_like(z)
    normal_product(mesh.triangles, owner_flat, bary_flat, cells, z, az, reg)
    r = b - az
    p = r.copy()
    rr = float(r @ r)
    norm_b = float(np.sqrt(b @ b)) or 1.0
    it = 0
    while it < max_iter and np.sqrt(rr) > tol * norm_b:
        normal_product(mesh.triangles, owner_flat, bary_flat, cells, p, az, reg)
        alpha = rr / float(p @ az)
        z += alpha * p
        r -= alpha * az
        rr_new = float(r @ r)
        p = r + (rr_new / rr) * p
        rr = rr_new
        it += 1
    vertices = mesh.vertices.copy()
    vertices[:, 2] = z + shift
    out = mesh.copy(vertices=vertices)
    out.info["fit"] = {"iterations": it, "residual": float(np.sqrt(rr) / norm_b)}
    return out
