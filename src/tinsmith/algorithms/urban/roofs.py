"""Roofs of buildings: one flat height per building (LoD 1.2), or planar roof facets (LoD 2-like).

**Flat roofs** (:func:`flat_roofs`) take one statistic of the surface
model's heights over a building's cells.  The conventions of the field:
the 3D BAG's LoD 1.2 and 1.3 blocks use the 70th percentile (``"p70"``,
the default here), 3dfier's default LoD 1 the 90th (``"p90"``); the median
(``"median"``) sits at mid-roof of a pitched roof and ``"max"`` at its
ridge (a block that encloses the whole roof, as wind engineers sometimes
prefer).

**Planar roofs** (:func:`roof_planes`, beyond the Salt Lake City thesis and without
footprints) are found by region growing on normals over each building's
cells: two neighbouring cells of a building join one facet when their
normals (of the best-fitting 3 x 3 planes,
:func:`tinsmith.algorithms.urban.buildings.plane_fits`, averaged over the 3 x 3
building cells around) differ by at most ``max_angle`` degrees and the
height between them changes as those planes predict (within
``max_residual`` of the building-detection residual).  Facets with at
least ``min_cells`` cells get a least-squares plane; neighbouring facets
of one building on nearly one plane (normals within ``max_angle``, planes
within ``max_residual`` of each other over the two) are merged and
refitted.  Every cell of the building then takes the plane, among its
building's, closest to its height (the 3 x 3 median: so ridge and eave
cells, where normals are unreliable, still go to a plane, and noise does
not scatter them).  A building
without a facet keeps a flat roof.  The roof is the piecewise planar
surface those planes make, sampled at the cells (:attr:`RoofPlanes.z`).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from ... import _checks
from ...core import Heightfield
from ...errors import InvalidInputError
from .buildings import MAX_RESIDUAL, metres_per_unit, plane_fits

__all__ = ["RoofPlanes", "flat_roofs", "parse_statistic", "roof_planes"]

#: Least spread of a facet's cells across its narrowest direction (cells, a standard deviation): a facet of one
#: row of cells (a ridge's, between the two slopes) fixes no slope across the row, and its least-squares plane
#: would tilt at random there and take the cells of the slopes around.  Two rows have a spread of 0.5.
MIN_SPREAD = 0.45


def parse_statistic(statistic: str) -> float:
    """The percentile (0-100) a roof statistic names: "median" 50, "max" 100, "pNN" NN."""
    text = str(statistic).strip().lower()
    if text == "median":
        return 50.0
    if text == "max":
        return 100.0
    if text.startswith("p"):
        try:
            value = float(text[1:])
        except ValueError:
            value = -1.0
        if 0.0 <= value <= 100.0:
            return value
    raise InvalidInputError(f"roof statistic {statistic!r}: expected median, max, or pNN with NN a percentile 0-100 (e.g. p70)")


def flat_roofs(hf: Heightfield, labels: np.ndarray, n: int, statistic: str = "p70") -> np.ndarray:
    """(n,) the roof height of every building 0..n-1 of ``labels``: a percentile of its valid cells (NaN for none)."""
    q = parse_statistic(statistic)
    out = np.full(n, np.nan)
    sel = (labels >= 0) & hf.valid
    ids, z = labels[sel], hf.z[sel].astype(np.float64)
    order = np.lexsort((z, ids))
    ids, z = ids[order], z[order]
    starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]]) if len(ids) else np.array([], np.int64)
    for s0, s1 in pairwise(np.r_[starts, len(ids)]):  # each building's run of cells (none without cells)
        out[ids[s0]] = np.percentile(z[s0:s1], q)
    return out


@dataclass
class RoofPlanes:
    """What :func:`roof_planes` finds: the facets' planes, the facet of every cell, and the roof surface at the cells."""

    planes: np.ndarray  #: (P, 3) per facet: z = a + b * col + c * row (grid units)
    building: np.ndarray  #: (P,) the building of each facet
    facet: np.ndarray  #: (H, W) the facet of each building cell, -1 elsewhere (or where the building keeps a flat roof)
    z: np.ndarray  #: (H, W) the roof surface at building cells, NaN elsewhere
    grown: np.ndarray  #: (H, W) bool: the cells region growing put in a facet (the rest joined the closest plane)


def roof_planes(hf: Heightfield, labels: np.ndarray, n: int, *, flat: np.ndarray, max_angle: float = 10.0,
                max_residual: float | None = None, min_cells: int | None = None, fits=None) -> RoofPlanes:
    """Planar roof facets of the buildings 0..n-1 of ``labels`` (module docstring); ``flat`` their flat heights (fallback).

    ``fits`` is :func:`tinsmith.algorithms.urban.buildings.plane_fits` of ``hf`` when the caller has it.
    """
    from scipy import ndimage

    max_angle = _checks.number("max_angle", max_angle, minimum=0.0, exclusive_min=True, maximum=90.0)
    a, b, _, d, e, _ = hf.transform
    cell = float(np.sqrt(abs(a * e - b * d)))
    tol = MAX_RESIDUAL / metres_per_unit(hf.crs) if max_residual is None else _checks.number(
        "max_residual", max_residual, minimum=0.0, exclusive_min=True)
    min_cells = max(6, int(round(2.0 / (cell * cell * metres_per_unit(hf.crs) ** 2)))) if min_cells is None else \
        _checks.integer("min_cells", min_cells, minimum=3)  # default: facets of 2 m2 and more
    h, w = labels.shape
    z = np.where(hf.valid, hf.z, np.nan).astype(np.float64)
    _, gx, gy = plane_fits(hf) if fits is None else fits
    inb = (labels >= 0) & np.isfinite(z) & np.isfinite(gx)
    # normals averaged over the 3 x 3 cells of buildings around (noise of a max-of-points DSM out)
    weight = ndimage.uniform_filter(inb.astype(np.float64), 3)
    with np.errstate(invalid="ignore", divide="ignore"):
        sx = ndimage.uniform_filter(np.where(inb, gx, 0.0), 3) / weight
        sy = ndimage.uniform_filter(np.where(inb, gy, 0.0), 3) / weight
    normal = np.stack([-sx / cell, -sy / cell, np.ones_like(sx)], axis=-1)
    with np.errstate(invalid="ignore"):
        normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    cos_max = np.cos(np.radians(max_angle))
    comp = _grow(inb, labels, z, gx, gy, normal, cos_max, tol)
    rows, cols = np.divmod(np.arange(h * w), w)
    zf = z.ravel()
    ids, counts = np.unique(comp[comp >= 0], return_counts=True)
    big = ids[counts >= min_cells]
    members = [m for m in _members(comp, big) if _spread(cols[m], rows[m]) >= MIN_SPREAD]
    planes = np.array([_fit(cols[m], rows[m], zf[m]) for m in members]).reshape(-1, 3)
    owner = np.array([int(labels.ravel()[m[0]]) for m in members], dtype=np.int64)
    # facets of one building on one plane (split by noise) become one
    facet_of = np.full(h * w, -1, np.int64)
    for k, m in enumerate(members):
        facet_of[m] = k
    groups = _merge_coplanar(facet_of.reshape(h, w), planes, owner, cos_max, tol, rows.reshape(h, w), cols.reshape(h, w))
    merged = [np.concatenate([members[k] for k in g]) for g in groups]
    planes = np.array([_fit(cols[m], rows[m], zf[m]) for m in merged]).reshape(-1, 3)
    owner = np.array([int(labels.ravel()[m[0]]) for m in merged], dtype=np.int64)
    grown = np.zeros(h * w, bool)
    for m in merged:
        grown[m] = True
    # every building cell: the closest of its building's planes to its (3 x 3 median) height
    smooth = ndimage.median_filter(np.where(np.isfinite(z), z, np.nanmin(z)), 3).ravel()
    facet = np.full(h * w, -1, np.int64)
    surface = np.full(h * w, np.nan)
    flat_labels = labels.ravel()
    cells = np.flatnonzero(flat_labels >= 0)
    by_building = np.argsort(owner, kind="stable")
    first = np.searchsorted(owner[by_building], np.arange(n), "left")
    last = np.searchsorted(owner[by_building], np.arange(n), "right")
    cell_order = cells[np.argsort(flat_labels[cells], kind="stable")]
    starts = np.searchsorted(flat_labels[cell_order], np.arange(n), "left")
    stops = np.searchsorted(flat_labels[cell_order], np.arange(n), "right")
    for bld in range(n):
        at = cell_order[starts[bld]:stops[bld]]
        mine = by_building[first[bld]:last[bld]]
        if len(at) == 0:
            continue
        if len(mine) == 0:
            surface[at] = flat[bld]
            continue
        p = planes[mine]
        pred = p[:, 0][None, :] + p[:, 1][None, :] * cols[at][:, None] + p[:, 2][None, :] * rows[at][:, None]
        target = np.where(np.isfinite(zf[at]), smooth[at], flat[bld])
        best = np.abs(pred - target[:, None]).argmin(axis=1)
        facet[at] = mine[best]
        surface[at] = pred[np.arange(len(at)), best]
    return RoofPlanes(planes=planes, building=owner, facet=facet.reshape(h, w), z=surface.reshape(h, w),
                      grown=grown.reshape(h, w))


def _grow(inb, labels, z, gx, gy, normal, cos_max, tol) -> np.ndarray:
    """(H*W,) region of every cell grown over neighbours of one building with close normals and a predicted height step."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    h, w = labels.shape
    index = np.arange(h * w).reshape(h, w)
    src, dst = [], []
    for s1, s2, g in (((slice(None), slice(0, -1)), (slice(None), slice(1, None)), gx),
                      ((slice(0, -1), slice(None)), (slice(1, None), slice(None)), gy)):
        with np.errstate(invalid="ignore"):
            same = inb[s1] & inb[s2] & (labels[s1] == labels[s2])
            cos = (normal[s1] * normal[s2]).sum(axis=-1)
            predicted = (g[s1] + g[s2]) / 2.0
            ok = same & (cos >= cos_max) & (np.abs(z[s2] - z[s1] - predicted) <= tol)
        src.append(index[s1][ok])
        dst.append(index[s2][ok])
    src, dst = np.concatenate(src), np.concatenate(dst)
    _, comp = connected_components(sp.coo_matrix((np.ones(len(src), np.int8), (src, dst)), shape=(h * w, h * w)),
                                   directed=False)
    return np.where(inb.ravel(), comp, -1)


def _members(comp: np.ndarray, ids: np.ndarray) -> list:
    """The flat cell indices of each region id in ``ids``."""
    order = np.argsort(comp, kind="stable")
    sorted_comp = comp[order]
    return [order[np.searchsorted(sorted_comp, c, "left"):np.searchsorted(sorted_comp, c, "right")] for c in ids]


def _spread(cols, rows) -> float:
    """The standard deviation of cells across their narrowest direction (grid units): 0 for cells on one line."""
    if len(cols) < 3:
        return 0.0
    return float(np.sqrt(max(np.linalg.eigvalsh(np.cov(np.vstack([cols, rows]).astype(np.float64)))[0], 0.0)))


def _fit(cols, rows, z) -> np.ndarray:
    """Least-squares plane z = a + b * col + c * row."""
    coef, *_ = np.linalg.lstsq(np.column_stack([np.ones(len(cols)), cols, rows]), z, rcond=None)
    return coef


def _merge_coplanar(facet, planes, owner, cos_max, tol, rows, cols) -> list:
    """Groups of facets (lists of indices) joined where two neighbours of one building lie on nearly one plane."""
    parent = np.arange(len(planes))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    normals = np.column_stack([-planes[:, 1], -planes[:, 2], np.ones(len(planes))])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    pairs = set()
    for s1, s2 in (((slice(None), slice(0, -1)), (slice(None), slice(1, None))),
                   ((slice(0, -1), slice(None)), (slice(1, None), slice(None)))):
        a, b = facet[s1], facet[s2]
        m = (a >= 0) & (b >= 0) & (a != b)
        pairs.update(zip(a[m].tolist(), b[m].tolist(), strict=True))
    for a, b in sorted(pairs):
        if owner[a] != owner[b] or normals[a] @ normals[b] < cos_max:
            continue
        # the two planes agree along their common boundary
        on = ((facet == a) | (facet == b))
        r, c = rows[on], cols[on]
        gap = np.abs((planes[a, 0] - planes[b, 0]) + (planes[a, 1] - planes[b, 1]) * c + (planes[a, 2] - planes[b, 2]) * r)
        if np.median(gap) <= tol:
            parent[find(a)] = find(b)
    roots = np.array([find(i) for i in range(len(planes))])
    return [list(np.flatnonzero(roots == r)) for r in np.unique(roots)]
