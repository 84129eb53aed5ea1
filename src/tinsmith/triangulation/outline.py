"""The outline of the data in a grid with nodata, as segments between cell centres.

The covered region is the union of the full-resolution grid triangles (see
:mod:`.grid`): a square of four neighbouring cell centres is covered when all
four are valid, half of it (the triangle of the three valid corners) when three
are.  Its boundary runs along unit grid edges and the hypotenuses of
three-valid squares.  Methods that cut holes (greedy insertion) take these
segments as constrained edges, so no triangle ever covers a nodata cell centre.
Straight runs are merged into one segment (lossless: only collinear points
are dropped).
"""

from __future__ import annotations

import numpy as np

from ..kernels.outline import merge_straight_runs

__all__ = ["boundary_edges", "boundary_segments", "covered", "signed_area"]


def boundary_edges(valid: np.ndarray) -> np.ndarray:
    """(E, 4) unit boundary edges as (r0, c0, r1, c1), each once."""
    v = valid.astype(bool)
    a, b, c, d = v[:-1, :-1], v[:-1, 1:], v[1:, :-1], v[1:, 1:]
    h, w = v.shape
    top = a & b & (c | d)  # edge (r, c)-(r, c+1) used by square (r, c)
    bottom = c & d & (a | b)  # edge (r+1, c)-(r+1, c+1) used by square (r, c)
    left = a & c & (b | d)  # edge (r, c)-(r+1, c)
    right = b & d & (a | c)  # edge (r, c+1)-(r+1, c+1)

    # horizontal edges between (r, c) and (r, c+1), r = 0..h-1: used from above and below
    from_below = np.zeros((h, w - 1), bool)
    from_below[:-1] = top
    from_above = np.zeros((h, w - 1), bool)
    from_above[1:] = bottom
    hr, hc = np.nonzero(from_below ^ from_above)
    # vertical edges between (r, c) and (r+1, c), c = 0..w-1
    from_right = np.zeros((h - 1, w), bool)
    from_right[:, :-1] = left
    from_left = np.zeros((h - 1, w), bool)
    from_left[:, 1:] = right
    vr, vc = np.nonzero(from_right ^ from_left)
    # hypotenuses of three-valid squares
    three = (a.astype(np.int8) + b + c + d) == 3
    sr, sc = np.nonzero(three & (~a | ~d))  # missing a or d: hypotenuse b-c
    tr, tc = np.nonzero(three & (~b | ~c))  # missing b or c: hypotenuse a-d
    return np.concatenate(
        [
            np.column_stack([hr, hc, hr, hc + 1]),
            np.column_stack([vr, vc, vr + 1, vc]),
            np.column_stack([sr, sc + 1, sr + 1, sc]),
            np.column_stack([tr, tc, tr + 1, tc + 1]),
        ]
    ).astype(np.int64)


def boundary_segments(valid: np.ndarray) -> np.ndarray:
    """Segments of the outline of the covered region, straight runs merged.

    Parameters
    ----------
    valid : (H, W) bool array_like

    Returns
    -------
    (K, 2, 2) ndarray of int64
        Segment end points as (row, col) cell indices.
    """
    valid = np.asarray(valid, dtype=bool)
    edges = boundary_edges(valid)
    if len(edges) == 0:
        return np.empty((0, 2, 2), np.int64)
    w = valid.shape[1]
    runs = merge_straight_runs(edges[:, 0] * w + edges[:, 1], edges[:, 2] * w + edges[:, 3], w)
    return np.stack([runs // w, runs % w], axis=2)


def covered(valid: np.ndarray, row: float, col: float) -> bool:
    """True when the point (row, col) lies in the covered region (closed)."""
    h, w = valid.shape
    for r0 in {int(np.floor(row)), int(np.ceil(row)) - 1}:
        for c0 in {int(np.floor(col)), int(np.ceil(col)) - 1}:
            if not (0 <= r0 < h - 1 and 0 <= c0 < w - 1):
                continue
            a, b, c, d = valid[r0, c0], valid[r0, c0 + 1], valid[r0 + 1, c0], valid[r0 + 1, c0 + 1]
            u, v = row - r0, col - c0  # local coordinates in the square, 0..1
            n = int(a) + int(b) + int(c) + int(d)
            if n == 4:
                return True
            if n == 3 and (
                (not a and u + v >= 1) or (not d and u + v <= 1) or (not b and u >= v) or (not c and v >= u)
            ):
                return True
    return False


def signed_area(ring: np.ndarray) -> float:
    """The area of a closed ring of (x, y) corners (not repeated), positive when counter-clockwise in (x, y)."""
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
