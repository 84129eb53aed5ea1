"""The seam contract: every tile edge is simplified once, as a 1-D problem, and fixed.

A tile edge (a seam between two tiles, or a side of the DEM) is a line of
cells that both tiles hold.  Its profile is simplified within the error bound
(:func:`tinsmith.kernels.seam.simplify_profile`); the kept cells become
vertices of both tiles and the cells between them are set to the straight
line through their neighbours, so that the tile's method never needs another
vertex there (the line is exact on them) and never adds one.  Both tiles
compute the same kept cells from the same cells, so the merged mesh has no
crack and no T-junction.

Forced cells: the tile corners and every cell where the shape of the data
changes along the seam, on either side of it (the 2 x 2 validity pattern of
the squares the seam bounds).  The outline of the data, which greedy
insertion keeps as constrained edges, bends only at such cells, so it meets
the seam at vertices of the seam in both tiles.  The pattern of the far side
comes from a halo of one cell around the tile.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from ..kernels.seam import simplify_profile

__all__ = ["SeamSides", "seam_sides"]


class SeamSides:
    """The kept cells of a tile's four sides and the tile heights with the sides set to their lines.

    Attributes
    ----------
    nodes : (K, 2) int64
        (row, col) in the tile of every kept cell (the seam vertices).
    z : (h, w) float64
        The tile's heights with every side cell between two kept ones replaced
        by the line through them (NaN where there is no data).
    max_error : float
        Largest distance of a side cell from its line (at most the bound).
    """

    def __init__(self, nodes: np.ndarray, z: np.ndarray, max_error: float):
        self.nodes = nodes
        self.z = z
        self.max_error = max_error


def _pattern(line: np.ndarray, beside: np.ndarray | None) -> np.ndarray:
    """Per square along a line: the 2 x 2 validity pattern (0..15) of it and the line beside it (0 if none)."""
    a = line[:-1].astype(np.int8) + 2 * line[1:]
    if beside is None:
        return a
    return a + 4 * beside[:-1] + 8 * beside[1:]


def _side(z: np.ndarray, valid: np.ndarray, before, after, bound: float):
    """Kept indices along one side and the side's heights set to the lines between them."""
    n = len(z)
    keep = np.zeros(n, np.uint8)
    keep[0] = keep[-1] = 1
    p1, p2 = _pattern(valid, before), _pattern(valid, after)
    change = (p1[1:] != p1[:-1]) | (p2[1:] != p2[:-1])
    keep[1:-1] |= change
    keep &= valid
    # spans between kept cells that are all valid are simplified; others hold no data
    zz = np.where(valid, z, 0.0).astype(np.float64)
    error = float(simplify_profile(zz, valid.astype(np.uint8), keep, bound, np.arange(len(zz), dtype=np.float64)))
    idx = np.flatnonzero(keep)
    line = np.array(z, dtype=np.float64)
    for a, b in pairwise(idx.tolist()):
        if b - a > 1 and valid[a:b + 1].all():
            k = np.arange(a + 1, b)
            line[a + 1:b] = zz[a] + (zz[b] - zz[a]) * ((k - a) / (b - a))
    return idx, line, error


def seam_sides(z: np.ndarray, valid: np.ndarray, rows: tuple[int, int], cols: tuple[int, int], bound: float) -> SeamSides:
    """Seam vertices and side lines of the tile ``z[rows[0]:rows[1]+1, cols[0]:cols[1]+1]`` of a halo window.

    Parameters
    ----------
    z, valid : (H, W) arrays
        The window read around the tile: the tile plus a halo of one cell
        where the raster goes on (none at the raster's own edges).
    rows, cols : (int, int)
        First and last row and column of the tile in the window.
    bound : float
        The error bound of the run.
    """
    r0, r1 = rows
    c0, c1 = cols
    H, W = z.shape
    tz = np.array(z[r0:r1 + 1, c0:c1 + 1], dtype=np.float64)
    nodes = []
    worst = 0.0

    def row_side(r):
        before = valid[r - 1, c0:c1 + 1] if r > 0 else None
        after = valid[r + 1, c0:c1 + 1] if r + 1 < H else None
        return _side(z[r, c0:c1 + 1], valid[r, c0:c1 + 1], before, after, bound)

    def col_side(c):
        before = valid[r0:r1 + 1, c - 1] if c > 0 else None
        after = valid[r0:r1 + 1, c + 1] if c + 1 < W else None
        return _side(z[r0:r1 + 1, c], valid[r0:r1 + 1, c], before, after, bound)

    for r in (r0, r1):
        idx, line, err = row_side(r)
        tz[r - r0, :] = line
        nodes.append(np.column_stack([np.full(len(idx), r - r0), idx]))
        worst = max(worst, err)
    for c in (c0, c1):
        idx, line, err = col_side(c)
        tz[:, c - c0] = line
        nodes.append(np.column_stack([idx, np.full(len(idx), c - c0)]))
        worst = max(worst, err)
    tz[~valid[r0:r1 + 1, c0:c1 + 1]] = np.nan
    rc = np.unique(np.concatenate(nodes).astype(np.int64), axis=0)
    return SeamSides(rc, tz, worst)
