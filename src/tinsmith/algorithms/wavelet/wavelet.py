"""Spline and Haar-wavelet filtering of city terrain steered by land use, then the quadtree (Goebbels and Pohle-Fröhlich 2015).

Goebbels and Pohle-Fröhlich (2015) (sections 3 to 6) draws a city with triangles only where they are
needed.  Every grid point first takes the height of the linear-spline best
approximation after ``spline_iterations`` coarsenings
(:mod:`.spline`): the terrain "drawn with poor precision".  Points that
matter get more detail (section 5):

- **class 1**, points near a shoreline, an embankment, a bridge or a street
  that touches a bridge (:mod:`.landuse`: a square ``window`` of grid points
  around the point holds one); inside an embankment they are extra strict;
- **class 2**, the other points whose unfiltered height departs from the
  spline by more than ``delta`` (heaps, hills, and in a surface model,
  buildings); inside a forest they get the forest thresholds;
- **class 3**, the rest: spline heights.

Points of classes 1 and 2 take the non-linear Haar low pass of the
unfiltered heights (:mod:`.haar`, formula 3 or 4) with their class's row of
thresholds (:data:`TABLE_1` by default), but only where it differs from the
spline height by more than ``replace_tolerance`` (0.3 m): ``replace="hard"``
is the paper's switch; the default ``"soft"`` adds the difference shrunk by
the tolerance instead, so that no step appears where the detail sets in.  Each water body
(4-connected cells of water polygons) is then flattened to the median of
its unfiltered heights (the paper: their average; the median is not lifted
by trees, boats or bridge decks over the water), bridge decks that the
model holds left out.  The quadtree of squares cut by formula 1
(:class:`.quadtree.QuadtreeHierarchy` with ``diagonal="rule"``) meshes the
result at the accuracy ``max_error``.  ``spline_iterations="auto"`` tries 1
to 6 iterations and keeps the count with the fewest triangles (Table 3).

The Haar transform runs over as many levels as the table has columns (9),
at most ``log2`` of the grid's shorter side; with fewer levels the finest
columns are used.  ``variant=None`` keeps the unfiltered heights of the
points of classes 1 and 2 (where they differ from the spline by more than
the tolerance): the middle column of the paper's Table 2.

The filtered heights are a pre-filter for any other method too
(:func:`wavelet_filter`, ``tinsmith simplify --prefilter wavelet``): the
paper's future work.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import ndimage

from ... import _checks, _deprecation
from ...core import Heightfield, TerrainMesh
from ...core.stop import StopCriteria
from ...errors import InvalidInputError, InvalidOptionError
from ...resources import check_memory, estimate_method
from ...triangulation.grid import filled
from ...triangulation.sampling import rasterize
from ..grid.quadtree import QuadtreeHierarchy
from ..registry import register
from .haar import haar_transform
from .landuse import LandUse, LandUseClasses, landuse_classes, read_landuse
from .spline import max_iterations, spline_approximation
from .wavelet_table import TABLE_1

__all__ = ["CLASS_NAMES", "TABLE_1", "WaveletFilter", "error_by_class", "wavelet", "wavelet_filter", "wavelet_model"]

#: The accuracy of the quadtree (z units) when no max_error is given: the paper's 0.2 m.
DEFAULT_MAX_ERROR = 0.2

_ROWS = tuple(TABLE_1)  # row r of the table is used by the points of class code r + 1

#: The codes of :attr:`WaveletFilter.classes` (0: nodata).
CLASS_NAMES = {
    1: "class 1",
    2: "class 1, embankment interior",
    3: "class 2",
    4: "class 2, forest",
    5: "class 3",
    6: "water",
}

#: The spline iteration counts "auto" tries (the paper's Tables 3 and 4).
AUTO_ITERATIONS = range(1, 7)


@dataclass
class WaveletFilter:
    """The result of :func:`wavelet_filter`.

    ``heightfield`` the filtered heights (nodata where the input has none),
    ``spline`` the spline heights alone, ``classes`` the code of every grid
    point (:data:`CLASS_NAMES`, 0 for nodata), ``landuse`` what the polygons
    gave (None without land use), ``triangles`` the triangle count of every
    iteration count tried by "auto" (empty otherwise).
    """

    heightfield: Heightfield
    spline: Heightfield
    classes: np.ndarray
    spline_iterations: int
    landuse: LandUseClasses | None = None
    triangles: dict = field(default_factory=dict)

    def class_counts(self) -> dict:
        """Grid points per class name."""
        counts = np.bincount(self.classes.ravel(), minlength=len(CLASS_NAMES) + 1)
        return {name: int(counts[code]) for code, name in CLASS_NAMES.items()}


def _table(thresholds) -> np.ndarray:
    """The threshold table (4, levels): Table 1 with the rows given in ``thresholds`` replaced."""
    rows = dict(TABLE_1)
    if thresholds is not None:
        if not isinstance(thresholds, dict):
            raise InvalidOptionError(
                f"thresholds must be a dict with rows of {', '.join(_ROWS)} (any of them), got {type(thresholds).__name__}"
            )
        unknown = sorted(set(thresholds) - set(_ROWS))
        if unknown:
            raise InvalidOptionError(f"thresholds has no row {unknown[0]!r}; its rows are {', '.join(_ROWS)}")
        rows.update(thresholds)
    try:
        table = np.array([np.asarray(rows[r], dtype=np.float64) for r in _ROWS])
    except (TypeError, ValueError):
        raise InvalidOptionError(
            "thresholds: every row must be a sequence of numbers, one per level, all rows of one length"
        ) from None
    if table.ndim != 2 or table.shape[1] < 1:
        raise InvalidOptionError("thresholds: every row must be a sequence of numbers, one per level, all rows of one length")
    if not (np.isfinite(table) & (table >= 0)).all():
        raise InvalidOptionError("thresholds must be finite numbers of at least 0 (metres, per level)")
    return table


class _Filter:
    """What the filter needs that does not depend on the spline iterations: classes from land use and the
    low-pass heights of every point as if it were of class 1 or 2."""

    def __init__(self, hf, lu: LandUseClasses | None, *, delta, table, variant, replace_tolerance, replace, flatten_water):
        self.hf, self.lu, self.delta, self.tolerance, self.table = hf, lu, delta, replace_tolerance, table
        self.soft = replace == "soft"
        self.z = filled(hf)
        h, w = hf.shape
        near = lu.near if lu is not None else np.zeros(hf.shape, bool)
        # the class code a point has if it is of class 1, or else of class 2 (the delta test comes later)
        code = np.full(hf.shape, 3, np.int8)
        if lu is not None:
            code[lu.forest] = 4
            code[near] = 1
            code[near & lu.embankment] = 2
        self.detail_code = code
        # soft: a point never moves more than its class's largest threshold from the detail (embankments 0.1 m)
        self.soft_tolerance = np.minimum(replace_tolerance, table.max(axis=1))[code - 1]
        if variant is None:
            self.detail = self.z
        else:
            levels = int(min(table.shape[1], np.floor(np.log2(min(h, w)))))
            coeffs = haar_transform(self.z, levels)
            self.detail = coeffs.reconstruct(table[:, -levels:], variant=variant, rows=code - 1)
        self.limit = min(max_iterations(h), max_iterations(w))
        self.flat, self.level = _water_surface(self.z, lu) if flatten_water and lu is not None else (None, None)

    def run(self, iterations: int) -> WaveletFilter:
        hf, z, lu = self.hf, self.z, self.lu
        valid = hf.valid
        spline = spline_approximation(z, iterations)
        detailed = (self.detail_code <= 2) | (np.abs(z - spline) > self.delta)
        classes = np.where(detailed, self.detail_code, 5).astype(np.uint8)
        change = self.detail - spline
        if self.soft:  # shrink the change by the tolerance: continuous where the detail sets in
            change = np.sign(change) * np.maximum(np.abs(change) - self.soft_tolerance, 0.0)
        else:  # the paper: the detail replaces the spline where they differ by more than the tolerance
            change = np.where(np.abs(change) > self.tolerance, change, 0.0)
        out = np.where(detailed, spline + change, spline)
        if self.flat is not None:
            out[self.flat] = self.level[self.flat]
            classes[self.flat] = 6
        classes[~valid] = 0
        nodata = ~valid
        return WaveletFilter(
            heightfield=Heightfield(out, transform=hf.transform, crs=hf.crs, nodata_mask=nodata),
            spline=Heightfield(spline, transform=hf.transform, crs=hf.crs, nodata_mask=nodata),
            classes=classes,
            spline_iterations=iterations,
            landuse=lu,
        )


#: A bridge over water keeps its heights when they stand this much (m) above the water: a deck in the model.
DECK_CLEARANCE = 1.0


def _water_surface(z: np.ndarray, lu: LandUseClasses):
    """(cells to flatten, their level): each water body at the median of its heights, bridge decks left out.

    The median, not the mean: trees, boats and decks over the water do not
    lift it.  A bridge whose heights over the water stand more than
    :data:`DECK_CLEARANCE` above the level is a deck the model holds (a
    surface model) and keeps them; under a bridge the model does not hold
    (a terrain model) the water is flat too.
    """
    bodies, decks = lu.water, lu.decks
    n = int(bodies.max())
    if n == 0:
        return None, None
    open_water = np.where(decks > 0, 0, bodies)
    index = np.arange(1, n + 1)
    level = np.asarray(ndimage.median(z, open_water, index=index), dtype=np.float64)
    whole = np.asarray(ndimage.median(z, bodies, index=index), dtype=np.float64)
    level = np.concatenate([[0.0], np.where(np.isnan(level), whole, level)])  # a body all under bridges
    flat = bodies > 0
    for d in np.unique(decks[flat & (decks > 0)]):
        cells = flat & (decks == d)
        body = np.bincount(bodies[cells]).argmax()
        if np.median(z[cells]) > level[body] + DECK_CLEARANCE:
            flat &= ~cells
    return flat, level[bodies]


def _prepare(hf, landuse, roles, attribute, *, delta, thresholds, variant, window, bridge_extension, replace_tolerance,
             replace, flatten_water):
    if not isinstance(hf, Heightfield):
        raise InvalidInputError(f"the wavelet filter takes a Heightfield, got {type(hf).__name__}")
    check_memory(estimate_method("wavelet", hf.n_cells), f"wavelet on {hf.shape[0]:,} x {hf.shape[1]:,} cells",
                 "'tinsmith tile' meshes a DEM of any size in windows")
    delta = _checks.number("delta", delta, minimum=0.0)
    replace_tolerance = _checks.number("replace_tolerance", replace_tolerance, minimum=0.0)
    if variant not in (3, 4, None):
        raise InvalidOptionError(f"variant must be 3 or 4 (the paper's formulas) or None (unfiltered detail), got {variant!r}")
    table = _table(thresholds)
    if replace not in ("hard", "soft"):
        raise InvalidOptionError(f"replace must be one of 'hard' (the paper) or 'soft', got {replace!r}")
    if not isinstance(flatten_water, bool):
        raise InvalidOptionError(f"flatten_water must be True or False, got {flatten_water!r}")
    if hf.n_valid == 0:
        raise InvalidInputError("the heightfield has no valid cell")
    if isinstance(landuse, (str, Path)) or hasattr(landuse, "geometry"):  # a file, or a GeoDataFrame
        landuse = read_landuse(landuse, roles, attribute)
    elif landuse is not None and (roles is not None or attribute is not None):
        raise InvalidOptionError("roles and attribute apply to a land-use file; a LandUse has its roles already")
    elif roles is not None or attribute is not None:
        raise InvalidOptionError("roles and attribute need a land-use file (landuse=...)")
    if landuse is not None and not isinstance(landuse, LandUse):
        raise InvalidInputError(f"landuse must be a file name or a LandUse, got {type(landuse).__name__}")
    lu = landuse_classes(hf, landuse, window=window, bridge_extension=bridge_extension) if landuse is not None else None
    return _Filter(hf, lu, delta=delta, table=table, variant=variant, replace_tolerance=replace_tolerance,
                   replace=replace, flatten_water=flatten_water)


def _iterations(stage: _Filter, spline_iterations) -> list:
    """The iteration counts to try: 1 to 6 (as far as the grid allows) for "auto", else the one given."""
    if isinstance(spline_iterations, str) and spline_iterations == "auto":
        return [k for k in AUTO_ITERATIONS if k <= stage.limit] or [stage.limit]
    if isinstance(spline_iterations, bool) or not isinstance(spline_iterations, (int, np.integer)) \
            or not 0 <= spline_iterations <= stage.limit:
        raise InvalidOptionError(
            f"spline_iterations must be 'auto' or a whole number from 0 to {stage.limit} for a "
            f"{stage.hf.shape[0]} x {stage.hf.shape[1]} grid, got {spline_iterations!r}"
        )
    return [int(spline_iterations)]


def _run(stage: _Filter, spline_iterations, epsilon: float):
    """The filter at the given iteration count, or for "auto" the count of fewest triangles; with its mesh."""
    tries = _iterations(stage, spline_iterations)
    best, counts = None, {}
    for k in tries:
        result = stage.run(k)
        mesh = QuadtreeHierarchy(result.heightfield, diagonal="rule").mesh(epsilon)
        counts[k] = mesh.n_triangles
        if best is None or mesh.n_triangles < best[1].n_triangles:  # ties: the fewer iterations
            best = (result, mesh)
    result, mesh = best
    if len(tries) > 1:
        result.triangles = counts
    return result, mesh


def wavelet_filter(
    hf: Heightfield,
    *,
    landuse=None,
    roles: dict | None = None,
    attribute: str | None = None,
    spline_iterations="auto",
    delta: float = 4.0,
    thresholds: dict | None = None,
    variant: int | None = 4,
    max_error: float = DEFAULT_MAX_ERROR,
    window: int = 9,
    bridge_extension: float = 2.0,
    replace_tolerance: float = 0.3,
    replace: str = "soft",
    flatten_water: bool = True,
    epsilon: float | None = None,
) -> WaveletFilter:
    """The heights filtered by spline and land-use-steered Haar wavelets.

    The method of Goebbels and Pohle-Fröhlich (2015), which the module docstring describes.

    Parameters
    ----------
    hf : Heightfield
        The terrain or surface model.
    landuse : str, Path or LandUse, optional
        A vector file of land-use features (read with ``roles`` and
        ``attribute``, see :func:`tinsmith.algorithms.wavelet.landuse.read_landuse`)
        or features with roles already.  Without it no point is of class 1.
    roles : dict, optional
        Layer name, usage value or ``"field=value"`` -> role; default the
        BGT's (:data:`tinsmith.algorithms.wavelet.landuse.BGT_ROLES`).
    attribute : str, optional
        The usage column of the file.
    spline_iterations : "auto" or int
        Coarsenings of the spline approximation; "auto" tries 1 to 6 and
        keeps the count whose quadtree mesh at ``max_error`` has the fewest
        triangles.
    delta : float
        Class 2: points whose unfiltered height departs from the spline by
        more than this (z units).
    thresholds : dict, optional
        Rows of Table 1 to replace: ``class1``, ``embankment``, ``class2``,
        ``forest``, each one threshold per level, coarsest first.
    variant : {4, 3, None}
        The low pass: formula 4 (tail cut), formula 3, or None for the
        unfiltered heights.
    max_error : float
        The accuracy of the quadtree that "auto" counts triangles with (z
        units, > 0): the bound :func:`wavelet` meshes the result at.
    window : int
        Side, in grid points, of the square that makes a point near a
        feature (class 1).
    bridge_extension : float
        Bridges are grown by this much (world units).
    replace_tolerance : float
        Low-pass heights replace spline heights only where they differ by
        more than this (0.3 m in the paper).
    replace : {"soft", "hard"}
        "hard", the paper: where the low pass differs from the spline by more
        than the tolerance it replaces it, which leaves steps of the
        tolerance or more wherever the detail sets in.  "soft": the spline
        plus the difference shrunk by the tolerance (at most the largest
        threshold of the point's row of the table: 0.1 m inside
        embankments), continuous; with ``variant=None`` a point of class 1
        or 2 is then never further than that from its unfiltered height.
        The default: on the Delft DTM it halves the triangles of "hard".
    flatten_water : bool
        Flatten each water body to the mean of its heights (the paper).
    epsilon : float, optional
        Deprecated: the former name of ``max_error``.

    Examples
    --------
    >>> import numpy as np
    >>> import shapely
    >>> import tinsmith
    >>> rng = np.random.default_rng(0)
    >>> z = 2.0 + 0.02 * np.arange(64.0) + rng.normal(0.0, 0.05, size=(64, 64))  # a gentle slope, 1 m cells
    >>> z[:, 30:34] = -1.0 + rng.normal(0.0, 0.05, size=(64, 4))  # a canal across it
    >>> dtm = tinsmith.Heightfield(z, cell_size=1.0)
    >>> canal = tinsmith.LandUse([shapely.box(30.0, 0.0, 34.0, 64.0)], ["water"])
    >>> filtered = tinsmith.wavelet_filter(dtm, landuse=canal)
    >>> filtered.class_counts()["water"]  # 64 rows x 4 columns
    256
    >>> water = filtered.heightfield.z[:, 30:34]
    >>> bool(water.min() == water.max())  # the water is flattened to its mean height
    True
    """
    if epsilon is not None:
        _deprecation.warn("epsilon of wavelet_filter is deprecated and will be removed: use max_error")
        max_error = _checks.number("epsilon", epsilon, minimum=0.0, exclusive_min=True)
    epsilon = _checks.number("max_error", max_error, minimum=0.0, exclusive_min=True)
    stage = _prepare(hf, landuse, roles, attribute, delta=delta, thresholds=thresholds, variant=variant,
                     window=window, bridge_extension=bridge_extension, replace_tolerance=replace_tolerance,
                     replace=replace, flatten_water=flatten_water)
    if isinstance(spline_iterations, str) and spline_iterations == "auto":
        return _run(stage, spline_iterations, epsilon)[0]
    return stage.run(_iterations(stage, spline_iterations)[0])


def error_by_class(mesh: TerrainMesh, hf: Heightfield, classes: np.ndarray, filtered: Heightfield | None = None) -> dict:
    """Vertical error of ``mesh`` against the unfiltered ``hf``, per class (:data:`CLASS_NAMES`).

    For each class present: its grid points, the largest and the RMS error
    of the mesh, and with ``filtered`` the largest error of the filtered
    heights alone (what the filter gave up before the triangulation).
    """
    z = hf.z.astype(np.float64)
    err = np.abs(rasterize(mesh, hf) - z)
    report = {}
    for code, name in CLASS_NAMES.items():
        cells = (classes == code) & hf.valid
        if not cells.any():
            continue
        e = err[cells]
        e = e[np.isfinite(e)]
        entry = {"cells": int(cells.sum()),
                 "max": float(e.max()) if len(e) else float("nan"),
                 "rmse": float(np.sqrt(np.mean(e * e))) if len(e) else float("nan")}
        if filtered is not None:
            entry["filter_max"] = float(np.abs(filtered.z[cells].astype(np.float64) - z[cells]).max())
        report[name] = entry
    return report


@register("wavelet")
def wavelet(hf, *, landuse, roles, attribute, spline_iterations, delta, thresholds, variant, window, bridge_extension,
            replace_tolerance, replace, flatten_water, stop: StopCriteria, progress=None,
            return_filter: bool = False) -> TerrainMesh:
    """A city terrain as a quadtree mesh of its spline- and wavelet-filtered heights (Goebbels and Pohle-Fröhlich 2015).

    The options are those of :func:`wavelet_filter`; ``max_error`` (default
    0.2) is the accuracy of the quadtree, its strict bound against the
    filtered heights.  ``mesh.info["wavelet"]`` holds the iteration count
    used (and every count "auto" tried with its triangles), the grid points
    per class and :func:`error_by_class` against the unfiltered heights.
    The filtered heights and the classes themselves are
    :func:`wavelet_filter` (``return_filter=True``, which made this return
    ``(mesh, WaveletFilter)``, and ``epsilon``, the former name of
    ``max_error``, are deprecated).

    Examples
    --------
    >>> import numpy as np
    >>> import shapely
    >>> import tinsmith
    >>> rng = np.random.default_rng(0)
    >>> z = 2.0 + 0.02 * np.arange(64.0) + rng.normal(0.0, 0.05, size=(64, 64))  # a gentle slope, 1 m cells
    >>> z[:, 30:34] = -1.0 + rng.normal(0.0, 0.05, size=(64, 4))  # a canal across it
    >>> dtm = tinsmith.Heightfield(z, cell_size=1.0)
    >>> canal = tinsmith.LandUse([shapely.box(30.0, 0.0, 34.0, 64.0)], ["water"])
    >>> mesh = tinsmith.wavelet(dtm, landuse=canal, max_error=0.2)
    >>> mesh.n_vertices < dtm.n_cells
    True
    >>> filtered = tinsmith.wavelet_filter(dtm, landuse=canal)  # the heights the mesh was made of
    >>> tinsmith.vertical_error(mesh, filtered.heightfield)["max"] <= 0.2  # the bound holds on them
    True
    """
    mesh, result = wavelet_model(
        hf, max_error=DEFAULT_MAX_ERROR if stop.max_error is None else stop.max_error, landuse=landuse, roles=roles,
        attribute=attribute, spline_iterations=spline_iterations, delta=delta, thresholds=thresholds, variant=variant,
        window=window, bridge_extension=bridge_extension, replace_tolerance=replace_tolerance, replace=replace,
        flatten_water=flatten_water)
    if progress is not None:
        progress(1.0)
    return (mesh, result) if return_filter else mesh


def wavelet_model(hf: Heightfield, *, max_error: float = DEFAULT_MAX_ERROR, landuse=None, roles: dict | None = None,
                  attribute: str | None = None, spline_iterations="auto", delta: float = 4.0,
                  thresholds: dict | None = None, variant: int | None = 4, window: int = 9,
                  bridge_extension: float = 2.0, replace_tolerance: float = 0.3, replace: str = "soft",
                  flatten_water: bool = True) -> tuple[TerrainMesh, WaveletFilter]:
    """``(mesh, filter)``: the mesh of :func:`wavelet` and the :class:`WaveletFilter` it was made of, in one run.

    What ``tinsmith wavelet --filtered --class-map`` writes; the method
    (:func:`wavelet`) returns the mesh alone, :func:`wavelet_filter` the
    filter alone.  No registry bookkeeping: ``mesh.info["method"]`` is set,
    the options are not recorded.
    """
    epsilon = _checks.number("max_error", max_error, minimum=0.0, exclusive_min=True)
    stage = _prepare(hf, landuse, roles, attribute, delta=delta, thresholds=thresholds, variant=variant,
                     window=window, bridge_extension=bridge_extension, replace_tolerance=replace_tolerance,
                     replace=replace, flatten_water=flatten_water)
    result, mesh = _run(stage, spline_iterations, epsilon)
    mesh.info["method"] = "wavelet"
    mesh.info["max_error_used"] = epsilon
    mesh.info["wavelet"] = {
        "spline_iterations": result.spline_iterations,
        "triangles_by_iterations": result.triangles,
        "classes": result.class_counts(),
        "error_by_class": error_by_class(mesh, hf, result.classes, result.heightfield),
        "landuse_outside": result.landuse.outside if result.landuse is not None else 0,
    }
    return mesh, result
