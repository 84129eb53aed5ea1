"""Urban surface models: standard-deviation thresholds and collapsed contouring (the Salt Lake City thesis, chapter 4).

A city surface model (DSM) holds buildings, but also trees, cars and street
furniture.  The Salt Lake City thesis turns it into a tree of building outlines:

1. **Thresholds** (section 4.1, :func:`urban_thresholds`): from the mean
   ``m`` and the sample standard deviation ``s`` of the valid heights, the
   band ``[m - s, m + s]`` is cut into ``lod`` equal slices and the centre
   of each slice is a threshold; the lowest and the highest height give two
   more.  The lowest is the root: every valid point.
2. **Collapsed contouring** (section 4.2, :mod:`tinsmith.kernels.contour`):
   at a threshold a grid point qualifies when its height is above it; the
   outline of each region of qualifying points is traced through grid
   points only, with N/S/E/W moves, holes (courtyards) included, and kept
   as the corners of its straight runs (contour compression).
3. **Hierarchy**: the regions of a threshold are searched inside the
   regions of the one below, whose children they become: the root is the
   outline of the data, the leaves are roof tops.
4. **Noise controller**: a region with fewer grid points than
   ``noise_factor`` (the thesis' NF), with less area than ``min_area`` or
   narrower than ``min_width`` (the rows of trees the thesis could not
   remove) is dropped, with everything it would have held; beyond the
   thesis, so is a region rougher than ``max_roughness`` (tree crowns: see
   :func:`roughness`).
5. **Relative to ground** (beyond the thesis, whose limitation 5 is one
   histogram of absolute heights: on sloping ground the thresholds slice
   the slope, not the buildings): with ``relative_to_ground=True`` the
   thresholds and the test of a point use the height above the ground,
   the ground given (a DTM on the same grid) or estimated from the DSM by
   a grey-scale opening (:func:`estimate_ground`).

A region is made of the unit squares between four qualifying points (see
:mod:`tinsmith.kernels.contour`), so its outline runs through the grid
points at its edge, as the thesis draws it; a one-point-wide spur has no
area and is no region.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ... import _checks, _deprecation
from ...core import Heightfield, TerrainMesh
from ...errors import InvalidInputError
from ...io.crs import refuse_geographic
from ...kernels import contour as kc
from ...kernels.morphology import running_extreme
from ...resources import check_memory, estimate_method
from ...triangulation.outline import signed_area
from ..greedy.greedy import greedy
from ..registry import register
from .blocks import block_model

__all__ = ["Region", "BuildingTree", "UrbanModel", "blocks", "building_tree", "estimate_ground", "opening", "require_metres",
           "roughness", "urban", "urban_model", "urban_thresholds"]

#: Default width (world units) of the opening that estimates the ground: wider than most buildings.
GROUND_WINDOW = 60.0


def require_metres(crs, bounds, cell: float, ground_window: float = GROUND_WINDOW) -> None:
    """Refuse a surface model in a geographic CRS, before anything is allocated.

    The urban options are lengths and areas in metres (the ground window,
    the least building area and width, the margin): in degrees the ground
    window of 60 alone would span hundreds of thousands of cells (an
    opening padded by half of it: terabytes).  A DSM is not reprojected here:
    that resamples roofs and walls, and moves the outputs to a CRS the user
    did not choose; the message names the UTM zone to reproject to.
    """
    if isinstance(ground_window, bool) or not isinstance(ground_window, (int, float)) or not ground_window > 0:
        ground_window = GROUND_WINDOW  # a bad value is reported by its own check, once the CRS is right
    cells = ground_window / cell if cell > 0 else float("inf")
    refuse_geographic(crs, bounds, "urban",
                      f"the ground window of {ground_window:g} would be {ground_window:g} degrees ({cells:,.0f} cells "
                      "a side), and every length and area option alike")


def estimate_ground(hf: Heightfield, window: float = GROUND_WINDOW) -> Heightfield:
    """The ground under a surface model: a grey-scale opening (minimum, then maximum, over a square window).

    Objects narrower than ``window`` (world units) in some direction are
    removed; a plane, tilted or not, comes back exactly, up to the edges
    (the grid is continued by odd reflection).  Nodata stays nodata.  Linear time whatever the window
    (:mod:`tinsmith.kernels.morphology`).
    A surface model in a geographic CRS is refused (:func:`require_metres`).
    """
    window = _checks.number("ground_window", window, minimum=0.0, exclusive_min=True)
    a, b, _, d, e, _ = hf.transform
    cell = float(np.sqrt(abs(a * e - b * d)))
    require_metres(hf.crs, hf.bounds, cell, window)
    half = max(1, int(np.ceil(window / (2.0 * cell))))
    z = np.where(hf.valid, hf.z, np.nan).astype(np.float64)
    # held above the lowest height, so that a window wider than the data cannot dig below it
    opened = opening(z, half, floor=np.nanmin(z))
    return Heightfield(opened, transform=hf.transform, crs=hf.crs, nodata_mask=~hf.valid)


def opening(z: np.ndarray, half: int, floor: float = -np.inf) -> np.ndarray:
    """Grey-scale opening (minimum, then maximum) of ``z`` over the (2 half + 1)-square window, in linear time.

    The grid is continued by odd reflection across its edges: a slope goes on, so windows near an edge still
    fit under it, and an object near the edge becomes a pit outside, which an opening leaves outside.  The
    continued grid is held at ``floor`` or above.
    """
    padded = np.maximum(np.pad(z, half, mode="reflect", reflect_type="odd"), floor)
    return running_extreme(running_extreme(padded, half, True), half, False)[half:-half, half:-half]


def urban_thresholds(z, lod: int) -> np.ndarray:
    """The thresholds of the Salt Lake City thesis, section 4.1, increasing: lowest height, ``lod`` slice centres, highest height.

    With ``m`` the mean and ``s`` the sample standard deviation (n - 1) of
    the heights ``z`` (valid ones only), threshold ``k`` of the band is
    ``m - s + (k + 1/2) * 2 s / lod`` for ``k = 0 .. lod - 1``: the centres
    of ``lod`` equal slices of ``[m - s, m + s]``.  A centre at or below the
    lowest height, or at or above the highest, is left out (a skewed
    distribution).

    Raises
    ------
    InvalidInputError
        When the heights do not vary (no building can be told from the ground).
    """
    lod = _checks.integer("lod", lod, minimum=1)
    z = np.asarray(z, dtype=np.float64).ravel()
    z = z[np.isfinite(z)]
    if len(z) < 2 or z.min() == z.max():
        raise InvalidInputError(
            "the heights do not vary (a flat surface model): no building can be told from the ground"
        )
    m, s = z.mean(), z.std(ddof=1)
    centres = m - s + (np.arange(lod) + 0.5) * (2.0 * s / lod)
    centres = centres[(centres > z.min()) & (centres < z.max())]
    return np.concatenate([[z.min()], centres, [z.max()]])


@dataclass
class Region:
    """A region of the building tree: one outline (with holes) at one threshold.

    Coordinates are world (x, y); the outline is counter-clockwise, holes
    clockwise, not closed (the first corner is not repeated).
    """

    id: int
    level: int  #: index into :attr:`BuildingTree.thresholds` (0: the root, every valid point)
    threshold: float
    parent: int | None
    outline: np.ndarray
    holes: list = field(default_factory=list)
    n_points: int = 0  #: grid points of the region (the thesis' point count)
    area: float = 0.0  #: outline minus holes, in world units squared
    width: float = 0.0  #: twice the largest distance from inside to the edge, in world units
    height: float = float("nan")  #: median height of the region's own squares (those of no child)
    children: list = field(default_factory=list)


@dataclass
class BuildingTree:
    """The regions of every threshold, parents before children; :attr:`roots` are the outlines of the data."""

    thresholds: np.ndarray  #: of the height, or of the height above the ground (``relative_to_ground``)
    regions: list
    dropped: dict  #: regions the noise controller removed, by reason
    relative_to_ground: bool = False
    owner: np.ndarray | None = None  #: (H-1, W-1) the deepest region of every square, -1 for none

    @property
    def roots(self) -> list:
        return [r for r in self.regions if r.parent is None]

    def leaves(self) -> list:
        return [r for r in self.regions if not r.children]

    def at_level(self, level: int) -> list:
        return [r for r in self.regions if r.level == level]


def roughness(hf: Heightfield) -> np.ndarray:
    """(H-1, W-1) roughness of every square: the mean over its corners of |z - the mean of its four neighbours| (z units).

    Zero on any plane, so on flat and sloping roofs alike except along
    their ridges and edges; large in tree crowns.  Cells without data and
    the edge of the grid count as zero.
    """
    z = np.where(hf.valid, hf.z, np.nan).astype(np.float64)
    dev = np.zeros_like(z)
    with np.errstate(invalid="ignore"):
        dev[1:-1, 1:-1] = np.abs(z[1:-1, 1:-1] - (z[:-2, 1:-1] + z[2:, 1:-1] + z[1:-1, :-2] + z[1:-1, 2:]) / 4.0)
    dev = np.nan_to_num(dev)
    return (dev[:-1, :-1] + dev[:-1, 1:] + dev[1:, :-1] + dev[1:, 1:]) / 4.0


def _group_medians(ids: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """(n,) median of ``values`` for each id in 0..n-1 (NaN where an id has none; negative ids are left out)."""
    sel = ids >= 0
    ids, values = ids[sel], values[sel]
    order = np.lexsort((values, ids))
    ids, values = ids[order], values[order]
    out = np.full(n, np.nan)
    starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
    ends = np.r_[starts[1:], len(ids)]
    for s0, s1 in zip(starts, ends, strict=True):
        out[ids[s0]] = np.median(values[s0:s1])
    return out


def _contains(ring: np.ndarray, p) -> bool:
    """Whether point ``p`` is inside the polygon ``ring`` (even-odd rule)."""
    x, y = ring[:, 0], ring[:, 1]
    x2, y2 = np.roll(x, -1), np.roll(y, -1)
    crosses = ((y > p[1]) != (y2 > p[1])) & (p[0] < (x2 - x) * (p[1] - y) / np.where(y2 == y, 1, y2 - y) + x)
    return bool(np.count_nonzero(crosses) % 2)


def _threshold_surface(hf: Heightfield, z: np.ndarray, relative_to_ground: bool, ground, ground_window) -> tuple:
    """(the cells that may qualify, what the thresholds cut there: the height ``z``, or the height above the
    ground; -inf elsewhere)."""
    valid = hf.valid
    test = z
    if ground is not None and not relative_to_ground:
        raise InvalidInputError("ground is used only with relative_to_ground=True")
    if relative_to_ground:
        if ground is None:
            ground = estimate_ground(hf, ground_window)
        elif not isinstance(ground, Heightfield) or ground.shape != hf.shape or tuple(ground.transform) != tuple(hf.transform):
            raise InvalidInputError("ground must be a Heightfield on the grid of the surface model (same shape and transform)")
        valid = valid & ground.valid
        test = np.where(valid, hf.z - np.where(ground.valid, ground.z, 0.0), -np.inf).astype(np.float64)
        if not valid.any():
            raise InvalidInputError("the ground has no data where the surface model has")
    return valid, test


def _building_cells(hf: Heightfield, valid: np.ndarray, mask) -> np.ndarray:
    """The cells that may qualify and that ``mask`` marks as buildings."""
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != hf.shape:
        raise InvalidInputError(f"mask must have the surface model's shape {hf.shape}, got {mask.shape}")
    building = valid & mask
    if building.sum() < 2:
        raise InvalidInputError("no building cell in the surface model: nothing for the thresholds to slice")
    return building


def _dropped_by(n_points, area, width, rough, noise_factor, min_area, min_width, max_roughness) -> str | None:
    """The rule that drops a region above level 0 (the name of its option), or None when it is kept."""
    if n_points < noise_factor:
        return "noise_factor"
    if min_area is not None and area < min_area:
        return "min_area"
    if min_width is not None and width < min_width:
        return "min_width"
    if rough is not None and rough > max_roughness:
        return "max_roughness"
    return None


def _outlines(hf: Heightfield, pix: list) -> list:
    """[(outline, its holes)] in world coordinates of a region's traced pixel rings: outlines counter-clockwise,
    holes clockwise; a region whose squares touch at a corner has several outlines, each with the holes inside it."""
    outer, holes = [], []
    for p in pix:
        x, y = hf.pixel_to_world(p[:, 1], p[:, 0])
        world = np.column_stack([x, y])
        (outer if signed_area(p.astype(np.float64)) > 0 else holes).append(world)
    out = []
    for ring in outer:
        ring = ring if signed_area(ring) > 0 else ring[::-1]
        mine = [h if signed_area(h) < 0 else h[::-1] for h in holes if len(outer) == 1 or _contains(ring, h[0])]
        out.append((ring, mine))
    return out


def building_tree(
    hf: Heightfield,
    *,
    lod: int = 4,
    noise_factor: int = 10,
    min_area: float | None = None,
    min_width: float | None = None,
    relative_to_ground: bool = False,
    ground: Heightfield | None = None,
    ground_window: float = GROUND_WINDOW,
    max_roughness: float | None = None,
    mask: np.ndarray | None = None,
) -> BuildingTree:
    """The tree of building outlines of a surface model (the Salt Lake City thesis, chapter 4; see the module docstring).

    Parameters
    ----------
    hf : Heightfield
        A surface model (DSM); nodata cells never qualify.
    lod : int
        Slices of the band of one standard deviation around the mean.
    noise_factor : int
        Regions with fewer grid points are dropped (0 keeps all).
    min_area : float, optional
        Regions with less area (world units squared) are dropped.
    min_width : float, optional
        Regions narrower than this (world units) are dropped.
    relative_to_ground : bool
        Thresholds on the height above the ground instead of the height.
    ground : Heightfield, optional
        The ground (a DTM on the grid of ``hf``); default :func:`estimate_ground`.
    ground_window : float
        Window of :func:`estimate_ground` (world units).
    max_roughness : float, optional
        Regions whose median :func:`roughness` exceeds this (z units) are
        dropped: tree crowns, not roofs.
    mask : (H, W) bool array, optional
        The cells that may be buildings (e.g.
        :func:`tinsmith.algorithms.urban.buildings.building_cells`): level 1 is
        every region of them (the buildings), and the thesis' thresholds,
        taken over their heights, slice only them above, so a tree touching
        a house never joins it.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> z = np.zeros((60, 80))  # flat ground at 0, 0.5 m cells
    >>> z[10:30, 10:40] = 12.0  # a building 10 x 15 m, 12 m high
    >>> z[15:25, 15:25] = 20.0  # a tower on its roof
    >>> z[40:55, 50:75] = 8.0  # a lower building
    >>> dsm = tinsmith.Heightfield(z, cell_size=0.5)
    >>> tree = tinsmith.building_tree(dsm, lod=4)
    >>> len(tree.roots)  # the outline of the data
    1
    >>> sorted(float(region.height) for region in tree.leaves())  # the roof tops
    [8.0, 20.0]
    """
    if not isinstance(hf, Heightfield):
        raise InvalidInputError(f"building_tree needs a Heightfield, got {type(hf).__name__}")
    noise_factor = _checks.integer("noise_factor", noise_factor, minimum=0)
    lod = _checks.integer("lod", lod, minimum=1)
    for name, value in (("min_area", min_area), ("min_width", min_width), ("max_roughness", max_roughness)):
        if value is not None:
            _checks.number(name, value, minimum=0.0)
    z = np.where(hf.valid, hf.z, -np.inf).astype(np.float64)
    valid, test = _threshold_surface(hf, z, relative_to_ground, ground, ground_window)
    building = valid if mask is None else _building_cells(hf, valid, mask)
    thresholds = urban_thresholds(test[building], lod)
    if mask is not None:  # level 1: every building cell (its buildings); the thesis' thresholds slice above
        thresholds = np.concatenate([[test[valid].min(), np.nextafter(thresholds[0], -np.inf)], thresholds[1:]])
    a, b, _, d, e, _ = hf.transform
    cell_area = abs(a * e - b * d)
    cell = np.sqrt(cell_area)
    square_z = (z[:-1, :-1] + z[:-1, 1:] + z[1:, :-1] + z[1:, 1:]) / 4.0

    regions: list[Region] = []
    dropped = {"noise_factor": 0, "min_area": 0, "min_width": 0, "max_roughness": 0}
    square_rough = roughness(hf) if max_roughness is not None else None
    parent_labels = np.ones((hf.shape[0] - 1, hf.shape[1] - 1), np.int32)  # level 0: everywhere
    parent_ids = {1: None}
    owner = np.full(parent_labels.shape, -1, np.int64)  # the deepest region of each square
    for level, t in enumerate(thresholds):
        qualifies = valid if level == 0 else building & (test >= t if level == len(thresholds) - 1 else test > t)
        labels, n = kc.label_squares(np.ascontiguousarray(qualifies), parent_labels > 0)
        if n == 0:
            break
        ring_label, ring_start, xy, n_points = kc.trace(labels, n, np.zeros((labels.shape[0] + 1, labels.shape[1] + 1), np.bool_))
        depth_max = np.zeros(n + 1)
        np.maximum.at(depth_max, labels.ravel(), kc.chamfer_depth(labels).ravel())
        parent_of = np.zeros(n + 1, np.int64)
        parent_of[labels.ravel()] = parent_labels.ravel()
        rings: dict[int, list] = {}
        for r, lab in enumerate(ring_label):
            rings.setdefault(int(lab), []).append(xy[ring_start[r]:ring_start[r + 1]])
        rough = None
        if square_rough is not None:  # by label, 1..n (no label: left out)
            rough = _group_medians(np.where(labels > 0, labels, -1).ravel(), square_rough.ravel(), n + 1)
        keep = np.zeros(n + 1, bool)
        new_ids = {}
        for lab in range(1, n + 1):
            pix = rings[lab]
            pixel_area = sum(signed_area(p.astype(np.float64)) for p in pix)
            area = pixel_area * cell_area
            width = 2.0 * depth_max[lab] * cell
            if level > 0:
                reason = _dropped_by(n_points[lab], area, width, None if rough is None else rough[lab],
                                     noise_factor, min_area, min_width, max_roughness)
                if reason is not None:
                    dropped[reason] += 1
                    continue
            keep[lab] = True
            parent = parent_ids.get(int(parent_of[lab]))
            for ring, mine in _outlines(hf, pix):  # one outline each (two when squares of a region touch at a corner)
                region = Region(
                    id=len(regions), level=level, threshold=float(t), parent=parent, outline=ring, holes=mine,
                    n_points=int(n_points[lab]), area=float(area), width=float(width),
                )
                regions.append(region)
                if parent is not None:
                    regions[parent].children.append(region.id)
                new_ids.setdefault(lab, region.id)
        labels = np.where(keep[labels], labels, 0).astype(np.int32)
        inside = labels > 0
        owner[inside] = np.array([new_ids.get(int(v), -1) for v in range(n + 1)])[labels[inside]]
        parent_labels, parent_ids = labels, new_ids
    # the height of a region: the median over its own squares (mean of their corners)
    for region, height in zip(regions, _group_medians(owner.ravel(), square_z.ravel(), len(regions)), strict=True):
        region.height = float(height)
    return BuildingTree(
        thresholds=thresholds, regions=regions, dropped=dropped, relative_to_ground=relative_to_ground, owner=owner
    )


@dataclass
class UrbanModel:
    """What :func:`urban_model` returns: the building tree, the block model and its statistics."""

    tree: BuildingTree
    mesh: object  #: the block model (:class:`TerrainMesh`, a 3-D surface with vertical walls)
    ground: Heightfield  #: the ground under the walls and between the buildings
    stats: dict


@register("blocks")
def blocks(hf: Heightfield, *, lod, noise_factor, min_area, min_width, relative_to_ground, ground, ground_window,
           simplify_tolerance, ground_error, max_roughness, mask, progress=None) -> TerrainMesh:
    """The Salt Lake City thesis' block model of a city surface model: flat roofs, vertical walls and the ground in one surface.

    The tree of building outlines is :func:`building_tree` (the options it
    shares are documented there), the mesh the block model of
    :func:`urban_model`: flat roofs at the median height of each region's own
    squares, vertical walls down to the lower neighbour, the ground at the
    height of ``ground`` (default :func:`estimate_ground`).
    ``mesh.info["urban"]`` holds the statistics (thresholds, regions,
    buildings, leaves, what the noise controller dropped, points kept);
    ``mesh.triangle_attributes["building"]`` the building of every triangle
    (-1: the ground).  A ``mask`` raster counts its valid non-zero cells.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> z = np.zeros((60, 80))  # flat ground at 0, 0.5 m cells
    >>> z[10:30, 10:40] = 12.0  # a building 10 x 15 m, 12 m high
    >>> z[15:25, 15:25] = 20.0  # a tower on its roof
    >>> z[40:55, 50:75] = 8.0  # a lower building
    >>> dsm = tinsmith.Heightfield(z, cell_size=0.5)
    >>> mesh = tinsmith.blocks(dsm)
    >>> mesh.info["urban"]["n_buildings"], mesh.info["urban"]["n_leaves"]
    (2, 2)
    >>> mesh.n_vertices < dsm.n_cells / 100  # flat roofs and walls need few vertices
    True
    """
    if isinstance(mask, Heightfield):
        mask = mask.valid & (np.where(mask.valid, mask.z, 0) != 0)
    if progress is not None:
        progress(0.0)
    model = urban_model(hf, lod=lod, noise_factor=noise_factor, min_area=min_area, min_width=min_width,
                        relative_to_ground=relative_to_ground, ground=ground, ground_window=ground_window,
                        simplify_tolerance=simplify_tolerance, ground_error=ground_error, max_roughness=max_roughness,
                        mask=mask)
    if progress is not None:
        progress(1.0)
    return model.mesh


def urban(hf: Heightfield, **options) -> UrbanModel:
    """Deprecated: the block model is :func:`blocks` (a mesh); the tree and the statistics with it :func:`urban_model`.

    Takes the options of :func:`urban_model` and returns its
    :class:`UrbanModel`, with a :class:`DeprecationWarning`.
    """
    _deprecation.warn("tinsmith.urban is deprecated and will be removed: the block model is tinsmith.blocks(dsm, ...) "
                      "(its statistics in mesh.info['urban']), its tree of outlines tinsmith.building_tree(dsm, ...)")
    return urban_model(hf, **options)


def urban_model(
    hf: Heightfield,
    *,
    lod: int = 4,
    noise_factor: int = 10,
    min_area: float | None = None,
    min_width: float | None = None,
    relative_to_ground: bool = False,
    ground: Heightfield | None = None,
    ground_window: float = GROUND_WINDOW,
    simplify_tolerance: float = 0.0,
    ground_error: float | None = None,
    max_roughness: float | None = None,
    mask: np.ndarray | None = None,
) -> UrbanModel:
    """A city surface model as a tree of building outlines and a crack-free block model (the Salt Lake City thesis, chapter 4).

    :func:`blocks` is its mesh as a registered method; this returns the tree
    and the ground with it (what ``tinsmith city --roofs levels`` writes).

    The tree comes from :func:`building_tree` (see there for the options);
    the block model from :func:`tinsmith.algorithms.urban.blocks.block_model`:
    flat roofs at the median height of each region's own squares, vertical
    walls down to the lower neighbour, the ground at the height of
    ``ground`` (default :func:`estimate_ground`).  ``stats`` counts the
    regions, the buildings (regions on the ground), the leaves (roof tops),
    what the noise controller dropped, and the points kept: the block
    model's vertices against the valid cells of ``hf``.
    ``simplify_tolerance`` (world units) simplifies the outlines of the
    block model between the points where three faces meet (Douglas-Peucker,
    the same for both faces of an edge, never crossing another): the
    staircases of round and diagonal buildings become diagonal edges.
    ``ground_error`` (z units) refines the ground between the buildings:
    the points greedy insertion needs to meet it on the ground model are
    added inside the ground faces (those at least ``simplify_tolerance``
    plus two cells from any building), so the ground follows the terrain
    instead of spanning from outline to outline.  ``mask`` (the cells that
    may be buildings) restricts the thresholds to those cells (see
    :func:`building_tree`).

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> z = np.zeros((60, 80))  # flat ground at 0, 0.5 m cells
    >>> z[10:30, 10:40] = 12.0  # a building 10 x 15 m, 12 m high
    >>> z[15:25, 15:25] = 20.0  # a tower on its roof
    >>> z[40:55, 50:75] = 8.0  # a lower building
    >>> dsm = tinsmith.Heightfield(z, cell_size=0.5)
    >>> from tinsmith.algorithms.urban.urban import urban_model
    >>> model = urban_model(dsm)
    >>> model.stats["n_buildings"], model.stats["n_leaves"]
    (2, 2)
    >>> model.mesh.n_vertices < dsm.n_cells / 100  # flat roofs and walls need few vertices
    True
    """
    if isinstance(hf, Heightfield):  # else building_tree says what it takes
        require_metres(hf.crs, hf.bounds, min(hf.cell_size), ground_window)
        check_memory(estimate_method("urban", hf.n_cells), f"urban on {hf.shape[0]:,} x {hf.shape[1]:,} cells",
                     "'tinsmith tile' meshes a DEM of any size in windows")
    simplify_tolerance = _checks.number("simplify_tolerance", simplify_tolerance, minimum=0.0)
    tree = building_tree(
        hf, lod=lod, noise_factor=noise_factor, min_area=min_area, min_width=min_width,
        relative_to_ground=relative_to_ground, ground=ground, ground_window=ground_window,
        max_roughness=max_roughness, mask=mask,
    )
    if ground is None:
        ground = estimate_ground(hf, ground_window)
    ground_points = None
    if ground_error is not None:
        ground_points = _ground_points(hf, tree, ground, _checks.number("ground_error", ground_error, minimum=0.0),
                                       simplify_tolerance)
    mesh = block_model(hf, tree, ground, tolerance=simplify_tolerance, ground_points=ground_points)
    mesh.info["method"] = "urban"
    # the building (region on the ground) of every triangle, -1 for the ground: for CityJSON
    building = np.full(len(tree.regions), -1, np.int64)
    for region in tree.regions:  # parents come first
        if region.level == 1:
            building[region.id] = region.id
        elif region.level > 1:
            building[region.id] = building[region.parent]
    attrs = mesh.triangle_attributes
    attrs["building"] = np.where(attrs["kind"] == 0, -1, building[attrs["face"]])
    stats = {
        "thresholds": [float(t) for t in tree.thresholds],
        "relative_to_ground": relative_to_ground,
        "n_regions": len(tree.regions),
        "n_buildings": sum(1 for r in tree.regions if r.level == 1),
        "n_leaves": sum(1 for r in tree.leaves() if r.level > 0),
        "dropped": dict(tree.dropped),
        "n_vertices": mesh.n_vertices,
        "n_triangles": mesh.n_triangles,
        "points_kept": mesh.n_vertices / hf.n_valid,
    }
    mesh.info["urban"] = stats
    return UrbanModel(tree=tree, mesh=mesh, ground=ground, stats=stats)


def _ground_points(hf: Heightfield, tree: BuildingTree, ground: Heightfield, max_error: float, tolerance: float) -> np.ndarray:
    """(K, 2) grid points (col, row) of greedy insertion on the ground, well inside the ground faces."""
    roots = np.array([r.level == 0 for r in tree.regions] + [False])
    on_ground = roots[tree.owner]  # squares of a ground face (-1, no face, indexes the False)
    labels = on_ground.astype(np.int32)
    a, b, _, d, e, _ = hf.transform
    margin = tolerance / np.sqrt(abs(a * e - b * d)) + 2.0  # cells
    deep = kc.chamfer_depth(labels) >= margin
    # a point qualifies when its four squares are deep inside the ground
    ok = np.zeros((deep.shape[0] + 1, deep.shape[1] + 1), bool)
    ok[1:-1, 1:-1] = deep[:-1, :-1] & deep[:-1, 1:] & deep[1:, :-1] & deep[1:, 1:]
    mesh = greedy(ground, max_error=max_error)
    rows, cols = ground.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    rows, cols = np.round(rows).astype(np.int64), np.round(cols).astype(np.int64)
    keep = ok[rows, cols]
    return np.column_stack([cols[keep], rows[keep]])
