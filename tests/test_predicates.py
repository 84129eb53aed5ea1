"""Robust predicates against exact rational arithmetic."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tinsmith.kernels.predicates import (
    incircle,
    incircle_exact,
    incircle_small_ints,
    orient2d,
    orient2d_exact,
    orient2d_small_ints,
)


def _sign(v) -> int:
    return (v > 0) - (v < 0)


def orient_true(a, b, c) -> int:
    (ax, ay), (bx, by), (cx, cy) = [(Fraction(x), Fraction(y)) for x, y in (a, b, c)]
    return _sign((ax - cx) * (by - cy) - (ay - cy) * (bx - cx))


def incircle_true(a, b, c, d) -> int:
    (ax, ay), (bx, by), (cx, cy), (dx, dy) = [(Fraction(x), Fraction(y)) for x, y in (a, b, c, d)]
    adx, ady, bdx, bdy, cdx, cdy = ax - dx, ay - dy, bx - dx, by - dy, cx - dx, cy - dy
    return _sign(
        (adx * adx + ady * ady) * (bdx * cdy - bdy * cdx)
        + (bdx * bdx + bdy * bdy) * (cdx * ady - cdy * adx)
        + (cdx * cdx + cdy * cdy) * (adx * bdy - ady * bdx)
    )


coord = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
offset = st.sampled_from([0.0, 1.0, 1e6, 5e6, -3e5])


@settings(max_examples=400, deadline=None)
@given(st.lists(coord, min_size=3, max_size=3), offset, st.integers(0, 3))
def test_orient2d_on_nearly_collinear_points(ts, off, nudge):
    # points on the line y = 2x (+ offset), the last one nudged by a few ulps
    pts = [(off + t, off + 2 * t) for t in ts]
    x, y = pts[2]
    # the predicates assume no underflow (subnormal products): no coordinate near the smallest doubles
    assume(nudge == 0 or abs(x) > 1e-100)
    assume(all(t == 0.0 or abs(t) > 1e-100 for t in ts))
    for _ in range(nudge):
        x = np.nextafter(x, np.inf)
    pts[2] = (x, y)
    a, b, c = pts
    expected = orient_true(a, b, c)
    assert _sign(orient2d(*a, *b, *c)) == expected
    assert orient2d_exact(*a, *b, *c) == expected


@settings(max_examples=400, deadline=None)
@given(st.lists(st.floats(0, 2 * np.pi).filter(lambda q: q == 0 or q > 1e-6), min_size=4, max_size=4), offset,
       st.sampled_from([1e-3, 1.0, 250.0]), st.booleans())
def test_incircle_on_nearly_cocircular_points(angles, off, radius, nudge):
    pts = [(off + radius * np.cos(q), off + radius * np.sin(q)) for q in angles]
    if nudge:
        assume(abs(pts[3][0]) > 1e-100)  # no underflow
        pts[3] = (np.nextafter(pts[3][0], -np.inf), pts[3][1])
    a, b, c, d = pts
    if orient_true(a, b, c) < 0:
        a, b = b, a
    expected = incircle_true(a, b, c, d)
    assert _sign(incircle(*a, *b, *c, *d)) == expected
    assert incircle_exact(*a, *b, *c, *d) == expected


@settings(max_examples=400, deadline=None)
@given(st.lists(st.integers(-5000, 5000), min_size=8, max_size=8))
def test_integer_grid_points_including_exact_zeros(v):
    a, b, c, d = [(float(v[i]), float(v[i + 1])) for i in range(0, 8, 2)]
    assert _sign(orient2d(*a, *b, *c)) == orient_true(a, b, c)
    assert _sign(incircle(*a, *b, *c, *d)) == incircle_true(a, b, c, d)


@settings(max_examples=400, deadline=None)
@given(
    st.lists(st.integers(0, 4096), min_size=8, max_size=8),
    st.lists(st.sampled_from([0, 4096]), min_size=8, max_size=8),
    st.lists(st.booleans(), min_size=8, max_size=8),
)
def test_small_int_predicates_are_exact_on_a_grid_of_4097_points_a_side(v, edge, at_edge):
    """Greedy insertion skips the filter on grids of at most 4097 cells a side: the plain evaluation must be exact."""
    v = [e if flag else x for x, e, flag in zip(v, edge, at_edge, strict=True)]  # the extremes, where the bound is tight
    a, b, c, d = [(float(v[i]), float(v[i + 1])) for i in range(0, 8, 2)]
    assert _sign(orient2d_small_ints(*a, *b, *c)) == orient_true(a, b, c)
    assert _sign(incircle_small_ints(*a, *b, *c, *d)) == incircle_true(a, b, c, d)


def test_small_int_incircle_at_the_largest_differences():
    n = 4096.0
    assert incircle_small_ints(0.0, 0.0, n, 0.0, n, n, 0.0, n) == 0.0  # the grid's corners: cocircular
    assert incircle_small_ints(0.0, 0.0, n, 0.0, n, n, 1.0, n) > 0.0
    assert incircle_small_ints(0.0, 0.0, n, 0.0, n - 1.0, n, 0.0, n) < 0.0
    assert _sign(incircle_small_ints(0.0, n, n, 0.0, n, n, 0.0, 0.0)) == incircle_true((0, n), (n, 0), (n, n), (0, 0))


def test_grid_square_is_cocircular_and_collinear_points_are_zero():
    assert incircle(0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0) == 0.0
    assert orient2d(0.0, 0.0, 1.0, 1.0, 3.0, 3.0) == 0.0
    assert orient2d(0.0, 0.0, 1.0, 0.0, 0.0, 1.0) > 0.0
    assert incircle(0.0, 0.0, 2.0, 0.0, 0.0, 2.0, 0.5, 0.5) > 0.0
