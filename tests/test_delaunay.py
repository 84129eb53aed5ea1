"""The constrained Delaunay kernel on its own: tinsmith.delaunay."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import InvalidInputError, TerrainMesh, delaunay, non_delaunay_edges


def as_mesh(result) -> TerrainMesh:
    return TerrainMesh(np.column_stack([result.points, np.zeros(len(result.points))]), result.triangles)


def hull_area(points: np.ndarray) -> float:
    """Area of the convex hull (monotone chain, exact enough for these tests)."""
    pts = sorted(set(map(tuple, points.tolist())))
    if len(pts) < 3:
        return 0.0

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    hull = lower[:-1] + upper[:-1]
    return 0.5 * abs(sum(hull[i][0] * hull[i - 1][1] - hull[i - 1][0] * hull[i][1] for i in range(len(hull))))


grid_points = st.lists(st.tuples(st.integers(0, 12), st.integers(0, 12)), min_size=3, max_size=80)
# magnitudes below 1e-100 would make products underflow, which the predicates (like Shewchuk's) exclude
coordinate = st.floats(-1e3, 1e3, allow_nan=False).map(lambda v: 0.0 if abs(v) < 1e-100 else v)
float_points = st.lists(st.tuples(coordinate, coordinate), min_size=3, max_size=60)


def _not_collinear(points) -> bool:
    p = np.asarray(points, dtype=float)
    a = p[0]
    a0, a1 = Fraction(a[0]), Fraction(a[1])
    return any(
        (Fraction(b[0]) - a0) * (Fraction(c[1]) - a1) != (Fraction(b[1]) - a1) * (Fraction(c[0]) - a0)
        for b in p for c in p
    )


@settings(max_examples=150, deadline=None)
@given(st.one_of(grid_points, float_points))
def test_property_delaunay_of_any_points(points):
    if not _not_collinear(points):
        with pytest.raises(InvalidInputError):
            delaunay(points)
        return
    result = delaunay(points)
    mesh = as_mesh(result)
    assert mesh.check() == []
    assert len(non_delaunay_edges(mesh)) == 0
    # every distinct point is a vertex, and the triangles tile the convex hull
    distinct = np.unique(result.duplicate_of)
    assert set(np.unique(result.triangles)) == set(distinct.tolist())
    area = mesh.signed_areas_2d().sum()
    assert area == pytest.approx(hull_area(result.points), rel=1e-9, abs=1e-9)


def _segments_on(points, a, b):
    """Consecutive pairs of the points lying on segment a-b (exactly), ordered along it."""
    pa, pb = points[a], points[b]
    on = []
    for i, p in enumerate(points):
        cross = (pb[0] - pa[0]) * (p[1] - pa[1]) - (pb[1] - pa[1]) * (p[0] - pa[0])
        t = (p[0] - pa[0]) * (pb[0] - pa[0]) + (p[1] - pa[1]) * (pb[1] - pa[1])
        if cross == 0 and 0 <= t <= (pb[0] - pa[0]) ** 2 + (pb[1] - pa[1]) ** 2:
            on.append((t, i))
    on.sort()
    return [(on[k][1], on[k + 1][1]) for k in range(len(on) - 1) if (points[on[k][1]] != points[on[k + 1][1]]).any()]


def _cross_properly(p, q, r, s) -> bool:
    def o(a, b, c):
        v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return int(v > 0) - int(v < 0)

    return o(p, q, r) * o(p, q, s) < 0 and o(r, s, p) * o(r, s, q) < 0


@settings(max_examples=150, deadline=None)
@given(
    pts=st.lists(st.tuples(st.integers(0, 10), st.integers(0, 10)), min_size=4, max_size=40, unique=True),
    pairs=st.lists(st.tuples(st.integers(0, 39), st.integers(0, 39)), max_size=25),
)
def test_property_constraints_are_kept_and_everything_else_is_delaunay(pts, pairs):
    points = np.asarray(pts, dtype=float)
    if not _not_collinear(points):
        return
    n = len(points)
    segs = []
    for a, b in pairs:
        a, b = a % n, b % n
        # crossings away from input points are refused; keep the others (touching, collinear, repeated)
        if a != b and not any(_cross_properly(points[a], points[b], points[c], points[d]) for c, d in segs):
            segs.append((a, b))
    result = delaunay(points, constraints=segs)
    mesh = as_mesh(result)
    assert mesh.check() == []
    constrained = {tuple(e) for e in result.constrained.tolist()}
    for a, b in segs:
        for u, v in _segments_on(points, a, b):
            assert (min(u, v), max(u, v)) in constrained
    assert len(non_delaunay_edges(mesh, constrained=result.constrained)) == 0


def test_crossing_constraints_give_a_clear_error():
    square = [[0, 0], [4, 0], [4, 4], [0, 4]]
    with pytest.raises(InvalidInputError, match="constraint 1 .* crosses an earlier constraint"):
        delaunay(square, constraints=[[0, 2], [1, 3]])
    # the same with the crossing point given: both diagonals are kept, split at the centre
    result = delaunay(square + [[2, 2]], constraints=[[0, 2], [1, 3]])
    assert {tuple(e) for e in result.constrained.tolist()} == {(0, 4), (2, 4), (1, 4), (3, 4)}


def test_duplicates_and_collinear_points():
    pts = [[0, 0], [1, 0], [2, 0], [3, 0], [0, 1], [1, 0], [3, 0]]
    result = delaunay(pts, constraints=[[0, 3], [6, 0]])
    assert result.duplicate_of.tolist() == [0, 1, 2, 3, 4, 1, 3]
    assert {tuple(e) for e in result.constrained.tolist()} == {(0, 1), (1, 2), (2, 3)}


@pytest.mark.parametrize(
    "points, constraints, message",
    [
        (np.zeros((4, 3)), None, r"shape \(N, 2\)"),
        ([[0, 0], [1, 1]], None, "at least 3"),
        ([[0, 0], [1, 1], [2, 2]], None, "one line"),
        ([[0, 0], [0, 0], [0, 0]], None, "single distinct point"),
        ([[0, 0], [1, 0], [np.nan, 1]], None, "finite"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 5]], "index points 0..2"),
        ([[0, 0], [1, 0], [0, 1]], [[0.5, 1]], "integer"),
    ],
)
def test_bad_input(points, constraints, message):
    with pytest.raises(InvalidInputError, match=message):
        tinsmith.delaunay(points, constraints=constraints)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 70_000))
def test_seeded_permutation_is_numpys_default_rng_0(n):
    """The insertion order's shuffle, compiled (no numpy.random import), gives numpy's values exactly."""
    from tinsmith.kernels import tin

    assert np.array_equal(tin.seeded_permutation(n), np.random.default_rng(0).permutation(n))


def test_seeded_permutation_starts_from_numpys_seed_state():
    from tinsmith.kernels import tin

    state = np.random.PCG64(0).state["state"]
    low = (1 << 64) - 1
    assert (state["state"] >> 64, state["state"] & low, state["inc"] >> 64, state["inc"] & low) == tin.PCG64_SEED0
