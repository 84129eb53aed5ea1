"""TELEMAC's geometry file (SELAFIN) and boundary-conditions file (.cli), read back independently.

The Python readers of SELAFIN on PyPI are GPL-3.0 (python-serafin, and
xarray-selafin, which depends on it), so :func:`read_selafin` below parses
the file from the layout in the TELEMAC documentation ("Binary file format":
big-endian Fortran sequential records of title, NBV, variable names, IPARAM,
NELEM/NPOIN/NDP, IKLE, IPOBO, X, Y and the time steps) and :func:`read_cli`
the boundary file's columns (LIHBOR LIUBOR LIVBOR HBOR UBOR VBOR AUBOR LITBOR
TBOR ATBOR BTBOR N K), with no code of tinsmith's writer.
"""

from __future__ import annotations

import struct
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

import tinsmith
from tinsmith.cli.main import main
from tinsmith.core import Heightfield, TerrainMesh
from tinsmith.errors import FormatError, InvalidInputError
from tinsmith.io.slivers import SliverWarning
from tinsmith.triangulation.grid import grid_mesh


# -- independent readers, from the documented layouts --------------------------------------------------------
def read_selafin(path: Path) -> dict:
    data = path.read_bytes()
    at = 0

    def record() -> bytes:
        nonlocal at
        (size,) = struct.unpack(">i", data[at : at + 4])
        payload = data[at + 4 : at + 4 + size]
        (end,) = struct.unpack(">i", data[at + 4 + size : at + 8 + size])
        assert end == size, "record markers differ"
        at += size + 8
        return payload

    title = record().decode("ascii")
    assert len(title) == 80
    real = {"SERAFIN ": ">f4", "SERAFIND": ">f8"}[title[72:]]
    nbv1, nbv2 = np.frombuffer(record(), ">i4")
    names = [record().decode("ascii") for _ in range(nbv1 + nbv2)]
    iparam = np.frombuffer(record(), ">i4")
    assert len(iparam) == 10
    if iparam[9] == 1:
        record()  # the date
    nelem, npoin, ndp, one = np.frombuffer(record(), ">i4")
    ikle = np.frombuffer(record(), ">i4").reshape(nelem, ndp).astype(np.int64)
    ipobo = np.frombuffer(record(), ">i4").astype(np.int64)
    x = np.frombuffer(record(), real).astype(np.float64)
    y = np.frombuffer(record(), real).astype(np.float64)
    steps = []
    while at < len(data):
        (time,) = np.frombuffer(record(), real)
        steps.append((float(time), [np.frombuffer(record(), real).astype(np.float64) for _ in names]))
    assert len(x) == len(y) == len(ipobo) == npoin and one == 1
    return {"title": title, "real": real, "nbv": (int(nbv1), int(nbv2)), "names": names, "iparam": iparam,
            "ikle": ikle, "ipobo": ipobo, "x": x, "y": y, "steps": steps}


def read_cli(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(codes LIHBOR LIUBOR LIVBOR LITBOR, (N, K)) of every line, both as int arrays."""
    rows = [line.split() for line in path.read_text().splitlines() if line.strip()]
    assert all(len(r) == 13 for r in rows)
    codes = np.array([[int(r[0]), int(r[1]), int(r[2]), int(r[7])] for r in rows])
    assert all(float(v) == 0.0 for r in rows for v in (r[3], r[4], r[5], r[6], r[8], r[9], r[10]))
    return codes, np.array([[int(r[11]), int(r[12])] for r in rows])


def _directed_border(ikle: np.ndarray) -> set[tuple[int, int]]:
    directed = {(t[i], t[(i + 1) % 3]) for t in ikle.tolist() for i in range(3)}
    return {(a, b) for a, b in directed if (b, a) not in directed}


def _loops(order: list[int], border: set[tuple[int, int]]) -> list[list[int]]:
    """The boundary order cut into loops: each step along a directed border edge (domain on the left)."""
    loops = [[order[0]]]
    for a, b in zip(order[:-1], order[1:], strict=True):
        if (a, b) in border:
            loops[-1].append(b)
        else:
            loops.append([b])
    for lp in loops:
        assert (lp[-1], lp[0]) in border, "a loop does not close along the border"
    return loops


def _signed_area(x: np.ndarray, y: np.ndarray, ids: list[int]) -> float:
    i = np.asarray(ids) - 1
    px, py = x[i] - x[i].mean(), y[i] - y[i].mean()
    return 0.5 * float(np.dot(px, np.roll(py, -1)) - np.dot(np.roll(px, -1), py))


def _holed_hf() -> Heightfield:
    """A 30 x 40 DEM, 2 m cells at UTM offsets, with two nodata holes (two islands)."""
    r, c = np.mgrid[0:30, 0:40]
    z = (-6.0 + 0.3 * r + 2.0 * np.sin(c / 5.0)).astype(np.float64)
    z[8:12, 10:15] = -9999.0
    z[18:22, 25:31] = -9999.0
    return Heightfield(z, transform=(2.0, 0.0, 500_000.3, 0.0, -2.0, 4_100_000.7), nodata=-9999.0)


def _written(mesh: TerrainMesh, path: Path) -> tuple[dict, np.ndarray, np.ndarray]:
    tinsmith.write(mesh, path)
    codes, nk = read_cli(path.with_suffix(".cli"))
    return read_selafin(path), codes, nk


# -- the geometry file ---------------------------------------------------------------------------------------
def test_selafin_header_elements_coordinates_and_bottom(tmp_path):
    mesh = grid_mesh(_holed_hf())
    got, _, _ = _written(mesh, tmp_path / "m.slf")
    assert got["title"].endswith("SERAFIN ") and got["real"] == ">f4"  # 80 m across: single precision keeps 1 mm
    assert got["nbv"] == (1, 0) and got["names"] == ["BOTTOM          M               "]
    ip = got["iparam"]
    assert ip[0] == 1 and (ip[6], ip[7], ip[8], ip[9]) == (0, 0, 0, 0)
    assert (ip[2], ip[3]) == (500_001, 4_099_941)  # whole units: floor of the smallest x and y (cell centres)
    assert len(got["x"]) == mesh.n_vertices and len(got["ikle"]) == mesh.n_triangles
    assert (got["ikle"] == mesh.triangles + 1).all()  # 1-based
    x, y = got["x"] + ip[2], got["y"] + ip[3]
    assert np.abs(x - mesh.vertices[:, 0]).max() < 1e-5 and np.abs(y - mesh.vertices[:, 1]).max() < 1e-5
    assert 0 <= got["x"].min() < 1 and 0 <= got["y"].min() < 1  # relative to the origin: float32 keeps them
    p = np.column_stack([x, y])[got["ikle"] - 1]
    p = p - p[:, :1]
    assert (p[:, 1, 0] * p[:, 2, 1] - p[:, 1, 1] * p[:, 2, 0] > 0).all()  # counter-clockwise
    [(time, [bottom])] = got["steps"]
    assert time == 0.0 and (bottom == mesh.vertices[:, 2].astype(np.float32)).all()


def test_selafin_goes_double_when_single_precision_would_lose_a_millimetre(tmp_path):
    v = [(300_000.123456, 5_000_000.654321, 1.5), (420_000.3, 5_000_000.2, 2.5), (300_000.5, 5_090_000.1, 3.25)]
    mesh = TerrainMesh(v, [(0, 1, 2)])  # 120 km across: float32 steps of 8 mm
    got, _, nk = _written(mesh, tmp_path / "wide.selafin")
    assert got["title"].endswith("SERAFIND") and got["real"] == ">f8"
    ip = got["iparam"]
    assert (got["x"] + ip[2] == mesh.vertices[:, 0]).all() and (got["y"] + ip[3] == mesh.vertices[:, 1]).all()
    assert (got["steps"][0][1][0] == mesh.vertices[:, 2]).all()
    assert sorted(nk[:, 0]) == [1, 2, 3]


# -- the boundary conditions ---------------------------------------------------------------------------------
def test_cli_numbers_every_border_node_once_outline_then_islands(tmp_path):
    mesh = grid_mesh(_holed_hf())
    got, codes, nk = _written(mesh, tmp_path / "holed.srf")
    n, k = nk[:, 0], nk[:, 1]
    assert (k == np.arange(1, len(k) + 1)).all()  # in boundary order
    assert (got["ipobo"][n - 1] == k).all()  # K is the node's IPOBO ...
    assert (np.delete(got["ipobo"], n - 1) == 0).all()  # ... and every other node's is 0
    border = _directed_border(got["ikle"])
    assert set(n.tolist()) == {v for e in border for v in e} and len(set(n.tolist())) == len(n)  # each once
    loops = _loops(n.tolist(), border)
    x, y = got["x"] + got["iparam"][2], got["y"] + got["iparam"][3]
    areas = [_signed_area(x, y, lp) for lp in loops]
    assert len(loops) == 3 and areas[0] > 0 and areas[1] < 0 and areas[2] < 0  # outline CCW, islands CW
    assert -areas[1] > -areas[2]  # the larger hole first
    start = loops[0][0] - 1
    assert x[start] == x.min() and y[start] == y[np.isclose(x, x.min())].min()  # from the south-west vertex
    assert (codes == [2, 2, 2, 2]).all()  # no node strings: walls all round


def test_cli_codes_follow_the_node_string_names(tmp_path):
    hf = Heightfield(np.add.outer(np.arange(12.0), np.arange(15.0)), cell_size=1.0)
    mesh = grid_mesh(hf)
    rows, cols = hf.shape
    west = np.arange(rows) * cols  # column 0, top to bottom
    east = np.arange(rows)[::-1] * cols + cols - 1  # last column, bottom to top
    mesh.node_strings = {"Inflow_west": west[2:9], "outflow": east[:5], "open_north": np.arange(9, 12),
                         "breakline_1": np.array([16, 17, 18]), "wall_south": np.arange(rows * cols - 6, rows * cols)}
    got, codes, nk = _written(mesh, tmp_path / "m.slf")
    by_node = {int(n): tuple(c) for n, c in zip(nk[:, 0], codes, strict=True)}
    expected = {v + 1: (4, 5, 5, 5) for v in west[2:9]}
    expected |= {v + 1: (5, 4, 4, 4) for v in np.concatenate([east[:5], np.arange(9, 12)])}
    for node, code in by_node.items():
        assert code == expected.get(node, (2, 2, 2, 2)), node
    assert set(expected) <= set(by_node)
    assert not {17, 18, 19} & set(by_node)  # the breakline is inside: no boundary
    assert Counter(by_node.values()) == {(4, 5, 5, 5): 7, (5, 4, 4, 4): 8, (2, 2, 2, 2): len(by_node) - 15}
    assert (got["ipobo"][nk[:, 0] - 1] == nk[:, 1]).all()
    liquid = [i for i, c in enumerate(codes.tolist()) if c != [2, 2, 2, 2]]
    runs = sum(1 for i in liquid if (i - 1) % len(codes) not in liquid)
    assert runs == 3  # three liquid boundaries, each one run along the boundary order


def test_open_string_off_the_border_is_refused_and_nothing_written(tmp_path):
    mesh = grid_mesh(Heightfield(np.zeros((6, 6)), cell_size=1.0))
    mesh.node_strings = {"outflow_x": np.array([7, 8, 9])}
    with pytest.raises(InvalidInputError, match="'outflow_x'.*not on the border"):
        tinsmith.write(mesh, tmp_path / "m.slf")
    assert list(tmp_path.iterdir()) == []


def test_a_pinched_mesh_is_refused(tmp_path):
    v = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (2, 1, 0), (2, 2, 0)]
    with pytest.raises(InvalidInputError, match="vertex 2 is on two border loops"):
        tinsmith.write(TerrainMesh(v, [(0, 1, 2), (2, 3, 4)]), tmp_path / "m.slf")
    assert list(tmp_path.iterdir()) == []


def test_a_failed_cli_leaves_neither_file_and_keeps_the_old_ones(tmp_path, monkeypatch):
    import tinsmith.io.selafin as selafin

    (tmp_path / "m.slf").write_bytes(b"old")
    (tmp_path / "m.cli").write_text("old")

    def broken(path, parts):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(selafin, "write_text", broken)
    with pytest.raises(FormatError, match="No space left"):
        tinsmith.write(grid_mesh(_holed_hf()), tmp_path / "m.slf")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.cli", "m.slf"]
    assert (tmp_path / "m.slf").read_bytes() == b"old" and (tmp_path / "m.cli").read_text() == "old"


# -- the dispatcher and the command line ---------------------------------------------------------------------
def test_slf_warns_of_slivers_and_is_quiet_on_a_well_shaped_mesh(tmp_path):
    v = [(0, 0, 1), (10, 0, 1), (5, 0.2, 1), (5, 10, 2)]
    with pytest.warns(SliverWarning, match=r"m\.slf.*1 of 3 triangles"):
        tinsmith.write(TerrainMesh(v, [(0, 1, 2), (0, 2, 3), (2, 1, 3)]), tmp_path / "m.slf")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tinsmith.write(grid_mesh(_holed_hf()), tmp_path / "ok.slf")


def test_cli_simplify_writes_slf_cli_and_prj(tmp_path, capsys):
    out = tmp_path / "out.slf"
    code = main(["simplify", "--sample", "st-helens", "--method", "quality", "--max-error", "20", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.cli", "out.prj", "out.slf"]
    got = read_selafin(out)
    codes, nk = read_cli(tmp_path / "out.cli")
    border = _directed_border(got["ikle"])
    assert set(nk[:, 0].tolist()) == {v for e in border for v in e}
    assert (got["ipobo"][nk[:, 0] - 1] == nk[:, 1]).all()
    assert _signed_area(got["x"], got["y"], _loops(nk[:, 0].tolist(), border)[0]) > 0


def test_formats_lists_selafin(capsys):
    assert main(["formats"]) == 0
    out = capsys.readouterr().out
    assert ".slf .srf .selafin: TELEMAC geometry file" in out
