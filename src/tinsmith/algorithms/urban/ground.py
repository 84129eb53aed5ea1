"""The ground under a surface model or a point cloud: a progressive morphological filter that holds on hills.

A surface model (DSM) holds the ground and what stands on it.  The ground
is found in three steps:

1. **Progressive morphological filter** (Zhang, Chen, Whitman, Shyu, Yan and
   Zhang 2003, "A progressive morphological filter for removing nonground
   measurements from airborne LIDAR data", IEEE Transactions on Geoscience
   and Remote Sensing 41(4), 872-882): the surface is opened (a minimum,
   then a maximum, over a square window) with windows growing
   exponentially, ``w_k = 2 * 2^k + 1`` cells (the paper's ``b = 2``), the
   last one ``max_window`` wide.  A cell higher than the opened surface by
   more than ``dh_k = min(dh_max, slope * (w_k - w_(k-1)) * c + dh0)`` is
   not ground (``c`` the cell size; ``dh0`` for the first window): an
   object narrower than a window is removed by it, and the threshold
   grows with the window as far as a slope of ``slope`` could raise the
   terrain across the added width.  The surface model itself is compared
   with each opening (not the previous opening), so a building of tiers,
   each lower than ``dh_max``, goes as a whole.
2. **Objects have walls** (beyond the paper): the opening also cuts the
   tops of hills, which rise gently, whatever the window (the cut of a
   crest of curvature ``k`` under a window ``w`` wide is ``k w^2 / 8``: 6 m
   for a sine of 5 m over 120 m under 60 m), and a threshold capped at
   ``dh_max`` takes them for objects.  What the filter takes out is split
   into pieces wherever the height above the widest opening changes
   between two neighbouring cells by more than a slope of ``wall_slope``
   allows, plus ``dh0`` (the slope test of Vosselman 2000, "Slope based
   filtering of laser altimetry data", IAPRS 33(B3), 935-942, over one
   cell); a piece stays off the ground when such walls make at least
   :data:`WALL_SHARE` of its edge.  Roofs and crowns stand on walls; the
   top of a hill has none, and is ground again.
3. **The DTM**: the ground cells keep their heights; the others are filled
   from them by Laplace's equation (:func:`laplace_fill`), exact on a
   plane, so the ground under a building on a slope continues the slope.
   Nodata stays nodata.

A point cloud is gridded first at ``cell_size``, each cell its lowest point
(the paper's minimum surface), and filtered the same way.

Lengths are in metres (the metre defaults are converted when the CRS's
unit is a foot); a surface model in a geographic CRS is refused.
"""

from __future__ import annotations

import numpy as np

from ... import _checks
from ...core import Heightfield, PointCloud
from ...errors import InvalidInputError, NoDataError
from .buildings import metres_per_unit
from .urban import GROUND_WINDOW, opening, require_metres

__all__ = ["DH0", "DH_MAX", "FILL_BATCH", "SLOPE", "WALL_SHARE", "WALL_SLOPE", "ground", "ground_cells", "laplace_fill"]

#: The threshold of the first window (m): what the smallest opening may cut from the ground (the paper's dh0).
DH0 = 0.3
#: The largest threshold (m): an object at least this high is removed once a window is wider than it (cars, sheds
#: and garden walls too, so the ground between the buildings is the ground).
DH_MAX = 1.0
#: The terrain slope (rise over run) the thresholds allow for as the windows grow: 45 degrees.
SLOPE = 1.0
#: A wall (rise over run, plus DH0) between two neighbouring cells, in the height above the widest opening: 45 degrees
#: plus DH0 (52 degrees between 1 m cells, 58 between 0.5 m cells; on a plane the height above the opening is 0).
WALL_SLOPE = 1.0
#: An object: a piece of what the filter takes out with walls along at least this share of its edge (a building
#: half dug into a slope, or whose walls a smoothed surface model blurs, still shows some).
WALL_SHARE = 0.1


def _windows(max_window: float, cell: float) -> list[int]:
    """Half-widths (cells) of the growing windows: 2^k cells each side, k = 0, 1, ..., the last one ``max_window`` wide."""
    last = max(1, int(np.ceil(max_window / (2.0 * cell))))
    halves, k = [], 0
    while 2**k < last:
        halves.append(2**k)
        k += 1
    return [*halves, last]


def _walls(cut: np.ndarray, cell: float, wall_slope: float, dh0: float) -> list:
    """Per neighbour direction (right, down, down-right, down-left): the slices of the two cells of each pair, whether
    both have data, and whether a wall stands between them (their heights above the opened surface ``cut`` differ by
    more than ``wall_slope`` times their distance plus ``dh0``)."""
    h, w = cut.shape
    pairs = []
    with np.errstate(invalid="ignore"):
        for (dr, dc) in ((0, 1), (1, 0), (1, 1), (1, -1)):
            limit = wall_slope * cell * np.hypot(dr, dc) + dh0
            a = (slice(0, h - dr), slice(max(0, -dc), w - max(0, dc)))
            b = (slice(dr, h), slice(max(0, dc), w - max(0, -dc)))
            diff = np.abs(cut[a] - cut[b])
            pairs.append((a, b, np.isfinite(diff), diff > limit))
    return pairs


def _walled(off: np.ndarray, pairs: list, share: float) -> np.ndarray:
    """The cells of ``off`` in pieces (8-connected, never across a wall) with walls along at least ``share`` of
    their edge (the pairs of one of their cells and a cell of no piece or of another piece; nodata left out)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    h, w = off.shape
    index = np.arange(h * w).reshape(h, w)
    src, dst = [], []
    for a, b, both, wall in pairs:
        ok = off[a] & off[b] & both & ~wall
        src.append(index[a][ok])
        dst.append(index[b][ok])
    src, dst = np.concatenate(src), np.concatenate(dst)
    graph = sp.coo_matrix((np.ones(len(src), np.int8), (src, dst)), shape=(h * w, h * w))
    _, labels = connected_components(graph, directed=False)
    labels = np.where(off.ravel(), labels, -1).reshape(h, w)
    n = int(labels.max()) + 1
    edge, walls = np.zeros(n), np.zeros(n)
    for a, b, both, wall in pairs:
        la, lb = labels[a], labels[b]
        across = both & (la != lb)
        for side in (la, lb):
            at = across & (side >= 0)
            edge += np.bincount(side[at], minlength=n)
            walls += np.bincount(side[at & wall], minlength=n)
    keep = np.r_[walls >= share * edge, False]
    return keep[labels]


def ground_cells(hf: Heightfield, *, max_window: float = GROUND_WINDOW, slope: float = SLOPE, dh0: float | None = None,
                 dh_max: float | None = None, wall_slope: float = WALL_SLOPE) -> np.ndarray:
    """(H, W) bool: the valid cells of ``hf`` that are ground (steps 1 and 2 of the module docstring; options of :func:`ground`).

    ``max_window`` is in world units, ``dh0`` and ``dh_max`` in z units
    (default :data:`DH0` and :data:`DH_MAX` metres, in the CRS's unit),
    ``slope`` and ``wall_slope`` rise over run.
    """
    if not isinstance(hf, Heightfield):
        raise InvalidInputError(f"ground_cells needs a Heightfield, got {type(hf).__name__}")
    max_window = _checks.number("max_window", max_window, minimum=0.0, exclusive_min=True)
    slope = _checks.number("slope", slope, minimum=0.0)
    wall_slope = _checks.number("wall_slope", wall_slope, minimum=0.0, exclusive_min=True)
    unit = 1.0 / metres_per_unit(hf.crs)
    dh0 = DH0 * unit if dh0 is None else _checks.number("dh0", dh0, minimum=0.0)
    dh_max = DH_MAX * unit if dh_max is None else _checks.number("dh_max", dh_max, minimum=0.0)
    if dh_max < dh0:
        raise InvalidInputError(f"dh_max must be >= dh0 ({dh0:g}), got {dh_max:g}")
    a, b, _, d, e, _ = hf.transform
    cell = float(np.sqrt(abs(a * e - b * d)))
    require_metres(hf.crs, hf.bounds, cell, max_window)
    valid = hf.valid
    if not valid.any():
        raise NoDataError("the surface model has no valid cell: no ground to find")
    z = np.where(valid, hf.z, np.nan).astype(np.float64)
    off = np.zeros(z.shape, bool)
    surface = z
    previous = 0
    for half in _windows(max_window, cell):
        surface = opening(surface, half)  # no floor: a steep slope's low edge would rise
        width, before = 2 * half + 1, 2 * previous + 1
        dh = dh0 if previous == 0 else min(dh_max, slope * (width - before) * cell + dh0)
        with np.errstate(invalid="ignore"):
            off |= (z - surface) > dh
        previous = half
    off &= valid
    return valid & ~_walled(off, _walls(z - surface, cell, wall_slope, dh0), WALL_SHARE)


#: Unknowns of one sparse solve of the Laplace fill: pieces are solved together up to this many (memory stays bounded).
FILL_BATCH = 250_000


def laplace_fill(hf: Heightfield, known: np.ndarray) -> np.ndarray:
    """(H, W) float64: the heights of ``known`` cells kept, the other valid cells filled by Laplace's equation.

    Each filled cell is the mean of its valid 4-neighbours (the edge of the
    data and nodata are no constraint: the fill meets them level), so a
    plane is filled exactly.  A piece of the data without a known cell
    takes the nearest known height.  Nodata cells are NaN.  The pieces to
    fill (4-connected) are independent: they are solved in batches of up
    to :data:`FILL_BATCH` cells (a sparse LU factorization each), so the
    memory goes with the largest piece, not with the grid.
    """
    from scipy import ndimage

    valid = hf.valid
    known = known & valid
    if not known.any():
        raise NoDataError("no ground cell: nothing to fill the ground from")
    z = np.where(valid, hf.z, np.nan).astype(np.float64)
    out = np.where(known, z, np.nan)
    unknown = valid & ~known
    pieces, n = ndimage.label(unknown)  # 4-connected, as the equations couple the cells
    if n == 0:
        return out
    size = np.bincount(pieces.ravel(), minlength=n + 1)
    touching = np.zeros(n + 1, bool)
    touching[pieces[ndimage.binary_dilation(known) & unknown]] = True
    alone = unknown & ~touching[pieces]
    if alone.any():  # pieces that touch no known cell take the nearest known height
        nearest = ndimage.distance_transform_edt(~known, return_distances=False, return_indices=True)
        out[alone] = z[tuple(nearest)][alone]
    batch = np.zeros(n + 1, np.int64)
    total = count = 0
    for label in np.flatnonzero(touching):
        if total and total + size[label] > FILL_BATCH:
            count, total = count + 1, 0
        batch[label] = count + 1
        total += size[label]
    order = np.argsort(batch[pieces.ravel()], kind="stable")
    sorted_batches = batch[pieces.ravel()][order]
    for b in range(1, count + 2):
        cells = order[np.searchsorted(sorted_batches, b, "left"):np.searchsorted(sorted_batches, b, "right")]
        _solve(out, valid, np.unravel_index(cells, z.shape))
    return out


def _solve(out: np.ndarray, valid: np.ndarray, cells) -> None:
    """Laplace's equation on ``cells`` (row and column arrays), the other valid cells of ``out`` known; in place."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import spsolve

    h, w = out.shape
    m = len(cells[0])
    number = np.full((h, w), -1, np.int64)
    number[cells] = np.arange(m)
    rows, cols = [np.arange(m)], [np.arange(m)]
    diagonal = np.zeros(m)
    vals, rhs = [], np.zeros(m)
    for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        r, c = cells[0] + dr, cells[1] + dc
        inside = (r >= 0) & (r < h) & (c >= 0) & (c < w)
        i = np.flatnonzero(inside)
        r, c = r[inside], c[inside]
        ok = valid[r, c]
        i, r, c = i[ok], r[ok], c[ok]
        diagonal += np.bincount(i, minlength=m)
        j = number[r, c]
        inner = j >= 0
        rows.append(i[inner])
        cols.append(j[inner])
        vals.append(-np.ones(int(inner.sum())))
        rhs += np.bincount(i[~inner], weights=out[r[~inner], c[~inner]], minlength=m)
    matrix = sp.csc_matrix((np.concatenate([diagonal, *vals]), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(m, m))
    out[cells] = spsolve(matrix, rhs)


def ground(data, *, max_window: float = GROUND_WINDOW, slope: float = SLOPE, dh0: float | None = None,
           dh_max: float | None = None, wall_slope: float = WALL_SLOPE, cell_size: float | None = None) -> Heightfield:
    """The ground (a DTM) under a surface model or a point cloud (module docstring).

    Parameters
    ----------
    data : Heightfield or PointCloud
        A surface model (DSM), or a point cloud gridded at ``cell_size``
        with each cell's lowest point.
    max_window : float
        The widest window (world units): wider than the largest building (default 60).
    slope : float
        The terrain slope (rise over run) the thresholds allow for as the windows grow (default 1: 45 degrees).
    dh0, dh_max : float, optional
        The threshold of the first window and the largest one (z units; default 0.3 m and 1 m).
    wall_slope : float
        A wall: steeper than this (rise over run, plus ``dh0``) between two neighbouring cells (default 1).
    cell_size : float, optional
        The grid of a point cloud (world units; default its
        :meth:`~tinsmith.PointCloud.default_cell_size`).

    Returns
    -------
    Heightfield
        On the grid of ``data``: the ground cells' heights, the others
        filled from them; nodata where ``data`` has none.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> rows, cols = np.mgrid[0:120, 0:160]
    >>> slope = 0.5 * cols * 0.5  # a 27-degree hillside, 0.5 m cells
    >>> z = slope.copy()
    >>> z[40:80, 60:100] += 9.0  # a house 20 m x 20 m, 9 m high
    >>> dtm = tinsmith.ground(tinsmith.Heightfield(z, cell_size=0.5))
    >>> float(np.abs(dtm.z - slope).max()) < 0.01  # the slope under the house
    True
    """
    if isinstance(data, PointCloud):
        if cell_size is not None:
            cell_size = _checks.number("cell_size", cell_size, minimum=0.0, exclusive_min=True)
        hf = data.to_heightfield(cell_size, statistic="min")
    elif isinstance(data, Heightfield):
        if cell_size is not None:
            raise InvalidInputError("cell_size grids a point cloud; a Heightfield keeps its grid")
        hf = data
    else:
        raise InvalidInputError(f"ground needs a Heightfield (a DSM) or a PointCloud, got {type(data).__name__}")
    known = ground_cells(hf, max_window=max_window, slope=slope, dh0=dh0, dh_max=dh_max, wall_slope=wall_slope)
    z = laplace_fill(hf, known)
    return Heightfield(np.where(hf.valid, z, 0.0), transform=hf.transform, crs=hf.crs, nodata_mask=~hf.valid)

