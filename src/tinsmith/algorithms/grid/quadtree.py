"""Crack-free quadtree triangulation: a right-triangulated irregular network (RTIN), as Martini.

The Salt Lake City thesis section 2.2 (hierarchical subdivision) and Goebbels and Pohle-Fröhlich (2015) section 2 (its
quadtree triangulation); the hierarchy and its error propagation follow
Martini (mapbox), see :mod:`tinsmith.kernels.quadtree`.  The square is cut
along a diagonal, and every triangle is bisected from its right angle to the
middle of its hypotenuse while its error exceeds the bound; an error is
shared by the two triangles across a hypotenuse and includes the errors
below, so neighbours split together: the mesh has no T-junction at any level.

**Strict bound** (the default): the error of a triangle is the largest
vertical error over every cell it covers, measured with the expression the
metrics use, so the mesh never exceeds ``max_error`` anywhere.  Martini
estimates it at the hypotenuse midpoints only and can exceed the bound
(benchmarks/RESULTS_quadtree.md, "Martini max error"); ``strict=False`` reproduces
its meshes exactly, for comparison and speed.

**Goebbels and Pohle-Fröhlich (2015)'s diagonal rule** (``diagonal="rule"``): a quadtree of squares
instead, each cut along the diagonal of Goebbels and Pohle-Fröhlich (2015)'s formula 1 and split
into four while its two triangles exceed the bound, as the paper does, but
restricted (neighbouring leaves one level apart at most) and with a square
next to finer ones cut into a fan through the middles of their edges, so
that it is crack-free too (see :mod:`tinsmith.kernels.quadtree_rule`); the
bound is strict.

**Any grid**: the hierarchy is built over the smallest (2^k + 1)-square that
holds the grid.  A triangle reaching into the padding is cut back to the
data and written as a fan (measured as written; :func:`.kernels.quadtree._clip`),
and so is a square of the diagonal rule.  A triangle
holding cells with and without data always splits, so the mesh follows
holes in the data at full resolution.  The errors are computed once
(:class:`QuadtreeHierarchy`); every level after that costs only an
extraction.
"""

from __future__ import annotations

import numpy as np

from ...core import Heightfield, StopCriteria, TerrainMesh
from ...core.stop import default_max_error
from ...errors import InvalidInputError, InvalidOptionError, NoDataError
from ...kernels import quadtree as kq
from ...kernels import quadtree_rule as kr
from ..registry import register

__all__ = ["QuadtreeHierarchy", "quadtree"]


class QuadtreeHierarchy:
    """The RTIN hierarchy of a heightfield with the split error of every node; :meth:`mesh` extracts a level.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> tree = tinsmith.QuadtreeHierarchy(dem)  # the errors of every node, computed once
    >>> coarse, fine = tree.mesh(20.0), tree.mesh(2.0)
    >>> coarse.n_vertices < fine.n_vertices
    True
    >>> tree.counts(20.0) == (coarse.n_vertices, coarse.n_triangles)
    True
    """

    def __init__(self, hf: Heightfield, *, strict: bool = True, diagonal: str = "alternate"):
        if not isinstance(hf, Heightfield):
            raise InvalidInputError(f"quadtree needs a Heightfield, got {type(hf).__name__}")
        if diagonal not in ("alternate", "rule"):
            raise InvalidOptionError(f"diagonal must be 'alternate' or 'rule', got {diagonal!r}")
        if diagonal == "rule" and not strict:
            raise InvalidOptionError(
                "strict=False reproduces Martini's meshes, whose diagonals alternate; diagonal='rule' is always strict"
            )
        self.hf = hf
        self.strict = bool(strict)
        self.diagonal = diagonal
        h, w = hf.shape
        size = 3
        while size < max(h, w):
            size = 2 * size - 1
        self.size = size
        self._right, self._bottom = w - 1, h - 1  # the last column and row of the data in the padded square
        # both cut their triangles back to the data: the padding is never measured or written
        self._all_valid = not hf.nodata_mask.any()
        z = np.zeros((size, size), dtype=hf.z.dtype)
        z[:h, :w] = np.where(hf.valid, hf.z, 0)
        if diagonal == "rule":  # formula 1 picks the diagonals of squares across the edge from these heights
            z[:h, w:] = z[:h, w - 1 : w]
            z[h:, :] = z[h - 1 : h, :]
        valid = np.zeros((size, size), dtype=np.uint8)
        valid[:h, :w] = hf.valid
        self._z, self._valid = z.ravel(), valid.ravel()
        self._lookup, self._stamp = None, 0
        if diagonal == "rule":
            self._levels = (size - 1).bit_length() - 1
            self._rule_err, self._fan_err = kr.square_errors(
                self._z, self._valid, size, self._all_valid, self._levels, self._right, self._bottom
            )
            self.errors = np.concatenate([self._rule_err, self._fan_err])  # every bound at which the mesh changes
            self._state = np.zeros(len(self._rule_err), dtype=np.int32)
        else:
            self.errors = np.zeros(size * size, dtype=np.float64 if self.strict else np.float32)
            kq.hierarchy_errors(
                self._z, self._valid, size, self._all_valid, self.strict, self.errors, self._right, self._bottom
            )

    def _extract(self, max_error: float):
        """(vertices in world coordinates, triangles) of the mesh at ``max_error``."""
        if self._lookup is None or self._stamp >= (1 << 29) - 1:  # a stamp and a state share an int32
            self._lookup = np.zeros((self.size * self.size, 2), dtype=np.int32)  # kept for the next levels
            if self.diagonal == "rule":
                self._state[:] = 0
            self._stamp = 0
        self._stamp += 1
        bound = np.float64(max_error) if self.strict else np.float32(max_error)
        transform = np.array(self.hf.transform[:6], dtype=np.float64)
        if self.diagonal == "rule":  # written clockwise in (col, row), as the tree's triangles
            return kr.extract(
                self._rule_err, self._fan_err, self._z, self._valid, self.size, self._all_valid, self._levels,
                bound, self._state, self._stamp, self._lookup, transform, self.hf.handedness > 0,
                self._right, self._bottom,
            )
        # every triangle of the tree winds as the two roots do, clockwise in (col, row):
        # written (a, c, b) when the transform keeps the orientation, counter-clockwise from +z
        return kq.extract(
            self.errors, self._z, self._valid, self.size, self._all_valid, bound,
            self._lookup, self._stamp, transform, self.hf.handedness > 0, self._right, self._bottom,
        )

    def counts(self, max_error: float) -> tuple[int, int]:
        """(vertices, triangles) of the mesh at ``max_error``."""
        vertices, triangles = self._extract(max_error)
        return len(vertices), len(triangles)

    def mesh(self, max_error: float) -> TerrainMesh:
        """The mesh at ``max_error``: every triangle split while its error exceeds the bound."""
        vertices, triangles = self._extract(max_error)
        if len(triangles) == 0:
            raise NoDataError("no triangle of the quadtree holds three cells with data")
        mesh = TerrainMesh(vertices, triangles, crs=self.hf.crs)
        mesh.info["grid"] = self.hf.grid_spec()
        mesh.info["max_error_used"] = float(max_error)
        return mesh

    def threshold_for_counts(self, max_vertices=None, max_triangles=None) -> float:
        """The smallest error bound whose mesh has at most these counts (the meshes are nested)."""
        candidates = np.unique(self.errors[np.isfinite(self.errors)].astype(np.float64))
        rule = StopCriteria(max_vertices=max_vertices, max_triangles=max_triangles)

        def fits(bound):
            return rule.counts_fit(*self.counts(bound))

        lo, hi = 0, len(candidates) - 1
        if len(candidates) == 0 or not fits(candidates[hi]):
            v, t = self.counts(np.inf if len(candidates) == 0 else candidates[hi])
            raise InvalidInputError(
                f"the coarsest quadtree mesh has {v} vertices and {t} triangles, "
                f"more than max_vertices={max_vertices} / max_triangles={max_triangles} allow"
            )
        while lo < hi:
            mid = (lo + hi) // 2
            if fits(candidates[mid]):
                hi = mid
            else:
                lo = mid + 1
        return float(candidates[lo])


@register("quadtree")
def quadtree(hf: Heightfield, *, strict, diagonal, stop: StopCriteria, progress=None) -> TerrainMesh:
    """Right-triangulated quadtree at the error bound (strict by default), crack-free on any grid.

    ``max_vertices`` / ``max_triangles`` take the smallest bound whose mesh
    fits; without a stop rule the bound is 1/1000 of the height range.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> mesh = tinsmith.quadtree(dem, max_error=10.0)
    >>> tinsmith.vertical_error(mesh, dem)["max"] <= 10.0  # strict: the bound holds at every cell
    True
    >>> tinsmith.quadtree(dem, max_triangles=500).n_triangles <= 500
    True
    """
    tree = QuadtreeHierarchy(hf, strict=strict, diagonal=diagonal)
    if stop.max_vertices is not None or stop.max_triangles is not None:
        bound = tree.threshold_for_counts(stop.max_vertices, stop.max_triangles)
        if stop.max_error is not None:
            bound = max(bound, stop.max_error)  # the first rule reached wins
    elif stop.max_error is not None:
        bound = stop.max_error
    else:
        bound = default_max_error(hf)
    return tree.mesh(bound)
