"""segment_outline: the outline cut into inflow, outflow, wall and hole segments, and the writers that take them."""

from __future__ import annotations

import contextlib
import io
from collections import Counter

import numpy as np
import pytest

import tinsmith
from tinsmith.core import Heightfield
from tinsmith.errors import InvalidInputError, InvalidOptionError
from tinsmith.io.boundaries import named_boundaries, segment_outline

from .test_selafin import read_cli
from .test_solver_formats import read_fort14


def _plane(nx=20, ny=10, cell=10.0, hole=None):
    """A plane falling 1 in 20 towards the east (high at x = 500000), on a grid of cells, UTM."""
    z = np.tile(100.0 - 0.05 * cell * np.arange(nx + 1, dtype=float), (ny + 1, 1))
    if hole is not None:
        z[hole] = np.nan
    hf = Heightfield(z, transform=(cell, 0, 500000.0, 0, -cell, 4100000.0 + ny * cell), crs="EPSG:32610",
                     nodata=float("nan"))
    return tinsmith.simplify(hf, method="grid")


def _river(mesh, reverse=False):
    """A straight stream west to east across the middle of the mesh, starting and ending outside it."""
    x0, y0, _, x1, y1, _ = mesh.bounds
    y = 0.5 * (y0 + y1) + 1.0
    line = np.array([[x0 - 50.0, y], [0.5 * (x0 + x1), y], [x1 + 50.0, y]])
    return line[::-1] if reverse else line


def _border(mesh):
    loops = named_boundaries(mesh)["outline"]
    return Counter((min(a, b), max(a, b)) for lp in loops for a, b in zip(lp[:-1].tolist(), lp[1:].tolist(),
                                                                                      strict=True))


def _edges(ids):
    return [(min(a, b), max(a, b)) for a, b in zip(ids[:-1].tolist(), ids[1:].tolist(), strict=True)]


def _check_partition(mesh, strings):
    """Every border edge in exactly one segment; each segment a run of consecutive border vertices."""
    border = _border(mesh)
    covered = Counter(e for ids in strings.values() for e in _edges(ids))
    assert covered == border


@pytest.mark.parametrize("reverse", [False, True])
def test_tilted_plane_has_one_inflow_high_and_one_outflow_low(reverse):
    mesh = _plane()
    out = segment_outline(mesh, streams=[_river(mesh, reverse)])  # the heights say which way it flows
    strings = out.node_strings
    assert sorted(strings) == ["inflow_1", "outflow_1", "wall_1", "wall_2"]
    x0, _, _, x1, _, _ = mesh.bounds
    assert (out.vertices[strings["inflow_1"], 0] == x0).all()  # the high west side
    assert (out.vertices[strings["outflow_1"], 0] == x1).all()  # the low east side
    # default opening: 3 edges of 10 m centred on the crossing, 1 m off a vertex: 4 edges overlap it
    assert len(strings["inflow_1"]) == 5 and len(strings["outflow_1"]) == 5
    _check_partition(mesh, strings)
    assert mesh.node_strings == {}  # the input is left as it was


def test_vertex_order_and_width():
    mesh = _plane()
    up = segment_outline(mesh, streams=[_river(mesh, reverse=True)], order="vertices")  # drawn east to west
    x0 = mesh.bounds[0]
    assert (up.vertices[up.node_strings["outflow_1"], 0] == x0).all()
    wide = segment_outline(mesh, streams=[_river(mesh)], width=55.0)
    assert len(wide.node_strings["inflow_1"]) == 7  # 6 edges of 10 m overlap 55 m centred 1 m off a vertex
    _check_partition(mesh, wide.node_strings)


def test_no_stream_is_one_closed_wall_and_a_stream_that_never_crosses_adds_nothing():
    mesh = _plane()
    x0, y0, _, x1, y1, _ = mesh.bounds
    inside = np.array([[x0 + 20, y0 + 20], [x1 - 20, y1 - 20]])
    for streams in (None, [inside], [np.array([[0.0, 0.0], [1.0, 1.0]])]):
        strings = segment_outline(mesh, streams=streams).node_strings
        assert list(strings) == ["wall_1"]
        assert strings["wall_1"][0] == strings["wall_1"][-1]
        _check_partition(mesh, strings)


def test_a_user_line_overrides_a_wall():
    mesh = _plane()
    x0, y0, _, x1, y1, _ = mesh.bounds
    weir = np.array([[x0 + 50, y1], [x0 + 120, y1]])  # along the north side
    out = segment_outline(mesh, streams=[_river(mesh)], lines={"weir": weir})
    strings = out.node_strings
    assert sorted(strings) == ["inflow_1", "outflow_1", "wall_1", "wall_2", "wall_3", "weir"]
    xs = out.vertices[strings["weir"], 0]
    assert sorted(xs.tolist()) == [x0 + 50 + 10 * k for k in range(8)]
    assert (out.vertices[strings["weir"], 1] == y1).all()
    _check_partition(mesh, strings)
    # a line over an inflow wins too; one that is nowhere near the outline names nothing
    west = np.array([[x0, y0], [x0, y1]])
    strings = segment_outline(mesh, streams=[_river(mesh)], lines={"gate": west, "far": [[0, 0], [1, 1]]}).node_strings
    assert "inflow_1" not in strings and "gate" in strings and "far" not in strings
    _check_partition(mesh, strings)


def test_a_hole_gets_a_hole_segment_and_interior_strings_are_kept():
    mesh = _plane(hole=(slice(4, 7), slice(8, 12)))
    mesh.node_strings = {"outline_1": named_boundaries(mesh)["outline"][0], "dyke": np.array([30, 31, 32])}
    strings = segment_outline(mesh, streams=[_river(mesh)]).node_strings
    assert "hole_1" in strings and strings["hole_1"][0] == strings["hole_1"][-1]
    assert "dyke" in strings and "outline_1" not in strings  # the old outline string is replaced
    assert sum(k.startswith("inflow") for k in strings) == 1
    _check_partition(mesh, {k: v for k, v in strings.items() if k != "dyke"})


def test_bad_input_is_one_line_naming_the_parameter():
    mesh = _plane()
    with pytest.raises(InvalidInputError, match=r"streams\[0\].*non-finite"):
        segment_outline(mesh, streams=[np.array([[0.0, np.nan], [1.0, 1.0]])])
    with pytest.raises(InvalidInputError, match=r"streams\[1\]"):
        segment_outline(mesh, streams=[_river(mesh), np.array([1.0, 2.0])])
    with pytest.raises(InvalidInputError, match=r"streams"):
        segment_outline(mesh, streams=42)
    with pytest.raises(InvalidInputError, match=r"lines\['weir'\].*non-finite"):
        segment_outline(mesh, lines={"weir": [[0, 0], [np.inf, 1]]})
    with pytest.raises(InvalidInputError, match=r"lines"):
        segment_outline(mesh, lines=[[0, 0], [1, 1]])
    for option, value in (("width", 0), ("width", "wide"), ("tolerance", -1.0), ("tolerance", np.nan)):
        with pytest.raises(InvalidOptionError, match=option):
            segment_outline(mesh, streams=[_river(mesh)], **{option: value})
    with pytest.raises(InvalidOptionError, match="order"):
        segment_outline(mesh, order="upstream")


def test_streams_from_a_vector_file_in_another_crs_are_reprojected(tmp_path):
    gpd = pytest.importorskip("geopandas")
    shapely = pytest.importorskip("shapely")
    mesh = _plane()
    river = gpd.GeoSeries([shapely.LineString(_river(mesh))], crs="EPSG:32610").to_crs("EPSG:4326")
    path = tmp_path / "streams.geojson"
    gpd.GeoDataFrame(geometry=river).to_file(path)
    with pytest.warns(tinsmith.errors.TinsmithNote, match="reprojected"):
        strings = segment_outline(mesh, streams=path).node_strings
    assert sorted(strings) == ["inflow_1", "outflow_1", "wall_1", "wall_2"]


# -- the writers -----------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def segmented():
    mesh = _plane(hole=(slice(4, 7), slice(8, 12)))
    x0, _, _, _, y1, _ = mesh.bounds
    return segment_outline(mesh, streams=[_river(mesh)], lines={"weir": [[x0 + 50, y1], [x0 + 120, y1]]})


def test_2dm_and_gmsh_carry_the_segments(segmented, tmp_path):
    py2dm = pytest.importorskip("py2dm")
    path = tinsmith.write(segmented, tmp_path / "m.2dm")
    with py2dm.Reader(str(path)) as reader:
        strings = {ns.name: np.asarray(ns.nodes) - 1 for ns in reader.iter_node_strings()}
    for name, ids in segmented.node_strings.items():
        np.testing.assert_array_equal(strings[name], ids)
    meshio = pytest.importorskip("meshio")
    back = meshio.read(tinsmith.write(segmented, tmp_path / "m.msh"))
    lines = np.concatenate([c.data for c in back.cells if c.type == "line"])
    physical = np.concatenate([p for c, p in zip(back.cells, back.cell_data["gmsh:physical"], strict=True) if c.type == "line"])
    for name, ids in segmented.node_strings.items():
        tag, dim = back.field_data[name]
        assert dim == 1
        np.testing.assert_array_equal(lines[physical == tag], np.column_stack([ids[:-1], ids[1:]]))


def test_fort14_opens_the_inflow_and_outflow(segmented, tmp_path):
    got = read_fort14(tinsmith.write(segmented, tmp_path / "fort.14"))
    opened = [ids for _, ids in got["open"]]
    assert sorted(map(sorted, opened)) == sorted(sorted(segmented.node_strings[n] + 1) for n in ("inflow_1",
                                                                                                  "outflow_1"))
    kinds = Counter(k for k, _ in got["land"])
    assert kinds[21] == 1 and kinds[20] >= 3  # the hole an island; the walls and the weir land, split at the weir


def test_selafin_cli_codes_are_the_segments(segmented, tmp_path):
    tinsmith.write(segmented, tmp_path / "m.slf")
    codes, nk = read_cli(tmp_path / "m.cli")
    by_node = {int(n) - 1: tuple(c) for n, c in zip(nk[:, 0], codes, strict=True)}
    inflow, outflow = segmented.node_strings["inflow_1"], segmented.node_strings["outflow_1"]
    assert {by_node[v] for v in inflow} == {(4, 5, 5, 5)} and {by_node[v] for v in outflow} == {(5, 4, 4, 4)}
    walls = set(by_node) - set(inflow.tolist()) - set(outflow.tolist())
    assert walls and {by_node[v] for v in walls} == {(2, 2, 2, 2)}  # the walls, the weir and the hole


def test_to_anuga_tags_are_the_segments(segmented):
    with contextlib.redirect_stdout(io.StringIO()):
        pytest.importorskip("anuga")
    domain = segmented.to_anuga()
    tags = set(domain.get_boundary_tags())
    assert tags == set(segmented.node_strings)


# -- a real DEM ------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def helens():
    hf = tinsmith.read_heightfield(tinsmith.sample_path("st-helens"))
    mesh = tinsmith.simplify(hf, method="quality", max_error=20)
    return hf, mesh


def test_every_crossing_of_a_real_dem_becomes_a_segment(helens):
    from tinsmith import shapes
    from tinsmith.io.boundaries import _crossings, _start_west

    hf, mesh = helens
    streams = shapes.stream_network(hf)
    out = segment_outline(mesh, streams=streams)
    strings = out.node_strings
    _check_partition(mesh, strings)
    for name, ids in strings.items():
        assert name.rsplit("_", 1)[0] in ("inflow", "outflow", "wall", "hole"), name
        assert len(ids) >= 2
    # every crossing's crossed edge lies in a segment of an inflow or outflow
    loops = [_start_west(mesh.vertices[:, :2], lp) for lp in named_boundaries(mesh)["outline"]]
    found = _crossings(mesh, mesh.vertices[:, :2], loops, [True] + [False] * (len(loops) - 1), 1.0, streams,
                       "heights")
    assert len(found) >= 3
    opened = {e: name for name, ids in strings.items() if name.startswith(("inflow", "outflow")) for e in _edges(ids)}
    for k, pos, _ in found:
        a, b = loops[k][int(pos)], loops[k][int(pos) + 1]
        assert (min(a, b), max(a, b)) in opened
    n_open = sum(name.startswith(("inflow", "outflow")) for name in strings)
    assert 1 <= n_open <= len(found)
    # downstream paths leave the DEM: outflow where they cross it
    assert any(name.startswith("outflow") for name in strings)
    again = segment_outline(mesh, streams=streams).node_strings  # deterministic
    assert list(again) == list(strings) and all((again[k] == strings[k]).all() for k in strings)


# -- the command line: tinsmith simplify --streams / --boundary -------------------------------------------------

def _streams_file(hf, path):
    gpd = pytest.importorskip("geopandas")
    shapely = pytest.importorskip("shapely")
    from tinsmith import shapes

    lines = [shapely.LineString(line) for line in shapes.stream_network(hf)]
    gpd.GeoDataFrame(geometry=gpd.GeoSeries(lines, crs=hf.crs)).to_file(path)
    return path


def _node_strings(path):
    py2dm = pytest.importorskip("py2dm")
    with py2dm.Reader(str(path)) as reader:
        nodes = np.array([n.pos for n in reader.iter_nodes()])
        return nodes, {ns.name: np.asarray(ns.nodes) - 1 for ns in reader.iter_node_strings()}


def _simplify(tmp_path, capsys, *extra):
    from tinsmith.cli.main import main

    out = tmp_path / "m.2dm"
    code = main(["simplify", "--sample", "st-helens", "--method", "quality", "--max-error", "20", "-o", str(out),
                 *extra])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return out, captured


def test_cli_streams_write_inflow_outflow_and_wall_node_strings(tmp_path, capsys):
    hf = tinsmith.read_heightfield(tinsmith.sample_path("st-helens"))
    streams = _streams_file(hf, tmp_path / "streams.geojson")
    out, captured = _simplify(tmp_path, capsys, "--streams", str(streams))
    _, strings = _node_strings(out)
    kinds = {name.rsplit("_", 1)[0] for name in strings if not name.startswith(("outline", "breakline"))}
    assert {"inflow", "outflow", "wall"} <= kinds, sorted(strings)
    assert "boundary segments: " in captured.out and "inflow_1" in captured.out
    assert "note" not in captured.err  # a 2DM carries the segments


def test_cli_boundary_overrides_the_segments_and_a_ply_gets_a_note(tmp_path, capsys):
    hf = tinsmith.read_heightfield(tinsmith.sample_path("st-helens"))
    streams = _streams_file(hf, tmp_path / "streams.geojson")
    x0, y0, _, y1 = hf.bounds
    gpd = pytest.importorskip("geopandas")
    shapely = pytest.importorskip("shapely")
    x, dy = x0 + 0.5 * hf.cell_size[0], hf.cell_size[1]  # the first column of cells: the western border
    west = tmp_path / "west.geojson"
    line = shapely.LineString([(x, y0 - dy), (x, y1 + dy)])
    gpd.GeoDataFrame(geometry=gpd.GeoSeries([line], crs=hf.crs)).to_file(west)
    ply = tmp_path / "m.ply"
    out, captured = _simplify(tmp_path, capsys, "--streams", str(streams), "--boundary", f"west={west}",
                              "-o", str(ply))
    assert ply.exists()
    notes = [line for line in captured.err.splitlines() if line.startswith("tinsmith: note:")]
    assert len(notes) == 1 and "2DM" in notes[0], captured.err
    nodes, strings = _node_strings(out)
    assert "west" in strings, sorted(strings)
    ids = strings["west"]
    assert len(ids) >= 2 and (nodes[ids, 0] - nodes[:, 0].min()).max() < 4 * hf.cell_size[0]  # a ragged edge
    west_edges = set(_edges(ids))
    assert not any(west_edges & set(_edges(strings[n])) for n in strings if n.startswith(("wall", "inflow")))
