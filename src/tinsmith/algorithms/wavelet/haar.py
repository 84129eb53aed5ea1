"""Haar wavelets for Goebbels and Pohle-Fröhlich (2015)'s non-linear low pass (section 4, Algorithms 2 and 3, formulas 3 and 4).

The simplified non-standard transform (Kopp and Purgathofer 1998): each
level transforms every row of the current averages into pair means and half
differences (Algorithm 2), then only the columns of the means (the
simplification: the row differences are not transformed again), and goes on
with the quarter of means of means.  A level ``i`` (0 the coarsest, as in
Table 1) leaves two sets of coefficients: ``row[i]``, the half differences
of horizontal pairs, and ``col[i]``, those of vertical pairs of row means.

A height is rebuilt from the coarsest means by adding, level by level from
the coarsest, each coefficient with the sign of the Haar wavelet at that
point (formula 2).  The low pass of formula 3 leaves out, at each point, the
coefficients below that point's threshold for their level; formula 4 cuts
the sum after the finest coefficient above its threshold.  Thresholds can
change from point to point (the land-use classes of section 5): a table of
threshold rows and the row of every point.

Sizes: the grid is padded by repeating its last row and column up to a
multiple of ``2**levels``; the padding is cut off again.
"""

from __future__ import annotations

import numpy as np

from ...errors import InvalidOptionError

__all__ = ["HaarTransform", "haar_transform"]


class HaarTransform:
    """The coefficients of the simplified non-standard transform of a grid (see the module docstring).

    ``means`` the coarsest averages, ``row[i]`` and ``col[i]`` the
    coefficients of level ``i`` (0 the coarsest), ``shape`` the grid's shape
    before padding.
    """

    def __init__(self, means: np.ndarray, row: list, col: list, shape: tuple):
        self.means, self.row, self.col, self.shape = means, row, col, shape

    @property
    def levels(self) -> int:
        return len(self.row)

    def reconstruct(self, thresholds=None, variant: int = 3, rows=None) -> np.ndarray:
        """The heights, every coefficient kept (the exact inverse), or with ``thresholds`` a low pass.

        ``thresholds`` holds one value per level (coarsest first) for the
        whole grid, or a table (K, levels) of such rows together with
        ``rows``, an (H, W) array that gives each grid point the index of its
        row (the land-use classes).  A coefficient is large at a point when its
        magnitude is at least that point's threshold for its level.
        ``variant`` 3 (formula 3) keeps the large coefficients only.  Variant 4
        (formula 4) keeps, at each point, every coefficient up to the finest
        large one: with ``m1`` the finest level of a large row coefficient and
        ``m0`` of a large column coefficient (-1 for none), the row
        coefficients of levels up to ``max(m1, m0)`` and the column ones up to
        ``max(m1 - 1, m0)``.  Memory: a few grids, whatever the level count.
        """
        if variant not in (3, 4):
            raise InvalidOptionError(f"variant must be 3 or 4 (the paper's formulas), got {variant!r}")
        padded = (self.means.shape[0] << self.levels, self.means.shape[1] << self.levels)
        step = 1 << self.levels
        out = np.repeat(np.repeat(self.means, step, axis=0), step, axis=1)
        if thresholds is None:
            for i in range(self.levels):
                row_term, col_term = self._terms(i, padded)
                out += row_term
                out += col_term
            return out[: self.shape[0], : self.shape[1]]
        threshold = self._thresholds(thresholds, rows, padded)
        if variant == 3:
            for i in range(self.levels):
                t = threshold(i)
                for term in self._terms(i, padded):
                    out += np.where(np.abs(term) >= t, term, 0.0)
            return out[: self.shape[0], : self.shape[1]]
        m1 = np.full(padded, -1, dtype=np.int8)
        m0 = np.full(padded, -1, dtype=np.int8)
        for i in range(self.levels):
            t = threshold(i)
            row_term, col_term = self._terms(i, padded)
            m1[np.abs(row_term) >= t] = i
            m0[np.abs(col_term) >= t] = i
        row_to, col_to = np.maximum(m1, m0), np.maximum(m1 - 1, m0)
        del m1, m0
        for i in range(self.levels):
            row_term, col_term = self._terms(i, padded)
            out += np.where(i <= row_to, row_term, 0.0)
            out += np.where(i <= col_to, col_term, 0.0)
        return out[: self.shape[0], : self.shape[1]]

    def _thresholds(self, thresholds, rows, padded):
        """A function of the level giving the threshold: a number, or one per (padded) grid point."""
        table = np.asarray(thresholds, dtype=np.float64)
        if table.ndim == 1:
            table = table[None, :]
        if table.ndim != 2 or table.shape[1] != self.levels:
            raise InvalidOptionError(
                f"thresholds must hold {self.levels} values (one per level, coarsest first), or a table of rows "
                f"of {self.levels} values, got shape {table.shape}"
            )
        if not (np.isfinite(table) & (table >= 0)).all():
            raise InvalidOptionError("thresholds must be finite numbers of at least 0")
        if rows is None:
            if len(table) != 1:
                raise InvalidOptionError(f"a table of {len(table)} threshold rows needs `rows`, the row of every point")
            return lambda i: table[0, i]
        rows = np.asarray(rows)
        if rows.shape != self.shape or not np.issubdtype(rows.dtype, np.integer):
            raise InvalidOptionError(f"rows must be an integer array of shape {self.shape}, got {rows.dtype} {rows.shape}")
        if rows.size and (rows.min() < 0 or rows.max() >= len(table)):
            raise InvalidOptionError(f"rows must index the {len(table)} rows of thresholds")
        index = np.pad(rows, ((0, padded[0] - self.shape[0]), (0, padded[1] - self.shape[1])), mode="edge")
        return lambda i: table[:, i][index]

    def _terms(self, i: int, padded: tuple) -> tuple:
        """Level i's row and column coefficients at every (padded) grid point, with the Haar wavelet's sign."""
        size = 1 << (self.levels - i)  # side of the block one coefficient of this level covers
        half = size >> 1
        # the row wavelet: + on the left half of its block, - on the right; the column wavelet: + top, - bottom
        row_sign = np.tile(np.r_[np.ones(half), -np.ones(half)], padded[1] // size)[None, :]
        col_sign = np.tile(np.r_[np.ones(half), -np.ones(half)], padded[0] // size)[:, None]
        row_term = np.repeat(np.repeat(self.row[i], half, axis=0), size, axis=1)
        col_term = np.repeat(np.repeat(self.col[i], size, axis=0), size, axis=1)
        row_term *= row_sign
        col_term *= col_sign
        return row_term, col_term


def haar_transform(z: np.ndarray, levels: int) -> HaarTransform:
    """The simplified non-standard Haar transform of ``z`` over ``levels`` levels (Algorithm 3)."""
    z = np.asarray(z, dtype=np.float64)
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 1:
        raise InvalidOptionError(f"levels must be a whole number of at least 1, got {levels!r}")
    if not np.isfinite(z).all():
        raise InvalidOptionError("the Haar transform needs a finite value at every grid point (fill nodata first)")
    step = 1 << levels
    pad = (-z.shape[0] % step, -z.shape[1] % step)
    a = np.pad(z, ((0, pad[0]), (0, pad[1])), mode="edge")
    rows, cols = [], []
    for _ in range(levels):
        means = (a[:, 0::2] + a[:, 1::2]) / 2.0  # Algorithm 2 on every row
        rows.append((a[:, 0::2] - a[:, 1::2]) / 2.0)
        a = (means[0::2] + means[1::2]) / 2.0  # then on the columns of the means only
        cols.append((means[0::2] - means[1::2]) / 2.0)
    # rows[-1] belongs to the coarsest level: number the levels coarsest first
    return HaarTransform(a, rows[::-1], cols[::-1], z.shape)
