"""Full-resolution grid triangulation: every valid cell centre a vertex (the ``grid`` method).

The reference mesh every method is judged against, and the starting point of
decimation, remeshing and cCVT's curvature.  Each square of four neighbouring
cell centres becomes two triangles; the diagonal follows Goebbels and Pohle-Fröhlich (2015) (section 2, formula 1): with ``h`` the
mean of the four corner heights, the square is cut along the diagonal
``(r, c)-(r+1, c+1)`` when ``max(|z00 - h|, |z11 - h|) < max(|z10 - h|, |z01 - h|)``
and along the other one otherwise.  A square with one nodata corner keeps the
one triangle its three valid corners make; with two or more it is left out, so
holes in the data are holes in the mesh.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..core import Heightfield, TerrainMesh
from ..errors import NoDataError

__all__ = ["diagonal_rule", "filled", "grid_mesh", "lattice_mesh"]


def grid_mesh(hf: Heightfield) -> TerrainMesh:
    """The full-resolution mesh of ``hf`` (what the ``grid`` method returns, without registry bookkeeping)."""
    h, w = hf.shape
    return lattice_mesh(hf, np.arange(h), np.arange(w))


def diagonal_rule(heights: np.ndarray) -> np.ndarray:
    """(H-1, W-1) bool: True where Goebbels and Pohle-Fröhlich (2015)'s formula 1 cuts the square along (r, c)-(r+1, c+1).

    The module docstring describes the rule.
    """
    z = np.asarray(heights).astype(np.float64, copy=False)  # the rule in full precision
    za, zb, zc, zd = z[:-1, :-1], z[:-1, 1:], z[1:, :-1], z[1:, 1:]
    with np.errstate(invalid="ignore"):
        mean = (za + zb + zc + zd) / 4.0
        return np.maximum(abs(za - mean), abs(zd - mean)) < np.maximum(abs(zb - mean), abs(zc - mean))


def lattice_mesh(hf: Heightfield, keep_rows: np.ndarray, keep_cols: np.ndarray) -> TerrainMesh:
    """The mesh of the lattice of cells ``keep_rows x keep_cols`` (increasing indices into ``hf``).

    Every valid lattice node is a vertex; each square of four neighbouring
    nodes becomes two triangles by the diagonal rule, one triangle when a
    corner is nodata, none with two or more.
    """
    sub = np.ix_(keep_rows, keep_cols)
    valid = hf.valid[sub]
    h, w = valid.shape
    index = np.full((h, w), -1, dtype=np.int64)
    rows, cols = np.nonzero(valid)
    index[rows, cols] = np.arange(len(rows))
    x, y = hf.pixel_to_world(keep_rows[rows], keep_cols[cols])
    heights = hf.z[sub]
    vertices = np.column_stack([x, y, heights[rows, cols]])

    # corners of every square: a=(r,c) b=(r,c+1) c=(r+1,c) d=(r+1,c+1)
    ia, ib, ic, id_ = index[:-1, :-1], index[:-1, 1:], index[1:, :-1], index[1:, 1:]
    va, vb, vc, vd = ia >= 0, ib >= 0, ic >= 0, id_ >= 0
    n_valid = va.astype(np.int8) + vb + vc + vd
    main_diag = diagonal_rule(heights)

    full = n_valid == 4
    parts = []
    sel = full & main_diag  # diagonal a-d
    parts += [(ia[sel], ic[sel], id_[sel]), (ia[sel], id_[sel], ib[sel])]
    sel = full & ~main_diag  # diagonal b-c
    parts += [(ia[sel], ic[sel], ib[sel]), (ib[sel], ic[sel], id_[sel])]
    three = n_valid == 3
    for present, corners in ((va, (ib, ic, id_)), (vb, (ia, ic, id_)), (vc, (ia, id_, ib)), (vd, (ia, ic, ib))):
        sel = three & ~present  # this corner is the missing one
        parts.append(tuple(c[sel] for c in corners))
    triangles = np.concatenate([np.column_stack(p) for p in parts])
    if len(triangles) == 0:
        raise NoDataError("no square of neighbouring cells has three valid corners; nothing to triangulate")
    mesh = TerrainMesh(vertices, triangles, crs=hf.crs)
    # orient counter-clockwise seen from +z whatever the transform's handedness
    cw = mesh.signed_areas_2d() < 0
    mesh.triangles[cw] = mesh.triangles[cw][:, [0, 2, 1]]
    mesh.info["grid"] = hf.grid_spec()
    return mesh


def filled(hf: Heightfield) -> np.ndarray:
    """The heights as float64 with every nodata cell given the height of the nearest valid cell (for filters)."""
    z = hf.z.astype(np.float64)
    valid = hf.valid
    if not valid.all():
        nearest = ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
        z = z[tuple(nearest)]
    return z
