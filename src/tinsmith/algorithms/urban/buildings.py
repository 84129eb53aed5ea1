"""Which cells of a surface model are buildings, and which building each belongs to.

The Salt Lake City thesis contours everything above a height threshold, so a tree touching
a house fuses with it and a leafy district becomes one region per block.
Before any threshold, this module decides per cell, from what the data
offers (:func:`building_cells`):

- **height above the ground** of at least ``min_height`` (default
  :data:`MIN_HEIGHT`, 2.5 m: a storey; garden walls, cars and hedges stay
  ground);
- **planarity**: roofs, flat or pitched, are planes; tree crowns are not.
  The residual (root mean square) of a least-squares plane over each 3 x 3
  window of cells is computed, and a cell is planar when one of the nine
  windows that contain it fits within ``max_residual`` (default
  :data:`MAX_RESIDUAL`, 0.2 m): a cell at the edge of a roof has a window
  inside the roof, a cell of a crown has none;
- **LiDAR classes and returns**, when the surface model comes from a point
  cloud (:func:`class_shares`): where the cloud has building points (ASPRS
  class 6) a cell is a building when they are at least half of its points
  (instead of the planarity test), and a cell whose points are mostly
  vegetation (classes 3-5, or, in a cloud without them, points of pulses
  with several returns) never is;
- an optional **mask** (True where buildings may be).

The planar cells are cleaned (an opening by a 3 x 3 square removes the
one-cell spurs along crowns; then the high cells next to a building join
it, the edge of a roof whose every window straddles the wall, and so do
small high holes enclosed by a building, up to ``MIN_AREA``: chimneys,
dormers, skylights, not the trees of a courtyard) and split into **buildings**
(:func:`split_buildings`): neighbouring cells belong to one building when
the height changes between them no more than their planes predict plus
``step`` (default :data:`STEP`, 1 m; only planes of planar cells count,
no steeper than 60 degrees, so the cells on a wall never bridge it),
so adjacent roofs at different
heights are different buildings while a pitched roof's two sides and its
ridge stay one.  Buildings smaller than ``min_area`` (default
:data:`MIN_AREA`, 10 m2) are dropped, and so are those whose median
residual exceeds half of ``max_residual``: a crown has planar patches,
but most of its cells are not (on Delft every region of a crown has a
median residual of 0.13 m or more, every roof larger than 35 m2 below
0.1 m).

**Coarse cells.**  The 3 x 3 window needs a roof three cells across; where
three cells are wider than the narrowest house (:data:`MIN_HOUSE`, 3 m: cells
coarser than 1 m), a small house has no window inside it and every window
straddles a wall or a ridge (at 2 m a 40 m2 house is 2 to 3 cells wide).
There (:func:`coarse`):

- a high cell is also planar when every 2 x 2 window of high cells that
  contains it fits a plane (:func:`twist_fits`; its RMS residual, one degree
  of freedom, is scaled to the 3 x 3 window's six, so that both measure the
  same noise against ``max_residual``).  Every window, not the best: a
  canopy's noise lets one window of four fit by chance, a roof's cells fit
  in all of theirs, and the windows reaching over a wall to the ground are
  not high;
- the opening is skipped (a 3 x 3 square removes what is narrower than
  three cells: the small houses);
- in the split, such a cell's slope is that of its best 2 x 2 window
  (a small roof's cells have no 3 x 3 plane, and a slope of 0.6 rises
  1.2 m from one 2 m cell to the next: more than ``step``);
- a building that fails the median test may still be kept by the shape of
  a roof (:func:`ridge_roof`): a plane, or two planes meeting at a ridge or
  valley (z = a + b u + c v + d |v - v0| along a direction u), fitted
  robustly (trimmed least squares over 75% of its cells) to its cells: kept
  when at least :data:`RIDGE_SHARE` (75%) of them, and at least eight (twice
  the model's four parameters), lie within ``max_residual`` of it; a crown
  touching a house, a bumpy canopy, fits no such roof.  Then the cells
  around it that lie on that roof (within ``max_residual``) join it, until
  none does: the parts of a small roof whose 2 x 2 windows all reach into a
  tree.

Heights are taken in metres unless the CRS's unit is a foot, in which case
the metre defaults are converted (:func:`metres_per_unit`); a grid without
CRS is taken to be in metres.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from ... import _checks
from ...core import Heightfield
from ...errors import InvalidInputError
from ...io.crs import linear_unit

__all__ = [
    "MAX_RESIDUAL", "MIN_AREA", "MIN_HEIGHT", "MIN_HOUSE", "RIDGE_SHARE", "ROW_STEP", "ROW_VALLEY", "STEP",
    "building_cells", "class_shares", "coarse", "metres_per_unit", "plane_fits", "ridge_roof", "row_cuts",
    "split_buildings", "twist_fits",
]

#: Least height above the ground of a building (m): a storey.
MIN_HEIGHT = 2.5
#: Largest residual (m, RMS) of the plane of a 3 x 3 window for its cells to be a roof.
MAX_RESIDUAL = 0.2
#: Height change between neighbouring cells beyond what their planes predict that separates two buildings (m).
STEP = 1.0
#: Smallest building kept (m2).
MIN_AREA = 10.0
#: The steepest roof (rise over run: 60 degrees) whose slope explains a height change between two cells.
MAX_ROOF_SLOPE = 1.75
#: Row houses: the least height change between two cross-sections beyond the roof's slope that cuts a row (m).
ROW_STEP = 0.1
#: Row houses: the least change of slope into a valley between two cross-sections that cuts a row (m per cell).
ROW_VALLEY = 0.3
#: Row houses: the narrowest house a cut may leave (m).
MIN_HOUSE = 3.0
#: Coarse cells: the least share of a building's cells on its one-ridge roof model for the model to keep it.
RIDGE_SHARE = 0.75
#: A row: at least this many times longer than deep ...
ROW_ELONGATION = 2.0
#: ... and filling at least this share of its box along its directions (not a tree belt, a tower or a courtyard block).
ROW_FILL = 0.4


def metres_per_unit(crs) -> float:
    """Metres in one unit of the CRS (1 without a CRS or when the unit is not a foot)."""
    unit = linear_unit(crs).lower() if crs else "unknown"
    if "us survey" in unit:
        return 1200.0 / 3937.0
    if "foot" in unit or "feet" in unit:
        return 0.3048
    return 1.0


def _windows(a: np.ndarray) -> np.ndarray:
    from numpy.lib.stride_tricks import sliding_window_view

    return sliding_window_view(np.pad(a, 1, constant_values=np.nan), (3, 3))


def plane_fits(hf: Heightfield):
    """Per cell: the residual (RMS, z units) of the best plane among the 3 x 3 windows that contain it, and that plane's gradient.

    Returns ``(residual, gx, gy)``: ``gx`` the height change per column,
    ``gy`` per row (z units per cell).  Windows with nodata do not fit
    (residual inf).
    """
    z = np.where(hf.valid, hf.z, np.nan).astype(np.float64)
    h, w = z.shape
    win = _windows(z)  # (H, W, 3, 3), centred on each cell
    t = np.array([-1.0, 0.0, 1.0])
    mean = win.mean(axis=(2, 3))
    gx = (win * t[None, :]).sum(axis=(2, 3)) / 6.0
    gy = (win * t[:, None]).sum(axis=(2, 3)) / 6.0
    res = win - mean[..., None, None] - gx[..., None, None] * t[None, :] - gy[..., None, None] * t[:, None]
    rms = np.sqrt((res * res).mean(axis=(2, 3)))
    rms = np.where(np.isfinite(rms), rms, np.inf)
    # the best of the nine windows that contain each cell
    around = _windows(rms).reshape(h, w, 9)
    around = np.where(np.isnan(around), np.inf, around)
    k = around.argmin(axis=2)
    rows = np.clip(np.arange(h)[:, None] + k // 3 - 1, 0, h - 1)
    cols = np.clip(np.arange(w)[None, :] + k % 3 - 1, 0, w - 1)
    return around.min(axis=2), gx[rows, cols], gy[rows, cols]


def _cell_size(hf: Heightfield) -> float:
    a, b, _, d, e, _ = hf.transform
    return float(np.sqrt(abs(a * e - b * d)))


def coarse(hf: Heightfield) -> bool:
    """Whether three cells of ``hf`` are wider than the narrowest house (:data:`MIN_HOUSE`; module docstring)."""
    return 3.0 * _cell_size(hf) > MIN_HOUSE / metres_per_unit(hf.crs)


def twist_fits(hf: Heightfield) -> np.ndarray:
    """(H + 1, W + 1): the RMS residual of the plane of each 2 x 2 window (window ``[i, j]`` has the cells
    ``i - 1..i``, ``j - 1..j``; inf where it has nodata or leaves the grid), scaled to the 3 x 3 window's.

    Four cells and three parameters leave one degree of freedom: every
    residual is ``±(z00 - z01 - z10 + z11) / 4``.  For noise of standard
    deviation s its RMS is s / 2, the 3 x 3 window's is s sqrt(6 / 9); the
    result is multiplied by their ratio, sqrt(8 / 3), so that both compare
    with ``max_residual`` alike.
    """
    z = np.pad(np.where(hf.valid, hf.z, np.nan).astype(np.float64), 1, constant_values=np.nan)
    twist = np.abs(z[:-1, :-1] - z[:-1, 1:] - z[1:, :-1] + z[1:, 1:]) / 4.0 * np.sqrt(8.0 / 3.0)
    return np.where(np.isfinite(twist), twist, np.inf)


def _twist_gradients(hf: Heightfield, cells: np.ndarray):
    """Per cell, the gradient (per column, per row) of the best-fitting 2 x 2 window of ``cells`` containing it."""
    z = np.pad(np.where(hf.valid, hf.z, np.nan).astype(np.float64), 1, constant_values=np.nan)
    inside = np.pad(cells, 1)
    inside = inside[:-1, :-1] & inside[:-1, 1:] & inside[1:, :-1] & inside[1:, 1:]
    twist = np.where(inside, twist_fits(hf), np.inf)
    gx = ((z[:-1, 1:] + z[1:, 1:]) - (z[:-1, :-1] + z[1:, :-1])) / 2.0
    gy = ((z[1:, :-1] + z[1:, 1:]) - (z[:-1, :-1] + z[:-1, 1:])) / 2.0
    h, w = hf.shape
    four = np.stack([twist[:-1, :-1], twist[:-1, 1:], twist[1:, :-1], twist[1:, 1:]], axis=2)
    k = four.argmin(axis=2)
    rows, cols = np.arange(h)[:, None] + k // 2, np.arange(w)[None, :] + k % 2
    return gx[rows, cols], gy[rows, cols]


def _every_window_fits(hf: Heightfield, above: np.ndarray, max_residual: float) -> np.ndarray:
    """Per cell: it has a 2 x 2 window of high cells, and every such window containing it fits (module docstring)."""
    high = np.pad(above, 1)
    window = high[:-1, :-1] & high[:-1, 1:] & high[1:, :-1] & high[1:, 1:]
    bad = window & (twist_fits(hf) > max_residual)

    def around(a):
        return a[:-1, :-1] | a[:-1, 1:] | a[1:, :-1] | a[1:, 1:]

    return above & around(window) & ~around(bad)


def ridge_roof(rows, cols, z, tolerance: float, start=None):
    """The one-ridge roof that fits most of a building's cells (module docstring).

    ``rows``, ``cols`` the building's cells and ``z`` their heights;
    ``start`` (bool per cell, optional) the cells to begin the fits with
    (the planar ones: a crown over part of the roof is not among them; all
    cells when fewer than eight).  The model z = a + b u + c v + d |v - v0|
    (u along a direction, v across, in cells) is fitted for each direction
    and ridge position by least trimmed squares over :data:`RIDGE_SHARE` of
    the cells (five concentration steps from the start: least squares, then
    again over the cells it fits best; Rousseeuw and Van Driessen, 2006,
    "Computing LTS regression for large data sets"), and scored by the truncated squared
    residual sum of min(r, t)^2 (MSAC: Torr and Zisserman, 2000): directions
    every 7.5 degrees and ridge positions every half cell with t four times
    ``tolerance`` (a ridge a quarter of a cell off misses its own cells by
    more than ``tolerance`` on a steep roof), then around the best every
    1.25 degrees and a tenth of a cell with t = ``tolerance``.  Returns
    ``(inliers, model)``: the cells within ``tolerance`` of the best model,
    and the model for :func:`_ridge_roof_at`; ``(all False, None)`` with
    fewer than 8 cells (twice the parameters) or a nodata height.
    """
    n = len(z)
    z = np.asarray(z, dtype=np.float64)
    if n < 8 or not np.isfinite(z).all():
        return np.zeros(n, bool), None
    x, y = cols.astype(np.float64), -rows.astype(np.float64)
    xm, ym = float(x.mean()), float(y.mean())
    x, y = x - xm, y - ym
    keep = int(np.ceil(RIDGE_SHARE * n))
    first = np.asarray(start, bool) if start is not None and np.count_nonzero(start) >= 8 else np.ones(n, bool)

    def fit(angles, v0s, tol):  # every (direction, ridge position) at once; the best
        u = x[None, :] * np.cos(angles)[:, None] + y[None, :] * np.sin(angles)[:, None]
        v = -x[None, :] * np.sin(angles)[:, None] + y[None, :] * np.cos(angles)[:, None]
        a = np.stack([np.ones_like(u), u, v, np.abs(v - v0s[:, None])], axis=2)
        use = np.broadcast_to(first, u.shape).astype(np.float64)
        for _ in range(5):
            normal = np.einsum("kn,kni,knj->kij", use, a, a)
            coef = (np.linalg.pinv(normal) @ np.einsum("kn,kni,n->ki", use, a, z)[..., None])[..., 0]
            r = np.abs(z[None, :] - np.einsum("kni,ki->kn", a, coef))
            use = np.zeros_like(use)
            np.put_along_axis(use, np.argsort(r, axis=1, kind="stable")[:, :keep], 1.0, axis=1)
        t = np.minimum(r, tol)
        b = int(np.argmin((t * t).sum(axis=1)))
        return r[b] <= tolerance, (float(angles[b]), float(v0s[b]), coef[b], xm, ym)

    pairs = []
    for angle in np.radians(np.arange(0.0, 180.0, 7.5)):
        v = -x * np.sin(angle) + y * np.cos(angle)
        pairs += [(angle, v0) for v0 in np.arange(np.floor(v.min() * 2.0) / 2.0, v.max() + 0.5, 0.5)]
    angles, v0s = np.array(pairs).T
    _, (angle0, v00, *_) = fit(angles, v0s, 4.0 * tolerance)  # the grid is coarse: so is the score
    angles, v0s = (g.ravel() for g in np.meshgrid(angle0 + np.radians(np.arange(-3.75, 3.76, 1.25)),
                                                   v00 + np.arange(-0.5, 0.51, 0.1), indexing="ij"))
    return fit(angles, v0s, tolerance)


def _ridge_roof_at(model, rows, cols) -> np.ndarray:
    """The height of :func:`ridge_roof`'s ``model`` at cells ``rows``, ``cols``."""
    angle, v0, coef, xm, ym = model
    x, y = cols.astype(np.float64) - xm, -rows.astype(np.float64) - ym
    u = x * np.cos(angle) + y * np.sin(angle)
    v = -x * np.sin(angle) + y * np.cos(angle)
    return coef[0] + coef[1] * u + coef[2] * v + coef[3] * np.abs(v - v0)


def class_shares(cloud, hf: Heightfield):
    """(building, vegetation) shares of the points of each cell of ``hf`` (NaN where a cell has none; None where unknown).

    Building: ASPRS class 6, when the cloud has any.  Vegetation: classes
    3-5 when the cloud has any; else, when the cloud has no building class
    either but records returns, the points of pulses with more than one
    return (a canopy splits a pulse, a roof does not; the edge of a roof
    does too, which the building class, when there, makes moot).  Returns
    None when the cloud offers neither.
    """
    xyz = cloud.xyz
    cls = getattr(cloud, "classification", None)
    returns = cloud.attributes.get("number_of_returns")
    is_building = cls == 6 if cls is not None and np.any(cls == 6) else None
    if cls is not None and np.any((cls >= 3) & (cls <= 5)):
        is_vegetation = (cls >= 3) & (cls <= 5)
    elif is_building is None and returns is not None and np.any(returns > 1):
        is_vegetation = returns > 1
    else:
        is_vegetation = None
    if is_building is None and is_vegetation is None:
        return None
    rows, cols = hf.world_to_pixel(xyz[:, 0], xyz[:, 1])
    rows, cols = np.round(rows).astype(np.int64), np.round(cols).astype(np.int64)
    h, w = hf.shape
    inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
    flat = rows[inside] * w + cols[inside]
    total = np.bincount(flat, minlength=h * w).astype(np.float64)

    def share(mask):
        if mask is None:
            return None
        with np.errstate(invalid="ignore", divide="ignore"):
            return (np.bincount(flat, weights=mask[inside], minlength=h * w) / total).reshape(h, w)

    return share(is_building), share(is_vegetation)


def building_cells(hf: Heightfield, ground: Heightfield, *, min_height: float | None = None,
                   max_residual: float | None = None, shares=None, mask=None, fits=None) -> tuple[np.ndarray, dict]:
    """(H, W) bool: the cells of ``hf`` that are buildings, and how many cells each rule took out (module docstring).

    ``min_height`` and ``max_residual`` are in z units (default: the metre
    defaults in the CRS's unit); ``shares`` is :func:`class_shares`;
    ``mask`` an (H, W) bool array, True where buildings may be; ``fits``
    is :func:`plane_fits` of ``hf`` when the caller has it.
    """
    scale = 1.0 / metres_per_unit(hf.crs)
    min_height = MIN_HEIGHT * scale if min_height is None else _checks.number("min_height", min_height, minimum=0.0)
    max_residual = (MAX_RESIDUAL * scale if max_residual is None
                    else _checks.number("max_residual", max_residual, minimum=0.0, exclusive_min=True))
    if not isinstance(ground, Heightfield) or ground.shape != hf.shape:
        raise InvalidInputError("ground must be a Heightfield on the grid of the surface model (same shape)")
    from scipy import ndimage

    valid = hf.valid & ground.valid
    with np.errstate(invalid="ignore"):
        above = np.where(valid, hf.z - np.where(ground.valid, ground.z, 0.0), -np.inf) >= min_height
    counts = {"cells": int(valid.sum()), "high": int(above.sum())}
    building, vegetation = shares if shares is not None else (None, None)
    if building is not None:
        cells = above & (np.nan_to_num(building) >= 0.5)
        counts["by_classes"] = int(cells.sum())
    else:
        residual, _, _ = plane_fits(hf) if fits is None else fits
        cells = above & (residual <= max_residual)
        if coarse(hf):
            cells |= _every_window_fits(hf, above, max_residual)
        counts["planar"] = int(cells.sum())
    if vegetation is not None:
        cells &= ~(np.nan_to_num(vegetation) >= 0.5)
        counts["not_vegetation"] = int(cells.sum())
    if not coarse(hf):
        cells = ndimage.binary_opening(cells, structure=np.ones((3, 3), bool))
    if mask is not None:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != hf.shape:
            raise InvalidInputError(f"the building mask must have the surface model's shape {hf.shape}, got {mask.shape}")
        cells &= mask
    # the cell at the edge of a roof whose windows all straddle the wall, and holes inside a building that
    # stand high (chimneys, dormers, skylights), belong to it
    cells |= ndimage.binary_dilation(cells) & above
    holes, n_holes = ndimage.label(ndimage.binary_fill_holes(cells) & ~cells)
    if n_holes:
        a, b, _, d, e, _ = hf.transform
        small = np.r_[False, np.bincount(holes.ravel())[1:] * abs(a * e - b * d) <= MIN_AREA * scale * scale]
        cells |= small[holes] & above  # not a courtyard's tree
    counts["buildings"] = int(cells.sum())
    return cells, counts


def split_buildings(hf: Heightfield, cells: np.ndarray, *, step: float | None = None,
                    min_area: float | None = None, max_residual: float | None = None, fits=None) -> np.ndarray:
    """(H, W) int labels: -1 off buildings, 0..n-1 one per building (module docstring); ordered by first cell.

    ``fits`` is :func:`plane_fits` of ``hf`` when the caller has it.
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    scale = 1.0 / metres_per_unit(hf.crs)
    step = STEP * scale if step is None else _checks.number("step", step, minimum=0.0)
    min_area = MIN_AREA * scale * scale if min_area is None else _checks.number("min_area", min_area, minimum=0.0)
    max_residual = (MAX_RESIDUAL * scale if max_residual is None
                    else _checks.number("max_residual", max_residual, minimum=0.0, exclusive_min=True))
    a, b, _, d, e, _ = hf.transform
    cell_area = abs(a * e - b * d)
    z = np.where(hf.valid, hf.z, np.nan).astype(np.float64)
    residual, gx, gy = plane_fits(hf) if fits is None else fits
    # the slope a cell may explain a height change by: its roof plane's, when it is on one (a cell on a wall,
    # added to a building for its edge, has a steep plane that would bridge the wall), and no steeper than a roof
    steepest = MAX_ROOF_SLOPE * np.sqrt(cell_area)
    planar = residual <= max_residual
    if coarse(hf):  # a small roof's cells have no 3 x 3 window on it: the slope of their best 2 x 2 window
        fit2 = _every_window_fits(hf, cells, max_residual) & ~planar
        gx2, gy2 = _twist_gradients(hf, cells)
        gx, gy = np.where(fit2, gx2, gx), np.where(fit2, gy2, gy)
        planar = planar | fit2
    gx = np.where(planar, np.clip(np.nan_to_num(gx), -steepest, steepest), 0.0)
    gy = np.where(planar, np.clip(np.nan_to_num(gy), -steepest, steepest), 0.0)
    h, w = z.shape
    index = np.arange(h * w).reshape(h, w)
    src, dst = [], []
    for (s1, s2), g in ((((slice(None), slice(0, -1)), (slice(None), slice(1, None))), gx),
                        (((slice(0, -1), slice(None)), (slice(1, None), slice(None))), gy)):
        with np.errstate(invalid="ignore"):
            jump = np.abs(z[s2] - z[s1]) - np.maximum(np.abs(g[s1]), np.abs(g[s2]))
        ok = cells[s1] & cells[s2] & (jump <= step)
        src.append(index[s1][ok])
        dst.append(index[s2][ok])
    src, dst = np.concatenate(src), np.concatenate(dst)
    graph = sp.coo_matrix((np.ones(len(src), np.int8), (src, dst)), shape=(h * w, h * w))
    _, labels = connected_components(graph, directed=False)
    labels = np.where(cells.ravel(), labels, -1)
    # keep those large enough and planar enough, numbered in order of their first cell
    ids, first, inverse, size = np.unique(labels, return_index=True, return_inverse=True, return_counts=True)
    order = np.argsort(inverse, kind="stable")
    bounds = np.r_[0, np.cumsum(size)]
    res = np.minimum(residual.ravel()[order], 1e300)
    median = np.array([np.median(res[bounds[k]:bounds[k + 1]]) for k in range(len(ids))])
    keep = (ids >= 0) & (size * cell_area >= min_area) & (median <= max_residual / 2.0)
    roofs = {}
    if coarse(hf):  # or on a one-ridge roof (module docstring)
        zs = z.ravel()[order]
        for k in np.flatnonzero((ids >= 0) & (size * cell_area >= min_area) & ~keep):
            at = order[bounds[k]:bounds[k + 1]]
            inliers, model = ridge_roof(at // w, at % w, zs[bounds[k]:bounds[k + 1]], max_residual,
                                        start=planar.ravel()[at])
            if inliers.sum() >= 8 and inliers.mean() >= RIDGE_SHARE:
                keep[k] = True
                roofs[k] = (model, at)
    order = np.argsort(first[keep])
    new = np.full(ids.shape, -1, np.int64)
    new[np.flatnonzero(keep)[order]] = np.arange(int(keep.sum()))
    out = new[np.searchsorted(ids, labels)].reshape(h, w)
    from scipy import ndimage

    # the cells around a building kept by its roof's shape that lie on that roof join it
    for k, (model, at) in roofs.items():
        b = new[k]
        r0, r1, c0, c1 = (at // w).min(), (at // w).max(), (at % w).min(), (at % w).max()
        while True:  # within the building's box and one cell around it
            r0, c0, r1, c1 = max(r0 - 1, 0), max(c0 - 1, 0), min(r1 + 1, h - 1), min(c1 + 1, w - 1)
            box = out[r0:r1 + 1, c0:c1 + 1]
            ring = ndimage.binary_dilation(box == b) & (box < 0) & np.isfinite(z[r0:r1 + 1, c0:c1 + 1])
            rr, cc = np.nonzero(ring)
            rr, cc = rr + r0, cc + c0
            on = np.abs(z[rr, cc] - _ridge_roof_at(model, rr, cc)) <= max_residual
            if not on.any():
                break
            out[rr[on], cc[on]] = b
    # the cells of a wall top or eave left in a sliver of their own join the building they border
    # (only slivers too small to stand: one building each, never a bridge between two)
    too_small = (ids >= 0) & (size * cell_area < min_area)
    sliver = too_small[np.searchsorted(ids, labels)].reshape(h, w) & cells
    for _ in range(2):
        grown = ndimage.maximum_filter(out, size=3)
        take = sliver & (out < 0) & (grown >= 0)
        if not take.any():
            break
        out = np.where(take, grown, out)
    return out


def row_cuts(hf: Heightfield, labels: np.ndarray, n: int, directions, *, step: float | None = None,
             valley: float | None = None, min_width: float | None = None) -> list:
    """Where rows of houses under one roof part into houses: per building, the cut lines across its long axis.

    A row of terraced houses is one region of building cells (the roof is
    continuous), but its houses show where they meet: the roof steps a
    little (a different eave or ridge height, a party wall standing
    proud), or falls into a valley (houses whose gables face the street).
    Along the building's long axis (of ``directions[b]``, its dominant
    direction in radians, and the perpendicular), the cells are binned into
    cross-sections one cell thick; between consecutive sections the median
    height change ``dz`` (over the positions across the row both have)
    is compared with the slopes on either side: a **step** where ``dz``
    leaves the range of those two slopes by ``step`` or more (default
    :data:`ROW_STEP`, 0.1 m; at a ridge or a valley it stays inside), a
    **valley** where the slope rises
    by ``valley`` or more from the section before to the one after
    (default :data:`ROW_VALLEY`, 0.3 m; a ridge, where it falls, is no
    cut).  The strongest local maxima are kept while every piece stays at
    least ``min_width`` wide (default :data:`MIN_HOUSE`, 3 m).  Only rows
    are cut: buildings at least :data:`ROW_ELONGATION` (2) times longer
    than deep that fill at least :data:`ROW_FILL` (40%) of their box along
    their directions; a tower, a courtyard block or a ragged belt of trees
    is left whole.

    Returns, per building 0..n-1, a list of ``((x0, y0), (x1, y1))`` cut
    lines reaching across it (world coordinates).
    """
    scale = 1.0 / metres_per_unit(hf.crs)
    step = ROW_STEP * scale if step is None else _checks.number("row_step", step, minimum=0.0, exclusive_min=True)
    valley = ROW_VALLEY * scale if valley is None else _checks.number("row_valley", valley, minimum=0.0,
                                                                       exclusive_min=True)
    min_width = MIN_HOUSE * scale if min_width is None else _checks.number("min_house", min_width, minimum=0.0)
    cell = _cell_size(hf)
    z = np.where(hf.valid, hf.z, np.nan).astype(np.float64)
    flat = labels.ravel()
    order = np.argsort(flat, kind="stable")
    starts = np.searchsorted(flat[order], np.arange(n), "left")
    stops = np.searchsorted(flat[order], np.arange(n), "right")
    w = labels.shape[1]
    out = []
    for bld in range(n):
        at = order[starts[bld]:stops[bld]]
        rows, cols = np.divmod(at, w)
        x, y = hf.pixel_to_world(rows, cols)
        zz = z.ravel()[at]
        best = None
        for angle in (directions[bld], directions[bld] + np.pi / 2):
            u = x * np.cos(angle) + y * np.sin(angle)
            v = -x * np.sin(angle) + y * np.cos(angle)
            if best is None or np.ptp(u) > best[0]:
                best = (np.ptp(u), angle, u, v)
        length, angle, u, v = best
        cuts: list = []
        depth = np.ptp(v) + cell
        row_like = (length + cell) >= ROW_ELONGATION * depth and len(at) * cell * cell >= ROW_FILL * (length + cell) * depth
        if row_like and length >= 2 * min_width and np.isfinite(zz).sum() > 3:
            for pos in _section_cuts(u, v, zz, cell, step, valley, min_width):
                uc = u.min() + pos * cell
                v0, v1 = v.min() - 2 * cell, v.max() + 2 * cell
                ends = [(uc * np.cos(angle) - vv * np.sin(angle), uc * np.sin(angle) + vv * np.cos(angle)) for vv in (v0, v1)]
                cuts.append(tuple(ends))
        out.append(cuts)
    return out


def _section_cuts(u, v, z, cell, step, valley, min_width) -> list:
    """Cut positions (in sections from the start of ``u``) of one building (see :func:`row_cuts`)."""
    ub = np.floor((u - u.min()) / cell).astype(np.int64)
    vb = np.floor((v - v.min()) / cell).astype(np.int64)
    total = np.zeros((ub.max() + 1, vb.max() + 1))
    count = np.zeros_like(total)
    ok = np.isfinite(z)
    np.add.at(total, (ub[ok], vb[ok]), z[ok])
    np.add.at(count, (ub[ok], vb[ok]), 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        sections = np.where(count > 0, total / count, np.nan)
        diff = np.diff(sections, axis=0)
    has = np.isfinite(diff).any(axis=1)
    dz = np.zeros(len(diff))
    dz[has] = np.nanmedian(diff[has], axis=1)
    if len(dz) < 3:
        return []
    before, after = np.r_[dz[0], dz[:-1]], np.r_[dz[1:], dz[-1]]
    # a step: the change leaves the range of the slopes on either side (at a ridge or valley it stays inside)
    jump = np.maximum(0.0, np.maximum(dz - np.maximum(before, after), np.minimum(before, after) - dz))
    rise = after - before
    score = np.where(jump >= step, jump, 0.0) + np.where(rise >= valley, rise, 0.0)
    n_sections = len(sections)
    width = int(np.ceil(min_width / cell))
    peaks = [i for i in np.flatnonzero(score > 0) if score[i] == score[max(0, i - 3):i + 4].max()]
    cuts: list = []
    for i in sorted(peaks, key=lambda k: (-score[k], k)):
        edges = [0, *sorted(cuts + [i + 1]), n_sections]
        if all(b - a >= width for a, b in pairwise(edges)):
            cuts = edges[1:-1]
    return cuts
