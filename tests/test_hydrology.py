"""tinsmith.hydrology: depression filling, D8 directions, flow accumulation, stream lines and HAND."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import Heightfield, InvalidInputError, NoDataError
from tinsmith import hydrology as hydro
from tinsmith.kernels.hydro import DC, DR

from .conftest import shared


def _path(codes, r, c):
    """The D8 path from (r, c) to its outlet, as a list of cells (raises after more steps than cells)."""
    path = [(r, c)]
    for _ in range(codes.size):
        k = codes[r, c]
        if k < 0:
            return path
        r, c = r + DR[k], c + DC[k]
        path.append((r, c))
    raise AssertionError(f"the D8 path from {path[0]} does not reach an outlet in {codes.size} steps")


def _is_seed(valid, r, c):
    h, w = valid.shape
    if r in (0, h - 1) or c in (0, w - 1):
        return True
    return not valid[r - 1:r + 2, c - 1:c + 2].all()


def _check_drainage(hf: Heightfield):
    """Every valid cell's D8 path descends strictly on the filled surface to an outlet on the edge or next to nodata."""
    filled = hydro.fill_depressions(hf).z
    codes = hydro.flow_directions(hf)
    valid = hf.valid
    assert np.all(codes[~valid] == -1)
    assert np.all(filled[valid] >= np.asarray(hf.z, dtype=np.float64)[valid]), "filling lowered a cell"
    assert np.isnan(filled[~valid]).all()
    for r, c in zip(*np.nonzero(valid), strict=True):
        path = _path(codes, r, c)
        heights = [filled[p] for p in path]
        assert all(a > b for a, b in zip(heights, heights[1:], strict=False)), f"not descending from {(r, c)}"
        assert all(valid[p] for p in path)
        assert _is_seed(valid, *path[-1]), f"{(r, c)} ends at {path[-1]}, which is no outlet"


def _area(hf):
    dx, dy = hf.cell_size
    return dx * dy


# -- analytic cases ---------------------------------------------------------------------------------
def test_a_tilted_plane_drains_to_its_lowest_edge_and_accumulates_linearly():
    rows, cols = np.mgrid[0:9, 0:6]
    z = 3.0 * (8 - rows) + 1.0 * cols  # falls to the south (last row), less so to the west
    hf = Heightfield(z, cell_size=(2.0, 2.0))
    codes = hydro.flow_directions(hf)
    assert np.all(codes[:-1] == 2), "every cell above the last row drains south"
    assert np.all(codes[-1, 1:] == 4), "the last row drains west, along the edge"
    assert codes[-1, 0] == -1, "the lowest corner is the only outlet"
    acc = hydro.flow_accumulation(hf)
    for c in range(6):
        np.testing.assert_array_equal(acc[:-1, c], 4.0 * np.arange(1, 9))  # linear downslope
    np.testing.assert_array_equal(acc[-1, 0], 4.0 * z.size)


def test_a_plane_falling_south_has_one_outlet_per_column():
    z = np.add.outer(np.arange(7.0, 0.0, -1.0), np.zeros(4))
    hf = Heightfield(z, cell_size=5.0)
    np.testing.assert_array_equal(hydro.flow_directions(hf)[-1], -1)
    np.testing.assert_array_equal(hydro.flow_accumulation(hf), 25.0 * np.add.outer(np.arange(1.0, 8.0), np.zeros(4)))


@pytest.fixture
def valley() -> Heightfield:
    """A V valley along column 4 of a 12 x 9 grid of 10 m cells, its axis falling 0.5 m per row to the south."""
    rows, cols = np.mgrid[0:12, 0:9]
    return Heightfield(3.0 * np.abs(cols - 4) + 0.5 * (11 - rows), cell_size=10.0)


def test_a_v_valley_puts_the_stream_on_its_axis(valley):
    acc = hydro.flow_accumulation(valley)
    np.testing.assert_array_equal(acc[:, 4], 100.0 * 9 * np.arange(1, 13))  # the whole width of every row upstream
    lines = hydro.stream_lines(valley, min_area=100.0 * 9 * 3.5)
    assert len(lines) == 1
    (line,) = lines
    x, y = valley.pixel_to_world(np.arange(3, 12), np.full(9, 4))
    np.testing.assert_allclose(line[:, 0], x)
    np.testing.assert_allclose(line[:, 1], y)  # upstream (north) first
    np.testing.assert_allclose(line[:, 2], np.asarray(valley.z)[3:, 4])


def test_hand_is_the_height_above_the_valley_axis(valley):
    hand = hydro.height_above_drainage(valley, min_area=100.0 * 9 * 3.5)
    cols = np.arange(9)
    for r in range(3, 12):
        np.testing.assert_allclose(hand[r], 3.0 * np.abs(cols - 4), atol=1e-9)
    for r in range(3):  # above the channel head (row 3): the height above that head
        np.testing.assert_allclose(hand[r], 3.0 * np.abs(cols - 4) + 0.5 * (3 - r), atol=1e-9)


def test_a_pit_is_filled_to_its_spill_height():
    z = np.full((7, 7), 10.0)
    z[2:5, 2:5] = 2.0  # the pit
    z[1, 3] = 7.0  # the notch it spills through
    z[0, 3] = 5.0  # to the edge
    hf = Heightfield(z, cell_size=1.0)
    filled = hydro.fill_depressions(hf)
    assert isinstance(filled, Heightfield) and filled.transform == hf.transform
    expected = z.copy()
    expected[2:5, 2:5] = 7.0
    np.testing.assert_allclose(filled.z, expected, rtol=0, atol=1e-9)
    assert np.all(filled.z >= z)
    assert np.all(filled.z[2:5, 2:5] > 7.0), "epsilon: the filled pit is not flat"
    codes = hydro.flow_directions(hf)
    assert _path(codes, 3, 3)[-2:] == [(1, 3), (0, 3)]
    _check_drainage(hf)


def test_a_flat_drains_and_nodata_cells_are_outlets_neighbours():
    z = np.full((8, 10), 5.0)
    z[3:5, 4:6] = np.nan  # a hole in the middle
    hf = Heightfield(z, cell_size=1.0, nodata=float("nan"))
    _check_drainage(hf)
    codes = hydro.flow_directions(hf)
    assert np.all(codes[3:5, 4:6] == -1)
    acc = hydro.flow_accumulation(hf)
    assert np.isnan(acc[3:5, 4:6]).all()
    outlets = (codes == -1) & hf.valid
    assert outlets[2, 4] and outlets[0, 0]
    assert np.nansum(acc[outlets]) == pytest.approx(hf.n_valid * _area(hf))


def test_stream_cells_have_zero_hand_and_hand_is_never_negative():
    hf = tinsmith.sample("st-helens")
    min_area = 500 * _area(hf)
    hand = hydro.height_above_drainage(hf, min_area=min_area)
    acc = hydro.flow_accumulation(hf)
    stream = np.nan_to_num(acc) > min_area
    assert np.all(hand[stream] == 0.0)
    assert np.nanmin(hand) >= 0.0
    assert np.isnan(hand[~hf.valid]).all()


# -- real data ----------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def helens() -> Heightfield:
    return tinsmith.read_heightfield(tinsmith.sample_path("st-helens"))


def test_st_helens_conserves_area_and_the_crater_drains_north(helens):
    acc = hydro.flow_accumulation(helens)
    codes = hydro.flow_directions(helens)
    outlets = (codes == -1) & helens.valid
    assert np.nansum(acc[outlets]) == pytest.approx(helens.n_valid * _area(helens), rel=1e-12)
    assert np.all(acc[helens.valid] >= _area(helens))
    # the 1980 crater is breached to the north: its floor drains out through the north edge
    r, c = (int(round(v)) for v in helens.world_to_pixel(562300.0, 5116000.0))
    end = _path(codes, r, c)[-1]
    assert end[0] < 10, f"the crater drains to {end}, not to the north edge (the nodata margin there)"
    assert acc[end] > 3000 * _area(helens), "the crater's stream (the North Fork Toutle's head) is a main one"


def test_st_helens_stream_lines(helens):
    lines = hydro.stream_lines(helens)  # the default: 1000 cells, 0.9 km2
    assert 40 <= len(lines) <= 120
    acc = hydro.flow_accumulation(helens)
    threshold = hydro.DEFAULT_STREAM_CELLS * _area(helens)
    for line in lines:
        assert line.shape[1] == 3 and len(line) >= 2
        rows, cols = helens.world_to_pixel(line[:, 0], line[:, 1])
        cells = (np.round(rows).astype(int), np.round(cols).astype(int))
        a = acc[cells]
        assert np.all(a[1:] > a[:-1]), "a stream line runs downstream"
        assert np.all(a > threshold)
        step = np.hypot(np.diff(line[:, 0]), np.diff(line[:, 1]))
        assert np.all(step <= 30.0 * np.sqrt(2) + 1e-6)
    # the pieces cover every stream cell (confluences end one piece and start the next) but the single-cell
    # streams: an outlet on the edge whose cells upstream are all below the threshold
    stream = np.nan_to_num(acc) > threshold
    codes = hydro.flow_directions(helens)
    fed = np.zeros_like(stream)
    for r, c in zip(*np.nonzero(stream & (codes >= 0)), strict=True):
        k = codes[r, c]
        fed[r + DR[k], c + DC[k]] = True
    single = stream & ~fed & (codes == -1)
    covered = {tuple(p) for line in lines for p in line[:, :2]}
    assert len(covered) == int(stream.sum() - single.sum())
    assert single.sum() <= 5


def test_results_are_deterministic(helens):
    again = tinsmith.read_heightfield(tinsmith.sample_path("st-helens"))
    np.testing.assert_array_equal(hydro.fill_depressions(helens).z, hydro.fill_depressions(again).z)
    np.testing.assert_array_equal(hydro.flow_directions(helens), hydro.flow_directions(again))
    a, b = hydro.stream_lines(helens), hydro.stream_lines(again)
    assert len(a) == len(b) and all(np.array_equal(p, q) for p, q in zip(a, b, strict=True))
    np.testing.assert_array_equal(hydro.height_above_drainage(helens), hydro.height_above_drainage(again))


def test_delft_dtm_default_streams():
    hf = tinsmith.read_heightfield(shared("urban/delft_ahn3/delft_dtm_0.5m.tif"))
    lines = hydro.stream_lines(hf)
    assert 50 <= len(lines) <= 250  # drains and ditches of a flat city block (120 with the default)
    acc = hydro.flow_accumulation(hf)
    assert np.nansum(acc[(hydro.flow_directions(hf) == -1)]) == pytest.approx(hf.n_valid * 0.25)


def test_landlab_agrees_on_a_window(helens):
    """An independent D8 (landlab's FlowAccumulator after its DepressionFinderAndRouter) on a window of St. Helens."""
    landlab = pytest.importorskip("landlab")
    from landlab.components import FlowAccumulator

    z = np.array(helens.z[250:330, 60:140], dtype=np.float64)
    assert np.isfinite(z).all()
    # a low rim: both sides then take every edge cell as an outlet and nothing flows in from the edge
    z[[0, -1], :] = z[:, [0, -1]] = z.min() - 100.0
    hf = Heightfield(z, cell_size=30.0)
    mine = hydro.flow_accumulation(hf)[1:-1, 1:-1]

    grid = landlab.RasterModelGrid(z.shape, xy_spacing=30.0)
    grid.add_field("topographic__elevation", np.flipud(z).ravel().copy(), at="node")
    fa = FlowAccumulator(grid, flow_director="D8", depression_finder="DepressionFinderAndRouter")
    fa.run_one_step()
    theirs = np.flipud(grid.at_node["drainage_area"].reshape(z.shape))[1:-1, 1:-1]

    # the heights are whole metres: equal slopes are common, and the two break their ties differently, which
    # moves some of the area from one channel to its neighbour; where the steepest descent is unique, they agree
    same = np.isclose(mine, theirs, rtol=1e-9)
    assert same.mean() > 0.9, f"only {same.mean():.1%} of the cells agree"
    assert np.corrcoef(np.log(mine).ravel(), np.log(theirs).ravel())[0, 1] > 0.95
    assert mine.max() == pytest.approx(theirs.max(), rel=0.01)
    receivers = np.flipud(grid.at_node["flow__receiver_node"].reshape(z.shape))
    codes = hydro.flow_directions(hf)
    h, w = z.shape
    dist = 30.0 * np.hypot(DR, DC)
    raised = hydro.fill_depressions(hf).z > z
    checked = 0
    for r in range(1, h - 1):
        for c in range(1, w - 1):
            slopes = (z[r, c] - z[r + DR, c + DC]) / dist
            if raised[r - 1:r + 2, c - 1:c + 2].any() or slopes.max() <= 0 or np.sum(slopes == slopes.max()) > 1:
                continue  # by a depression or flat (filled, and routed differently by landlab) or a tie
            k = int(np.argmax(slopes))
            assert codes[r, c] == k
            assert receivers[r, c] == (h - 1 - r - DR[k]) * w + c + DC[k], f"landlab's receiver of {(r, c)} differs"
            checked += 1
    assert checked > 0.8 * (h - 2) * (w - 2)


# -- properties ----------------------------------------------------------------------------------------
@st.composite
def small_grids(draw):
    h = draw(st.integers(2, 7))
    w = draw(st.integers(2, 7))
    z = np.array(draw(st.lists(st.integers(0, 4), min_size=h * w, max_size=h * w)), dtype=np.float64).reshape(h, w)
    holes = np.array(draw(st.lists(st.booleans(), min_size=h * w, max_size=h * w))).reshape(h, w)
    holes &= draw(st.booleans())
    if holes.all():
        holes[0, 0] = False
    z[holes] = np.nan
    return Heightfield(z, cell_size=draw(st.sampled_from([1.0, 2.5])), nodata=float("nan"))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(small_grids())
def test_every_cell_drains_and_area_is_conserved(hf):
    _check_drainage(hf)
    acc = hydro.flow_accumulation(hf)
    codes = hydro.flow_directions(hf)
    outlets = (codes == -1) & hf.valid
    assert np.sum(acc[outlets]) == pytest.approx(hf.n_valid * _area(hf))
    assert np.all(acc[hf.valid] >= _area(hf))
    hand = hydro.height_above_drainage(hf, min_area=_area(hf) * 1.5)
    assert not np.any(hand < 0)


# -- bad input -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("min_area", [0, -1.0, float("nan"), float("inf"), "big", True])
def test_a_bad_min_area_is_refused(valley, min_area):
    for func in (hydro.stream_lines, hydro.height_above_drainage):
        with pytest.raises(InvalidInputError, match="min_area"):
            func(valley, min_area=min_area)


@pytest.mark.parametrize("func", [hydro.fill_depressions, hydro.flow_directions, hydro.flow_accumulation,
                                  hydro.stream_lines, hydro.height_above_drainage])
def test_a_non_heightfield_is_refused(func):
    with pytest.raises(InvalidInputError, match="hf must be a tinsmith.Heightfield"):
        func(np.zeros((4, 4)))


def test_a_heightfield_without_valid_cells_is_refused(valley):
    valley.nodata_mask = np.ones(valley.shape, dtype=bool)
    with pytest.raises(NoDataError, match="hf has no valid cell"):
        hydro.flow_accumulation(valley)
