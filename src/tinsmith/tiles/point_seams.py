"""The seam contract for point clouds: every tile side is a profile of the points' TIN, simplified once.

Raster tiles share a line of cells (:mod:`.seams`); point tiles share a line
in the plane that no point is obliged to lie on.  The height along that line
is the TIN of the points near it, cut at ``max_edge`` as the whole survey's
TIN is (:mod:`tinsmith.triangulation.pointtin`):

- **the strip**: the points within ``reach`` of the side (and up to ``reach``
  past its ends), sorted, duplicates merged by the run's rule, triangulated
  and cut at ``max_edge``;
- **the profile**: where the side crosses the kept triangles, a height at
  every crossing of a TIN edge (computed from the edge's end points in a
  fixed order, so a crossing has one value whichever triangle reports it)
  and at every point lying exactly on the line; a stretch of the side is
  *covered* where a kept triangle spans it and a *gap* elsewhere;
- **the corners**: the tile corners a side ends at take their height from the
  TIN of the points within ``reach`` of the corner, so that the two to four
  sides meeting there agree;
- **simplification**: Douglas-Peucker with the vertical distance within the
  bound (:func:`tinsmith.kernels.seam.simplify_profile`), always keeping the
  corners, the ends of every covered stretch and the points on the line.

Both tiles along a side select the same points by their coordinates alone and
compute the same profile from them, so they share its vertices and segments
exactly: the merged mesh has no crack and no T-junction.  A covered segment
is an edge of a triangle on both sides; a gap segment of none (the gap is
open in both tiles).  A triangle of the full TIN with all edges at most
``max_edge`` has every vertex within ``max_edge`` of any point inside it, so
``reach >= max_edge`` sees every such triangle that crosses the side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInputError, NoDataError
from ..kernels import tin as ktin
from ..kernels.greedy_points import plane_height
from ..kernels.seam import simplify_profile
from ..triangulation.pointtin import build_point_tin

__all__ = ["Side", "SideProfile", "corner_height", "side_profile"]


@dataclass(frozen=True)
class Side:
    """A seam: the line ``axis`` = ``at`` (0: x = at, a vertical side; 1: y = at) from ``lo`` to ``hi`` along the other axis."""

    axis: int
    at: float
    lo: float
    hi: float

    def world(self, s: np.ndarray) -> np.ndarray:
        """(K, 2) world x-y of positions ``s`` along the side."""
        s = np.asarray(s, np.float64)
        fixed = np.full(len(s), self.at)
        return np.column_stack([fixed, s] if self.axis == 0 else [s, fixed])

    def strip(self, xyz: np.ndarray, reach: float) -> np.ndarray:
        """Mask of the points within ``reach`` of the side (and up to ``reach`` past its ends)."""
        across, along = xyz[:, self.axis], xyz[:, 1 - self.axis]
        return (np.abs(across - self.at) <= reach) & (along >= self.lo - reach) & (along <= self.hi + reach)


@dataclass
class SideProfile:
    """The kept vertices of a side and the segments between them.

    ``xyz`` (K, 3) in order along the side; ``covered`` (K - 1,) whether the
    segment from vertex k to k + 1 is covered by the points' TIN (a gap
    otherwise).  (The bound of a tiled run holds at the points, which greedy
    insertion refines to; the profile's own error is not part of it.)
    """

    xyz: np.ndarray
    covered: np.ndarray

    @classmethod
    def empty(cls) -> SideProfile:
        return cls(np.empty((0, 3)), np.empty(0, bool))


def canonical(xyz: np.ndarray) -> np.ndarray:
    """The points sorted by x, y, z: a set gives one triangulation whatever order it was read in."""
    return xyz[np.lexsort((xyz[:, 2], xyz[:, 1], xyz[:, 0]))]


def _tin(xyz: np.ndarray, duplicates: str, max_edge):
    """The point TIN of a canonical point set, or None when the points span no area."""
    if len(xyz) < 3:
        return None
    try:
        return build_point_tin(canonical(xyz), duplicates=duplicates, max_edge=max_edge)
    except (NoDataError, InvalidInputError):  # too few distinct points, points on a line, or nothing kept
        return None


def corner_height(xyz: np.ndarray, x: float, y: float, reach: float, duplicates: str) -> float | None:
    """Height at the corner (x, y) of the TIN of the points within ``reach`` of it (all its triangles), or None outside it."""
    near = (np.abs(xyz[:, 0] - x) <= reach) & (np.abs(xyz[:, 1] - y) <= reach)
    ptin = _tin(xyz[near], duplicates, None)
    if ptin is None:
        return None
    t = ktin.locate(ptin.m, x, y, 0)
    if t < 0:
        return None
    p = ptin.xyz
    a, b, c = ptin.triangles[t]
    return float(plane_height(p[a, 0], p[a, 1], p[a, 2], p[b, 0], p[b, 1], p[b, 2], p[c, 0], p[c, 1], p[c, 2], x, y))


def _crossings(ptin, side: Side):
    """Positions, heights and on-line flags of the profile samples, and the covered stretches (start, end) positions."""
    tri = ptin.triangles[ptin.keep]
    p = ptin.xyz
    across = p[:, side.axis] - side.at
    along = p[:, 1 - side.axis]
    # each edge once per triangle, its ends in a fixed order (the smaller vertex id first)
    u = np.concatenate([tri[:, 0], tri[:, 1], tri[:, 2]])
    v = np.concatenate([tri[:, 1], tri[:, 2], tri[:, 0]])
    a, b = np.minimum(u, v), np.maximum(u, v)
    da, db = across[a], across[b]
    cross = da * db < 0
    t = np.where(cross, da / np.where(cross, da - db, 1.0), 0.0)
    s_edge = np.where(cross, along[a] + t * (along[b] - along[a]), np.nan)
    z_edge = np.where(cross, p[a, 2] + t * (p[b, 2] - p[a, 2]), np.nan)
    # vertices on the line
    on = across[tri] == 0
    s_vert = np.where(on, along[tri], np.nan)
    n = len(tri)
    s_all = np.column_stack([s_edge.reshape(3, n).T, s_vert])
    lo = np.where(np.isnan(s_all), np.inf, s_all).min(axis=1)
    hi = np.where(np.isnan(s_all), -np.inf, s_all).max(axis=1)
    spans = np.column_stack([lo, hi])[hi > lo]
    online = np.unique(tri[on])
    s = np.concatenate([s_edge[cross], along[online]])
    z = np.concatenate([z_edge[cross], p[online, 2]])
    point = np.concatenate([np.zeros(int(cross.sum()), bool), np.ones(len(online), bool)])
    order = np.lexsort((~point, s))  # at one position, a point on the line first
    s, z, point = s[order], z[order], point[order]
    first = np.r_[True, s[1:] != s[:-1]]
    return s[first], z[first], point[first], spans


def side_profile(xyz: np.ndarray, side: Side, *, reach: float, max_edge: float, duplicates: str, bound: float,
                 corners: tuple[float | None, float | None]) -> SideProfile:
    """The simplified profile of the points' TIN along a side (see the module notes).

    ``xyz`` holds at least every point within ``reach`` of the side;
    ``corners`` the heights at its two ends (:func:`corner_height`).
    """
    ptin = _tin(xyz[side.strip(xyz, reach)], duplicates, max_edge)
    if ptin is None:
        return SideProfile.empty()
    s, z, point, spans = _crossings(ptin, side)
    inside = (s > side.lo) & (s < side.hi)
    s, z, point = s[inside], z[inside], point[inside]
    # the ends, at the corners' heights
    s = np.r_[side.lo, s, side.hi]
    z = np.r_[np.nan if corners[0] is None else corners[0], z, np.nan if corners[1] is None else corners[1]]
    point = np.r_[False, point, False]
    # coverage of each stretch between consecutive samples: a kept triangle spans it
    # (stretch k lies between samples k and k + 1; a span [a, b] covers stretches first .. end - 1)
    first = np.searchsorted(s, spans[:, 0], side="left")
    end = np.searchsorted(s, spans[:, 1], side="right") - 1
    real = end > first
    depth = np.zeros(len(s) + 1, np.int64)
    np.add.at(depth, first[real], 1)
    np.add.at(depth, end[real], -1)
    covered = np.cumsum(depth)[: len(s) - 1] > 0
    # an end without a height closes no covered stretch
    if corners[0] is None:
        covered[0] = False
    if corners[1] is None:
        covered[-1] = False
    touched = np.r_[covered, False] | np.r_[False, covered]
    # the samples that stay: those a covered stretch touches, and the points on the line
    used = np.flatnonzero(touched | point)
    if not len(used):
        return SideProfile.empty()
    # between consecutive used samples every stretch is covered (then they are neighbours) or none is
    seg_covered = covered[used[:-1]] & (np.diff(used) == 1)
    run_change = np.r_[True, seg_covered[1:] != seg_covered[:-1], True] if len(used) > 1 else np.ones(1, bool)
    # forced: the ends of covered runs (the corners among them) and the points on the line
    keep = (run_change | point[used]).astype(np.uint8)
    s, z = s[used], z[used]
    simplify_profile(z, np.ones(len(s), np.uint8), keep, bound, s)
    kept = np.flatnonzero(keep)
    return SideProfile(np.column_stack([side.world(s[kept]), z[kept]]), seg_covered[kept[:-1]])
