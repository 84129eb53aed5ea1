"""``max_edge="auto"`` of points meshed in tiles: the median edge sampled in blocks spread over them.

One piece takes "auto" as :data:`~tinsmith.triangulation.pointtin.AUTO_EDGE_FACTOR`
times the median edge of the whole TIN.  Tiles need it before any tile is
meshed (the buckets reach twice as far), so it is sampled:
:data:`SPREAD_BLOCKS` x :data:`SPREAD_BLOCKS` square blocks, one at the
centre of each cell of that grid over the points' box, each the size that
holds about :data:`SPREAD_POINTS` points at their mean density, are
triangulated apart (on threads) and their edges pooled.  Points the blocks
would hold nearly all of are triangulated whole: their median exactly.

- A cloud in memory (:mod:`.point_threads`) spreads the blocks over all of
  its points.
- A survey on disk (:func:`.points.tile_cloud`) spreads them over the files
  nearest its centre, enough of them to hold the blocks several times over
  (one file of the 100M-point survey), streamed a chunk at a time; the blocks
  are sized by the files' header counts (every class).

Against the whole TIN's median (of the file, for a survey):

| points | in memory | as a survey | the survey's sample before (the 200,000 points nearest the centre) |
| --- | --- | --- | --- |
| Delft, ground | +0.04% | +0.12% | +3.75% |
| Delft, every class | -1.42% | -1.42% | +21.5% |
| CODEM | 0.00% | 0.00% | 0.00% |
| the 100M survey's first file, ground | +0.44% | +0.75% | +37.4% (a forest at its centre) |
| the 100M survey (its centre file), ground | | +1.04% | -1.13% |
"""

from __future__ import annotations

import math

import numpy as np

from .._threads import thread_map
from ..errors import InvalidInputError, NoDataError
from ..io.points import iter_xyz, read_clouds
from ..kernels import pointtin as kpt
from ..triangulation.pointtin import auto_max_edge, auto_max_edge_of, build_point_tin

__all__ = ["SPREAD_BLOCKS", "SPREAD_POINTS", "spread_max_edge", "survey_max_edge"]

#: The blocks: SPREAD_BLOCKS x SPREAD_BLOCKS of them, of about SPREAD_POINTS points each.
SPREAD_BLOCKS, SPREAD_POINTS = 8, 2_000
#: A survey's sample: the files nearest its centre until they hold this many times the blocks' points.
SURVEY_SAMPLE_FACTOR = 4


def _whole(n: int) -> bool:
    """Whether ``n`` points are few enough for their whole TIN (the blocks would hold nearly all of them)."""
    return n <= SPREAD_BLOCKS * SPREAD_BLOCKS * SPREAD_POINTS


def blocks_of(x: np.ndarray, y: np.ndarray, bounds, n: int) -> np.ndarray:
    """(N,) int64: the block of each point (row-major over the grid on ``bounds``), -1 outside every block.

    The blocks are sized for ``n`` points spread evenly over ``bounds``.
    """
    g = SPREAD_BLOCKS
    x0, y0, x1, y1 = bounds
    wx, wy = (x1 - x0) / g, (y1 - y0) / g
    half = 0.5 * math.sqrt(max(wx * wy * g * g, 1e-24) * SPREAD_POINTS / max(n, 1))
    hx, hy = min(half, wx / 2), min(half, wy / 2)
    col = np.clip(((x - x0) / wx).astype(np.int64), 0, g - 1) if wx > 0 else np.zeros(len(x), np.int64)
    row = np.clip(((y - y0) / wy).astype(np.int64), 0, g - 1) if wy > 0 else np.zeros(len(y), np.int64)
    inside = (np.abs(x - (x0 + (col + 0.5) * wx)) <= hx) & (np.abs(y - (y0 + (row + 0.5) * wy)) <= hy)
    return np.where(inside, row * g + col, -1)


def blocks_max_edge(xyz: np.ndarray, block: np.ndarray, workers: int, duplicates: str = "lowest") -> float | None:
    """"auto" of the pooled edges of the TINs of the blocks (``block`` as :func:`blocks_of`), or None when no
    block has a TIN; the blocks are triangulated on ``workers`` threads."""
    ids = np.flatnonzero(block >= 0)
    b = block[ids]
    ids = ids[np.argsort(b, kind="stable")]
    parts = np.split(ids, np.cumsum(np.bincount(b, minlength=SPREAD_BLOCKS * SPREAD_BLOCKS))[:-1])

    def lengths(part):
        try:
            return kpt.edge_lengths(build_point_tin(xyz[part], duplicates=duplicates, max_edge=None).m)
        except (InvalidInputError, NoDataError):  # a block of fewer than 3 points, or of points on one line
            return np.empty(0)

    pooled = np.concatenate(thread_map(lengths, parts, workers))
    return auto_max_edge(float(kpt.median(pooled))) if len(pooled) else None


def spread_max_edge(xyz: np.ndarray, bounds, workers: int) -> float:
    """"auto" of a cloud in memory ((N, 3) points in ``bounds``): blocks spread over all of it."""
    if not _whole(len(xyz)):
        edge = blocks_max_edge(xyz, blocks_of(xyz[:, 0], xyz[:, 1], bounds, len(xyz)), workers)
        if edge is not None:
            return edge
    return auto_max_edge_of(xyz, workers=workers)  # few points, or the blocks missed every area of points


def survey_max_edge(infos, codes, duplicates: str, workers: int) -> float:
    """"auto" of a survey (``infos``: its files' :class:`~tinsmith.io.points.CloudInfo` with points): blocks
    spread over the files nearest its centre, enough to hold the blocks :data:`SURVEY_SAMPLE_FACTOR` times."""
    b = np.array([i.bounds for i in infos])
    cx, cy = (b[:, 0].min() + b[:, 3].max()) / 2, (b[:, 1].min() + b[:, 4].max()) / 2
    away = np.hypot(np.maximum(0.0, np.maximum(b[:, 0] - cx, cx - b[:, 3])),
                    np.maximum(0.0, np.maximum(b[:, 1] - cy, cy - b[:, 4])))
    centre_away = np.hypot((b[:, 0] + b[:, 3]) / 2 - cx, (b[:, 1] + b[:, 4]) / 2 - cy)
    order = np.lexsort((centre_away, away))  # the files around the centre first, nearest middles first
    wanted = SURVEY_SAMPLE_FACTOR * SPREAD_BLOCKS * SPREAD_BLOCKS * SPREAD_POINTS
    chosen, total = [], 0
    for k in order:
        chosen.append(infos[k])
        total += infos[k].count
        if total >= wanted:
            break
    c = np.array([i.bounds for i in chosen])
    region = (c[:, 0].min(), c[:, 1].min(), c[:, 3].max(), c[:, 4].max())
    paths = [i.path for i in chosen]
    if not _whole(total):
        kept, blocks = [], []
        for path in paths:  # a chunk at a time: only the blocks' points are held
            for xyz in iter_xyz(path, classes=codes):
                block = blocks_of(xyz[:, 0], xyz[:, 1], region, total)
                inside = block >= 0
                kept.append(xyz[inside])
                blocks.append(block[inside])
        if kept:
            edge = blocks_max_edge(np.concatenate(kept), np.concatenate(blocks), workers, duplicates)
            if edge is not None:
                return edge
    # few points, or the blocks missed the kept classes: the whole TIN of the files' kept points, or of every
    # file's when the sample keeps too few (a rare class: few points held)
    xyz = _kept(paths, codes)
    if len(xyz) < 3 and len(chosen) < len(infos):
        xyz = _kept([i.path for i in infos], codes)
    if len(xyz) < 3:
        raise NoDataError(f"too few points of the kept classes to mesh ({len(xyz)})")
    return auto_max_edge_of(xyz, duplicates=duplicates, workers=workers)


def _kept(paths, codes) -> np.ndarray:
    try:
        return read_clouds(list(paths), classes=codes).xyz
    except NoDataError:
        return np.empty((0, 3))
