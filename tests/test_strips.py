"""The Delaunay triangulation made in strips on threads, merged exactly (tinsmith.triangulation.strips)."""

from __future__ import annotations

from pathlib import Path

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith.kernels import strips as kstrips
from tinsmith.kernels import tin as ktin
from tinsmith.kernels.predicates import incircle, incircle_perturbed
from tinsmith.triangulation import strips
from tinsmith.triangulation.delaunay import triangulate_points

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def triangle_set(m, same) -> np.ndarray:
    """The triangles of ``m`` over first-occurrence ids, each from its lowest vertex, sorted."""
    n = int(m[9][1])
    t = same[m[2][: 3 * n].reshape(-1, 3).astype(np.int64)]
    r = np.argmin(t, axis=1)
    i = np.arange(len(t))
    t = np.column_stack([t[i, r], t[i, (r + 1) % 3], t[i, (r + 2) % 3]])
    return t[np.lexsort(t.T[::-1])]


def one_piece(pts):
    """The sequential triangulation, duplicates named by their lowest index (as the strips name them)."""
    m, same, _ = triangulate_points(pts, unique=True)
    kstrips.lowest_duplicates(m[2], m[9][1], m[5], same)
    return m, same


def assert_one_piece(m, same, pts) -> None:
    """``m`` and ``same`` are the sequential triangulation of ``pts``, triangle for triangle, and a valid one."""
    m0, s0 = one_piece(pts)
    np.testing.assert_array_equal(triangle_set(m, same), triangle_set(m0, s0))
    np.testing.assert_array_equal(same, s0)
    check_triangulation(m, pts, same)


@numba.njit
def _illegal_edges(m):
    count = 0
    for e in range(3 * m[9][1]):
        if ktin._illegal(m, e, ktin.PERTURBED):
            count += 1
    return count


def check_triangulation(m, pts, same) -> None:
    """Twins, vertex edges, every point a vertex or a duplicate, locally Delaunay, a convex hull."""
    n = int(m[9][1])
    tri, half = m[2][: 3 * n].astype(np.int64), m[3][: 3 * n].astype(np.int64)
    nxt = lambda e: e - e % 3 + (e + 1) % 3  # noqa: E731
    e = np.flatnonzero(half >= 0)
    assert (half[half[e]] == e).all()
    assert (tri[half[e]] == tri[nxt(e)]).all() and (tri[nxt(half[e])] == tri[e]).all()
    kept = np.flatnonzero(same == np.arange(len(same)))
    assert np.array_equal(np.unique(tri), kept)
    assert (tri[m[5][kept]] == kept).all()
    x, y = pts[:, 0], pts[:, 1]
    a, b, c = tri[0::3], tri[1::3], tri[2::3]
    assert ((x[b] - x[a]) * (y[c] - y[a]) - (y[b] - y[a]) * (x[c] - x[a]) > 0).all()
    assert _illegal_edges(m) == 0
    hull = np.flatnonzero(half < 0)
    assert n == 2 * len(kept) - 2 - len(hull)
    from tinsmith.kernels.strips import hull_turns_left

    assert hull_turns_left(m[2], m[3], n, m[0], m[1])


@pytest.fixture
def small_strips(monkeypatch):
    """Strips of about 40 points, so that small inputs are cut into several."""
    monkeypatch.setattr(strips, "STRIP_POINTS", 40)


def test_perturbed_incircle_is_never_zero_and_decides_a_square():
    # the corners of a square are cocircular: the plain test says 0, the perturbed one a side
    sq = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    flat = [v for p in sq for v in p]
    assert incircle(*flat) == 0.0
    s = incircle_perturbed(*flat)
    assert s != 0.0
    # the two diagonals of the square: exactly one of them is legal under the perturbation
    a, b, c, d = sq
    other = incircle_perturbed(*b, *c, *d, *a)
    assert (s > 0) != (other > 0)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 15), st.integers(0, 15)), min_size=3, max_size=200), st.integers(0, 2**31))
def test_property_unique_whatever_the_insertion_order(points, seed):
    pts = np.asarray(points, float)
    if len(np.unique(pts, axis=0)) < 3 or np.linalg.matrix_rank(pts - pts[0]) < 2:
        return
    perm = np.random.default_rng(seed).permutation(len(pts))
    m0, s0, _ = triangulate_points(pts, unique=True)
    m1, s1, _ = triangulate_points(pts[perm], unique=True)
    # name every vertex by its first occurrence in pts, in both
    _, first, inverse = np.unique(pts, axis=0, return_index=True, return_inverse=True)
    canon = first[inverse.ravel()]
    t0 = triangle_set(m0, canon[s0])
    t1 = triangle_set(m1, canon[perm][s1])
    np.testing.assert_array_equal(t0, t1)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 40), st.integers(0, 12)), min_size=3, max_size=400),
       st.sampled_from([1, 2, 3]))
def test_property_strips_are_the_one_piece_triangulation(points, workers):
    """Grids, duplicates, collinear runs: in strips on any number of threads, the one-piece triangles."""
    pts = np.asarray(points, float)
    if len(np.unique(pts, axis=0)) < 3 or np.linalg.matrix_rank(pts - pts[0]) < 2:
        return
    saved = strips.STRIP_POINTS, strips.LARGE_STRIP
    strips.STRIP_POINTS, strips.LARGE_STRIP = 20, 30  # up to 8 strips of 20 points, then of 30 (14 at 400)
    try:
        m, same, info = strips.triangulate_unique(pts, workers)
    finally:
        strips.STRIP_POINTS, strips.LARGE_STRIP = saved
    assert_one_piece(m, same, pts)


def test_large_clouds_are_cut_into_more_strips_of_bounded_size():
    """8 strips while none holds more than LARGE_STRIP points, then strips of at most LARGE_STRIP, up to MOST_STRIPS."""
    assert strips.n_strips(strips.STRIP_POINTS - 1) == 1
    assert strips.n_strips(3 * strips.STRIP_POINTS) == 3
    assert strips.n_strips(strips.MAX_STRIPS * strips.LARGE_STRIP) == strips.MAX_STRIPS
    assert strips.n_strips(strips.MAX_STRIPS * strips.LARGE_STRIP + 1) == strips.MAX_STRIPS + 1
    assert strips.n_strips(4_495_786) == 18  # the survey's first file: strips of 249,766 points
    for n in (10 * strips.MOST_STRIPS * strips.LARGE_STRIP, 10**9):
        assert strips.n_strips(n) == strips.MOST_STRIPS
    n = np.arange(strips.STRIP_POINTS, strips.MOST_STRIPS * strips.LARGE_STRIP, 99_991)
    k = np.array([strips.n_strips(int(v)) for v in n])
    assert (np.diff(k) >= 0).all() and (n / k <= strips.LARGE_STRIP).all()


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 30), min_size=0, max_size=60))
def test_merged_count_counts_the_points_mapped_elsewhere(targets):
    same = np.array([min(t, i) for i, t in enumerate(targets)], np.int32)  # each point at itself or below
    assert kstrips.merged_count(same) == np.count_nonzero(same != np.arange(len(same)))


def test_strips_are_used_and_identical_on_one_and_two_workers(small_strips):
    rng = np.random.default_rng(5)
    grid = np.stack(np.meshgrid(np.arange(60.0), np.arange(20.0)), -1).reshape(-1, 2)
    pts = np.concatenate([grid, rng.uniform(0, 60, (800, 2)), grid[:50]])  # cocircular cells, duplicates
    one = strips.triangulate_unique(pts, 1)
    two = strips.triangulate_unique(pts, 2)
    assert one[2]["strips"] == strips.MAX_STRIPS and one[2]["border_points"] > 0
    n = int(one[0][9][1])
    for a, b in zip(one[0][:9], two[0][:9], strict=True):
        np.testing.assert_array_equal(a[: 3 * n] if len(a) > len(pts) else a, b[: 3 * n] if len(b) > len(pts) else b)
    np.testing.assert_array_equal(one[1], two[1])
    check_triangulation(one[0], pts, one[1])


def test_a_strip_of_collinear_points_falls_back_to_one_piece(small_strips):
    # the points of the first strip all lie on one vertical line: that strip has no triangle
    line = np.column_stack([np.zeros(100), np.arange(100.0)])
    rest = np.random.default_rng(2).uniform(1, 300, (300, 2))
    pts = np.concatenate([line, rest])
    m, same, info = strips.triangulate_unique(pts, 2)
    assert_one_piece(m, same, pts)


def test_a_thin_corridor_is_cut_across_its_length(small_strips):
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(0, 50, 2000), rng.uniform(0, 20000, 2000)])  # 50 m x 20 km, along y
    axis, cuts = strips._cuts(pts, 8)
    assert axis == 1 and len(cuts) == 7
    m, same, info = strips.triangulate_unique(pts, 2)
    assert info["strips"] == 8
    check_triangulation(m, pts, same)


@pytest.mark.parametrize("name", ["terrain/lidR_forest_lakes/MixedConifer.laz", "urban/codem_ncalm/codem_pc.laz"])
def test_real_clouds_in_strips(name):
    path = DATA / name
    if not path.exists():
        pytest.skip(f"{path} not present")
    pts = np.ascontiguousarray(tinsmith.read(path).xyz[:, :2])
    m, same, info = strips.triangulate_unique(pts, 2)
    assert info["strips"] == strips.n_strips(len(pts)) > 1
    assert_one_piece(m, same, pts)


def test_tin_is_the_same_on_one_and_two_workers(small_strips):
    rng = np.random.default_rng(9)
    xy = rng.uniform(0, 100, (3000, 2)).round(1)  # decimetre coordinates: cocircular and repeated points
    cloud = tinsmith.PointCloud(np.column_stack([xy, np.sin(xy[:, 0] / 9) + xy[:, 1] / 50]))
    one, two = tinsmith.tin(cloud, workers=1), tinsmith.tin(cloud, workers=2)
    np.testing.assert_array_equal(one.triangles, two.triangles)
    np.testing.assert_array_equal(one.vertices, two.vertices)
    assert one.check() == []


@pytest.mark.parametrize("bad", [0, -1, 1.5, "two"])
def test_workers_must_be_a_positive_whole_number(bad):
    cloud = tinsmith.PointCloud(np.random.default_rng(1).uniform(0, 10, (50, 3)))
    with pytest.raises(tinsmith.InvalidInputError, match="workers must be a whole number >= 1"):
        tinsmith.tin(cloud, workers=bad)


def test_points_at_one_place_are_named_by_their_lowest_index(small_strips):
    rng = np.random.default_rng(4)
    pts = rng.integers(0, 30, (600, 2)).astype(float)  # about half the points repeat another
    m, same, _ = strips.triangulate_unique(pts, 2)
    _, first, inverse = np.unique(pts, axis=0, return_index=True, return_inverse=True)
    np.testing.assert_array_equal(same, first[inverse.ravel()])
    check_triangulation(m, pts, same)


def test_greedy_on_points_is_the_same_on_one_and_two_workers(small_strips):
    rng = np.random.default_rng(12)
    xy = rng.uniform(0, 200, (4000, 2)).round(2)
    cloud = tinsmith.PointCloud(np.column_stack([xy, 3 * np.sin(xy[:, 0] / 20) + np.cos(xy[:, 1] / 15)]))
    one = tinsmith.greedy(cloud, max_error=0.05, workers=1)
    two = tinsmith.greedy(cloud, max_error=0.05, workers=2)
    np.testing.assert_array_equal(one.triangles, two.triangles)
    np.testing.assert_array_equal(one.vertices, two.vertices)
    assert tinsmith.vertical_error_at_points(two, cloud.xyz)["max"] <= 0.05 + 1e-9


def test_thread_map_keeps_the_order_takes_the_caller_and_raises_the_first_error():
    import threading
    import time

    from tinsmith._threads import thread_map

    caller = threading.get_ident()
    seen = []

    def work(i):
        time.sleep(0.2 if i == 0 else 0.002 * (i % 3))  # whoever takes item 0 is busy while others take the rest
        seen.append(threading.get_ident())
        return i * i

    assert thread_map(work, list(range(12)), 3) == [i * i for i in range(12)]
    assert caller in seen and len(set(seen)) > 1  # the caller took items, and so did a helper
    assert thread_map(work, [5], 4) == [25] and thread_map(work, [], 2) == []

    def fails(i):
        if i == 4:
            raise ValueError("item 4")
        return i

    with pytest.raises(ValueError, match="item 4"):
        thread_map(fails, list(range(40)), 2)


@settings(max_examples=80, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=400), st.integers(1, 9), st.integers(0, 3))
def test_ranked_and_strip_ids_are_numpys_partition_and_stable_sort(values, k, repeat):
    """The cuts' kernels: the values at ranks without a copy, and each strip's points without a sort."""
    v = np.array(values * (repeat + 1))  # repeats put several ranks in one bin
    ranks = (np.arange(1, k) * len(v)) // k
    expected = np.partition(v, ranks)[ranks] if len(ranks) else np.empty(0)
    np.testing.assert_array_equal(kstrips.ranked(v, ranks), expected)
    cuts = np.unique(expected)
    starts = kstrips.strip_starts(v, cuts)
    strip = np.searchsorted(cuts, v, side="right")
    np.testing.assert_array_equal(starts, np.r_[0, np.cumsum(np.bincount(strip, minlength=len(cuts) + 1))])
    bounds = np.r_[-np.inf, cuts, np.inf]
    members = np.concatenate([kstrips.strip_ids(v, bounds[s], bounds[s + 1], starts[s + 1] - starts[s])
                              for s in range(len(cuts) + 1)])
    np.testing.assert_array_equal(members, np.argsort(strip, kind="stable"))
