"""Solver formats: the sliver warning of every solver writer, and ADCIRC's fort.14 read back independently.

No permissive, small Python package reads fort.14 (adcircpy is GPL-3.0; pyschism
pulls in a cloud and weather stack), so :func:`read_fort14` below parses the
file from the layout in ADCIRC's manual ("ADCIRC Grid and Boundary Information
File (fort.14)"), with no code of tinsmith's writer.
"""

from __future__ import annotations

import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

import tinsmith
from tinsmith.cli.main import main
from tinsmith.core import Heightfield, TerrainMesh
from tinsmith.errors import InvalidInputError, TinsmithWarning
from tinsmith.io.slivers import SliverWarning
from tinsmith.triangulation.grid import grid_mesh

from .conftest import shared

BIG_TUJUNGA = "terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"


# -- an independent fort.14 reader, from the manual's layout -------------------------------------------------
def read_fort14(path: Path) -> dict:
    """AGRID; NE NP; NP lines ``JN X Y DP``; NE lines ``JE NHY N1 N2 N3``; NOPE, NETA, then per open segment
    ``NVDLL IBTYPEE`` and NVDLL node lines; NBOU, NVEL, then per land segment ``NVELL IBTYPE`` and NVELL node
    lines (one node id a line for IBTYPE 0, 1, 2, 10, 11, 12, 20, 21, 22, 30).  Values are read as Fortran's
    list-directed READ does: the leading numbers of a line, the rest ignored."""
    lines = iter(path.read_text().splitlines())

    def numbers(count: int) -> list[str]:
        fields = next(lines).split()
        return fields[:count]

    header = next(lines)
    ne, np_ = (int(v) for v in numbers(2))
    nodes = np.array([[float(v) for v in numbers(4)] for _ in range(np_)])
    elements = np.array([[int(v) for v in numbers(5)] for _ in range(ne)], dtype=np.int64)
    nope, neta = int(numbers(1)[0]), int(numbers(1)[0])
    opened = []
    for _ in range(nope):
        nvdll, ibtypee = (int(v) for v in numbers(2))
        opened.append((ibtypee, [int(numbers(1)[0]) for _ in range(nvdll)]))
    nbou, nvel = int(numbers(1)[0]), int(numbers(1)[0])
    land = []
    for _ in range(nbou):
        nvell, ibtype = (int(v) for v in numbers(2))
        assert ibtype in (0, 1, 2, 10, 11, 12, 20, 21, 22, 30), ibtype  # one node id a line
        land.append((ibtype, [int(numbers(1)[0]) for _ in range(nvell)]))
    assert [line for line in lines if line.strip()] == [], "lines after the last segment"
    assert sum(len(ids) for _, ids in opened) == neta and sum(len(ids) for _, ids in land) == nvel
    return {"header": header, "nodes": nodes, "elements": elements, "open": opened, "land": land}


def _border_nodes(elements: np.ndarray) -> set[int]:
    """Nodes on an edge of one element only (the border), from the element lines read back."""
    tri = elements[:, 2:5]
    edges = Counter(tuple(sorted(e)) for t in tri.tolist() for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])))
    return {v for e, n in edges.items() if n == 1 for v in e}


def _signed_area(nodes: np.ndarray, ids: list[int]) -> float:
    xy = nodes[np.asarray(ids) - 1, 1:3]
    xy = xy - xy.mean(axis=0)
    return 0.5 * float(np.sum(xy[:-1, 0] * xy[1:, 1] - xy[1:, 0] * xy[:-1, 1]))


def _holed_hf() -> Heightfield:
    """A 30 x 40 DEM 2 m cells at UTM-like offsets, with two nodata holes (two islands)."""
    r, c = np.mgrid[0:30, 0:40]
    z = (-6.0 + 0.3 * r + 2.0 * np.sin(c / 5.0)).astype(np.float64)
    z[8:12, 10:15] = -9999.0
    z[18:22, 25:31] = -9999.0
    return Heightfield(z, transform=(2.0, 0.0, 500_000.0, 0.0, -2.0, 4_100_000.0), nodata=-9999.0)


# -- ADCIRC fort.14 ------------------------------------------------------------------------------------------
def test_fort14_nodes_elements_depth_and_orientation(tmp_path):
    mesh = grid_mesh(_holed_hf())
    path = tinsmith.write(mesh, tmp_path / "fort.14")
    got = read_fort14(path)
    nodes, elements = got["nodes"], got["elements"]
    assert len(nodes) == mesh.n_vertices and len(elements) == mesh.n_triangles
    assert (nodes[:, 0] == np.arange(1, mesh.n_vertices + 1)).all()
    assert (nodes[:, 1:3] == mesh.vertices[:, :2]).all()  # 17 significant digits: exact
    assert (nodes[:, 3] == -mesh.vertices[:, 2]).all()  # depth positive down
    assert (nodes[:, 3] > 0).any() and (nodes[:, 3] < 0).any()  # below and above the datum
    assert (elements[:, 0] == np.arange(1, mesh.n_triangles + 1)).all() and (elements[:, 1] == 3).all()
    assert (elements[:, 2:] == mesh.triangles + 1).all()
    p = nodes[elements[:, 2:] - 1, 1:3]
    p = p - p[:, :1]
    cross = p[:, 1, 0] * p[:, 2, 1] - p[:, 1, 1] * p[:, 2, 0]
    assert (cross > 0).all()  # counter-clockwise seen from above
    assert "depth = -z" in got["header"]


def test_fort14_outline_is_land_and_holes_are_islands(tmp_path):
    mesh = grid_mesh(_holed_hf())
    got = read_fort14(tinsmith.write(mesh, tmp_path / "holed.14"))
    assert got["open"] == []
    kinds = [k for k, _ in got["land"]]
    assert kinds == [20, 21, 21]  # the outline first, then the islands
    for kind, ids in got["land"]:
        assert ids[0] == ids[-1]  # closed: the first node repeated
        area = _signed_area(got["nodes"], ids)
        assert area > 0 if kind == 20 else area < 0  # round the data counter-clockwise, islands clockwise
    covered = Counter(v for _, ids in got["land"] for v in set(ids))
    assert set(covered) == _border_nodes(got["elements"])  # every border node ...
    assert set(covered.values()) == {1}  # ... in one segment only


def test_fort14_node_strings_become_open_segments(tmp_path):
    hf = Heightfield(np.add.outer(np.arange(12.0), np.arange(15.0)), cell_size=1.0)
    mesh = grid_mesh(hf)
    rows, cols = hf.shape
    west = np.arange(rows) * cols  # column 0, top to bottom
    east = np.arange(rows)[::-1] * cols + cols - 1  # last column, bottom to top
    mesh.node_strings = {"Inflow_west": west[2:9], "outflow": east[:5], "breakline_1": np.array([16, 17, 18]),
                         "wall_north": np.arange(3, 9)}
    got = read_fort14(tinsmith.write(mesh, tmp_path / "m.grd"))
    assert [k for k, _ in got["open"]] == [0, 0]
    opened = [set(ids) for _, ids in got["open"]]
    assert opened == [set(west[2:9] + 1), set(east[:5] + 1)]
    assert all(k == 20 for k, _ in got["land"])
    border = _border_nodes(got["elements"])
    segments = [ids for _, ids in got["open"]] + [ids for _, ids in got["land"]]
    assert set().union(*map(set, segments)) == border  # every border node on a segment
    assert all(ids[0] != ids[-1] for ids in segments)  # none closed: they meet end to end
    ends = Counter(v for ids in segments for v in (ids[0], ids[-1]))
    assert set(ends.values()) == {2}  # each junction shared by two segments, and nothing else shared
    inner = Counter(v for ids in segments for v in ids[1:-1])
    assert set(inner.values()) == {1} and not set(inner) & set(ends)
    assert {17, 18, 19}.isdisjoint(inner)  # the breakline is inside: no boundary
    assert any(ids in ([4, 5, 6, 7, 8, 9], [9, 8, 7, 6, 5, 4]) for _, ids in got["land"])  # the wall: its own
    directed = _directed_border(got["elements"])
    for ids in segments:  # along the border, the domain on the left (counter-clockwise round it)
        assert all((a, b) in directed for a, b in zip(ids[:-1], ids[1:], strict=True))


def _directed_border(elements: np.ndarray) -> set[tuple[int, int]]:
    tri = elements[:, 2:5].tolist()
    directed = {(t[i], t[(i + 1) % 3]) for t in tri for i in range(3)}
    return {(a, b) for a, b in directed if (b, a) not in directed}


def test_fort14_open_string_off_the_border_is_refused(tmp_path):
    mesh = grid_mesh(Heightfield(np.zeros((6, 6)), cell_size=1.0))
    mesh.node_strings = {"open_sea": np.array([7, 8, 9])}
    with pytest.raises(InvalidInputError, match="'open_sea'.*not on the border"):
        tinsmith.write(mesh, tmp_path / "fort.14")
    assert list(tmp_path.iterdir()) == []


def test_fort14_of_a_real_dem_with_its_crs(tmp_path):
    hf = tinsmith.read_heightfield(shared(BIG_TUJUNGA))
    hf = Heightfield(hf.z[100:160, 200:280].copy(), crs=hf.crs, transform=_window(hf.transform, 100, 200))
    mesh = grid_mesh(hf)
    path = tinsmith.write(mesh, tmp_path / "fort.14")
    assert (tmp_path / "fort.prj").is_file()  # no CRS in fort.14: a sidecar
    got = read_fort14(path)
    assert np.allclose(got["nodes"][:, 3], -mesh.vertices[:, 2], rtol=0, atol=0)
    assert (got["nodes"][:, 3] < 0).all()  # a mountain canyon: all land above the datum, negative depths
    assert [k for k, _ in got["land"]] == [20]


def _window(transform, r0, c0):
    a, b, c, d, e, f = transform
    return (a, b, c + a * c0 + b * r0, d, e, f + d * c0 + e * r0)


def test_formats_lists_fort14(capsys):
    assert main(["formats"]) == 0
    out = capsys.readouterr().out
    assert ".14 .grd: ADCIRC grid and boundary file" in out


# -- slivers into a solver format ----------------------------------------------------------------------------
def _sliver_mesh() -> TerrainMesh:
    """Three triangles, one of them a sliver (2.3 degrees at two corners)."""
    v = [(0, 0, 1), (10, 0, 1), (5, 0.2, 1), (5, 10, 2)]
    return TerrainMesh(v, [(0, 1, 2), (0, 2, 3), (2, 1, 3)])


@pytest.mark.parametrize("name", ["m.2dm", "m.msh", "fort.14", "m.slf"])
def test_solver_formats_warn_of_slivers_in_one_line(tmp_path, name):
    with pytest.warns(SliverWarning) as seen:
        tinsmith.write(_sliver_mesh(), tmp_path / name)
    assert len(seen) == 1 and issubclass(seen[0].category, TinsmithWarning)
    message = str(seen[0].message)
    assert "\n" not in message and name in message
    assert "1 of 3 triangles (33.3%)" in message and "under 10 degrees" in message and "2.3 degrees" in message
    assert "--method quality" in message and "30-degree" in message
    assert (tmp_path / name).is_file()  # written all the same


@pytest.mark.parametrize("name", ["m.ply", "m.obj", "m.landxml"])
def test_other_formats_do_not_judge_slivers(tmp_path, name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tinsmith.write(_sliver_mesh(), tmp_path / name)


def test_a_well_shaped_mesh_goes_to_a_solver_without_a_word(tmp_path):
    mesh = grid_mesh(_holed_hf())  # right isosceles triangles: 45 degrees
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in ("m.2dm", "m.msh", "fort.14", "m.slf"):
            tinsmith.write(mesh, tmp_path / name)
