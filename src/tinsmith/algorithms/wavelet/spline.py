"""Linear-spline best approximation of a heightfield on coarser scales (Goebbels and Pohle-Fröhlich 2015, section 3, Algorithm 1).

A row of heights ``y_0 .. y_{L-1}`` is the piecewise linear function with
those values at unit spacing.  Its best approximation, in the L2 inner
product on the row, by a piecewise linear function on every other node (the
coarse knots 0, 2, 4, ..., and the last node when ``L - 1`` is odd) solves
the normal equations of the coarse hat functions::

    G_c x = P^T T_f y

``T_f`` is the Gram matrix of the fine hats (tridiagonal: 1/6, 2/3, 1/6,
with 1/3 at both ends), ``P`` the prolongation from coarse to fine values
(linear interpolation) and ``G_c = P^T T_f P`` the tridiagonal Gram matrix of
the coarse hats.  The paper works with scaled hat coefficients
(``m 2^i c_{i,k}`` are heights); with node values the equations are the
same.  One step of Algorithm 1 approximates every row, then every column of
the result, each direction as one banded solve with all rows as right-hand
sides.  After ``iterations`` steps the coarse heights are interpolated back
to every grid point on the coarse squares, each cut on the diagonal of
formula 1 (:func:`tinsmith.triangulation.grid.diagonal_rule`).

The paper's grids have ``m 2^n + 1`` points (m odd); here any size is taken:
where a row has an even number of points, its last coarse interval is one
fine step long, and the equations are set up for such uneven knots (the
fine Gram matrix and the prolongation weighted by the node spacing).  Planes
are reproduced exactly at every scale.  Nodata cells are filled from the
nearest valid cell for the filter (:func:`tinsmith.triangulation.grid.filled`)
and are nodata again in its result.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_banded

from ...core import Heightfield
from ...errors import InvalidOptionError
from ...triangulation.grid import diagonal_rule, filled

__all__ = ["coarse_knots", "max_iterations", "spline_approximation", "spline_filter", "spline_reduce"]


def coarse_knots(n: int) -> np.ndarray:
    """Indices of the fine nodes that stay knots on the next coarser scale: every other one, and the last."""
    knots = np.arange(0, n, 2)
    return knots if knots[-1] == n - 1 else np.append(knots, n - 1)


def max_iterations(n: int) -> int:
    """How many coarsenings a side of ``n`` points allows (down to two knots)."""
    count = 0
    while n > 2:
        n = len(coarse_knots(n))
        count += 1
    return count


def _approximate(y: np.ndarray, pos: np.ndarray) -> np.ndarray:
    """Best approximation of every column of ``y`` (L, M), piecewise linear over nodes at ``pos`` (L), on the
    coarse knots ``coarse_knots(L)``: (len(knots), M)."""
    knots = coarse_knots(len(pos))
    d = np.diff(pos)[:, None]
    # T_f y: the fine hats' inner products with the function
    r = np.zeros_like(y)
    r[:-1] += d * (2.0 * y[:-1] + y[1:]) / 6.0
    r[1:] += d * (y[:-1] + 2.0 * y[1:]) / 6.0
    # P^T: a fine node between two knots shares its product between them, by where it lies
    rhs = r[knots].copy()
    gap = np.diff(pos[knots])
    inner = np.flatnonzero(np.diff(knots) == 2)
    mid = knots[inner] + 1
    w = ((pos[mid] - pos[knots[inner]]) / gap[inner])[:, None]
    rhs[inner] += (1.0 - w) * r[mid]
    rhs[inner + 1] += w * r[mid]
    # G_c, the coarse hats' Gram matrix, in banded form
    ab = np.zeros((3, len(knots)))
    ab[1, :-1] += gap / 3.0
    ab[1, 1:] += gap / 3.0
    ab[0, 1:] = gap / 6.0
    ab[2, :-1] = gap / 6.0
    return solve_banded((1, 1), ab, rhs, overwrite_b=True, check_finite=False)


def spline_reduce(z: np.ndarray, rows_at=None, cols_at=None) -> np.ndarray:
    """One step of Algorithm 1: the best approximation of every row on the coarse knots, then of every column.

    ``rows_at`` and ``cols_at`` are the positions of the grid's rows and
    columns (unit spacing by default; uneven after a side of even length was
    coarsened).
    """
    z = np.asarray(z, dtype=np.float64)
    rows_at = np.arange(z.shape[0], dtype=float) if rows_at is None else np.asarray(rows_at, float)
    cols_at = np.arange(z.shape[1], dtype=float) if cols_at is None else np.asarray(cols_at, float)
    rows = _approximate(z.T, cols_at).T  # each row: one right-hand side
    return _approximate(rows, rows_at)


def _interpolate(coarse: np.ndarray, rows_at: np.ndarray, cols_at: np.ndarray, shape) -> np.ndarray:
    """Heights at every fine grid point from the coarse heights at fine positions ``rows_at`` x ``cols_at``, on the
    coarse squares cut by formula 1."""
    r = np.arange(shape[0])
    c = np.arange(shape[1])
    i = np.clip(np.searchsorted(rows_at, r, side="right") - 1, 0, len(rows_at) - 2)
    j = np.clip(np.searchsorted(cols_at, c, side="right") - 1, 0, len(cols_at) - 2)
    v = ((r - rows_at[i]) / (rows_at[i + 1] - rows_at[i]))[:, None]
    u = ((c - cols_at[j]) / (cols_at[j + 1] - cols_at[j]))[None, :]
    ii, jj = i[:, None], j[None, :]
    za, zb = coarse[ii, jj], coarse[ii, jj + 1]
    zc, zd = coarse[ii + 1, jj], coarse[ii + 1, jj + 1]
    main = diagonal_rule(coarse)[ii, jj]  # True: the square is cut from (i, j) to (i + 1, j + 1)
    on_main = np.where(u >= v, za + u * (zb - za) + v * (zd - zb), za + v * (zc - za) + u * (zd - zc))
    on_anti = np.where(u + v <= 1.0, za + u * (zb - za) + v * (zc - za),
                       zd + (1.0 - u) * (zc - zd) + (1.0 - v) * (zb - zd))
    return np.where(main, on_main, on_anti)


def spline_approximation(z: np.ndarray, iterations: int) -> np.ndarray:
    """Heights at every grid point of the spline approximation after ``iterations`` calls of Algorithm 1."""
    z = np.asarray(z, dtype=np.float64)
    limit = min(max_iterations(z.shape[0]), max_iterations(z.shape[1]))
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) or not 0 <= iterations <= limit:
        raise InvalidOptionError(
            f"spline_iterations must be a whole number from 0 to {limit} for a {z.shape[0]} x {z.shape[1]} grid, "
            f"got {iterations!r}"
        )
    if iterations == 0:
        return z.copy()
    coarse = z
    rows_at, cols_at = np.arange(z.shape[0], dtype=float), np.arange(z.shape[1], dtype=float)
    for _ in range(iterations):
        coarse = spline_reduce(coarse, rows_at, cols_at)
        rows_at = rows_at[coarse_knots(len(rows_at))]
        cols_at = cols_at[coarse_knots(len(cols_at))]
    return _interpolate(coarse, rows_at, cols_at, z.shape)


def spline_filter(hf: Heightfield, iterations: int) -> Heightfield:
    """The heightfield low-pass filtered by ``iterations`` steps of linear-spline best approximation.

    Nodata cells take the height of the nearest valid cell for the filter and
    are nodata again in the result.
    """
    return Heightfield(spline_approximation(filled(hf), iterations), transform=hf.transform, crs=hf.crs,
                       nodata_mask=~hf.valid)
